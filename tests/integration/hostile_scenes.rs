//! Hostile scene files. The shipped scenes are mutated at random, byte by byte (bit flips,
//! truncations, insertions, deletions) and value by value (lines duplicated or deleted,
//! values replaced by extreme numbers, strings, arrays of other lengths, tables), with a
//! fixed seed, and every result must either be refused with a located message (exit status
//! 2) or render, at 4x4 with 1 sample and depth 4, first and last frame, with finite pixels
//! (no sample dropped for not being finite). Never a panic. Then the binary on inputs that are not scene files at all.
//!
//! ```text
//! cargo test --release --test integration hostile_scenes:: -- --nocapture   # prints the counts and times
//! ```

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use raytrace_core::Scene;
use raytrace_core::renderer::{CpuShot, FrameJob};
use raytrace_scene::scene_file::SceneFile;

/// The shipped scenes, and one that uses every key of the format (camera keyframes and a
/// keyframed sphere, which no shipped scene has).
const SCENES: [(&str, &str); 7] = [
    ("every_key", EVERY_KEY),
    (
        "bouncing_spheres",
        include_str!("../../scenes/bouncing_spheres.toml"),
    ),
    ("defocus", include_str!("../../scenes/defocus.toml")),
    ("orbits", include_str!("../../scenes/orbits.toml")),
    ("quick", include_str!("../../scenes/quick.toml")),
    ("turntable", include_str!("../../scenes/turntable.toml")),
    ("propeller", include_str!("../../scenes/propeller.toml")),
];

const EVERY_KEY: &str = r#"
[shot]
fps = 4
frames = 3
first_frame = 2
start_time = 0.25
shutter_angle = 270
shutter_position = "end"
shutter_curve = [[0, 0], [0.25, 1], [0.75, 1], [1, 0]]
rolling_shutter = { readout = 0.05, direction = "bottom-to-top" }
[output]
path = "renders/every_key_####.png"
width = 16
height = 9
[render]
samples = 2
max_depth = 8
seed = 7
sampler = "independent"
[camera]
look_from = [0.0, 1.0, 4.0]
look_at = [0.0, 0.5, 0.0]
up = [0.0, 1.0, 0.0]
vfov = 40.0
aperture = 0.05
focus_distance = 4.0
keyframes = [ { time = 0.0 }, { time = 0.5, look_from = [2.0, 1.5, 3.0] }, { time = 1.0, look_at = [0.5, 0.0, 0.0] } ]
[background]
color = [0.9, 0.95, 1.0]
[materials]
ground = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
steel = { type = "metal", albedo = [0.8, 0.7, 0.6], fuzz = 0.2 }
glass = { type = "dielectric", ior = 1.5 }
[[sphere]]
center = [0.0, -100.5, 0.0]
radius = 100.0
material = "ground"
[[sphere]]
center = [-1.0, 0.0, 0.0]
radius = 0.5
material = "steel"
velocity = [0.5, 0.25, 0.0]
[[sphere]]
radius = 0.4
material = "glass"
keyframes = [ { time = 0.0, center = [1.0, 0.0, 0.0] }, { time = 1.0, center = [1.0, 1.0, 0.5] } ]
[[sphere]]
center = [0.0, 1.2, 0.0]
radius = 0.2
material = { type = "lambertian", albedo = [0.9, 0.2, 0.1] }
orbit = { pivot = [0.0, 0.5, 0.0], axis = [0.0, 1.0, 0.2], degrees_per_second = 90.0 }
"#;

/// The file name every message must start with.
const FILE: &str = "hostile.toml";

/// Cases per property: a few hundred, under a second each. `HOSTILE_CASES` and `HOSTILE_SEED`
/// run more, or others, when looking for trouble.
const CASES: u32 = 500;

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Bytes worth inserting: TOML's punctuation, line breaks, quotes, a NUL, a byte that is
/// never UTF-8, the start of a multi-byte character, a byte-order mark.
const BYTES: &[&[u8]] = &[
    b"[",
    b"]",
    b"{",
    b"}",
    b"=",
    b",",
    b".",
    b"\"",
    b"'",
    b"'''",
    b"\"\"\"",
    b"#",
    b"\n",
    b"\r",
    b"\t",
    b"\0",
    b"\xff",
    b"\xe2\x82",
    b"\xef\xbb\xbf",
    b"-",
    b"e",
    b"9",
    b"\\",
    b"[[sphere]]\n",
    b"\n[shot]\n",
    b"\n[camera]\n",
    b"x = 1\n",
];

/// Values put in place of a value of the file.
const VALUES: &[&str] = &[
    "nan",
    "-nan",
    "inf",
    "-inf",
    "0",
    "-0.0",
    "0.5",
    "1",
    "2",
    "2.5",
    "-1",
    "1e6",
    "1.0000001",
    "3.4e38",
    "3.5e38",
    "-3.4e38",
    "1e308",
    "-1e308",
    "1e400",
    "1e-300",
    "5e-324",
    "9223372036854775807",
    "-9223372036854775808",
    "18446744073709551615",
    "170141183460469231731687303715884105728",
    "\"x\"",
    "\"\"",
    "\"center\"",
    "\"lambertian\"",
    "\"a_####.png\"",
    "true",
    "1979-05-27",
    "[]",
    "[1]",
    "[1, 2]",
    "[0, 0, 0]",
    "[1, 2, 3, 4]",
    "[1e308, -1e308, 1e308]",
    "[3e38, 3e38, 3e38]",
    "[1e-300, 0, 0]",
    "[nan, 0, 0]",
    "[[1, 2, 3]]",
    "{}",
    "{ a = 1 }",
    "{ type = \"metal\", albedo = [1, 1, 1] }",
    "[{ time = 0 }, { time = 0 }]",
    "{ degrees_per_second = 1e308 }",
];

/// A place in a file, as a fraction of its length (so it fits any length, and shrinks toward
/// the start).
#[derive(Clone, Copy, Debug)]
struct Index(u64);

impl Index {
    fn index(self, size: usize) -> usize {
        ((self.0 as u128 * size as u128) >> 64) as usize
    }

    fn fraction(f: f64) -> Index {
        Index((f * 2f64.powi(64)) as u64)
    }
}

fn place() -> impl Strategy<Value = Index> {
    any::<u64>().prop_map(Index)
}

/// One change to a scene file's bytes.
#[derive(Clone, Debug)]
enum Mutation {
    Flip(Index, u8),
    Truncate(Index),
    Insert(Index, &'static [u8]),
    Delete(Index, usize),
    DuplicateLine(Index),
    DeleteLine(Index),
    /// The value at this index among the file's values, replaced.
    Replace(Index, &'static str),
}

fn byte_mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (place(), 0u8..8).prop_map(|(i, b)| Mutation::Flip(i, b)),
        place().prop_map(Mutation::Truncate),
        (place(), proptest::sample::select(BYTES)).prop_map(|(i, b)| Mutation::Insert(i, b)),
        (place(), 1usize..64).prop_map(|(i, n)| Mutation::Delete(i, n)),
    ]
}

fn value_mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (place(), proptest::sample::select(VALUES)).prop_map(|(i, v)| Mutation::Replace(i, v)),
        1 => place().prop_map(Mutation::DuplicateLine),
        1 => place().prop_map(Mutation::DeleteLine),
    ]
}

/// Byte ranges of the values written after `=`, or after `[` or `,` (array elements, and keys
/// of inline tables after the first): numbers, words, quoted strings, and one-line arrays and
/// inline tables. Header lines are skipped.
fn values(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut header = true;
    let mut prev = b'\n';
    for i in 0..text.len() {
        let c = text[i];
        if prev == b'\n' {
            header = c == b'[';
        }
        let starts = !header && matches!(prev, b'=' | b'[' | b',') && c != b' ';
        if c != b' ' {
            prev = c;
        }
        if !starts {
            continue;
        }
        let end = match c {
            b'"' => text[i + 1..]
                .iter()
                .position(|&c| c == b'"' || c == b'\n')
                .map(|j| i + j + 2),
            b'[' | b'{' => {
                let close = if c == b'[' { b']' } else { b'}' };
                let mut depth = 0i32;
                let mut end = None;
                for (j, &d) in text[i..].iter().enumerate() {
                    if d == b'\n' {
                        break;
                    } else if d == c {
                        depth += 1;
                    } else if d == close {
                        depth -= 1;
                        if depth == 0 {
                            end = Some(i + j + 1);
                            break;
                        }
                    }
                }
                end
            }
            _ if c.is_ascii_alphanumeric() || c == b'-' || c == b'+' => Some(
                i + text[i..]
                    .iter()
                    .position(|c| !(c.is_ascii_alphanumeric() || b"-+._:".contains(c)))
                    .unwrap_or(text.len() - i),
            ),
            _ => None,
        };
        if let Some(end) = end {
            out.push((i, end.min(text.len())));
        }
    }
    out
}

/// The start of each line.
fn lines(text: &[u8]) -> Vec<usize> {
    std::iter::once(0)
        .chain(
            text.iter()
                .enumerate()
                .filter(|(_, c)| **c == b'\n')
                .map(|(i, _)| i + 1),
        )
        .filter(|&i| i < text.len())
        .collect()
}

fn apply(text: &mut Vec<u8>, m: &Mutation) {
    let len = text.len().max(1);
    match m {
        Mutation::Flip(i, bit) => {
            if !text.is_empty() {
                let i = i.index(len);
                text[i] ^= 1 << bit;
            }
        }
        Mutation::Truncate(i) => text.truncate(i.index(len)),
        Mutation::Insert(i, b) => {
            let i = i.index(len + 1);
            text.splice(i..i, b.iter().copied());
        }
        Mutation::Delete(i, n) => {
            let i = i.index(len).min(text.len());
            let end = (i + n).min(text.len());
            text.drain(i..end);
        }
        Mutation::DuplicateLine(i) | Mutation::DeleteLine(i) => {
            let starts = lines(text);
            if starts.is_empty() {
                return;
            }
            let k = i.index(starts.len());
            let (a, b) = (starts[k], starts.get(k + 1).copied().unwrap_or(text.len()));
            if matches!(m, Mutation::DeleteLine(_)) {
                text.drain(a..b);
            } else {
                let line = text[a..b].to_vec();
                text.splice(b..b, line);
            }
        }
        Mutation::Replace(i, v) => {
            let spans = values(text);
            if spans.is_empty() {
                return;
            }
            let (a, b) = spans[i.index(spans.len())];
            text.splice(a..b, v.bytes());
        }
    }
}

/// What a mutated file gave.
#[derive(Default)]
struct Tally {
    refused: u32,
    rendered: u32,
}

/// The property: refused with a located message, or rendered with finite pixels.
fn check(text: &[u8], tally: &mut Tally) -> Result<(), TestCaseError> {
    match Scene::parse_bytes(text, Path::new(FILE)) {
        Err(e) => {
            prop_assert_eq!(e.exit_code(), 2);
            let msg = e.to_string();
            prop_assert!(located(&msg), "not located: {}", msg);
            for name in [
                "Raw",
                "internally tagged",
                "expected f64",
                "expected i64",
                "struct ",
            ] {
                prop_assert!(!msg.contains(name), "internal name in: {}", msg);
            }
            tally.refused += 1;
        }
        Ok(mut scene) => {
            scene.output.width = 4;
            scene.output.height = 4;
            scene.render.samples = 1;
            scene.render.max_depth = 4;
            let statics = CpuShot::new(&scene);
            let first = scene.shot.first_frame;
            for frame in [first, scene.shot.last_frame()] {
                let r = FrameJob::new(&scene, frame).sample(&statics).unwrap();
                for p in r.film.means() {
                    // Finite, and within the 32-bit floats frames are written in.
                    prop_assert!(
                        p.is_finite() && p.abs().max_element() <= f32::MAX as f64,
                        "frame {}: pixel {:?}",
                        frame,
                        p
                    );
                }
                // Not even a sample was dropped for not being finite.
                prop_assert_eq!(r.stats.non_finite, 0, "frame {}", frame);
            }
            tally.rendered += 1;
        }
    }
    Ok(())
}

/// `hostile.toml:3:7: ...` or `hostile.toml: sphere[2].radius ...`: the file, then a line
/// and column or the path of a field of the format.
fn located(msg: &str) -> bool {
    let Some(rest) = msg.strip_prefix(FILE) else {
        return false;
    };
    if let Some(rest) = rest.strip_prefix(':') {
        let mut parts = rest.splitn(3, ':');
        let line = parts.next().is_some_and(|l| l.parse::<u32>().is_ok());
        let col = parts.next().is_some_and(|c| c.parse::<u32>().is_ok());
        if line && col {
            return true;
        }
        let field = rest.trim_start();
        return [
            "shot",
            "output",
            "render",
            "camera",
            "background",
            "materials",
            "sphere",
        ]
        .iter()
        .any(|t| field.starts_with(t));
    }
    false
}

fn runner(seed: u8) -> TestRunner {
    let seed = env_or("HOSTILE_SEED", seed);
    let config = Config {
        cases: env_or("HOSTILE_CASES", CASES),
        failure_persistence: None,
        max_shrink_iters: 2000,
        ..Config::default()
    };
    TestRunner::new_with_rng(
        config,
        TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32]),
    )
}

fn run(name: &str, seed: u8, mutation: impl Strategy<Value = Mutation>) {
    let start = Instant::now();
    let strategy = (0..SCENES.len(), proptest::collection::vec(mutation, 1..4));
    let tally = std::cell::RefCell::new(Tally::default());
    let result = runner(seed).run(&strategy, |(scene, mutations)| {
        let mut text = SCENES[scene].1.as_bytes().to_vec();
        for m in &mutations {
            apply(&mut text, m);
        }
        check(&text, &mut tally.borrow_mut())
    });
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
    let t = tally.borrow();
    eprintln!(
        "[hostile] {name}: {} mutated scenes, {} refused with a located message, {} rendered with finite pixels, {:.2} s",
        t.refused + t.rendered,
        t.refused,
        t.rendered,
        start.elapsed().as_secs_f64()
    );
    // Both outcomes must be exercised, or the property says little.
    assert!(
        t.refused > 0 && t.rendered > 0,
        "{name}: {} refused, {} rendered",
        t.refused,
        t.rendered
    );
}

#[test]
fn byte_mutations_are_refused_with_a_place_or_render_finite() {
    run("bytes", 1, byte_mutation());
}

#[test]
fn value_mutations_are_refused_with_a_place_or_render_finite() {
    run("values", 2, value_mutation());
}

#[test]
fn the_mutations_reach_values_and_lines() {
    let text = b"[shot]\nfps = 24.0\n[camera]\nlook_from = [1, 2, 3]\nm = { a = \"x\" }\n";
    let spans: Vec<&str> = values(text)
        .iter()
        .map(|&(a, b)| std::str::from_utf8(&text[a..b]).unwrap())
        .collect();
    assert_eq!(
        spans,
        ["24.0", "[1, 2, 3]", "1", "2", "3", "{ a = \"x\" }", "\"x\""]
    );
    let mut t = text.to_vec();
    apply(&mut t, &Mutation::Replace(Index::fraction(0.0), "nan"));
    assert!(t.starts_with(b"[shot]\nfps = nan\n"));
    let mut t = text.to_vec();
    apply(&mut t, &Mutation::DuplicateLine(Index::fraction(0.2)));
    assert!(t.starts_with(b"[shot]\nfps = 24.0\nfps = 24.0\n"));
}

/// The largest colours the format allows: a mirror of albedo 1 in a background of 1e6 gives
/// pixels of at most 1e6, never infinity.
#[test]
fn the_brightest_scene_allowed_stays_finite() {
    let text = "[output]\nwidth = 8\nheight = 8\n[render]\nsamples = 4\nmax_depth = 50\n[background]\ncolor = [1e6, 1e6, 1e6]\n[camera]\nlook_from = [0, 0, 3]\nlook_at = [0, 0, 0]\n[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = { type = \"metal\", albedo = [1, 1, 1] }\n[[sphere]]\ncenter = [0, 0, -2.5]\nradius = 1\nmaterial = { type = \"metal\", albedo = [1, 1, 1] }\n";
    let scene = Scene::parse(text, Path::new(FILE)).unwrap();
    let statics = CpuShot::new(&scene);
    let r = FrameJob::new(&scene, 1).sample(&statics).unwrap();
    assert_eq!(r.stats.non_finite, 0);
    for p in r.film.means() {
        assert!(
            p.is_finite() && p.max_element() <= 1e6 * (1.0 + 1e-12),
            "{p:?}"
        );
    }
    for bad in [
        "[background]\ncolor = [3e38, 3e38, 3e38]\n",
        "[materials]\nm = { type = \"metal\", albedo = [3e38, 1, 1] }\n",
    ] {
        assert!(Scene::parse(bad, Path::new(FILE)).is_err(), "{bad}");
    }
}

/// The binary on inputs that are not scene files, or scenes that cannot be rendered: exit
/// status 2, a message that starts with the path, nothing written; never a wait or a panic.
#[test]
fn the_binary_refuses_what_is_not_a_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::os::unix::fs::symlink(d.join("loop_b.toml"), d.join("loop_a.toml")).unwrap();
    std::os::unix::fs::symlink(d.join("loop_a.toml"), d.join("loop_b.toml")).unwrap();
    std::fs::create_dir(d.join("folder.toml")).unwrap();
    let fifo = Command::new("mkfifo").arg(d.join("pipe.toml")).status();
    let long = format!("[camera]\nlook_from = [{}0]\n", "0, ".repeat(100_000));
    let files: &[(&str, &[u8])] = &[
        ("binary.toml", b"[shot]\nfps = 24\n\xff\xfe\x00\x01"),
        ("nul.toml", b"[shot]\nfps = 24\0\n"),
        ("long.toml", long.as_bytes()),
        (
            "through.toml",
            b"[shot]\nfps = 1\nstart_time = 0.5\nshutter = 0\n[camera]\nlook_from = [0, 0, 1]\nlook_at = [0, 0, 0]\nkeyframes = [{time = 0}, {time = 1, look_from = [0, 0, -1]}]\n",
        ),
    ];
    for (name, bytes) in files {
        std::fs::write(d.join(name), bytes).unwrap();
    }
    let mut cases = vec![
        ("folder.toml", "folder.toml: is a directory"),
        ("missing.toml", "missing.toml: No such file"),
        (
            "loop_a.toml",
            "loop_a.toml: Too many levels of symbolic links",
        ),
        ("/dev/zero", "/dev/zero: is a device"),
        (
            "binary.toml",
            "binary.toml:3:1: the file is not UTF-8 text: byte 0xFF",
        ),
        ("nul.toml", "nul.toml:2:9: control character U+0000"),
        (
            "long.toml",
            "long.toml:2:13: camera.look_from: expected an array of at most 4096 values",
        ),
        (
            "through.toml",
            "through.toml: camera.keyframes[0..1]: look_from meets look_at at t = 0.5 s",
        ),
    ];
    if fifo.is_ok_and(|s| s.success()) {
        cases.push(("pipe.toml", "pipe.toml: is a named pipe"));
    }
    for (arg, want) in cases {
        for args in [
            vec!["check", arg],
            vec!["render", arg, "--output", "out/f_#.png"],
        ] {
            let o = Command::new(env!("CARGO_BIN_EXE_raytrace"))
                .args(&args)
                .current_dir(d)
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
            assert!(
                stderr.starts_with(&format!("error: {want}")),
                "{args:?}: {stderr}"
            );
            assert!(!stderr.contains("panicked"), "{stderr}");
        }
    }
    assert!(
        !d.join("out").exists(),
        "a refused scene must write nothing"
    );
}
