//! The binary end to end: what a user sees on the command line and on disk.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common;
use common::{mib_after, run, text};

const BIN: &str = env!("CARGO_BIN_EXE_raytrace");

/// Every file below `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<PathBuf> {
    fn walk(base: &Path, d: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.push(p.strip_prefix(base).unwrap().to_path_buf());
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

const SMALL: &str = r#"
[shot]
fps = 24.0
frames = 4
first_frame = 1
shutter_angle = 180.0
[output]
path = "out/f_####.exr"
width = 24
height = 16
[render]
samples = 4
max_depth = 8
seed = 3
[camera]
look_from = [0.0, 1.0, 5.0]
look_at = [0.0, 0.5, 0.0]
vfov = 40.0
aperture = 0.1
[materials]
red = { type = "lambertian", albedo = [0.7, 0.2, 0.1] }
[[sphere]]
center = [0.0, -100.0, 0.0]
radius = 100.0
material = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
[[sphere]]
center = [0.0, 0.5, 0.0]
radius = 0.5
material = "red"
velocity = [2.0, 0.0, 0.0]
"#;

fn setup(scene: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), scene).unwrap();
    dir
}

#[test]
fn renders_every_frame_with_padded_names() {
    let d = setup(SMALL);
    let o = run(d.path(), &["render", "shot.toml"]);
    assert!(o.status.success(), "{}", text(&o));
    let want: Vec<PathBuf> = [
        "out/f_0001.exr",
        "out/f_0002.exr",
        "out/f_0003.exr",
        "out/f_0004.exr",
        "shot.toml",
    ]
    .iter()
    .map(PathBuf::from)
    .collect();
    assert_eq!(files(d.path()), want);
    // One summary line per frame, and a total.
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        out.lines().filter(|l| l.starts_with("frame ")).count(),
        4,
        "{out}"
    );
    assert!(
        out.lines().last().unwrap().contains("4 frames rendered"),
        "{out}"
    );
}

#[test]
fn frame_is_identical_alone_in_a_range_and_on_any_thread_count() {
    let d = setup(SMALL);
    let ok = |args: &[&str]| {
        let o = run(d.path(), args);
        assert!(o.status.success(), "{}", text(&o));
    };
    ok(&[
        "render",
        "shot.toml",
        "--threads",
        "1",
        "--frames",
        "3",
        "--output",
        "a/f_####.exr",
    ]);
    ok(&[
        "render",
        "shot.toml",
        "--threads",
        "2",
        "--frames",
        "3",
        "--output",
        "b/f_####.exr",
    ]);
    ok(&[
        "render",
        "shot.toml",
        "--threads",
        "2",
        "--frames",
        "1-4",
        "--output",
        "c/f_####.exr",
    ]);
    let read = |p: &str| std::fs::read(d.path().join(p)).unwrap();
    assert!(
        read("a/f_0003.exr") == read("b/f_0003.exr"),
        "1 and 2 threads differ"
    );
    assert!(
        read("a/f_0003.exr") == read("c/f_0003.exr"),
        "alone and in a range differ"
    );
    assert!(
        read("c/f_0002.exr") != read("c/f_0003.exr"),
        "two frames are the same"
    );
}

#[test]
fn exr_has_linear_float_channels_and_frame_attributes() {
    let d = setup(SMALL);
    let o = run(d.path(), &["render", "shot.toml", "--frames", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    let img =
        exr::prelude::read_all_flat_layers_from_file(d.path().join("out/f_0002.exr")).unwrap();
    let layer = &img.layer_data[0];
    assert_eq!(layer.size, exr::math::Vec2(24, 16));
    let names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert_eq!(names, ["B", "G", "R"]);
    for c in &layer.channel_data.list {
        assert!(matches!(c.sample_data, exr::image::FlatSamples::F32(_)));
    }
    assert!(matches!(
        layer.encoding.compression,
        exr::compression::Compression::ZIP16
            | exr::compression::Compression::ZIP1
            | exr::compression::Compression::PIZ
    ));
    assert_eq!(layer.attributes.frames_per_second, Some((24, 1)));
    let attrs = format!("{:?}", layer.attributes.other);
    for key in [
        "frame",
        "shutterOpen",
        "shutterClose",
        "samples",
        "seed",
        "sampler",
        "estimatedRelativeError",
    ] {
        assert!(attrs.contains(key), "attribute {key} missing: {attrs}");
    }
}

#[test]
fn png_of_uniform_half_background_reads_188() {
    let d = setup(
        r#"
[output]
path = "bg.png"
width = 8
height = 4
[background]
color = [0.5, 0.5, 0.5]
"#,
    );
    let o = run(d.path(), &["render", "shot.toml"]);
    assert!(o.status.success(), "{}", text(&o));
    let img = image::open(d.path().join("bg.png")).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (8, 4));
    assert!(img.pixels().all(|p| p.0 == [188, 188, 188]));
}

#[test]
fn default_output_is_named_after_the_scene() {
    let d = setup("[output]\nwidth = 4\nheight = 4\n");
    let o = run(d.path(), &["render", "shot.toml"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        d.path().join("shot_0001.png").exists(),
        "{:?}",
        files(d.path())
    );
}

#[test]
fn skip_existing_leaves_complete_frames_untouched_and_redoes_the_rest() {
    let d = setup(SMALL);
    // Frame 2 rendered with other settings: a complete file, so it stays as it is.
    let o = run(
        d.path(),
        &["render", "shot.toml", "--frames", "2", "--samples", "1"],
    );
    assert!(o.status.success(), "{}", text(&o));
    let kept = std::fs::read(d.path().join("out/f_0002.exr")).unwrap();
    // Frame 3 empty, frame 4 cut short (as an interrupted copy leaves them): rendered again.
    std::fs::write(d.path().join("out/f_0003.exr"), b"").unwrap();
    std::fs::write(d.path().join("out/f_0004.exr"), &kept[..kept.len() - 10]).unwrap();
    let o = run(d.path(), &["render", "shot.toml", "--skip-existing"]);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    assert!(
        out.contains("frame 2: out/f_0002.exr exists, skipped"),
        "{out}"
    );
    assert!(
        out.contains("incomplete file out/f_0003.exr (0 bytes): frame 3 is rendered again"),
        "{out}"
    );
    assert!(
        out.contains("incomplete file out/f_0004.exr (truncated"),
        "{out}"
    );
    assert!(out.contains("3 frames rendered, 1 skipped"), "{out}");
    assert_eq!(
        std::fs::read(d.path().join("out/f_0002.exr")).unwrap(),
        kept
    );
    // The redone frames are whole, and the same as a fresh render's.
    let o = run(
        d.path(),
        &["render", "shot.toml", "--output", "ref/f_####.exr"],
    );
    assert!(o.status.success(), "{}", text(&o));
    for f in ["f_0001.exr", "f_0003.exr", "f_0004.exr"] {
        let a = std::fs::read(d.path().join("out").join(f)).unwrap();
        let b = std::fs::read(d.path().join("ref").join(f)).unwrap();
        assert!(a == b, "{f} differs from a fresh render");
    }
    assert_eq!(files(d.path()).len(), 9);
}

#[test]
fn check_describes_the_shot() {
    let d = setup(SMALL);
    let o = run(d.path(), &["check", "shot.toml", "--chunk-size", "3"]);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    for want in [
        "4 frames",
        "spheres: 2 (1 moving",
        "thin lens",
        "chunks: 2",
        "total samples: 6144",
    ] {
        assert!(out.contains(want), "missing {want:?} in\n{out}");
    }
    // Frame 2 at 24 fps with a centred 1/48 s shutter.
    assert!(
        out.contains(&format!(
            "2: shutter [{}, {}]",
            1.0 / 24.0 - 1.0 / 96.0,
            1.0 / 24.0 + 1.0 / 96.0
        )),
        "{out}"
    );
    assert_eq!(files(d.path()), [PathBuf::from("shot.toml")]);
}

#[test]
fn bare_frames_means_every_frame_and_lists_select_some() {
    let d = setup(SMALL);
    let o = run(d.path(), &["render", "shot.toml", "--frames"]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(files(d.path()).len(), 5);
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--frames",
            "1,3-4:1",
            "--output",
            "sel/x_#.png",
        ],
    );
    assert!(o.status.success(), "{}", text(&o));
    let names: Vec<String> = files(&d.path().join("sel"))
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    assert_eq!(names, ["x_1.png", "x_3.png", "x_4.png"]);
}

#[test]
fn stats_reports_times_rays_rates_and_memory() {
    let d = setup(SMALL);
    let o = run(
        d.path(),
        &["render", "shot.toml", "--frames", "2", "--stats"],
    );
    assert!(o.status.success(), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let line = out
        .lines()
        .find(|l| l.starts_with("frame 2 stats:"))
        .expect("a stats line");
    for want in [
        "prepare",
        "1 moving spheres",
        "render",
        "rays",
        "M/s",
        "samples 1536",
        "peak memory",
        "MiB",
    ] {
        assert!(line.contains(want), "{want:?} missing in {line}");
    }
    // At least one ray per camera sample.
    let rays: u64 = line
        .split("rays ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(rays >= 1536, "{line}");
}

#[test]
fn help_has_examples() {
    let o = Command::new(BIN)
        .args(["render", "--help"])
        .output()
        .unwrap();
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("Examples:"));
}

/// Malformed scenes and arguments: exit status 2, a message that locates the problem, and
/// nothing written.
#[test]
fn bad_input_exits_2_with_a_located_message_and_writes_nothing() {
    let cases: &[(&str, &[&str], &str)] = &[
        ("[shot]\nfps = 0.0\n", &[], "shot.fps"),
        ("[shot]\nfps = 24.0\nfps_typo = 1\n", &[], "shot.toml:3:1"),
        ("[shot\nfps = 24.0\n", &[], "shot.toml:1:"),
        ("[shot]\nframes = \"ten\"\n", &[], "shot.toml:2:"),
        (
            "[[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = -1.0\nmaterial = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\n",
            &[],
            "sphere[0].radius",
        ),
        (
            "[[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"nope\"\n",
            &[],
            "sphere[0].material",
        ),
        (
            "[shot]\nshutter = 0.01\nshutter_angle = 90.0\n",
            &[],
            "shutter",
        ),
        (
            "[camera]\nlook_from = [0.0, 0.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\n",
            &[],
            "camera",
        ),
        ("[camera]\nlook_at = [0.0, 1.0, 0.0]\n", &[], "camera"),
        ("[shot]\nframes = 4\n", &["--frames", "9"], "frame 9"),
        ("[shot]\nframes = 4\n", &["--frames", "3-1"], "--frames"),
        ("[shot]\nframes = 4\n", &["--frames", "x"], "--frames"),
        ("[shot]\nframes = 4\n", &["--output", "f.jpg"], "f.jpg"),
        (
            "[shot]\nframes = 4\n",
            &["--output", "same.png"],
            "same.png",
        ),
        ("[shot]\nframes = 4\n", &["--samples", "0"], "--samples"),
        ("[shot]\nframes = 4\n", &["--width", "0"], "--width"),
        ("[shot]\nframes = 4\n", &["--threads", "0"], "--threads"),
        (
            "[shot]\nframes = 4\n",
            &["--chunk-size", "2", "--chunk", "7"],
            "chunk",
        ),
        ("[shot]\nframes = 4\n", &["--bogus"], "--bogus"),
        ("[render]\nsampler = \"halton\"\n", &[], "shot.toml:2:"),
        ("[shot]\nframes = 4\n", &["--sampler", "halton"], "halton"),
        (
            "[shot]\nframes = 4\n",
            &["--time-limit", "0"],
            "--time-limit",
        ),
        (
            "[shot]\nframes = 4\n",
            &["--time-limit", "inf"],
            "--time-limit",
        ),
        (
            "[shot]\nframes = 4\n",
            &["--noise-threshold", "-0.1"],
            "--noise-threshold",
        ),
        (
            "[shot]\nframes = 4\n",
            &["--noise-threshold", "NaN"],
            "--noise-threshold",
        ),
        (
            "[shot]\nframes = 4\n",
            &["--max-samples", "64"],
            "--max-samples",
        ),
        (
            "[shot]\nframes = 4\n",
            &["--noise-threshold", "0.1", "--max-samples", "0"],
            "--max-samples",
        ),
    ];
    for (scene, args, want) in cases {
        let d = setup(scene);
        let mut all = vec!["render", "shot.toml"];
        all.extend_from_slice(args);
        let o = run(d.path(), &all);
        let msg = text(&o);
        assert_eq!(o.status.code(), Some(2), "{scene:?} {args:?}: {msg}");
        assert!(
            msg.contains(want),
            "{scene:?} {args:?}: message lacks {want:?}: {msg}"
        );
        assert!(!msg.contains("panicked"), "{msg}");
        assert_eq!(
            files(d.path()),
            [PathBuf::from("shot.toml")],
            "{scene:?} {args:?} wrote files"
        );
    }
    // A scene file that does not exist.
    let d = tempfile::tempdir().unwrap();
    let o = run(d.path(), &["render", "missing.toml"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("missing.toml"));
}

#[test]
fn unwritable_output_exits_2_naming_the_path_before_rendering() {
    let d = setup(SMALL);
    // A regular file where the output folder should be: fails even as root, and is found
    // before the frame is rendered.
    std::fs::write(d.path().join("out"), b"not a folder").unwrap();
    let o = run(d.path(), &["render", "shot.toml", "--frames", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("out/f_0001.exr cannot be written: out is not a folder"),
        "{}",
        text(&o)
    );
    assert!(!text(&o).contains("frame 1:"), "{}", text(&o));
    assert_eq!(files(d.path()), ["out", "shot.toml"].map(PathBuf::from));
}

#[test]
fn a_closed_stdout_does_not_stop_the_render() {
    // `raytrace render shot.toml | head -1`: the reader goes away after the first line.
    let d = setup(SMALL);
    let mut child = Command::new(BIN)
        .args(["render", "shot.toml"])
        .current_dir(d.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(files(&d.path().join("out")).len(), 4);
}

/// `render scenes/quick.toml --stats ARGS` into a new folder, written as `out` (a frame
/// pattern): the memory it estimates and the largest peak it prints, in MiB.
#[cfg(target_os = "linux")]
fn estimate_and_peak(out: &str, args: &[&str]) -> (f64, f64) {
    let d = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/quick.toml");
    let out = d.path().join(out);
    let mut all = vec![
        "render",
        scene.to_str().unwrap(),
        "--stats",
        "-o",
        out.to_str().unwrap(),
    ];
    all.extend(args);
    let o = run(d.path(), &all);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    let peak = t
        .split("peak memory ")
        .skip(1)
        .map(|rest| {
            rest.split_whitespace()
                .next()
                .unwrap()
                .parse::<f64>()
                .unwrap()
        })
        .fold(0.0, f64::max);
    (mib_after(&t, "memory: about "), peak)
}

// Peak and available memory are read from /proc.
#[cfg(target_os = "linux")]
#[test]
fn memory_estimate_is_within_a_quarter_of_the_peak() {
    // Raw, and finished: the denoiser's scratch and the written frame's terms are most of
    // what a denoised frame holds, and with --temporal a later frame holds the frame before's
    // terms for the stated flicker. PNG frames, as the scene writes them.
    for finish in [
        &[][..],
        &["--denoise"],
        &["--denoise", "--temporal", "--frames", "1-3"],
    ] {
        let args = [&["--samples", "2"][..], finish].concat();
        let (estimate, peak) = estimate_and_peak("f_####.png", &args);
        assert!(
            (estimate - peak).abs() <= 0.25 * peak,
            "{finish:?}: estimate {estimate} MiB, peak {peak} MiB"
        );
        // `check` states the same figure (of the scene as the file gives it: raw).
        if finish.is_empty() {
            let d = tempfile::tempdir().unwrap();
            let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/quick.toml");
            let o = run(d.path(), &["check", scene.to_str().unwrap()]);
            assert!(o.status.success(), "{}", text(&o));
            assert_eq!(mib_after(&text(&o), "memory: about "), estimate);
        }
    }
}

// Peak and available memory are read from /proc.
#[cfg(target_os = "linux")]
#[test]
fn memory_estimate_is_within_a_quarter_of_the_peak_at_1080p_on_each_device() {
    // At 1920x1080 finishing is most of a frame's memory (the denoiser's scratch, the
    // replicates, the written frame's terms), and the GPU adds its driver and buffers
    // (lavapipe's, in the process). One frame denoised; three frames with --temporal, whose
    // later frames hold the frame before's terms for the stated flicker.
    let devices: &[&str] = match common::gpu() {
        Some(_) => &["cpu", "gpu"],
        None => &["cpu"],
    };
    for device in devices {
        for finish in [
            &["--denoise", "--frames", "1"][..],
            &["--denoise", "--temporal", "--frames", "1-3"],
        ] {
            let size = ["--width", "1920", "--height", "1080", "--samples", "1"];
            let args = [&["--device", device][..], &size, finish].concat();
            let (estimate, peak) = estimate_and_peak("f_####.exr", &args);
            assert!(
                (estimate - peak).abs() <= 0.25 * peak,
                "{device} {finish:?}: estimate {estimate} MiB, peak {peak} MiB"
            );
        }
    }
}

// Peak memory is read from /proc.
#[cfg(target_os = "linux")]
#[test]
fn memory_estimate_is_within_a_quarter_of_the_peak_of_a_one_pixel_wide_denoised_frame() {
    // OIDN pads a side to a multiple of 16: a 1x65536 frame takes the scratch of 16x65536,
    // sixteen times what its own pixels would (about 360 MiB against 25).
    let size = ["--width", "1", "--height", "65536", "--samples", "1"];
    let (estimate, peak) = estimate_and_peak(
        "t_####.exr",
        &[&size[..], &["--denoise", "--frames", "1"]].concat(),
    );
    assert!(
        (estimate - peak).abs() <= 0.25 * peak && peak > 200.0,
        "estimate {estimate} MiB, peak {peak} MiB"
    );
}

// Peak and available memory are read from /proc.
#[cfg(target_os = "linux")]
#[test]
fn a_frame_too_large_for_memory_exits_2_and_writes_nothing() {
    let d = setup(SMALL);
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--width",
            "65536",
            "--height",
            "65536",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("65536x65536") && t.contains("MiB"), "{t}");
    assert!(t.contains("--width/--height"), "{t}");
    assert_eq!(files(d.path()), vec![PathBuf::from("shot.toml")]);
}

// procfs refuses a new folder to root too.
#[cfg(target_os = "linux")]
#[test]
fn an_output_folder_that_cannot_be_made_is_refused_before_rendering() {
    let d = setup(SMALL);
    let o = run(
        d.path(),
        &["render", "shot.toml", "-o", "/proc/nope/f_####.exr"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains("/proc/nope/f_0001.exr cannot be written: "),
        "{t}"
    );
    assert!(!t.contains("frame 1:"), "rendered: {t}");
    assert_eq!(files(d.path()), vec![PathBuf::from("shot.toml")]);
}
