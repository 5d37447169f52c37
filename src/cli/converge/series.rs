//! What `converge` measures: series of points (a sampler, uniform or adaptive, raw or
//! denoised), and the figures made from them: the plotted times, fitted slopes, the time each
//! series takes to an error level, and errors at equal time.

use crate::analysis::fit::log_log_slope;
use crate::analysis::stats::{Figure, crossing, nondecreasing, value_at};
use raytrace_core::sampler::SamplerKind;

/// The relative error levels whose times `converge` reports (0.05 = 5%).
pub(crate) const LEVELS: [f64; 3] = [0.05, 0.02, 0.01];

/// How a series spends its samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Sampling {
    /// Every pixel the same samples.
    Uniform,
    /// Rounds under a noise threshold (`render --noise-threshold`).
    Adaptive,
}

/// What a series measures of its renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Finish {
    /// The film as sampled.
    Raw,
    /// The frame denoised.
    Denoised,
}

/// One series: a sampler, its sampling and its finish.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct SeriesKind {
    pub(crate) sampler: SamplerKind,
    pub(crate) sampling: Sampling,
    pub(crate) finish: Finish,
}

impl SeriesKind {
    /// `sobol`, `sobol denoised`, `sobol adaptive`, `sobol adaptive denoised`.
    pub(crate) fn name(&self) -> String {
        let mut name = self.sampler.name().to_string();
        if self.sampling == Sampling::Adaptive {
            name.push_str(" adaptive");
        }
        if self.finish == Finish::Denoised {
            name.push_str(" denoised");
        }
        name
    }
}

/// What every render of a point takes: a sample count, or a noise threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Setting {
    Samples(u32),
    Threshold(f64),
}

/// One measured point: a series at one setting, rendered with each seed and repeated for
/// its time.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Point {
    pub(crate) series: SeriesKind,
    pub(crate) setting: Setting,
    /// The samples a pixel took, on average over the frame and the seeds.
    pub(crate) samples: f64,
    pub(crate) seeds: usize,
    /// Renders timed (each seed once, then repeats).
    pub(crate) renders: usize,
    /// The time plotted and compared: the wall medians along the series, made non-decreasing
    /// ([`Report::fit_times`]).
    pub(crate) seconds: f64,
    /// Wall seconds of one render (preparation and tracing, and denoising when denoised):
    /// median and half the interquartile range.
    pub(crate) wall: Figure,
    /// The process's CPU seconds of one render, likewise.
    pub(crate) cpu: Figure,
    /// The mean squared error against the truth (the references' cross-estimate): mean over
    /// the seeds and its standard error, as every error figure here.
    pub(crate) mse: Figure,
    pub(crate) rel_mse: Figure,
    /// The MSE the raw film estimates from its replicates (NaN when denoised).
    pub(crate) estimated_mse: Figure,
    /// The square of the relative error the render states for itself.
    pub(crate) estimated_rel_mse: Figure,
    /// Mean FLIP against the references' mean, 8-bit sRGB.
    pub(crate) flip: Figure,
    /// Each seed's relative MSE, in order of seeds: the spread of the times to levels.
    pub(crate) rel_mse_by_seed: Vec<f64>,
}

impl Point {
    /// `1 / (MSE x seconds)`: higher is better; equal for two renders that trade time for
    /// error at the rate of independent samples.
    pub(crate) fn efficiency(&self) -> f64 {
        1.0 / (self.mse.value * self.seconds)
    }
}

/// Everything `converge` measured, in the order it was measured.
#[derive(Clone, Debug, Default)]
pub(crate) struct Report {
    pub(crate) points: Vec<Point>,
}

impl Report {
    /// The series measured, in order of first appearance.
    pub(crate) fn kinds(&self) -> Vec<SeriesKind> {
        let mut kinds: Vec<SeriesKind> = Vec::new();
        for p in &self.points {
            if !kinds.contains(&p.series) {
                kinds.push(p.series);
            }
        }
        kinds
    }

    /// The points of one series, in order of their settings.
    pub(crate) fn series(&self, kind: SeriesKind) -> Vec<&Point> {
        self.points.iter().filter(|p| p.series == kind).collect()
    }

    /// Sets each point's plotted `seconds`: its series' wall medians made non-decreasing in
    /// the series' order ([`nondecreasing`]). A render of more samples does all the work of
    /// one of fewer (its first samples are the same) and more, so its time cannot be less: a
    /// median that runs backwards is the machine's noise, and the pair is plotted at their
    /// mean. Returns a line for each series with points so moved, naming them.
    pub(crate) fn fit_times(&mut self) -> Vec<String> {
        let mut notes = Vec::new();
        for kind in self.kinds() {
            let walls: Vec<f64> = self.series(kind).iter().map(|p| p.wall.value).collect();
            let fitted = nondecreasing(&walls);
            let mut moved = Vec::new();
            let points = self.points.iter_mut().filter(|p| p.series == kind);
            for (p, seconds) in points.zip(fitted) {
                p.seconds = seconds;
                if seconds != p.wall.value {
                    moved.push(setting_text(p.setting));
                }
            }
            if !moved.is_empty() {
                notes.push(format!(
                    "{}: the median times at {} ran backwards against their neighbours (the \
                     machine's noise): plotted at their pooled mean",
                    kind.name(),
                    moved.join(", ")
                ));
            }
        }
        notes
    }
}

/// `16 spp` or `threshold 2%`.
pub(crate) fn setting_text(setting: Setting) -> String {
    match setting {
        Setting::Samples(n) => format!("{n} spp"),
        Setting::Threshold(e) => format!("threshold {}%", 100.0 * e),
    }
}

/// The fitted log-log slopes of a series: MSE against samples, MSE against seconds, and
/// relative MSE against seconds (what the plot shows).
pub(crate) fn slopes(points: &[&Point]) -> [Option<f64>; 3] {
    let fit = |f: &dyn Fn(&Point) -> (f64, f64)| {
        log_log_slope(&points.iter().map(|p| f(p)).collect::<Vec<_>>())
    };
    [
        fit(&|p| (p.samples, p.mse.value)),
        fit(&|p| (p.seconds, p.mse.value)),
        fit(&|p| (p.seconds, p.rel_mse.value)),
    ]
}

/// A series' time to a relative error level, and how it compares with the first series.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LevelTime {
    pub(crate) series: SeriesKind,
    /// The relative error (0.02 = 2%).
    pub(crate) level: f64,
    /// Seconds to reach it along the series' curve of mean relative MSE against plotted
    /// seconds (interpolated on log-log axes), with the standard error of the same time
    /// taken along each seed's curve (NaN when fewer than two seeds' curves reach it).
    /// `None`: the curve does not reach it, or starts below it.
    pub(crate) seconds: Option<Figure>,
    /// This series' time over the first series' time, to the same level.
    pub(crate) time_ratio: Option<f64>,
    /// At equal time: the first series' relative MSE at the time it reaches the level, over
    /// this series' at that time (above 1: this series is better).
    pub(crate) error_ratio: Option<f64>,
}

/// The times of every series to each of [`LEVELS`], in the report's order of series.
pub(crate) fn level_times(report: &Report) -> Vec<LevelTime> {
    let kinds = report.kinds();
    let curve = |points: &[&Point]| -> Vec<(f64, f64)> {
        points
            .iter()
            .map(|p| (p.seconds, p.rel_mse.value))
            .collect()
    };
    let mut out = Vec::new();
    let Some(&base_kind) = kinds.first() else {
        return out;
    };
    let base = curve(&report.series(base_kind));
    for &kind in &kinds {
        let points = report.series(kind);
        let mean_curve = curve(&points);
        let seeds = points.iter().map(|p| p.rel_mse_by_seed.len()).min();
        for level in LEVELS {
            let target = level * level;
            let seconds = crossing(&mean_curve, target).map(|t| {
                let by_seed: Vec<f64> = (0..seeds.unwrap_or(0))
                    .filter_map(|s| {
                        let c: Vec<(f64, f64)> = points
                            .iter()
                            .map(|p| (p.seconds, p.rel_mse_by_seed[s]))
                            .collect();
                        crossing(&c, target)
                    })
                    .collect();
                Figure {
                    value: t,
                    spread: Figure::mean_of(&by_seed).spread,
                }
            });
            let base_time = crossing(&base, target);
            let time_ratio = seconds.zip(base_time).map(|(t, b)| t.value / b);
            let error_ratio = base_time
                .and_then(|b| value_at(&mean_curve, b))
                .map(|here| target / here);
            out.push(LevelTime {
                series: kind,
                level,
                seconds,
                time_ratio,
                error_ratio,
            });
        }
    }
    out
}

/// The first series' relative MSE over `other`'s at equal time, at each of `other`'s points
/// whose plotted time lies within the first series' times: pairs of (seconds, ratio).
pub(crate) fn equal_time_ratios(base: &[&Point], other: &[&Point]) -> Vec<(f64, f64)> {
    let curve: Vec<(f64, f64)> = base.iter().map(|p| (p.seconds, p.rel_mse.value)).collect();
    other
        .iter()
        .filter(|p| p.rel_mse.value > 0.0)
        .filter_map(|p| value_at(&curve, p.seconds).map(|b| (p.seconds, b / p.rel_mse.value)))
        .collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A point of `kind` at `seconds` with relative MSE `rel` (each seed's the same), and
    /// MSE `rel` too.
    pub(crate) fn point(kind: SeriesKind, samples: u32, seconds: f64, rel: f64) -> Point {
        let f = |value: f64| Figure { value, spread: 0.0 };
        Point {
            series: kind,
            setting: Setting::Samples(samples),
            samples: samples as f64,
            seeds: 2,
            renders: 3,
            seconds,
            wall: f(seconds),
            cpu: f(seconds),
            mse: f(rel),
            rel_mse: f(rel),
            estimated_mse: f(rel),
            estimated_rel_mse: f(rel),
            flip: f(0.1),
            rel_mse_by_seed: vec![rel, rel],
        }
    }

    /// Two raw series at one sample a point, timed at 0.1 to 100 s: the independent sampler's
    /// relative MSE `1e-2 / t` and Sobol's four times lower at every time.
    pub(crate) fn two_series() -> Report {
        let (a, b) = (
            kind(SamplerKind::Independent, Finish::Raw),
            kind(SamplerKind::Sobol, Finish::Raw),
        );
        let times = [0.1, 1.0, 10.0, 100.0];
        let mut points: Vec<Point> = times.iter().map(|&t| point(a, 1, t, 1e-2 / t)).collect();
        points.extend(times.iter().map(|&t| point(b, 1, t, 0.25e-2 / t)));
        Report { points }
    }

    pub(crate) const fn kind(sampler: SamplerKind, finish: Finish) -> SeriesKind {
        SeriesKind {
            sampler,
            sampling: Sampling::Uniform,
            finish,
        }
    }

    #[test]
    fn names_of_series() {
        let mut k = kind(SamplerKind::Sobol, Finish::Denoised);
        assert_eq!(k.name(), "sobol denoised");
        k.sampling = Sampling::Adaptive;
        assert_eq!(k.name(), "sobol adaptive denoised");
        assert_eq!(
            kind(SamplerKind::Independent, Finish::Raw).name(),
            "independent"
        );
    }

    #[test]
    fn plotted_times_never_run_backwards() {
        let k = kind(SamplerKind::Sobol, Finish::Raw);
        let mut report = Report {
            points: [(1, 0.2), (2, 0.3), (4, 0.25), (8, 0.9)]
                .map(|(n, t)| point(k, n, t, 1.0 / n as f64))
                .to_vec(),
        };
        let notes = report.fit_times();
        let seconds: Vec<f64> = report.points.iter().map(|p| p.seconds).collect();
        assert_eq!(seconds, [0.2, 0.275, 0.275, 0.9]);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].contains("sobol: the median times at 2 spp, 4 spp ran"),
            "{notes:?}"
        );
    }

    #[test]
    fn times_to_levels_and_ratios_at_equal_time() {
        // Base: relative MSE 1e-2 / t. Other: four times lower at every time.
        let report = two_series();
        let levels = level_times(&report);
        assert_eq!(levels.len(), 6);
        // 5%: rel. MSE 2.5e-3, at t = 4 for the base, t = 1 for the other.
        let (base5, other5) = (&levels[0], &levels[3]);
        assert_eq!((base5.level, other5.level), (0.05, 0.05));
        assert!((base5.seconds.unwrap().value - 4.0).abs() < 1e-9);
        assert!((other5.seconds.unwrap().value - 1.0).abs() < 1e-9);
        assert!((other5.time_ratio.unwrap() - 0.25).abs() < 1e-9);
        assert!((other5.error_ratio.unwrap() - 4.0).abs() < 1e-9);
        assert!((base5.time_ratio.unwrap() - 1.0).abs() < 1e-12);
        // Equal seeds' curves: no spread.
        assert_eq!(base5.seconds.unwrap().spread, 0.0);
        // 1%: 1e-4, at t = 100 for the base (its last point), 25 for the other.
        assert!((levels[2].seconds.unwrap().value - 100.0).abs() < 1e-6);
        let (a, b) = (
            kind(SamplerKind::Independent, Finish::Raw),
            kind(SamplerKind::Sobol, Finish::Raw),
        );
        let ratios = equal_time_ratios(&report.series(a), &report.series(b));
        assert_eq!(ratios.len(), 4);
        assert!(
            ratios.iter().all(|r| (r.1 - 4.0).abs() < 1e-9),
            "{ratios:?}"
        );
    }

    #[test]
    fn slopes_of_a_series() {
        let k = kind(SamplerKind::Independent, Finish::Raw);
        let points: Vec<Point> = [1, 2, 4, 8]
            .map(|n| point(k, n, 0.1 * n as f64, 0.5 / n as f64))
            .to_vec();
        let refs: Vec<&Point> = points.iter().collect();
        for s in slopes(&refs) {
            assert!((s.unwrap() + 1.0).abs() < 1e-12);
        }
    }
}
