//! The GPU's pipeline cache on disk (`RAYTRACE_GPU_CACHE`): written where the adapter has one,
//! and never a change to a frame's bits, whether the file is missing, present, corrupt or its
//! directory unusable (lavapipe where CI runs; under `CI=true` a missing adapter fails).

use crate::common::{gpu, text};

use std::path::Path;
use std::process::{Command, Output};

/// A small scene on the GPU, its one frame an EXR.
const SCENE: &str = "[output]\npath = \"f_####.exr\"\nwidth = 24\nheight = 12\n\
                     [render]\nsamples = 4\ndevice = \"gpu\"\n";

/// Renders `s.toml` in `dir` with `--stats` and the cache in `cache`; the run's output and
/// the frame's bytes.
fn render(dir: &Path, cache: &Path) -> (Output, Vec<u8>) {
    let frame = dir.join("f_0001.exr");
    let _ = std::fs::remove_file(&frame);
    let o = Command::new(env!("CARGO_BIN_EXE_raytrace"))
        .args(["render", "s.toml", "--stats"])
        .current_dir(dir)
        .env(raytrace_gpu::CACHE_VARIABLE, cache)
        .output()
        .expect("run raytrace");
    assert!(o.status.success(), "{}", text(&o));
    let bytes = std::fs::read(&frame).expect("the frame");
    (o, bytes)
}

/// The `gpu:` line's account of the cache: `cache hit`, `cold` or `no cache`.
fn cache_use(o: &Output) -> &'static str {
    let all = text(o);
    let line = all
        .lines()
        .find(|l| l.starts_with("gpu: ") && l.contains("start-up "))
        .unwrap_or_else(|| panic!("no start-up on the gpu: line: {all}"));
    ["cache hit", "cold", "no cache"]
        .into_iter()
        .find(|u| line.ends_with(&format!("{u})")))
        .unwrap_or_else(|| panic!("no cache use: {line}"))
}

/// Checks the `gpu:` line's start-up: what the run paid is the device and the wait for the
/// tracer, which compiled on its own thread beside the shot's build (so the wait is at most
/// the compilation), and it is said before the first frame's line.
fn check_startup(o: &Output) {
    let all = text(o);
    let line = all
        .lines()
        .position(|l| l.starts_with("gpu: "))
        .unwrap_or_else(|| panic!("no gpu: line: {all}"));
    let first_frame = all.lines().position(|l| l.starts_with("frame ")).unwrap();
    assert!(line < first_frame, "{all}");
    let line = all.lines().nth(line).unwrap();
    // The number before each of the line's words.
    let seconds = |before: &str| -> f64 {
        let at = line
            .find(before)
            .unwrap_or_else(|| panic!("no {before:?}: {line}"));
        let number = line[at + before.len()..].split(' ').next().unwrap();
        number
            .parse()
            .unwrap_or_else(|_| panic!("{number:?}: {line}"))
    };
    let paid = seconds("start-up ");
    let device = seconds("adapter and device ");
    let pipelines = seconds("pipelines ");
    let waited = line
        .split(", ")
        .find(|part| part.ends_with(" s of them waited for"))
        .and_then(|part| part.split(' ').next())
        .and_then(|n| n.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no wait: {line}"));
    // Each figure is rounded to a millisecond.
    assert!((paid - (device + waited)).abs() <= 0.0015, "{line}");
    assert!(waited <= pipelines + 0.0015 && pipelines > 0.0, "{line}");
}

/// `n` bytes of a fixed pseudo-random sequence (a 64-bit LCG, Knuth's MMIX constants).
fn noise(n: usize) -> Vec<u8> {
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..n)
        .map(|_| {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (x >> 56) as u8
        })
        .collect()
}

#[test]
fn the_pipeline_cache_is_written_and_never_changes_a_frame() {
    let Some(gpu) = gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), SCENE).unwrap();
    let cache = dir.path().join("cache");

    // No file: a cold start, and (where the adapter has a cache: Vulkan) the file written.
    let (o, cold) = render(dir.path(), &cache);
    check_startup(&o);
    let files: Vec<_> = std::fs::read_dir(&cache)
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    if gpu.describe().contains("(vulkan, ") {
        assert_eq!(cache_use(&o), "cold", "{}", text(&o));
        assert_eq!(files.len(), 1, "{files:?}");
        let name = files[0].file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            name.starts_with("tracer-wgpu_pipeline_cache_vulkan_") && name.ends_with(".bin"),
            "{name}"
        );
        assert!(std::fs::metadata(&files[0]).unwrap().len() > 0);
    } else {
        assert_eq!(cache_use(&o), "no cache", "{}", text(&o));
        assert!(files.is_empty(), "{files:?}");
    }

    // The file present: the same bits.
    let (o, warm) = render(dir.path(), &cache);
    assert!(cold == warm, "a frame with the cache differs: {}", text(&o));

    // Every cache file random bytes: the same bits, no failure, a cold start.
    for f in &files {
        std::fs::write(f, noise(4096)).unwrap();
    }
    let (o, corrupt) = render(dir.path(), &cache);
    assert!(cold == corrupt, "a frame with a corrupt cache differs");
    if !files.is_empty() {
        assert_eq!(cache_use(&o), "cold", "{}", text(&o));
        // Rewritten from the device's own data.
        assert!(std::fs::read(&files[0]).unwrap() != noise(4096));
    }

    // A directory that cannot be made (under a file): no cache, a note, the same bits.
    let blocked = dir.path().join("s.toml").join("cache");
    let (o, without) = render(dir.path(), &blocked);
    assert!(cold == without, "a frame without a cache differs");
    assert_eq!(cache_use(&o), "no cache", "{}", text(&o));
    if !files.is_empty() {
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("note: the GPU's pipeline cache directory")
                && err.contains("RAYTRACE_GPU_CACHE"),
            "{err}"
        );
    }
}
