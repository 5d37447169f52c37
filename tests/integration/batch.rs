//! Several scenes in one run: `render a.toml b.toml ...` and `check a.toml b.toml ...`.

use std::path::Path;

use crate::common;
use common::{ok, run, text};

fn refused(dir: &Path, args: &[&str], message: &str) {
    let o = run(dir, args);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
    assert!(text(&o).contains(message), "{args:?}: {}", text(&o));
}

/// Every file below `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<String> {
    fn walk(base: &Path, d: &Path, out: &mut Vec<String>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.push(p.strip_prefix(base).unwrap().display().to_string());
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// A small shot of `frames` frames written to `path`.
fn scene(frames: u32, path: &str) -> String {
    format!(
        r#"[shot]
fps = 24.0
frames = {frames}
[output]
path = "{path}"
width = 16
height = 12
[render]
samples = 2
max_depth = 4
[[sphere]]
center = [0.0, 0.0, -1.0]
radius = 0.5
material = {{ type = "lambertian", albedo = [0.7, 0.3, 0.2] }}
velocity = [0.5, 0.0, 0.0]
"#
    )
}

/// A folder with `a.toml` (4 frames), `b.toml` (3 frames) and `scenes` more.
fn setup(more: &[(&str, String)]) -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("a.toml"), scene(4, "a/f_####.png")).unwrap();
    std::fs::write(d.path().join("b.toml"), scene(3, "b/f_####.png")).unwrap();
    for (name, text) in more {
        std::fs::write(d.path().join(name), text).unwrap();
    }
    d
}

fn names(list: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = list.iter().map(|s| s.to_string()).collect();
    v.sort();
    v
}

#[test]
fn two_scenes_render_as_one_run_each_frame_as_it_renders_alone() {
    let d = setup(&[]);
    let out = ok(
        d.path(),
        &["render", "a.toml", "b.toml", "-o", "r/{scene}_##.png"],
    );
    let mut want = vec!["a.toml", "b.toml"];
    want.extend(["r/a_01.png", "r/a_02.png", "r/a_03.png", "r/a_04.png"]);
    want.extend(["r/b_01.png", "r/b_02.png", "r/b_03.png"]);
    assert_eq!(files(d.path()), names(&want));
    // A line per frame, a summary per shot, one for the run.
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.iter().filter(|l| l.starts_with("frame ")).count(), 7);
    assert!(
        lines[4].starts_with("a.toml: 4 frames rendered, 0 skipped"),
        "{out}"
    );
    assert!(
        lines[8].starts_with("b.toml: 3 frames rendered, 0 skipped"),
        "{out}"
    );
    assert!(
        lines[9].starts_with("7 frames rendered, 0 skipped"),
        "{out}"
    );
    assert_eq!(lines.len(), 10, "{out}");
    // The second shot's frames are those of a run of its own.
    ok(
        d.path(),
        &["render", "b.toml", "-o", "alone/{scene}_##.png"],
    );
    for f in 1..=3 {
        let batch = std::fs::read(d.path().join(format!("r/b_0{f}.png"))).unwrap();
        let alone = std::fs::read(d.path().join(format!("alone/b_0{f}.png"))).unwrap();
        assert_eq!(batch, alone, "frame {f}");
    }
    // {scene} in [output] path, and --frames applied to each scene.
    let c = scene(5, "c/{scene}-#.png");
    std::fs::write(d.path().join("c.toml"), c).unwrap();
    ok(
        d.path(),
        &["render", "c.toml", "a.toml", "--frames", "2-3", "-q"],
    );
    let made: Vec<String> = files(d.path())
        .into_iter()
        .filter(|f| f.starts_with("c/") || f.starts_with("a/"))
        .collect();
    assert_eq!(
        made,
        names(&["a/f_0002.png", "a/f_0003.png", "c/c-2.png", "c/c-3.png"])
    );
}

#[test]
fn a_bad_scene_anywhere_in_the_batch_writes_nothing() {
    let bad = scene(3, "b/f_####.png").replace("radius = 0.5", "radius = [0.5]");
    let d = setup(&[("bad.toml", bad)]);
    let before = files(d.path());
    let o = run(
        d.path(),
        &["render", "a.toml", "bad.toml", "-o", "r/{scene}_####.png"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    // The message names the file and where in it.
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.toml:13:10"), "{err}");
    assert_eq!(files(d.path()), before);
    // check refuses the batch the same way.
    refused(d.path(), &["check", "a.toml", "bad.toml"], "bad.toml:13:10");
}

#[test]
fn shots_that_would_write_the_same_files_are_refused() {
    let d = setup(&[("same.toml", scene(2, "a/f_####.png"))]);
    let before = files(d.path());
    refused(
        d.path(),
        &["render", "a.toml", "b.toml", "-o", "r/f_####.png"],
        "--output \"r/f_####.png\" has no {scene}",
    );
    refused(
        d.path(),
        &[
            "render",
            "a.toml",
            "b.toml",
            "-o",
            "r/{scene}_#.png",
            "--clip",
            "x.gif",
        ],
        "--clip \"x.gif\" has no {scene}",
    );
    refused(
        d.path(),
        &["render", "a.toml", "same.toml"],
        "a.toml and same.toml would both write frames \"a/f_####.png\"",
    );
    refused(
        d.path(),
        &["render", "a.toml", "a.toml", "-o", "r/{scene}_#.png"],
        "would both write",
    );
    refused(
        d.path(),
        &["check", "a.toml", "same.toml"],
        "would both write",
    );
    assert_eq!(files(d.path()), before);
}

#[test]
fn chunks_count_over_every_frame_of_the_batch_in_order() {
    let d = setup(&[]);
    let out = ok(
        d.path(),
        &["check", "a.toml", "b.toml", "--chunk-size", "3"],
    );
    let chunk_lines: Vec<&str> = out.lines().filter(|l| l.starts_with("chunks:")).collect();
    assert_eq!(chunk_lines, ["chunks: 3 of up to 3 frames"], "{out}");
    assert!(out.contains("batch: 2 scenes, 7 frames"), "{out}");
    assert!(
        out.contains("a.toml: ok") && out.contains("b.toml: ok"),
        "{out}"
    );
    // Chunk 1 of 3 frames: the last frame of a and the first two of b.
    let chunk = |i: &str, dir: &str| {
        let pattern = format!("{dir}/{{scene}}_#.png");
        ok(
            d.path(),
            &[
                "render",
                "a.toml",
                "b.toml",
                "--chunk-size",
                "3",
                "--chunk",
                i,
                "-o",
                &pattern,
            ],
        )
    };
    chunk("1", "one");
    assert_eq!(
        files(&d.path().join("one")),
        names(&["a_4.png", "b_1.png", "b_2.png"])
    );
    // Every chunk together: the whole batch, bit for bit.
    for i in ["0", "1", "2"] {
        chunk(i, "chunks");
    }
    ok(
        d.path(),
        &[
            "render",
            "a.toml",
            "b.toml",
            "-o",
            "all/{scene}_#.png",
            "-q",
        ],
    );
    let all = files(&d.path().join("all"));
    assert_eq!(files(&d.path().join("chunks")), all);
    for f in &all {
        let a = std::fs::read(d.path().join("all").join(f)).unwrap();
        let c = std::fs::read(d.path().join("chunks").join(f)).unwrap();
        assert_eq!(a, c, "{f}");
    }
    refused(
        d.path(),
        &[
            "render",
            "a.toml",
            "b.toml",
            "--chunk-size",
            "3",
            "--chunk",
            "3",
            "-o",
            "x/{scene}#.png",
        ],
        "chunk 3 is past the end: 7 frames in chunks of 3 make 3 chunks (0-2)",
    );
    refused(
        d.path(),
        &[
            "render",
            "a.toml",
            "--chunk-size",
            "3",
            "--chunk",
            "0",
            "--clip",
            "a.gif",
        ],
        "--clip",
    );
    assert!(!d.path().join("x").exists());
}

#[test]
fn a_chunk_of_a_shot_written_to_one_file_is_refused_as_check_refuses_the_shot() {
    // Each chunk of one frame would pass alone, and every chunk would overwrite one.png: the
    // rule counts the frames the chunks write between them, in `render` as in `check`.
    let d = setup(&[("one.toml", scene(4, "one.png"))]);
    let message = "output path \"one.png\" has no '#' for the frame number, so 4 frames would overwrite one file";
    refused(
        d.path(),
        &["check", "one.toml", "--chunk-size", "1"],
        message,
    );
    for index in ["0", "3"] {
        let args = ["render", "one.toml", "--chunk-size", "1", "--chunk", index];
        refused(d.path(), &args, message);
    }
    assert!(!d.path().join("one.png").exists());
    // One frame asked for is one file: rendered.
    ok(d.path(), &["render", "one.toml", "--frames", "2"]);
    assert!(d.path().join("one.png").is_file());
}
