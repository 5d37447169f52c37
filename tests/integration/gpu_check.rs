//! `contrib/gpu-check.sh`, the device check of a clean clip (docs/gpu.md), run at its reduced
//! size (`--quick`) on the GPU where CI runs (Mesa's lavapipe): it renders every run, and its
//! table of totals has a row a run with the figures of each. Without a GPU the test returns,
//! except under `CI=true`.

use std::path::Path;
use std::process::Command;

use crate::common;

/// A row of the script's totals table, split into its cells.
fn cells(row: &str) -> Vec<&str> {
    row.trim_matches('|').split('|').map(str::trim).collect()
}

#[test]
fn the_gpu_check_renders_each_run_and_totals_its_figures() {
    if common::gpu().is_none() {
        return;
    }
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
    assert!(t.contains("device: gpu, adapter: "), "{t}");
    let rows: Vec<Vec<&str>> = t
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| run") && !l.starts_with("| ---"))
        .map(cells)
        .collect();
    let names: Vec<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(
        names,
        ["gpu-raw", "gpu-denoise", "gpu-temporal", "cpu-denoise"],
        "{t}"
    );
    let number = |cell: &str| -> f64 {
        cell.trim_end_matches('%')
            .parse()
            .unwrap_or_else(|_| panic!("{cell:?} is not a figure: {t}"))
    };
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
