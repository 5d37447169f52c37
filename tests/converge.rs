//! `raytrace converge` end to end: the measurement is honest (the independent sampler's error
//! falls exactly as 1/samples), the estimate from the pixels' replicates tracks the true error
//! for both samplers, and a reference written once gives the same figures when reused.

use std::path::Path;
use std::process::Command;

mod common;
use common::run_ok as run;

const BIN: &str = env!("CARGO_BIN_EXE_raytrace");

/// A small scene with what a frame usually holds: a moving sphere, a lens, diffuse, metal and
/// glass.
const SCENE: &str = r#"
[shot]
fps = 24.0
frames = 1
shutter_angle = 180.0
[output]
width = 48
height = 32
[render]
samples = 16
max_depth = 10
seed = 11
[camera]
look_from = [0.0, 1.0, 4.0]
look_at = [0.0, 0.5, 0.0]
vfov = 45.0
aperture = 0.1
[[sphere]]
center = [0.0, -100.0, 0.0]
radius = 100.0
material = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
[[sphere]]
center = [-1.1, 0.5, 0.0]
radius = 0.5
material = { type = "lambertian", albedo = [0.7, 0.2, 0.1] }
velocity = [0.0, 6.0, 0.0]
[[sphere]]
center = [0.0, 0.5, 0.0]
radius = 0.5
material = { type = "dielectric", ior = 1.5 }
[[sphere]]
center = [1.1, 0.5, 0.0]
radius = 0.5
material = { type = "metal", albedo = [0.8, 0.8, 0.8], fuzz = 0.3 }
"#;

/// One CSV row: sampler, samples, and the numeric columns by name.
struct Row {
    sampler: String,
    samples: f64,
    mse: f64,
    rmse: f64,
    estimated_rmse: Option<f64>,
}

fn read_csv(path: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let num = |name: &str| f[col(name)].parse::<f64>().ok();
            Row {
                sampler: f[col("sampler")].to_string(),
                samples: num("samples").unwrap(),
                mse: num("mse").unwrap(),
                rmse: num("rmse").unwrap(),
                estimated_rmse: num("estimated_rmse"),
            }
        })
        .collect()
}

/// Least-squares slope of ln y against ln x.
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (lx, ly): (Vec<f64>, Vec<f64>) = points.iter().map(|(x, y)| (x.ln(), y.ln())).unzip();
    let mx = lx.iter().sum::<f64>() / n;
    let my = ly.iter().sum::<f64>() / n;
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = lx.iter().map(|x| (x - mx).powi(2)).sum();
    sxy / sxx
}

#[test]
fn independent_error_falls_as_one_over_samples_and_its_estimate_tracks_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    let out = run(
        d,
        &[
            "converge",
            "s.toml",
            "--sampler",
            "independent",
            "--reference-samples",
            "8192",
            "--max-samples",
            "256",
            "--csv",
            "c.csv",
            "--plot",
            "c.svg",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("independent: MSE slope"), "{stdout}");
    let rows = read_csv(&d.join("c.csv"));
    let samples: Vec<f64> = rows.iter().map(|r| r.samples).collect();
    assert_eq!(
        samples,
        [1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0]
    );
    assert!(rows.iter().all(|r| r.sampler == "independent"));
    // Independent samples: MSE = variance / samples, a slope of -1 on log-log axes.
    let s = slope(&rows.iter().map(|r| (r.samples, r.mse)).collect::<Vec<_>>());
    assert!((s + 1.0).abs() < 0.1, "slope {s}");
    // The estimate from the pixels' replicates (no reference) is within 25 percent of
    // the RMSE against the reference, from 2 samples up (1 sample has no variance).
    assert!(rows[0].estimated_rmse.is_none());
    for r in &rows[1..] {
        let ratio = r.estimated_rmse.unwrap() / r.rmse;
        assert!(
            (0.75..=1.25).contains(&ratio),
            "{} samples: {ratio}",
            r.samples
        );
    }
    // The reference was written for reuse, and the plot drawn.
    assert!(d.join("s_frame1_reference_8192spp.exr").is_file());
    let svg = std::fs::read_to_string(d.join("c.svg")).unwrap();
    assert!(svg.contains("independent"));
}

#[test]
fn a_reused_reference_gives_the_same_errors_and_both_samplers_are_measured() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    let common = ["converge", "s.toml", "--max-samples", "8", "--threads", "2"];
    let first = [
        &common[..],
        &[
            "--reference-samples",
            "256",
            "--write-reference",
            "ref.exr",
            "--csv",
            "a.csv",
        ],
    ]
    .concat();
    run(d, &first);
    let second = [&common[..], &["--reference", "ref.exr", "--csv", "b.csv"]].concat();
    let out = run(d, &second);
    let (a, b) = (read_csv(&d.join("a.csv")), read_csv(&d.join("b.csv")));
    assert_eq!(a.len(), 8);
    let key = |r: &Row| (r.sampler.clone(), r.samples, r.mse.to_bits());
    assert_eq!(
        a.iter().map(key).collect::<Vec<_>>(),
        b.iter().map(key).collect::<Vec<_>>()
    );
    let samplers: Vec<&str> = a.iter().map(|r| r.sampler.as_str()).collect();
    assert_eq!(samplers.iter().filter(|s| **s == "sobol").count(), 4);
    assert_eq!(samplers.iter().filter(|s| **s == "independent").count(), 4);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("equal time: independent MSE / sobol MSE"),
        "{stdout}"
    );
}

#[test]
fn bad_converge_arguments_exit_2_and_write_nothing() {
    let cases: &[&[&str]] = &[
        &["--reference", "missing.exr"],
        &["--plot", "p.jpg"],
        &["--max-samples", "0"],
        &["--budget", "-1"],
        &["--frame", "5"],
        &["--sampler", "halton"],
        &["--reference", "r.exr", "--reference-samples", "4"],
    ];
    for args in cases {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("s.toml"), SCENE).unwrap();
        let mut all = vec!["converge", "s.toml"];
        all.extend_from_slice(args);
        let o = Command::new(BIN)
            .args(&all)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let msg = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {msg}");
        assert!(!msg.contains("panicked"), "{msg}");
        let n = std::fs::read_dir(dir.path()).unwrap().count();
        assert_eq!(n, 1, "{args:?} wrote files");
    }
    // A reference of another size.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    run(
        d,
        &[
            "render",
            "s.toml",
            "--width",
            "8",
            "--height",
            "8",
            "-o",
            "small.exr",
        ],
    );
    let o = Command::new(BIN)
        .args(["converge", "s.toml", "--reference", "small.exr"])
        .current_dir(d)
        .output()
        .unwrap();
    let msg = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{msg}");
    assert!(msg.contains("small.exr") && msg.contains("8x8"), "{msg}");
}

#[test]
fn the_printed_error_is_within_15_percent_of_the_true_one_for_both_samplers() {
    use raytrace::analysis::metrics::rel_mse;
    use raytrace::renderer::{FrameJob, ShotGeometry};
    let render = |sampler: &str, samples: u32, seed: u64| {
        let mut scene = common::scene(SCENE);
        scene.render.sampler = sampler.parse().unwrap();
        scene.render.samples = samples;
        scene.render.seed = seed;
        let statics = ShotGeometry::cpu(&scene);
        FrameJob::new(&scene, 1).sample(&statics).unwrap()
    };
    // The reference's own error (from its replicates) is taken out of the measured one:
    // E[(v - ref)^2] = E[(v - truth)^2] + E[(ref - truth)^2] for independent renders.
    let reference = render("independent", 4096, 1234);
    let reference_mse = reference.stats.relative_error.powi(2);
    let reference = reference.film.means();
    for sampler in ["independent", "sobol"] {
        for samples in [16, 64] {
            // Squares summed over 8 seeds: one 48x32 frame's estimate and error both
            // scatter by about 15 percent on their own (a few dark, noisy pixels dominate
            // a relative error).
            let (mut estimated, mut truth) = (0.0, 0.0);
            for seed in 0..8 {
                let r = render(sampler, samples, seed);
                estimated += r.stats.relative_error.powi(2);
                truth += rel_mse(&r.film.means(), &reference) - reference_mse;
            }
            // Measured: independent 1.03 and 1.05, sobol 1.00 and 1.02.
            let ratio = (estimated / truth).sqrt();
            assert!(
                (0.85..=1.15).contains(&ratio),
                "{sampler} at {samples} samples: estimate / true error {ratio}"
            );
        }
    }
}
