//! `raytrace clip`, `render --clip` and `[output] clip`: clips read back and compared with the
//! frames they were made of. The `.mp4` tests need the `ffmpeg` and `ffprobe` programs
//! (`.ci/run` installs them): without them they are skipped with a note, except under
//! `CI=true`, where they fail. The `.gif`, `.apng` and `.png` tests need no other program.

use std::path::{Path, PathBuf};
use std::process::Command;

use raytrace_core::image::COLOUR;
use raytrace_io::{linear_to_srgb8, read_exr_colour};

use crate::common;
use common::{ok, run, text};

const BIN: &str = env!("CARGO_BIN_EXE_raytrace");

/// A 5-frame shot at 23.976 fps (24000/1001) of odd size, 65x37: a large saturated red sphere
/// sliding over a green ground (colours on which a wrong YUV matrix shows), smooth enough at
/// 16 samples for a lossy codec to be compared with.
const SHOT: &str = r#"
[shot]
fps = 23.976
frames = 5
shutter_angle = 180.0
[output]
path = "f/shot_####.png"
width = 65
height = 37
[render]
samples = 16
max_depth = 6
seed = 1
[camera]
look_from = [0.0, 1.0, 5.0]
look_at = [0.0, 0.5, 0.0]
vfov = 40.0
[[sphere]]
center = [0.0, -100.0, 0.0]
radius = 100.0
material = { type = "lambertian", albedo = [0.1, 0.5, 0.15] }
[[sphere]]
center = [-0.3, 1.0, 0.0]
radius = 1.0
material = { type = "lambertian", albedo = [0.9, 0.05, 0.05] }
velocity = [4.0, 0.0, 0.0]
"#;

const W: usize = 65;
const H: usize = 37;
const FRAMES: usize = 5;

/// A folder with the shot rendered as PNG (`f/shot_####.png`) and EXR (`e/shot_####.exr`).
fn rendered() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("shot.toml"), SHOT).unwrap();
    ok(d.path(), &["render", "shot.toml", "-q"]);
    ok(
        d.path(),
        &["render", "shot.toml", "-q", "-o", "e/shot_####.exr"],
    );
    d
}

/// The 8-bit RGB bytes of a PNG frame.
fn png_frame(d: &Path, frame: usize) -> Vec<u8> {
    image::open(d.join(format!("f/shot_{frame:04}.png")))
        .unwrap()
        .into_rgb8()
        .into_raw()
}

/// Every file in `dir` (hidden temporary files included), sorted.
fn listing(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

/// The exact frame start in hundredths rounded half up, computed in floating point: an
/// independent check of the integer rounding the GIF writer uses.
fn gif_start(i: usize) -> u64 {
    (i as f64 * 100.0 * 1001.0 / 24000.0 + 0.5).floor() as u64
}

#[test]
fn gif_has_every_frame_with_delays_that_add_up_to_the_shot() {
    use image::AnimationDecoder;
    let d = rendered();
    let out = ok(d.path(), &["clip", "shot.toml", "c/shot.gif"]);
    assert!(
        out.contains("5 frames, 65x37 at 24000/1001 fps, 0.209 s"),
        "{out}"
    );
    let file = std::fs::File::open(d.path().join("c/shot.gif")).unwrap();
    let decoder = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(file)).unwrap();
    let frames = decoder.into_frames().collect_frames().unwrap();
    assert_eq!(frames.len(), FRAMES);
    let mut total_ms = 0;
    for (i, f) in frames.iter().enumerate() {
        let (num, den) = f.delay().numer_denom_ms();
        let ms = num / den;
        assert_eq!(
            ms as u64,
            10 * (gif_start(i + 1) - gif_start(i)),
            "frame {i}"
        );
        total_ms += ms;
        assert_eq!(f.buffer().dimensions(), (W as u32, H as u32));
        // 256 colours a frame: close to the frame, not equal.
        let want = png_frame(d.path(), i + 1);
        let got: Vec<u8> = f
            .buffer()
            .pixels()
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        let mean_abs = want
            .iter()
            .zip(&got)
            .map(|(a, b)| (*a as f64 - *b as f64).abs())
            .sum::<f64>()
            / want.len() as f64;
        assert!(mean_abs < 4.0, "frame {i}: {mean_abs}");
    }
    // 5 frames of 1001/24000 s: 20.85 hundredths, 21 rounded.
    assert_eq!(total_ms, 210);
}

/// An APNG frame: its delay (numerator, denominator) and its 8-bit RGB bytes.
type ApngFrame = ((u16, u16), Vec<u8>);

/// The frame count an APNG file declares, and its frames.
fn read_apng(path: &Path) -> (u32, Vec<ApngFrame>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let actl = reader.info().animation_control.expect("an animated PNG");
    let mut frames = Vec::new();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    for _ in 0..actl.num_frames {
        let info = reader.next_frame(&mut buf).unwrap();
        let fctl = reader.info().frame_control.expect("a frame control chunk");
        assert_eq!((fctl.width, fctl.height), (W as u32, H as u32));
        frames.push((
            (fctl.delay_num, fctl.delay_den),
            buf[..info.buffer_size()].to_vec(),
        ));
    }
    (actl.num_frames, frames)
}

#[test]
fn apng_holds_the_frames_exactly_with_exact_delays_from_png_or_exr() {
    let d = rendered();
    ok(d.path(), &["clip", "shot.toml", "shot.apng"]);
    ok(
        d.path(),
        &[
            "clip",
            "shot.toml",
            "exr.apng",
            "--input",
            "e/{scene}_####.exr",
        ],
    );
    ok(
        d.path(),
        &[
            "clip",
            "shot.toml",
            "bright.apng",
            "--input",
            "e/shot_####.exr",
            "--exposure",
            "1",
            "--frames",
            "2-3",
        ],
    );
    let (n, frames) = read_apng(&d.path().join("shot.apng"));
    assert_eq!(n as usize, FRAMES);
    for (i, (delay, rgb)) in frames.iter().enumerate() {
        assert_eq!(*delay, (1001, 24000), "frame {i}");
        assert_eq!(*rgb, png_frame(d.path(), i + 1), "frame {i}");
    }
    // EXR frames are shown as the PNG output shows them: the same bytes.
    let (_, from_exr) = read_apng(&d.path().join("exr.apng"));
    assert_eq!(from_exr, frames);
    // One stop brighter: each linear value doubled, then the exact sRGB curve.
    let (n, bright) = read_apng(&d.path().join("bright.apng"));
    assert_eq!(n, 2);
    for (k, frame) in [2, 3].into_iter().enumerate() {
        let linear = read_exr_colour(&d.path().join(format!("e/shot_{frame:04}.exr"))).unwrap();
        let want: Vec<u8> = linear
            .interleaved(COLOUR)
            .unwrap()
            .into_iter()
            .map(|v| linear_to_srgb8((2.0 * v as f64) as f32))
            .collect();
        assert_eq!(bright[k].1, want, "frame {frame}");
        assert_ne!(bright[k].1, frames[frame - 1].1);
    }
    // Exposure means nothing to 8-bit PNG frames.
    let o = run(
        d.path(),
        &["clip", "shot.toml", "x.apng", "--exposure", "1"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(!d.path().join("x.apng").exists());
}

#[test]
fn contact_sheet_shows_each_frame_whole_in_a_grid() {
    let d = rendered();
    ok(d.path(), &["clip", "shot.toml", "sheet.png"]);
    let sheet = image::open(d.path().join("sheet.png")).unwrap().into_rgb8();
    // 5 frames: 3 columns, 2 rows; cells of the frame's size (wider than a label "5") and
    // 16 rows of label, 4 pixels apart and around.
    let (cw, ch) = (W as u32, H as u32 + 16);
    assert_eq!(sheet.dimensions(), (3 * (cw + 4) + 4, 2 * (ch + 4) + 4));
    for frame in 1..=FRAMES {
        let (col, row) = ((frame as u32 - 1) % 3, (frame as u32 - 1) / 3);
        let (x0, y0) = (4 + col * (cw + 4), 4 + row * (ch + 4));
        let want = png_frame(d.path(), frame);
        for y in 0..H as u32 {
            for x in 0..W as u32 {
                let i = ((y as usize * W) + x as usize) * 3;
                assert_eq!(
                    sheet.get_pixel(x0 + x, y0 + y).0,
                    want[i..i + 3],
                    "frame {frame}"
                );
            }
        }
        // Its label: some ink (near white) under the frame.
        let ink = (0..cw)
            .flat_map(|x| (H as u32..ch).map(move |y| (x, y)))
            .filter(|&(x, y)| sheet.get_pixel(x0 + x, y0 + y).0 == [235; 3])
            .count();
        assert!(ink > 10, "frame {frame}: {ink}");
    }
}

#[test]
fn a_missing_frame_is_named_and_nothing_is_written() {
    let d = rendered();
    std::fs::remove_file(d.path().join("f/shot_0003.png")).unwrap();
    std::fs::write(d.path().join("e/shot_0004.exr"), b"").unwrap();
    let before = listing(d.path());
    for clip in ["c.gif", "c.apng", "c.png", "c.mp4"] {
        let o = run(d.path(), &["clip", "shot.toml", clip]);
        assert_eq!(o.status.code(), Some(2), "{clip}: {}", text(&o));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("frame 3 is missing: f/shot_0003.png"), "{err}");
    }
    let o = run(
        d.path(),
        &["clip", "shot.toml", "c.gif", "--input", "e/shot_####.exr"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("frame 4: e/shot_0004.exr is not a complete frame (0 bytes)"));
    // Frames that are there make a clip.
    let o = run(d.path(), &["clip", "shot.toml", "c.txt"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains(".mp4, .gif, .apng or .png"),
        "{}",
        text(&o)
    );
    assert_eq!(listing(d.path()), before);
    ok(
        d.path(),
        &["clip", "shot.toml", "c.gif", "--frames", "1-2,4-5"],
    );
}

#[test]
fn render_makes_the_clip_of_clip_flag_or_scene_after_the_frames() {
    let d = tempfile::tempdir().unwrap();
    let with_clip = SHOT.replace("width = 65", "clip = \"c/{scene}.apng\"\nwidth = 65");
    std::fs::write(d.path().join("shot.toml"), &with_clip).unwrap();
    let out = ok(d.path(), &["render", "shot.toml"]);
    assert!(
        out.lines()
            .last()
            .unwrap()
            .starts_with("clip c/shot.apng: 5 frames"),
        "{out}"
    );
    let (n, _) = read_apng(&d.path().join("c/shot.apng"));
    assert_eq!(n, 5);
    // --clip replaces it; --frames picks the clip's frames too.
    ok(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--clip",
            "x.apng",
            "--frames",
            "1-2",
            "-q",
        ],
    );
    assert_eq!(read_apng(&d.path().join("x.apng")).0, 2);
    // One chunk cannot make the clip: refused, naming --no-clip, before anything is written;
    // with --no-clip it renders its frames and leaves the clip to a later `raytrace clip`.
    let chunk = [
        "render",
        "shot.toml",
        "--chunk-size",
        "2",
        "--chunk",
        "0",
        "-o",
        "k/f_#.png",
    ];
    let out = run(d.path(), &chunk);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("[output] clip") && err.contains("--no-clip"),
        "{err}"
    );
    assert!(!d.path().join("k").exists());
    let out = ok(d.path(), &[&chunk[..], &["--no-clip"]].concat());
    assert!(!out.contains("shot.apng"), "{out}");
    assert!(d.path().join("k/f_1.png").exists() && d.path().join("k/f_2.png").exists());
    // A bad [output] clip is a scene error.
    std::fs::write(
        d.path().join("bad.toml"),
        SHOT.replace("width = 65", "clip = \"c.avi\"\nwidth = 65"),
    )
    .unwrap();
    let o = run(d.path(), &["render", "bad.toml", "-o", "bad/f_#.png"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o)
            .contains("output.clip \"c.avi\": the file name must end in .mp4, .gif, .apng or .png"),
        "{}",
        text(&o)
    );
    assert!(!d.path().join("bad").exists());
}

/// A fake `ffmpeg` that answers `-version` and fails every encoding with a message.
fn failing_ffmpeg(dir: &Path) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let bin = dir.join("bin");
    std::fs::create_dir(&bin).unwrap();
    let script = bin.join("ffmpeg");
    std::fs::write(
        &script,
        "#!/bin/sh\n[ \"$1\" = -version ] && exit 0\necho 'Unknown encoder libx264' >&2\nexit 8\n",
    )
    .unwrap();
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
    bin
}

#[test]
fn an_absent_or_failing_ffmpeg_is_exit_1_with_its_message_and_no_file() {
    let d = rendered();
    let before = listing(d.path());
    let o = Command::new(BIN)
        .args(["clip", "shot.toml", "c/shot.mp4"])
        .current_dir(d.path())
        .env("PATH", "/nonexistent")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("ffmpeg") && err.contains(".gif, .apng or .png"),
        "{err}"
    );
    assert_eq!(listing(d.path()), before);
    let bin = failing_ffmpeg(d.path());
    let before = listing(d.path());
    let o = Command::new(BIN)
        .args(["clip", "shot.toml", "c/shot.mp4"])
        .current_dir(d.path())
        .env("PATH", &bin)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("ffmpeg failed") && err.contains("Unknown encoder libx264"),
        "{err}"
    );
    // No clip, no temporary file, no folder made for it.
    assert_eq!(listing(d.path()), before);
}

/// Whether `ffmpeg` and `ffprobe` run; without them a test is skipped with a note, except
/// under CI=true, where it fails.
fn have_ffmpeg() -> bool {
    let runs = |p: &str| {
        Command::new(p)
            .arg("-version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if runs("ffmpeg") && runs("ffprobe") {
        return true;
    }
    let msg = "ffmpeg and ffprobe are needed for the .mp4 test (Debian: apt-get install ffmpeg)";
    if std::env::var("CI").as_deref() == Ok("true") {
        panic!("CI=true but {msg}");
    }
    eprintln!("skipped: {msg}");
    false
}

#[test]
fn mp4_has_the_shots_frames_at_its_exact_rate_and_decodes_close_to_them() {
    if !have_ffmpeg() {
        return;
    }
    let d = rendered();
    let out = ok(d.path(), &["clip", "shot.toml", "c/shot.mp4"]);
    assert!(out.contains("at 24000/1001 fps"), "{out}");
    let probe = Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0", "-count_frames", "-show_entries"])
        .arg("stream=codec_name,pix_fmt,width,height,r_frame_rate,nb_read_frames,duration,color_space,color_primaries,color_transfer:format=duration")
        .args(["-of", "default=noprint_wrappers=1"])
        .arg(d.path().join("c/shot.mp4"))
        .output()
        .unwrap();
    assert!(probe.status.success(), "{}", text(&probe));
    let info = String::from_utf8_lossy(&probe.stdout).into_owned();
    let field = |k: &str| {
        info.lines()
            .find_map(|l| l.strip_prefix(&format!("{k}=")))
            .unwrap_or_else(|| panic!("{k} in {info}"))
            .to_string()
    };
    assert_eq!(field("codec_name"), "h264");
    assert_eq!(field("pix_fmt"), "yuv420p");
    // 65x37 padded to even sides.
    assert_eq!(
        (field("width"), field("height")),
        ("66".into(), "38".into())
    );
    assert_eq!(field("r_frame_rate"), "24000/1001");
    assert_eq!(field("nb_read_frames"), "5");
    for k in ["color_space", "color_primaries", "color_transfer"] {
        assert_eq!(field(k), "bt709", "{k}");
    }
    let duration: f64 = field("duration").parse().unwrap();
    assert!(
        (duration - 5.0 * 1001.0 / 24000.0).abs() < 1e-3,
        "{duration}"
    );
    // Frame 3 decoded back (ffmpeg honours the BT.709 tag) against the PNG frame.
    let decoded = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(d.path().join("c/shot.mp4"))
        .args(["-f", "rawvideo", "-pix_fmt", "rgb24", "-"])
        .output()
        .unwrap();
    assert!(decoded.status.success(), "{}", text(&decoded));
    let (pw, ph) = (66, 38);
    assert_eq!(decoded.stdout.len(), FRAMES * pw * ph * 3);
    let frame = &decoded.stdout[2 * pw * ph * 3..3 * pw * ph * 3];
    let want = png_frame(d.path(), 3);
    let (mut abs, mut bias) = (0.0, [0.0; 3]);
    for y in 0..H {
        for x in 0..W {
            for c in 0..3 {
                let e = frame[(y * pw + x) * 3 + c] as f64 - want[(y * W + x) * 3 + c] as f64;
                abs += e.abs();
                bias[c] += e;
            }
        }
    }
    let n = (W * H) as f64;
    // H.264 at CRF 18 with chroma at half resolution: about 4 levels per pixel on this
    // small frame's sharp edges, the mean shifted by at most 1.5 levels. Encoded with the
    // BT.601 matrix under the BT.709 tag instead, the same frame is 7.2 levels off and its
    // green 6.1 lower; in full range under a limited-range tag, 9.7 off and green 7.3 higher.
    assert!(abs / (3.0 * n) < 5.5, "mean abs error {}", abs / (3.0 * n));
    for (c, b) in bias.iter().enumerate() {
        assert!((b / n).abs() < 3.0, "channel {c}: mean error {}", b / n);
    }
}

#[test]
fn a_frame_of_another_size_is_refused_midway_and_nothing_is_written() {
    let d = rendered();
    ok(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--frames",
            "4",
            "--width",
            "20",
            "-q",
        ],
    );
    let before = listing(d.path());
    let mut clips = vec!["c.gif", "c.apng", "c.png"];
    if have_ffmpeg() {
        // Frames 1-3 are already in ffmpeg when frame 4 is read: it is stopped.
        clips.push("c.mp4");
    }
    for clip in clips {
        let o = run(d.path(), &["clip", "shot.toml", clip]);
        assert_eq!(o.status.code(), Some(2), "{clip}: {}", text(&o));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(
                "frame 4: f/shot_0004.png: the frame is 20x37, and the clip's first frame 65x37"
            ),
            "{clip}: {err}"
        );
        assert_eq!(listing(d.path()), before, "{clip}");
    }
}
