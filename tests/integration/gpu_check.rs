//! `contrib/gpu-check.sh`, the device checks of a clean clip and of scenes by size
//! (docs/gpu.md), run at their reduced size (`--quick`) on the GPU where CI runs (Mesa's
//! lavapipe): it renders every run, its table of totals has a row a run with the figures of
//! each, its table of scenes a row a scene with each device's figures, and its start-up's a
//! row a run, cold and warm. Without a GPU the test returns, except under `CI=true`.

use std::path::Path;
use std::process::Command;
use std::sync::OnceLock;

use crate::common;

/// The output of `contrib/gpu-check.sh --quick`, run once for the tests of its two tables;
/// panics, with the output, where the script fails.
fn quick_check() -> &'static str {
    static OUTPUT: OnceLock<String> = OnceLock::new();
    OUTPUT.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let o = Command::new("bash")
            .arg(root.join("contrib/gpu-check.sh"))
            .arg("--quick")
            .arg(env!("CARGO_BIN_EXE_raytrace"))
            .env_remove("OUT")
            .output()
            .unwrap();
        let t = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(o.status.success(), "{t}");
        t
    })
}

/// A row of one of the script's tables, split into its cells.
fn cells(row: &str) -> Vec<&str> {
    row.trim_matches('|').split('|').map(str::trim).collect()
}

/// The rows of the table in `text` whose header starts with `first`, split into cells.
fn table<'t>(text: &'t str, first: &str) -> Vec<Vec<&'t str>> {
    text.lines()
        .skip_while(|l| !l.starts_with(&format!("| {first} |")))
        .skip(2)
        .take_while(|l| l.starts_with("| "))
        .map(cells)
        .collect()
}

/// A cell's figure (a trailing `%` dropped); panics, with the script's output, where it is none.
fn number(cell: &str, output: &str) -> f64 {
    cell.trim_end_matches('%')
        .parse()
        .unwrap_or_else(|_| panic!("{cell:?} is not a figure: {output}"))
}

#[test]
fn the_gpu_check_renders_each_run_and_totals_its_figures() {
    if common::gpu().is_none() {
        return;
    }
    let t = quick_check();
    assert!(t.contains("device: gpu, adapter: "), "{t}");
    let rows = table(t, "run");
    let names: Vec<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(
        names,
        ["gpu-raw", "gpu-denoise", "gpu-temporal", "cpu-denoise"],
        "{t}"
    );
    let number = |cell: &str| number(cell, t);
    for row in &rows {
        let (name, frames) = (row[0], number(row[1]));
        // The clip's three frames, and the CPU's one; each printed above the table.
        let expected = if name.starts_with("gpu") { 3.0 } else { 1.0 };
        assert_eq!(frames, expected, "{name}: {t}");
        let section = t.split(&format!("== {name}:")).nth(1).unwrap();
        for frame in 1..=frames as u32 {
            assert!(
                section.contains(&format!("frame {frame} stats: ")),
                "{name}: {t}"
            );
        }
        // Wall time holds the render time; a denoised run spent some of it denoising.
        let (wall, render, denoising) = (number(row[2]), number(row[3]), number(row[4]));
        assert!(wall >= render && render > 0.0, "{name}: {t}");
        assert_eq!(
            denoising > 0.0,
            name.contains("denoise") || name.contains("temporal"),
            "{name}: {t}"
        );
        let busy = number(row[5]);
        assert!(busy > 0.0 && busy <= 100.0, "{name}: {t}");
        // The host's time a sample and the bytes read back are the GPU's figures.
        if name.starts_with("gpu") {
            assert!(number(row[6]) > 0.0 && number(row[7]) > 0.0, "{name}: {t}");
        } else {
            assert_eq!((row[6], row[7]), ("-", "-"), "{t}");
        }
        assert!(number(row[8]) > 0.0, "{name}: {t}");
    }
}

#[test]
fn the_gpu_check_renders_each_scene_on_each_device_side_by_side() {
    if common::gpu().is_none() {
        return;
    }
    let t = quick_check();
    assert!(t.contains("== scenes at 64x36"), "{t}");
    let rows = table(t, "scene");
    let names: Vec<(&str, &str)> = rows.iter().map(|r| (r[0], r[1])).collect();
    // The scenes cut down: 1e5, 1e6 and 1e7 spheres to 1e3, 2e3 and 4e3, 1e7 points
    // to 2e3; 64 samples to 4 and 16 to 2.
    assert_eq!(
        names,
        [
            ("books", "4"),
            ("spheres 1000", "4"),
            ("spheres 2000", "2"),
            ("spheres 4000", "2"),
            ("points 2000", "2"),
        ],
        "{t}"
    );
    for row in &rows {
        let name = row[0];
        // Each device's samples a second and whole-process wall time, the points' too.
        for at in [2, 4] {
            assert!(number(row[at], t) > 0.0, "{name}: {t}");
            assert!(number(row[at + 1], t) > 0.0, "{name}: {t}");
        }
        let busy = number(row[6], t);
        assert!(busy > 0.0 && busy <= 100.0, "{name}: {t}");
        assert!(number(row[7], t) > 0.0, "{name}: {t}");
    }
}

#[test]
fn the_gpu_check_times_the_start_up_cold_and_warm() {
    if common::gpu().is_none() {
        return;
    }
    let t = quick_check();
    let rows = table(t, "run");
    // The start-up's table is the second whose first header cell is `run`.
    let starts = table(
        t.split("== start-up").nth(1).expect("a start-up section"),
        "run",
    );
    assert!(rows.len() == 4 && starts.len() == 4, "{t}");
    let names: Vec<&str> = starts.iter().map(|r| r[0]).collect();
    assert_eq!(names, ["cold", "warm 1", "warm 2", "warm 3"], "{t}");
    for row in &starts {
        let [device, pipelines, waited, paid] = [1, 2, 3, 4].map(|at| number(row[at], t));
        // What the run paid is the device and the wait, which is at most the compilation;
        // each figure to a millisecond.
        assert!((paid - (device + waited)).abs() <= 0.0015, "{t}");
        assert!(waited <= pipelines + 0.0015 && pipelines > 0.0, "{t}");
        // The whole process holds its start-up.
        assert!(number(row[6], t) >= paid - 0.0015, "{t}");
        assert!(["cache hit", "cold", "no cache"].contains(&row[5]), "{t}");
    }
    // A new cache: nothing in it to take.
    assert_ne!(starts[0][5], "cache hit", "{t}");
}
