//! `raytrace converge` end to end: the measurement is honest (the independent sampler's error
//! falls exactly as 1/samples, on the cross-estimate that the references' noise does not
//! bias; plotted times never fall as samples grow), the cross-estimate is unbiased where the
//! truth is known, the estimate from the pixels' replicates tracks the true error for both
//! samplers, a pair of references written once gives the same figures when reused, and bad
//! input is refused before anything is rendered or written.

use std::path::Path;
use std::process::Command;

use crate::common;
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

/// One CSV row: its text columns, and its numeric columns by name (`None`: empty).
struct Row {
    series: String,
    sampler: String,
    values: std::collections::HashMap<String, Option<f64>>,
}

impl Row {
    fn get(&self, name: &str) -> Option<f64> {
        *self
            .values
            .get(name)
            .unwrap_or_else(|| panic!("no column {name}"))
    }

    fn num(&self, name: &str) -> f64 {
        self.get(name).unwrap_or_else(|| panic!("{name} is empty"))
    }
}

fn read_csv(path: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), header.len(), "{l}");
            let col = |name: &str| f[header.iter().position(|h| h == name).unwrap()].to_string();
            Row {
                series: col("series"),
                sampler: col("sampler"),
                values: header
                    .iter()
                    .zip(&f)
                    .map(|(h, v)| (h.clone(), v.parse::<f64>().ok()))
                    .collect(),
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
fn errors_fall_as_expected_and_plotted_times_never_fall() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    let out = run(
        d,
        &[
            "converge",
            "s.toml",
            "--reference-samples",
            "2048",
            "--max-samples",
            "256",
            "--seeds",
            "2",
            "--repeats",
            "3",
            "--csv",
            "c.csv",
            "--plot",
            "c.svg",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("independent: MSE slope"), "{stdout}");
    assert!(stdout.contains("time to a relative error"), "{stdout}");
    let rows = read_csv(&d.join("c.csv"));
    for sampler in ["independent", "sobol"] {
        let rows: Vec<&Row> = rows.iter().filter(|r| r.sampler == sampler).collect();
        let samples: Vec<f64> = rows.iter().map(|r| r.num("samples")).collect();
        assert_eq!(
            samples,
            [1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0]
        );
        assert!(
            rows.iter()
                .all(|r| r.series == sampler && r.num("seeds") == 2.0)
        );
        // The plotted times never fall as samples grow, and 256 samples take longer than 1.
        let seconds: Vec<f64> = rows.iter().map(|r| r.num("seconds")).collect();
        assert!(
            seconds.windows(2).all(|w| w[0] <= w[1]),
            "{sampler}: {seconds:?}"
        );
        assert!(seconds[8] > seconds[0], "{sampler}: {seconds:?}");
        assert!(rows.iter().all(|r| r.num("cpu_seconds") > 0.0));
        let mse: Vec<(f64, f64)> = rows
            .iter()
            .map(|r| (r.num("samples"), r.num("mse")))
            .collect();
        let rel: Vec<(f64, f64)> = rows
            .iter()
            .map(|r| (r.num("samples"), r.num("rel_mse")))
            .collect();
        let (s, r) = (slope(&mse), slope(&rel));
        match sampler {
            // Independent samples: MSE = variance / samples, a slope of -1 on log-log axes,
            // on the cross-estimate: the references' noise (1/8 of the last point's) would
            // bend a plain error against one of them towards a floor.
            "independent" => {
                assert!((s + 1.0).abs() < 0.1, "MSE slope {s}");
                assert!((r + 1.0).abs() < 0.1, "relative MSE slope {r}");
            }
            // Stratified samples: faster than independent ones (measured -1.22 to 64).
            _ => assert!(s < -1.05 && s > -1.6, "MSE slope {s}"),
        }
        // The estimate from the pixels' replicates (no reference) is within 25 percent of
        // the relative error against the truth, from 2 samples up (1 sample has none).
        assert!(rows[0].get("estimated_mse").is_none());
        for r in &rows[1..] {
            let ratio = (r.num("estimated_rel_mse") / r.num("rel_mse")).sqrt();
            assert!(
                (0.75..=1.25).contains(&ratio),
                "{sampler} at {} samples: {ratio}",
                r.num("samples")
            );
            assert!(r.num("flip") > 0.0 && r.num("flip") < rows[0].num("flip"));
        }
    }
    // The references were written for reuse, and the plot drawn with its guides.
    for name in ["a", "b"] {
        assert!(
            d.join(format!("s_frame1_reference_2048spp_{name}.exr"))
                .is_file()
        );
    }
    let svg = std::fs::read_to_string(d.join("c.svg")).unwrap();
    for text in ["independent (slope", "sobol (slope", "slope -1", "\n5%\n"] {
        assert!(svg.contains(text), "{text}");
    }
    let levels = std::fs::read_to_string(d.join("c_levels.csv")).unwrap();
    assert_eq!(levels.lines().count(), 1 + 2 * 3, "{levels}");
}

/// A furnace whose every pixel's distribution is known: the camera at the centre of a glass
/// sphere of index 3 in a uniform environment, two bounces at most. Every camera ray meets
/// the glass at normal incidence, where Schlick's reflectance is ((3 - 1) / (3 + 1))^2 = 1/4:
/// refracted (3 in 4), it leaves and sees the environment `C`; reflected, it crosses the
/// sphere and ends at the second bounce, black. A sample is `C` or 0, so the truth is `3C/4`
/// in every pixel and one sample's variance `3C^2/16`.
const FURNACE: &str = r#"
[shot]
frames = 1
[output]
width = 32
height = 24
[render]
samples = 16
max_depth = 2
seed = 5
[camera]
look_from = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
vfov = 60.0
[background]
color = [1.0, 0.5, 0.25]
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 2.0
material = { type = "dielectric", ior = 3.0 }
"#;

#[test]
fn the_cross_estimate_is_unbiased_where_the_truth_is_known() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("f.toml"), FURNACE).unwrap();
    // References of 64 samples: as noisy as a quarter of the 16-sample render's error, which
    // a plain error against one of them would add.
    run(
        d,
        &[
            "converge",
            "f.toml",
            "--sampler",
            "independent",
            "--reference-samples",
            "64",
            "--max-samples",
            "16",
            "--seeds",
            "16",
            "--repeats",
            "1",
            "--csv",
            "c.csv",
        ],
    );
    let colour = [1.0, 0.5, 0.25];
    for r in read_csv(&d.join("c.csv")) {
        let n = r.num("samples");
        // Per channel: the truth 3c/4, the variance of the mean of n samples 3c^2/(16 n).
        let truth_mse = colour.iter().map(|c| 3.0 * c * c / 16.0 / n).sum::<f64>() / 3.0;
        let truth_rel = colour
            .iter()
            .map(|c| 3.0 * c * c / 16.0 / n / (0.75 * c + 0.01_f64).powi(2))
            .sum::<f64>()
            / 3.0;
        for (name, truth) in [("mse", truth_mse), ("rel_mse", truth_rel)] {
            let (value, spread) = (r.num(name), r.num(&format!("{name}_spread")));
            // The test can tell a bias of 25% (a plain error against one 64-sample
            // reference, at 16 samples): the mean over 16 seeds is known to a few percent.
            assert!(
                spread < 0.04 * truth,
                "{name} at {n}: spread {spread} of {truth}"
            );
            // Within four standard errors, and 2% for the relative MSE's denominator (its
            // second-order bias, 1.5 x (1/3) / 64 = 0.8% here).
            assert!(
                (value - truth).abs() < 4.0 * spread + 0.02 * truth,
                "{name} at {n} samples: {value} +- {spread}, truth {truth}"
            );
        }
    }
}

#[test]
fn a_reused_reference_pair_gives_the_same_errors_and_both_samplers_are_measured() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    let common = [
        "converge",
        "s.toml",
        "--max-samples",
        "8",
        "--threads",
        "2",
        "--seeds",
        "2",
        "--repeats",
        "2",
    ];
    let first = [
        &common[..],
        &[
            "--reference-samples",
            "256",
            "--write-reference",
            "ref_a.exr",
            "ref_b.exr",
            "--csv",
            "a.csv",
        ],
    ]
    .concat();
    run(d, &first);
    let second = [
        &common[..],
        &["--reference", "ref_a.exr", "ref_b.exr", "--csv", "b.csv"],
    ]
    .concat();
    let out = run(d, &second);
    let (a, b) = (read_csv(&d.join("a.csv")), read_csv(&d.join("b.csv")));
    assert_eq!(a.len(), 8);
    let key = |r: &Row| {
        let bits = |name: &str| r.num(name).to_bits();
        (r.series.clone(), bits("samples"), bits("mse"), bits("flip"))
    };
    assert_eq!(
        a.iter().map(key).collect::<Vec<_>>(),
        b.iter().map(key).collect::<Vec<_>>()
    );
    let samplers: Vec<&str> = a.iter().map(|r| r.sampler.as_str()).collect();
    assert_eq!(samplers.iter().filter(|s| **s == "sobol").count(), 4);
    assert_eq!(samplers.iter().filter(|s| **s == "independent").count(), 4);
    // Both series are summed up (whether their times overlap, for a ratio at equal time,
    // depends on the machine).
    let stdout = String::from_utf8_lossy(&out.stdout);
    for line in ["independent: MSE slope", "sobol: MSE slope", "  sobol "] {
        assert!(stdout.contains(line), "{stdout}");
    }
}

#[test]
fn bad_converge_arguments_exit_2_and_write_nothing() {
    let cases: &[&[&str]] = &[
        &["--reference", "missing.exr", "other.exr"],
        &["--reference", "only_one.exr"],
        &["--write-reference", "only_one.exr"],
        // A reference that could not be read back as EXR: refused before it is written.
        &["--write-reference", "r.png", "s.png"],
        &["--write-reference", "r.exr", "r.exr"],
        &["--plot", "p.jpg"],
        &["--max-samples", "0"],
        &["--budget", "-1"],
        &["--frame", "5"],
        &["--sampler", "halton"],
        &["--seeds", "0"],
        &["--repeats", "0"],
        &["--thresholds", "0.05,1.5"],
        &["--thresholds", "0"],
        &["--reference", "r.exr", "s.exr", "--reference-samples", "4"],
        // Output files in a folder that cannot be made (procfs refuses it to root too):
        // refused before the references are rendered, not after.
        #[cfg(target_os = "linux")]
        &["--csv", "/proc/nope/x.csv"],
        #[cfg(target_os = "linux")]
        &["--plot", "/proc/nope/p.svg"],
        #[cfg(target_os = "linux")]
        &["--write-reference", "/proc/nope/a.exr", "b.exr"],
    ];
    for args in cases {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("s.toml"), SCENE).unwrap();
        let mut all = vec!["converge", "s.toml", "--max-samples", "2"];
        all.extend_from_slice(args);
        let o = Command::new(BIN)
            .args(&all)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let msg = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {msg}");
        assert!(!msg.contains("panicked"), "{msg}");
        assert!(
            !String::from_utf8_lossy(&o.stdout).contains("reference A"),
            "{args:?}: rendered"
        );
        let n = std::fs::read_dir(dir.path()).unwrap().count();
        assert_eq!(n, 1, "{args:?} wrote files");
    }
    // References of another size.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    for name in ["small_a.exr", "small_b.exr"] {
        run(
            d,
            &[
                "render", "s.toml", "--width", "8", "--height", "8", "-o", name,
            ],
        );
    }
    let o = Command::new(BIN)
        .args([
            "converge",
            "s.toml",
            "--reference",
            "small_a.exr",
            "small_b.exr",
        ])
        .current_dir(d)
        .output()
        .unwrap();
    let msg = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{msg}");
    assert!(msg.contains("small_a.exr") && msg.contains("8x8"), "{msg}");
}

#[test]
fn a_reference_that_is_a_named_pipe_is_refused_without_waiting_on_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    run(d, &["render", "s.toml", "--samples", "4", "-o", "b.exr"]);
    let made = Command::new("mkfifo").arg(d.join("pipe.exr")).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo");
    std::fs::create_dir(d.join("folder.exr")).unwrap();
    for (reference, want) in [
        ("pipe.exr", "is a named pipe, not a reference image"),
        ("folder.exr", "is a directory, not a reference image"),
    ] {
        // Opening a pipe without a writer would wait for ever: 20 s is far beyond a refusal.
        let o = common::run_limited(
            d,
            &["converge", "s.toml", "--reference", reference, "b.exr"],
            20,
            1 << 20,
        );
        let msg = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{reference}: {msg}");
        assert!(msg.contains(want) && msg.contains(reference), "{msg}");
    }
}

#[test]
fn denoised_points_are_timed_on_their_own_and_no_figure_is_negative() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    let out = run(
        d,
        &[
            "converge",
            "s.toml",
            "--denoise",
            "--sampler",
            "sobol",
            "--width",
            "24",
            "--height",
            "16",
            "--max-samples",
            "4",
            "--reference-samples",
            "64",
            "--seeds",
            "1",
            "--repeats",
            "3",
            "--csv",
            "c.csv",
        ],
    );
    let rows = read_csv(&d.join("c.csv"));
    let series: Vec<&str> = rows.iter().map(|r| r.series.as_str()).collect();
    assert_eq!(
        series,
        ["sobol", "sobol denoised"].repeat(3),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    for r in &rows {
        for name in ["seconds", "wall_seconds", "cpu_seconds", "efficiency"] {
            let v = r.num(name);
            assert!(v.is_finite() && v > 0.0, "{} {name} {v}", r.series);
        }
    }
}

/// A frame with nothing in it: a black environment.
const BLACK: &str = r#"
[shot]
frames = 1
[output]
width = 16
height = 12
[render]
samples = 4
[background]
color = [0.0, 0.0, 0.0]
[[sphere]]
center = [0.0, 0.0, -3.0]
radius = 1.0
material = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
"#;

#[test]
fn one_sample_and_black_frames_print_no_infinities_or_nans() {
    for (scene, max) in [(SCENE, "1"), (BLACK, "2")] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("s.toml"), scene).unwrap();
        let out = run(
            d,
            &[
                "converge",
                "s.toml",
                "--max-samples",
                max,
                "--reference-samples",
                "16",
                "--seeds",
                "1",
                "--repeats",
                "1",
                "--csv",
                "c.csv",
                "--plot",
                "c.svg",
            ],
        );
        let stdout = String::from_utf8_lossy(&out.stdout).to_lowercase();
        let csv = std::fs::read_to_string(d.join("c.csv"))
            .unwrap()
            .to_lowercase();
        for bad in ["inf", "nan"] {
            assert!(!stdout.contains(bad), "{stdout}");
            assert!(!csv.contains(bad), "{csv}");
        }
        assert!(stdout.contains(" - "), "{stdout}");
    }
}

#[test]
fn the_printed_error_is_within_15_percent_of_the_true_one_for_both_samplers() {
    use raytrace_core::metrics::rel_mse;
    use raytrace_core::renderer::{CpuShot, FrameJob};
    let render = |sampler: &str, samples: u32, seed: u64| {
        let mut scene = common::scene(SCENE);
        scene.render.sampler = sampler.parse().unwrap();
        scene.render.samples = samples;
        scene.render.seed = seed;
        let statics = CpuShot::new(&scene);
        FrameJob::new(&scene, 1).sample(&statics).unwrap()
    };
    // The reference's own error (from its replicates) is taken out of the measured one:
    // E[(v - ref)^2] = E[(v - truth)^2] + E[(ref - truth)^2] for independent renders.
    let reference = render("independent", 4096, 1234);
    let reference_mse = reference.stats.relative_error.powi(2);
    let reference = reference.image;
    for sampler in ["independent", "sobol"] {
        for samples in [16, 64] {
            // Squares summed over 8 seeds: one 48x32 frame's estimate and error both
            // scatter by about 15 percent on their own (a few dark, noisy pixels dominate
            // a relative error).
            let (mut estimated, mut truth) = (0.0, 0.0);
            for seed in 0..8 {
                let r = render(sampler, samples, seed);
                estimated += r.stats.relative_error.powi(2);
                truth += rel_mse(&r.image, &reference) - reference_mse;
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
