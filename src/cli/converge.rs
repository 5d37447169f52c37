//! `raytrace converge`: how a frame's error falls with run time, per sampler.
//!
//! A reference render of many samples (or an EXR the user gives) stands in for the converged
//! image. The frame is then rendered at 1, 2, 4, ... samples per pixel with each sampler,
//! timing the rendering alone, and each render is compared with the reference: mean squared
//! error, relative mean squared error, the error estimated from the pixels' replicates (which
//! needs no reference; see `film::Pixel::variance_of_mean`), and the efficiency
//! `1 / (MSE x seconds)`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::DVec3;

use super::args::ConvergeArgs;
use super::progress::print_line;
use crate::analysis::fit::log_log_slope;
use crate::analysis::{metrics, plot};
use crate::denoise::denoiser::Denoiser;
use crate::error::Error;
use crate::format::{FRAME_FORMATS, Format};
use crate::io;
use crate::output;
use crate::points::FramePoints;
use crate::renderer::{Budget, FrameResult, ShotGeometry, render_shot_frame_with};
use crate::rng::hash_words;
use crate::sampler::SamplerKind;
use crate::scene::{Device, Scene};
use crate::scene_file::{Overrides, SceneSource};

/// Default samples per pixel of the reference render.
pub(crate) const DEFAULT_REFERENCE_SAMPLES: u32 = 4096;

/// Renders shorter than this are repeated (up to [`MAX_REPEATS`] times) and their median
/// time taken, because a single short run's time is mostly noise.
const SHORT_RUN_SECONDS: f64 = 0.25;
const MAX_REPEATS: usize = 5;

/// One measured render.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Measurement {
    pub(crate) sampler: SamplerKind,
    pub(crate) samples: u32,
    /// Median wall time of the render (preparation and tracing, no file I/O).
    pub(crate) seconds: f64,
    pub(crate) mse: f64,
    pub(crate) rel_mse: f64,
    /// The mean squared error estimated from the pixels' replicates.
    pub(crate) estimated_mse: f64,
    pub(crate) estimated_rel_mse: f64,
    /// With `--denoise`: the same render denoised.
    pub(crate) denoised: Option<DenoisedMeasurement>,
}

/// A measured render, denoised.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct DenoisedMeasurement {
    /// Median wall time of the render and its denoising (the raw measurement's `seconds`
    /// leave the denoising out).
    pub(crate) seconds: f64,
    pub(crate) mse: f64,
    pub(crate) rel_mse: f64,
    /// The square of the denoised frame's estimated relative error (bias included).
    pub(crate) estimated_rel_mse: f64,
}

impl Measurement {
    /// `1 / (MSE x seconds)`: higher is better; equal for two renders that trade time for
    /// error at the rate of independent samples.
    pub(crate) fn efficiency(&self) -> f64 {
        1.0 / (self.mse * self.seconds)
    }
}

/// Everything `converge` measured.
#[derive(Clone, Debug)]
pub(crate) struct Report {
    pub(crate) runs: Vec<Measurement>,
}

impl Report {
    /// The runs of one sampler, in order of samples.
    pub(crate) fn series(&self, kind: SamplerKind) -> Vec<&Measurement> {
        self.runs.iter().filter(|m| m.sampler == kind).collect()
    }

    /// The samplers measured, in order.
    pub(crate) fn samplers(&self) -> Vec<SamplerKind> {
        let mut kinds: Vec<SamplerKind> = Vec::new();
        for m in &self.runs {
            if !kinds.contains(&m.sampler) {
                kinds.push(m.sampler);
            }
        }
        kinds
    }
}

/// The fitted log-log slope of MSE against samples and against seconds for `runs`.
pub(crate) fn slopes(runs: &[&Measurement]) -> (Option<f64>, Option<f64>) {
    let by_samples: Vec<(f64, f64)> = runs.iter().map(|m| (m.samples as f64, m.mse)).collect();
    let by_time: Vec<(f64, f64)> = runs.iter().map(|m| (m.seconds, m.mse)).collect();
    (log_log_slope(&by_samples), log_log_slope(&by_time))
}

/// `base`'s MSE over `other`'s at equal time, at each of `other`'s runs whose time lies
/// within `base`'s range: `base`'s log MSE is interpolated linearly in log time (the curves
/// are close to straight lines on log-log axes). Pairs of (seconds, factor).
pub(crate) fn equal_time_factors(base: &[&Measurement], other: &[&Measurement]) -> Vec<(f64, f64)> {
    let mut b: Vec<(f64, f64)> = base
        .iter()
        .filter(|m| m.mse > 0.0)
        .map(|m| (m.seconds.ln(), m.mse.ln()))
        .collect();
    b.sort_by(|p, q| p.0.total_cmp(&q.0));
    other
        .iter()
        .filter(|m| m.mse > 0.0)
        .filter_map(|m| {
            let t = m.seconds.ln();
            let i = b.windows(2).position(|w| w[0].0 <= t && t <= w[1].0)?;
            let (p, q) = (b[i], b[i + 1]);
            let f = if q.0 > p.0 {
                (t - p.0) / (q.0 - p.0)
            } else {
                0.0
            };
            let base_mse = (p.1 + f * (q.1 - p.1)).exp();
            Some((m.seconds, base_mse / m.mse))
        })
        .collect()
}

/// The samples per pixel of the measured renders: powers of two up to `max_samples`, and
/// `max_samples` itself.
pub(crate) fn schedule(max_samples: u32) -> Vec<u32> {
    let mut v: Vec<u32> = (0..32)
        .map(|k| 1u32 << k)
        .take_while(|&n| n < max_samples)
        .collect();
    v.push(max_samples);
    v
}

/// Runs `raytrace converge`, printing its table to stdout unless `--quiet`.
pub(crate) fn converge(args: &ConvergeArgs) -> Result<Report, Error> {
    let source = SceneSource::read(&args.scene)?;
    let overrides = args.scene_args.overrides();
    let scene = source.scene(&overrides)?;
    let frame = args.frame.unwrap_or(scene.shot.first_frame);
    if !scene.shot.contains_frame(frame) {
        return Err(Error::Usage(format!(
            "--frame {frame} is outside the shot's frames {}-{}",
            scene.shot.first_frame,
            scene.shot.last_frame()
        )));
    }
    if let Some(path) = &args.plot {
        plot::check_path(path).map_err(Error::Usage)?;
    }
    if let Some(path) = &args.csv {
        Format::of(path, &[Format::Csv], "measurements").map_err(Error::Usage)?;
    }
    let variant = |samples: u32, seed: Option<u64>, sampler: SamplerKind| {
        source.scene(&Overrides {
            samples: Some(samples),
            seed: seed.or(overrides.seed),
            sampler: Some(sampler),
            ..overrides.clone()
        })
    };
    super::threads::thread_pool(args.scene_args.threads)?
        .install(|| measure(&scene, &variant, frame, args))
}

/// A variant of the measured scene with other samples, seed (`None`: the scene's) and
/// sampler, made from the scene file through the validator.
type Variant<'a> = dyn Fn(u32, Option<u64>, SamplerKind) -> Result<Scene, Error> + Sync + 'a;

/// Measures `frame` of `scene`, rendering the `variant` of each sample count and sampler.
fn measure(
    scene: &Scene,
    variant: &Variant,
    frame: u32,
    args: &ConvergeArgs,
) -> Result<Report, Error> {
    let say = |s: &str| {
        if !args.scene_args.quiet {
            print_line(s);
        }
    };
    // The scene's device: the GPU opened before anything is measured, as the denoiser is
    // started: if either cannot start, nothing is written.
    let gpu = match scene.render.device {
        Device::Gpu => Some(super::device::open_gpu()?),
        Device::Cpu => None,
    };
    let geometry = ShotGeometry::new(scene, gpu.as_ref())?;
    // The frame's points, read once for every render of it.
    let points = match scene.points.is_empty() {
        true => FramePoints::none(),
        false => crate::point_cache::read_frame(scene, frame)?,
    };
    let shot = (&geometry, &points);
    let denoiser = match args.denoise {
        true => Some(Denoiser::new().map_err(|e| Error::Resource(e.to_string()))?),
        false => None,
    };
    let reference = reference(scene, variant, shot, frame, args, &say)?;
    say(&format!(
        "relative errors against the reference, less its own estimated error ({:.3}%; \
         the noise of the two is independent, so their squares add)",
        100.0 * reference.rel_mse.sqrt()
    ));

    let samplers = if args.sampler.is_empty() {
        SamplerKind::ALL.to_vec()
    } else {
        args.sampler.clone()
    };
    let max_samples = args.max_samples.unwrap_or(if args.budget.is_some() {
        u32::MAX
    } else {
        scene.render.samples
    });
    // The samplers take turns at each sample count, so that a change in the machine's load
    // during the measurement falls on all of them alike.
    let mut runs = Vec::new();
    let mut spent = vec![0.0; samplers.len()];
    let mut active = vec![true; samplers.len()];
    say(&header(args.denoise));
    for n in schedule(max_samples) {
        for (i, &kind) in samplers.iter().enumerate() {
            if !active[i] {
                continue;
            }
            let (result, seconds) =
                timed_render(&variant(n, None, kind)?, shot, frame, denoiser.as_ref())?;
            let denoised = result.denoised.as_ref().map(|d| {
                let image: Vec<DVec3> = d
                    .rgb
                    .chunks_exact(3)
                    .map(|c| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64))
                    .collect();
                DenoisedMeasurement {
                    seconds,
                    mse: reference.mse(&image),
                    rel_mse: reference.rel_mse(&image),
                    estimated_rel_mse: d.relative_error.powi(2),
                }
            });
            // The raw render's time leaves its denoising out.
            let seconds = seconds - result.stats.denoise_seconds;
            let m = Measurement {
                sampler: kind,
                samples: n,
                seconds,
                mse: reference.mse(&result.film.means()),
                rel_mse: reference.rel_mse(&result.film.means()),
                estimated_mse: metrics::estimated_mse(&result.film.variances()),
                // The square of the raw frame's estimated relative error.
                estimated_rel_mse: result.stats.noisy_relative_error.powi(2),
                denoised,
            };
            say(&row(&m));
            runs.push(m);
            spent[i] += seconds;
            let seconds = runs.last().map_or(seconds, |m: &Measurement| {
                m.denoised.as_ref().map_or(m.seconds, |d| d.seconds)
            });
            // The next render takes about twice as long as this one.
            if args.budget.is_some_and(|b| spent[i] + 2.0 * seconds > b) {
                active[i] = false;
            }
        }
        if !active.contains(&true) {
            break;
        }
    }
    let report = Report { runs };
    say(&summary(&report));
    if let Some(path) = &args.csv {
        io::write_file(path, csv(&report).as_bytes())?;
        say(&format!("CSV written to {}", path.display()));
    }
    if let Some(path) = &args.plot {
        let mut series: Vec<plot::Series> = Vec::new();
        for k in report.samplers() {
            let runs = report.series(k);
            series.push(plot::Series {
                name: k.name().to_string(),
                points: runs.iter().map(|m| (m.seconds, m.mse)).collect(),
                slope: slopes(&runs).1,
            });
            let denoised: Vec<(f64, f64)> = runs
                .iter()
                .filter_map(|m| m.denoised.as_ref().map(|d| (d.seconds, d.mse)))
                .collect();
            if !denoised.is_empty() {
                series.push(plot::Series {
                    name: format!("{} denoised", k.name()),
                    slope: log_log_slope(&denoised),
                    points: denoised,
                });
            }
        }
        let title = format!(
            "{} frame {frame}: error against render time",
            scene
                .source
                .file_name()
                .map_or("scene".into(), |n| n.to_string_lossy())
        );
        plot::write_plot(
            path,
            &title,
            "render time (s)",
            "MSE against reference",
            &series,
        )
        .map_err(|message| Error::Output {
            path: path.clone(),
            message,
        })?;
        say(&format!("plot written to {}", path.display()));
    }
    Ok(report)
}

/// The reference image and its own estimated relative error, which every measured relative
/// error, taken against it, holds too: the reference's noise is independent of a measured
/// render's, so their squared errors add, and the reference's is subtracted from each
/// measured one. (The MSE columns are against the reference as it is: a reference read back
/// records its relative error, not its MSE, and both ways must give the same figures.)
struct Reference {
    pixels: Vec<DVec3>,
    /// The square of its estimated relative error (0 when unknown).
    rel_mse: f64,
}

impl Reference {
    /// The mean squared error of `image` against the reference.
    fn mse(&self, image: &[DVec3]) -> f64 {
        metrics::mse(image, &self.pixels)
    }

    /// The relative mean squared error of `image` against the truth: against the reference,
    /// less the reference's own (never below 0).
    fn rel_mse(&self, image: &[DVec3]) -> f64 {
        (metrics::rel_mse(image, &self.pixels) - self.rel_mse).max(0.0)
    }
}

/// The reference image of `frame`: read from `--reference` (with its own error when its
/// `estimatedRelativeError` attribute records it), or rendered with many samples and a seed
/// of its own, written to EXR, and read back.
fn reference(
    scene: &Scene,
    variant: &Variant,
    (geometry, points): (&ShotGeometry, &FramePoints),
    frame: u32,
    args: &ConvergeArgs,
    say: &dyn Fn(&str),
) -> Result<Reference, Error> {
    let (width, height) = (scene.output.width, scene.output.height);
    if let Some(path) = &args.reference {
        let rel_mse = io::read_exr_number(path, "estimatedRelativeError").map_or(0.0, |e| e * e);
        return Ok(Reference {
            pixels: read_reference(path, width, height)?,
            rel_mse,
        });
    }
    let samples = args.reference_samples.unwrap_or(DEFAULT_REFERENCE_SAMPLES);
    let path = args
        .write_reference
        .clone()
        .unwrap_or_else(|| default_reference_path(scene, frame, samples, args));
    let format = Format::of(&path, FRAME_FORMATS, "reference").map_err(Error::Usage)?;
    // A seed of its own, so the reference's noise is independent of every measured render's;
    // 63 bits, as every seed a scene file or --seed can give.
    let seed = hash_words(&[scene.render.seed, 0x7265_6665_7265_6e63]) >> 1;
    let reference = variant(samples, Some(seed), SamplerKind::default())?;
    say(&format!(
        "reference: frame {frame}, {samples} samples per pixel, {} sampler...",
        reference.render.sampler
    ));
    let result = render_shot_frame_with(
        &reference,
        geometry,
        points,
        frame,
        &Budget::default(),
        None,
        &|_| {},
    )?;
    let non_finite = output::write_frame(&path, format, &reference, &result, &Budget::default())?;
    if non_finite > 0 {
        say(&format!(
            "reference: {non_finite} non-finite pixels written as 0"
        ));
    }
    say(&format!(
        "reference: {:.2} s, written to {}",
        result.stats.render_seconds + result.stats.prepare_seconds,
        path.display()
    ));
    // Compare against what was written (f32), as a reused reference would be.
    Ok(Reference {
        pixels: read_reference(&path, width, height)?,
        rel_mse: result.stats.relative_error.powi(2),
    })
}

/// Renders `frame` of `scene` with no file I/O and returns it with its wall time: the median
/// of several runs when one is short (the runs are bit-identical; the repeats only steady
/// the clock).
fn timed_render(
    scene: &Scene,
    (geometry, points): (&ShotGeometry, &FramePoints),
    frame: u32,
    denoiser: Option<&Denoiser>,
) -> Result<(FrameResult, f64), Error> {
    let mut times = Vec::new();
    let mut result = None;
    while times.len() < MAX_REPEATS {
        let start = Instant::now();
        let budget = Budget::default();
        let r = render_shot_frame_with(scene, geometry, points, frame, &budget, denoiser, &|_| {})?;
        times.push(start.elapsed().as_secs_f64());
        result.get_or_insert(r);
        if times.iter().sum::<f64>() >= SHORT_RUN_SECONDS * 2.0 || times[0] >= SHORT_RUN_SECONDS {
            break;
        }
    }
    times.sort_by(f64::total_cmp);
    Ok((
        result.expect("rendered at least once"),
        times[times.len() / 2],
    ))
}

fn default_reference_path(scene: &Scene, frame: u32, samples: u32, args: &ConvergeArgs) -> PathBuf {
    let stem = scene
        .source
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let dir = [&args.csv, &args.plot]
        .into_iter()
        .flatten()
        .next()
        .and_then(|p| p.parent())
        .map(Path::to_path_buf)
        .unwrap_or_default();
    dir.join(format!("{stem}_frame{frame}_reference_{samples}spp.exr"))
}

/// Reads the RGB channels of an EXR reference of the given size, as linear radiance.
pub(crate) fn read_reference(path: &Path, width: u32, height: u32) -> Result<Vec<DVec3>, Error> {
    let bad = |message: String| Error::Usage(format!("reference {}: {message}", path.display()));
    if !path.exists() {
        return Err(bad(
            "no such file (render one with --reference-samples)".into()
        ));
    }
    let (w, h, pixels) = io::read_exr_rgb(path).map_err(bad)?;
    if (w, h) != (width as usize, height as usize) {
        return Err(bad(format!("is {w}x{h}, the frame is {width}x{height}")));
    }
    if pixels.iter().any(|p| !p.is_finite()) {
        return Err(bad("has pixels that are not finite".into()));
    }
    Ok(pixels)
}

fn header(denoise: bool) -> String {
    let denoised = if denoise {
        format!(
            " {:>9} {:>10} {:>10} {:>8}",
            "dn. secs", "dn. error", "dn. est.", "est/true"
        )
    } else {
        String::new()
    };
    format!(
        "{:<12} {:>7} {:>9} {:>11} {:>11} {:>8} {:>10} {:>10} {:>8} {:>11}{denoised}",
        "sampler",
        "samples",
        "seconds",
        "RMSE",
        "est. RMSE",
        "est/RMSE",
        "rel. error",
        "est. error",
        "est/true",
        "efficiency"
    )
}

/// One measurement's line: the absolute error (RMSE) and the relative error (the square
/// root of the relative MSE, what a render prints as `est. error`), each against the
/// reference and as estimated from the samples, with the estimate's ratio to the truth.
fn row(m: &Measurement) -> String {
    let ratio = |est: f64, truth: f64| {
        if est.is_finite() {
            format!("{:.3}", est / truth)
        } else {
            "-".into()
        }
    };
    let (est, rel, est_rel) = (
        m.estimated_mse.sqrt(),
        m.rel_mse.sqrt(),
        m.estimated_rel_mse.sqrt(),
    );
    let denoised = m.denoised.as_ref().map_or(String::new(), |d| {
        let (true_rel, est) = (d.rel_mse.sqrt(), d.estimated_rel_mse.sqrt());
        format!(
            " {:>9.4} {:>9.3}% {:>9.3}% {:>8}",
            d.seconds,
            100.0 * true_rel,
            100.0 * est,
            ratio(est, true_rel)
        )
    });
    format!(
        "{:<12} {:>7} {:>9.4} {:>11.4e} {:>11.4e} {:>8} {:>9.3}% {:>9.3}% {:>8} {:>11.4e}{denoised}",
        m.sampler.name(),
        m.samples,
        m.seconds,
        m.mse.sqrt(),
        est,
        ratio(est, m.mse.sqrt()),
        100.0 * rel,
        100.0 * est_rel,
        ratio(est_rel, rel),
        m.efficiency()
    )
}

fn fmt_slope(s: Option<f64>) -> String {
    s.map_or("-".into(), |s| format!("{s:.3}"))
}

/// Slopes per sampler and equal-time comparisons with the first sampler.
pub(crate) fn summary(report: &Report) -> String {
    let mut s = String::new();
    let kinds = report.samplers();
    for &k in &kinds {
        let runs = report.series(k);
        let (by_samples, by_time) = slopes(&runs);
        let _ = writeln!(
            s,
            "{k}: MSE slope {} against samples, {} against seconds",
            fmt_slope(by_samples),
            fmt_slope(by_time)
        );
    }
    if let Some((&first, rest)) = kinds.split_first() {
        for &k in rest {
            let f = equal_time_factors(&report.series(first), &report.series(k));
            if let Some(&(t, last)) = f.last() {
                let mut all: Vec<f64> = f.iter().map(|p| p.1).collect();
                all.sort_by(f64::total_cmp);
                let _ = writeln!(
                    s,
                    "equal time: {first} MSE / {k} MSE = {last:.2} at {t:.3} s (median {:.2} over {} times)",
                    all[all.len() / 2],
                    all.len()
                );
            }
        }
    }
    s.trim_end().to_string()
}

/// The measurements as CSV, one row per render.
pub(crate) fn csv(report: &Report) -> String {
    let mut s = String::from(
        "sampler,samples,seconds,mse,rmse,rel_mse,estimated_mse,estimated_rmse,estimated_rel_mse,efficiency,denoised_seconds,denoised_mse,denoised_rel_mse,denoised_estimated_rel_mse\n",
    );
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:e}")
        } else {
            String::new()
        }
    };
    for m in &report.runs {
        let d = m.denoised.as_ref();
        let dn = |f: fn(&DenoisedMeasurement) -> f64| d.map_or(String::new(), |d| num(f(d)));
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            m.sampler,
            m.samples,
            num(m.seconds),
            num(m.mse),
            num(m.mse.sqrt()),
            num(m.rel_mse),
            num(m.estimated_mse),
            num(m.estimated_mse.sqrt()),
            num(m.estimated_rel_mse),
            num(m.efficiency()),
            dn(|d| d.seconds),
            dn(|d| d.mse),
            dn(|d| d.rel_mse),
            dn(|d| d.estimated_rel_mse)
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(sampler: SamplerKind, samples: u32, seconds: f64, mse: f64) -> Measurement {
        Measurement {
            sampler,
            samples,
            seconds,
            mse,
            rel_mse: mse,
            estimated_mse: mse,
            estimated_rel_mse: mse,
            denoised: None,
        }
    }

    #[test]
    fn schedules_are_powers_of_two_then_the_maximum() {
        assert_eq!(schedule(1), [1]);
        assert_eq!(schedule(8), [1, 2, 4, 8]);
        assert_eq!(schedule(12), [1, 2, 4, 8, 12]);
        assert_eq!(schedule(u32::MAX).len(), 33);
    }

    #[test]
    fn equal_time_factor_of_two_power_laws() {
        // Base: MSE = 1 / t. Other: MSE = 1 / (4 t) at the same times, so 4x lower.
        use SamplerKind::*;
        let base: Vec<Measurement> = (0..5)
            .map(|k| 2f64.powi(k))
            .map(|t| m(Independent, 1, t, 1.0 / t))
            .collect();
        let other: Vec<Measurement> = [1.5, 3.0, 10.0, 100.0]
            .into_iter()
            .map(|t| m(Sobol, 1, t, 0.25 / t))
            .collect();
        let f = equal_time_factors(
            &base.iter().collect::<Vec<_>>(),
            &other.iter().collect::<Vec<_>>(),
        );
        // 100 s lies outside the base's times (1..16 s): not compared.
        assert_eq!(f.len(), 3);
        for (_, factor) in f {
            assert!((factor - 4.0).abs() < 1e-9, "{factor}");
        }
    }

    #[test]
    fn efficiency_is_inverse_mse_times_seconds() {
        assert_eq!(m(SamplerKind::Sobol, 4, 0.5, 0.01).efficiency(), 200.0);
    }

    #[test]
    fn csv_has_a_row_per_run_and_leaves_unknowns_empty() {
        let mut r = m(SamplerKind::Independent, 1, 0.5, 0.04);
        r.estimated_mse = f64::INFINITY;
        let report = Report {
            runs: vec![r, m(SamplerKind::Sobol, 2, 1.0, 0.01)],
        };
        let text = csv(&report);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3);
        // No denoised measurement: its four columns are empty.
        assert_eq!(lines[1], "independent,1,5e-1,4e-2,2e-1,4e-2,,,4e-2,5e1,,,,");
        assert!(lines[2].starts_with("sobol,2,1e0,1e-2,1e-1,"));
        assert!(lines[2].ends_with(",,,,"));
    }

    #[test]
    fn csv_rows_carry_the_denoised_measurement() {
        let mut r = m(SamplerKind::Sobol, 4, 0.5, 0.04);
        r.denoised = Some(DenoisedMeasurement {
            seconds: 0.75,
            mse: 0.01,
            rel_mse: 0.0025,
            estimated_rel_mse: 0.0016,
        });
        let text = csv(&Report { runs: vec![r] });
        let row = text.lines().nth(1).unwrap();
        assert!(row.ends_with(",7.5e-1,1e-2,2.5e-3,1.6e-3"), "{row}");
    }
}
