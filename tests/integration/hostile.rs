//! Hostile arguments and inputs: each run ends within 5 seconds under a 1 GiB address-space
//! limit (`ulimit -v`, so an allocation proportional to a shot's length fails), with the
//! exit status stated (0, 1 or 2), no panic, and nothing partial or temporary left behind.

use crate::common;

use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SECONDS: u64 = 5;
const MEMORY_KIB: u64 = 1 << 20;

/// Runs the binary in `dir` under the limits; panics if it takes longer than [`SECONDS`].
fn run(dir: &Path, args: &[&str]) -> Output {
    common::run_limited(dir, args, SECONDS, MEMORY_KIB)
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Asserts the exit status and that the output has `want` and no panic.
fn expect(o: &Output, code: i32, want: &str) {
    let t = text(o);
    assert_eq!(o.status.code(), Some(code), "{}", shorten_text(&t));
    assert!(
        t.contains(want),
        "{want:?} missing in:\n{}",
        shorten_text(&t)
    );
    assert!(!t.contains("panicked"), "{}", shorten_text(&t));
}

fn shorten_text(t: &str) -> String {
    if t.len() > 3000 {
        format!("{}… ({} bytes)", &t[..2000], t.len())
    } else {
        t.to_string()
    }
}

/// Every file and folder below `dir`, relative, sorted.
fn tree(dir: &Path) -> Vec<PathBuf> {
    fn walk(base: &Path, d: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            out.push(p.strip_prefix(base).unwrap().to_path_buf());
            if p.is_dir() && !p.is_symlink() {
                walk(base, &p, out);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

fn scene(frames: u64, output: &str) -> String {
    format!(
        "[shot]\nframes = {frames}\nfirst_frame = 1\n[output]\npath = \"{output}\"\nwidth = 4\nheight = 4\n\
         [render]\nsamples = 2\n[[sphere]]\ncenter = [0.0, 0.0, -1.0]\nradius = 0.5\n\
         material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\n"
    )
}

fn setup(text: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), text).unwrap();
    dir
}

#[test]
fn the_longest_shots_are_selected_counted_and_chunked_without_listing_frames() {
    let d = setup(&scene(4_294_967_295, "out/f_##########.png"));
    let o = run(d.path(), &["check", "shot.toml", "--chunk-size", "1"]);
    expect(&o, 0, "chunks: 4294967295 of up to 1 frames");
    expect(&o, 0, "4294967295: shutter");
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--threads",
            "2",
            "--chunk-size",
            "1",
            "--chunk",
            "4294967294",
        ],
    );
    expect(&o, 0, "1 frames rendered");
    assert_eq!(
        tree(d.path()),
        ["out", "out/f_4294967295.png", "shot.toml"].map(PathBuf::from)
    );
    // Every frame of the shot, bare `--frames`, as the chunk past the end: an error that
    // counts them.
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--frames",
            "--chunk-size",
            "7",
            "--chunk",
            "613566757",
        ],
    );
    expect(
        &o,
        2,
        "chunk 613566757 is past the end: 4294967295 frames in chunks of 7 make 613566757 chunks",
    );

    let d = setup(&scene(1_000_000_000, "out/f_#.png"));
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--threads",
            "2",
            "--frames",
            "1-1000000000",
            "--chunk-size",
            "1",
            "--chunk",
            "999999999",
        ],
    );
    expect(&o, 0, "frame 1000000000:");
    assert_eq!(
        tree(d.path()),
        ["out", "out/f_1000000000.png", "shot.toml"].map(PathBuf::from)
    );
    // Overlapping parts of different steps are merged one by one only up to a bound.
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--frames",
            "1-1000000000:2,1-1000000000:3",
        ],
    );
    expect(&o, 2, "overlap on more than 1000000 frames");
}

#[test]
fn an_empty_frames_value_is_an_error_and_a_bare_flag_every_frame() {
    let d = setup(&scene(3, "out/f_#.png"));
    for empty in [&["--frames", ""][..], &["--frames="], &["--frames", "  "]] {
        let mut args = vec!["render", "shot.toml"];
        args.extend_from_slice(empty);
        expect(
            &run(d.path(), &args),
            2,
            "--frames: empty frame specification",
        );
        assert_eq!(tree(d.path()), [PathBuf::from("shot.toml")]);
    }
    let o = run(d.path(), &["render", "shot.toml", "--frames"]);
    expect(&o, 0, "3 frames rendered");
}

#[test]
fn negative_numbers_get_the_value_parsers_message() {
    let d = setup(&scene(3, "out/f_#.png"));
    let cases: &[(&[&str], &str)] = &[
        (
            &["render", "shot.toml", "--width", "-16"],
            "'-16' for '--width",
        ),
        (
            &["render", "shot.toml", "--height", "-1"],
            "'-1' for '--height",
        ),
        (
            &["render", "shot.toml", "--samples", "-4"],
            "'-4' for '--samples",
        ),
        (
            &["render", "shot.toml", "--seed", "-1"],
            "must be a whole number >= 0",
        ),
        (
            &["render", "shot.toml", "--threads", "-2"],
            "'-2' for '--threads",
        ),
        (
            &["render", "shot.toml", "--chunk-size", "-5", "--chunk", "0"],
            "'-5' for '--chunk-size",
        ),
        (
            &["render", "shot.toml", "--chunk-size", "5", "--chunk", "-1"],
            "'-1' for '--chunk",
        ),
        (
            &["render", "shot.toml", "--frames", "-3"],
            "negative frame numbers",
        ),
        (
            &["render", "shot.toml", "--time-limit", "-1"],
            "must be a number > 0",
        ),
        (
            &[
                "render",
                "shot.toml",
                "--noise-threshold",
                "0.1",
                "--max-samples",
                "-8",
            ],
            "'-8' for '--max-samples",
        ),
        (
            &["check", "shot.toml", "--chunk-size", "-3"],
            "'-3' for '--chunk-size",
        ),
        (
            &["converge", "shot.toml", "--frame", "-1"],
            "'-1' for '--frame",
        ),
        (
            &["converge", "shot.toml", "--reference-samples", "-9"],
            "'-9' for '--reference-samples",
        ),
        (
            &["converge", "shot.toml", "--budget", "-2"],
            "must be a number > 0",
        ),
        (
            &["generate", "--spheres", "-10", "-o", "g.toml"],
            "'-10' for '--spheres",
        ),
        (
            &["generate", "--moving", "-0.5", "-o", "g.toml"],
            "must be in [0, 1]",
        ),
        (
            &["generate", "--frames", "-2", "-o", "g.toml"],
            "'-2' for '--frames",
        ),
        (
            &["generate", "--seed", "-7", "-o", "g.toml"],
            "must be a whole number >= 0",
        ),
    ];
    for (args, want) in cases {
        let o = run(d.path(), args);
        expect(&o, 2, want);
        assert!(!text(&o).contains("unexpected argument"), "{}", text(&o));
        assert_eq!(tree(d.path()), [PathBuf::from("shot.toml")], "{args:?}");
    }
}

#[test]
fn threads_are_bounded_and_a_pool_that_cannot_start_is_exit_1() {
    let d = setup(&scene(2, "out/f_#.png"));
    for bad in ["0", "1025", "65536", "-1"] {
        let o = run(d.path(), &["render", "shot.toml", "--threads", bad]);
        expect(&o, 2, "--threads");
    }
    // 1024 threads of 2 MiB stacks do not fit 1 GiB of address space: a resource failure.
    let o = run(
        d.path(),
        &["render", "shot.toml", "--threads", "1024", "--frames", "1"],
    );
    expect(&o, 1, "cannot start worker threads");
    assert_eq!(tree(d.path()), [PathBuf::from("shot.toml")]);
}

#[test]
fn samples_and_a_budget_do_not_mix_and_a_threshold_has_a_finite_cap() {
    let d = setup(&scene(2, "out/f_#.exr"));
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--samples",
            "8",
            "--max-samples",
            "4",
            "--time-limit",
            "10",
        ],
    );
    expect(&o, 2, "'--samples <SAMPLES>' cannot be used with");
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--samples",
            "8",
            "--noise-threshold",
            "0.1",
        ],
    );
    expect(&o, 2, "cannot be used with");
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--samples",
            "8",
            "--max-samples",
            "4",
        ],
    );
    expect(&o, 2, "--max-samples");
    assert_eq!(tree(d.path()), [PathBuf::from("shot.toml")]);

    // A threshold no frame reaches stops at 65536 samples per pixel.
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--threads",
            "2",
            "--frames",
            "1",
            "--noise-threshold",
            "1e-300",
        ],
    );
    expect(&o, 0, "65536 spp (max samples)");
    let img = exr::prelude::read_all_flat_layers_from_file(d.path().join("out/f_1.exr")).unwrap();
    let attrs = format!("{:?}", img.layer_data[0].attributes.other);
    assert!(attrs.contains("I32(65536)"), "{attrs}");
    // --max-samples still sets the cap.
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--frames",
            "2",
            "--noise-threshold",
            "1e-300",
            "--max-samples",
            "32",
        ],
    );
    expect(&o, 0, "32 spp (max samples)");
    let help = run(d.path(), &["render", "--help"]);
    expect(&help, 0, "65536");
}

#[test]
fn scene_paths_that_name_no_readable_file_are_bad_arguments() {
    let d = setup(&scene(2, "out/f_#.png"));
    let p = d.path();
    std::fs::create_dir(p.join("folder.toml")).unwrap();
    symlink("loop_b.toml", p.join("loop_a.toml")).unwrap();
    symlink("loop_a.toml", p.join("loop_b.toml")).unwrap();
    let fifo = Command::new("mkfifo").arg(p.join("pipe.toml")).status();
    assert!(fifo.is_ok_and(|s| s.success()), "mkfifo");
    let cases = [
        ("folder.toml", "is a directory, not a scene file"),
        ("loop_a.toml", "Too many levels of symbolic links"),
        // Opening a pipe without a writer would wait for ever.
        ("pipe.toml", "is a named pipe, not a scene file"),
        ("/dev/zero", "is a device, not a scene file"),
        ("shot.toml/inner.toml", "Not a directory"),
        ("missing.toml", "missing.toml"),
    ];
    let long = format!("{}.toml", "s".repeat(5000));
    for command in ["render", "check", "converge"] {
        for (scene, want) in cases.iter().chain([&(long.as_str(), "bytes)")]) {
            let o = run(p, &[command, scene]);
            expect(&o, 2, want);
            assert!(text(&o).len() < 1000, "{}", shorten_text(&text(&o)));
        }
    }
    let mut want: Vec<PathBuf> = [
        "folder.toml",
        "loop_a.toml",
        "loop_b.toml",
        "pipe.toml",
        "shot.toml",
    ]
    .map(PathBuf::from)
    .to_vec();
    want.sort();
    assert_eq!(tree(p), want);
}

#[test]
fn check_refuses_what_render_refuses() {
    // Several frames into one file.
    let d = setup(&scene(4, "same.png"));
    for command in ["check", "render"] {
        let o = run(d.path(), &[command, "shot.toml"]);
        expect(
            &o,
            2,
            "has no '#' for the frame number, so 4 frames would overwrite one file",
        );
    }
    // A file name too long for the system (with its temporary file's name).
    let d = setup(&scene(4, &format!("out/{}_#.png", "n".repeat(240))));
    for command in ["check", "render"] {
        let o = run(d.path(), &[command, "shot.toml"]);
        expect(&o, 2, "the file name is 246 bytes long");
    }
    assert_eq!(tree(d.path()), [PathBuf::from("shot.toml")]);
    // One frame into a file of its own is fine.
    let d = setup(&scene(1, "same.png"));
    expect(&run(d.path(), &["check", "shot.toml"]), 0, "ok");
}

#[test]
fn huge_output_paths_are_quoted_short_and_create_nothing() {
    // 20 MB of nested folders in the scene: refused before any folder is made, and the
    // message quotes the path by its start, end and length.
    let nested = format!("{}f_####.exr", "d/".repeat(10 << 20));
    let d = setup(&scene(2, &nested));
    for command in ["render", "check"] {
        let o = run(d.path(), &[command, "shot.toml"]);
        expect(&o, 2, &format!("d/d/f_0001.exr ({} bytes)", nested.len()));
        assert!(text(&o).len() < 1000, "{} bytes of output", text(&o).len());
    }
    assert_eq!(tree(d.path()), [PathBuf::from("shot.toml")]);
    // The longest argument the system passes, as --output.
    let arg = format!("{}/f_#.png", "o".repeat(120_000));
    let d = setup(&scene(2, "out/f_#.png"));
    let o = run(d.path(), &["render", "shot.toml", "--output", &arg]);
    expect(&o, 2, "(120008 bytes)");
    assert!(text(&o).len() < 1000, "{} bytes of output", text(&o).len());
    assert_eq!(tree(d.path()), [PathBuf::from("shot.toml")]);
}

#[test]
fn generate_refuses_other_formats_and_sphere_counts_past_its_bound() {
    let d = tempfile::tempdir().unwrap();
    let o = run(d.path(), &["generate", "--spheres", "10", "-o", "g.png"]);
    expect(&o, 2, "must end in .toml");
    let o = run(
        d.path(),
        &["generate", "--spheres", "1000000000000", "-o", "g.toml"],
    );
    expect(&o, 2, "1000000000000 is not in 1..=");
    assert!(tree(d.path()).is_empty());
    let o = run(d.path(), &["generate", "--spheres", "10", "-o", "g.toml"]);
    expect(&o, 0, "");
    assert_eq!(tree(d.path()), [PathBuf::from("g.toml")]);
}
