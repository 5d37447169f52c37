//! `converge --flicker`: bad ranges and options refused naming `--flicker`, and a sequence of
//! any length measured holding a frame or two, never the list of its frames.

use crate::common;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{peak_kib, run, text};

/// A one-sphere shot of `frames` frames at 4x4 pixels and 1 sample.
fn shot(frames: u64) -> String {
    format!(
        "[shot]\nframes = {frames}\n[output]\nwidth = 4\nheight = 4\n[render]\nsamples = 1\n\
         [camera]\nlook_from = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n\
         [[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\
         material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\n"
    )
}

#[test]
fn bad_ranges_and_a_reference_to_write_are_refused_naming_the_options() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("s.toml"), shot(4)).unwrap();
    for (args, words) in [
        (
            vec!["--flicker", "9-12"],
            vec!["--flicker 9-12", "outside the shot"],
        ),
        (vec!["--flicker", "2"], vec!["--flicker 2", "at least two"]),
        (
            vec!["--flicker", "1-2", "--write-reference", "a.exr", "b.exr"],
            vec!["--write-reference", "--flicker"],
        ),
    ] {
        let mut all = vec!["converge", "s.toml", "--quiet"];
        all.extend(&args);
        let o = run(d.path(), &all);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
        for w in words {
            assert!(text(&o).contains(w), "{args:?}: {w}: {}", text(&o));
        }
    }
    // Nothing was written.
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 1);
}

#[test]
fn a_sequence_of_four_billion_frames_is_measured_holding_a_frame_or_two() {
    // Every frame number of 1-4294967295 listed first was 16 GiB before the first frame.
    // Measured a frame at a time, the run renders on in a few MiB: it is stopped after three
    // seconds, still running, its peak memory far below a list of its frames.
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("s.toml"), shot(4_294_967_295)).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_raytrace"))
        .args([
            "converge",
            "s.toml",
            "--quiet",
            "--flicker",
            "1-4294967295",
            "--reference-samples",
            "1",
        ])
        .current_dir(d.path())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let mut peak = 0;
    while start.elapsed() < Duration::from_secs(3) {
        if let Some(status) = child.try_wait().unwrap() {
            let o = child.wait_with_output().unwrap();
            panic!(
                "ended with {status}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        peak = peak.max(peak_kib(child.id()));
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    let _ = child.wait();
    assert!(peak < 512 * 1024, "peak {peak} KiB");
}
