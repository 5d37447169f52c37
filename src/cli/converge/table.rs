//! What `converge` prints and writes: the table of points, the summary (slopes, times to
//! error levels, ratios at equal time), the CSV files and the plot's series. A figure that is
//! not a number (an estimate from one sample, an error of a black frame) prints as `-` and is
//! left empty in the CSV.

use std::fmt::Write as _;

use super::series::{
    Finish, LevelTime, Point, Report, Sampling, Setting, equal_time_ratios, slopes,
};
use crate::analysis::plot::{Bar, Guides, Series, SlopeGuide};
use crate::analysis::stats::Figure;

/// `v` with `format`, or `-` when it is not finite.
fn finite_or_dash(v: f64, format: impl Fn(f64) -> String) -> String {
    if v.is_finite() { format(v) } else { "-".into() }
}

/// A relative error in percent from a relative MSE (`-` when not positive).
fn rel_mse_percent(rel_mse: f64) -> String {
    if rel_mse > 0.0 && rel_mse.is_finite() {
        format!("{:.3}%", 100.0 * rel_mse.sqrt())
    } else {
        "-".into()
    }
}

/// The root of a mean squared error figure (relative or not) with its spread carried by the
/// derivative; NaN when it is not positive.
fn relative_error(rel_mse: Figure) -> Figure {
    if rel_mse.value > 0.0 {
        rel_mse.map(f64::sqrt, |v| 0.5 / v.sqrt())
    } else {
        Figure {
            value: f64::NAN,
            spread: f64::NAN,
        }
    }
}

/// A point's efficiency, `1 / (MSE x seconds)`, with its spread carried from those of the
/// MSE and of the times (relative spreads added in quadrature).
fn efficiency(p: &Point) -> Figure {
    let value = p.efficiency();
    let relative = (p.mse.spread / p.mse.value).hypot(p.wall.spread / p.seconds);
    Figure {
        value,
        spread: value * relative,
    }
}

/// The table's header.
pub(crate) fn header() -> String {
    format!(
        "{:<26} {:>9} {:>9} {:>7} {:>9} {:>10} {:>9} {:>8} {:>9} {:>8} {:>7} {:>10}",
        "series",
        "samples",
        "seconds",
        "+-",
        "CPU s",
        "RMSE",
        "error",
        "+-",
        "estimate",
        "est/true",
        "FLIP",
        "efficiency"
    )
}

/// One point's line: its plotted time (and the spread of its wall times), its CPU time,
/// RMSE and relative error against the truth (with the standard error over the seeds), the
/// error the render states for itself and its ratio to the truth, mean FLIP, and efficiency.
pub(crate) fn row(p: &Point) -> String {
    let samples = match p.setting {
        Setting::Samples(n) => n.to_string(),
        Setting::Threshold(e) => format!("{:.1}@{}%", p.samples, 100.0 * e),
    };
    let rel = relative_error(p.rel_mse);
    let est = p.estimated_rel_mse.value.sqrt();
    format!(
        "{:<26} {:>9} {:>9.4} {:>7} {:>9.4} {:>10} {:>9} {:>8} {:>9} {:>8} {:>7} {:>10}",
        p.series.name(),
        samples,
        p.seconds,
        finite_or_dash(p.wall.spread, |v| format!("{v:.4}")),
        p.cpu.value,
        finite_or_dash(p.mse.value.max(0.0).sqrt(), |v| format!("{v:.4e}")),
        rel_mse_percent(p.rel_mse.value),
        finite_or_dash(100.0 * rel.spread, |v| format!("{v:.3}%")),
        finite_or_dash(100.0 * est, |v| format!("{v:.3}%")),
        finite_or_dash(est / rel.value, |v| format!("{v:.3}")),
        finite_or_dash(p.flip.value, |v| format!("{v:.4}")),
        finite_or_dash(p.efficiency(), |v| format!("{v:.4e}")),
    )
}

fn slope_text(s: Option<f64>) -> String {
    s.map_or("-".into(), |s| format!("{s:.3}"))
}

/// The summary after the table: slopes per series, the times to the error levels with their
/// ratios to the first series, and the first series' error over each other's at equal time.
pub(crate) fn summary(report: &Report, levels: &[LevelTime]) -> String {
    let mut s = String::new();
    let kinds = report.kinds();
    for &k in &kinds {
        let [samples, seconds, rel_seconds] = slopes(&report.series(k));
        let _ = writeln!(
            s,
            "{}: MSE slope {} against samples, {} against seconds; relative MSE slope {} \
             against seconds",
            k.name(),
            slope_text(samples),
            slope_text(seconds),
            slope_text(rel_seconds)
        );
    }
    if let Some(&base) = kinds.first() {
        let _ = writeln!(
            s,
            "time to a relative error (seconds +- standard error over the seeds; x: over {}'s \
             time to it):",
            base.name()
        );
        for &k in &kinds {
            let mut line = format!("  {:<26}", k.name());
            for l in levels.iter().filter(|l| l.series == k) {
                let time = l.seconds.map_or("not reached".to_string(), |t| {
                    let spread = finite_or_dash(t.spread, |v| format!("{v:.3}"));
                    let ratio = l.time_ratio.map_or(String::new(), |r| format!(" x{r:.2}"));
                    format!("{:.3} +- {spread}{ratio}", t.value)
                });
                let _ = write!(line, "  {}%: {time}", 100.0 * l.level);
            }
            let _ = writeln!(s, "{}", line.trim_end());
        }
        for &k in &kinds[1..] {
            let f = equal_time_ratios(&report.series(base), &report.series(k));
            if let Some(&(t, last)) = f.last() {
                let mut all: Vec<f64> = f.iter().map(|p| p.1).collect();
                all.sort_by(f64::total_cmp);
                let _ = writeln!(
                    s,
                    "equal time: {} rel. MSE / {} rel. MSE = {last:.2} at {t:.3} s (median {:.2} \
                     over {} times)",
                    base.name(),
                    k.name(),
                    all[all.len() / 2],
                    all.len()
                );
            }
        }
    }
    s.trim_end().to_string()
}

/// A number for the CSV: shortest round-trip form, or empty when not finite.
fn num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:e}")
    } else {
        String::new()
    }
}

/// The points as CSV, one row per point, every figure with its spread (`_spread`: half the
/// interquartile range of a time, the standard error over the seeds of an error).
pub(crate) fn csv(report: &Report) -> String {
    let mut s = String::from(
        "series,sampler,sampling,finish,samples,threshold,seeds,renders,seconds,\
         wall_seconds,wall_seconds_spread,cpu_seconds,cpu_seconds_spread,mse,mse_spread,rmse,\
         rmse_spread,rel_mse,rel_mse_spread,rel_error,rel_error_spread,estimated_mse,\
         estimated_mse_spread,estimated_rel_mse,estimated_rel_mse_spread,flip,flip_spread,\
         efficiency,efficiency_spread\n",
    );
    let pair = |f: Figure| format!("{},{}", num(f.value), num(f.spread));
    for p in &report.points {
        let threshold = match p.setting {
            Setting::Samples(_) => String::new(),
            Setting::Threshold(e) => num(e),
        };
        let sampling = match p.series.sampling {
            Sampling::Uniform => "uniform",
            Sampling::Adaptive => "adaptive",
        };
        let finish = match p.series.finish {
            Finish::Raw => "raw",
            Finish::Denoised => "denoised",
        };
        let _ = writeln!(
            s,
            "{},{},{sampling},{finish},{},{threshold},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            p.series.name(),
            p.series.sampler,
            num(p.samples),
            p.seeds,
            p.renders,
            num(p.seconds),
            pair(p.wall),
            pair(p.cpu),
            pair(p.mse),
            pair(relative_error(p.mse)),
            pair(p.rel_mse),
            pair(relative_error(p.rel_mse)),
            pair(p.estimated_mse),
            pair(p.estimated_rel_mse),
            pair(p.flip),
            pair(efficiency(p)),
        );
    }
    s
}

/// The times to the error levels as CSV, one row per series and level.
pub(crate) fn levels_csv(levels: &[LevelTime]) -> String {
    let mut s = String::from("series,level,seconds,seconds_spread,time_ratio,error_ratio\n");
    for l in levels {
        let (t, spread) = l
            .seconds
            .map_or((f64::NAN, f64::NAN), |t| (t.value, t.spread));
        let _ = writeln!(
            s,
            "{},{},{},{},{},{}",
            l.series.name(),
            num(l.level),
            num(t),
            num(spread),
            num(l.time_ratio.unwrap_or(f64::NAN)),
            num(l.error_ratio.unwrap_or(f64::NAN))
        );
    }
    s
}

/// The plot's series (relative MSE against plotted seconds, each point's spreads as bars)
/// and guides (the error levels, and a line of slope -1 through the first series' first
/// point).
pub(crate) fn plot_series(report: &Report) -> (Vec<Series>, Guides) {
    let series: Vec<Series> = report
        .kinds()
        .into_iter()
        .map(|k| {
            let points = report.series(k);
            let bars = points
                .iter()
                .map(|p| Bar {
                    x: (p.seconds - p.wall.spread, p.seconds + p.wall.spread),
                    y: (
                        p.rel_mse.value - p.rel_mse.spread,
                        p.rel_mse.value + p.rel_mse.spread,
                    ),
                })
                .collect();
            Series {
                name: k.name(),
                slope: slopes(&points)[2],
                points: points
                    .iter()
                    .map(|p| (p.seconds, p.rel_mse.value))
                    .collect(),
                bars,
            }
        })
        .collect();
    let through = series
        .first()
        .and_then(|s| s.points.iter().find(|p| p.0 > 0.0 && p.1 > 0.0).copied());
    let guides = Guides {
        levels: super::series::LEVELS
            .iter()
            .map(|&l| (l * l, format!("{}%", 100.0 * l)))
            .collect(),
        slope: through.map(|through| SlopeGuide {
            through,
            slope: -1.0,
            name: "slope -1 (independent samples)".into(),
        }),
    };
    (series, guides)
}

#[cfg(test)]
mod tests {
    use super::super::series::tests::{kind, point, two_series};
    use super::super::series::{Finish, Report, level_times};
    use super::*;
    use raytrace_core::sampler::SamplerKind;

    #[test]
    fn rows_print_dashes_for_what_is_not_a_number() {
        let mut p = point(kind(SamplerKind::Sobol, Finish::Raw), 1, 0.5, 0.0);
        p.estimated_rel_mse.value = f64::INFINITY;
        p.mse.value = 0.0;
        let line = row(&p);
        for bad in ["inf", "NaN", "nan"] {
            assert!(!line.contains(bad), "{line}");
        }
        assert!(line.contains(" - "), "{line}");
        let text = csv(&Report { points: vec![p] });
        for bad in ["inf", "NaN", "nan"] {
            assert!(!text.contains(bad), "{text}");
        }
    }

    #[test]
    fn csv_rows_carry_every_figure_with_its_spread() {
        let p = point(
            kind(SamplerKind::Independent, Finish::Denoised),
            4,
            0.5,
            0.04,
        );
        let text = csv(&Report { points: vec![p] });
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let row: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(header.len(), row.len());
        let col = |name: &str| row[header.iter().position(|h| *h == name).unwrap()];
        assert_eq!(col("series"), "independent denoised");
        assert_eq!(col("finish"), "denoised");
        assert_eq!(col("samples"), "4e0");
        assert_eq!(col("threshold"), "");
        assert_eq!(col("rel_mse"), "4e-2");
        assert_eq!(col("rel_error"), "2e-1");
        assert_eq!(col("efficiency"), "5e1");
        for h in &header {
            if h.ends_with("_spread") {
                assert!(header.contains(&h.trim_end_matches("_spread")), "{h}");
            }
        }
    }

    #[test]
    fn the_summary_and_the_levels_csv_name_every_series() {
        let report = two_series();
        let levels = level_times(&report);
        let text = summary(&report, &levels);
        // One sample count: no slope against samples.
        assert!(
            text.contains("independent: MSE slope - against samples, -1.000 against seconds"),
            "{text}"
        );
        assert!(text.contains("5%: 1.000 +- 0.000 x0.25"), "{text}");
        assert!(
            text.contains("equal time: independent rel. MSE / sobol rel. MSE = 4.00"),
            "{text}"
        );
        let csv = levels_csv(&levels);
        assert_eq!(csv.lines().count(), 7);
        let sobol_5: Vec<f64> = csv
            .lines()
            .find(|l| l.starts_with("sobol,5e-2,"))
            .unwrap()
            .split(',')
            .skip(2)
            .map(|v| v.parse().unwrap())
            .collect();
        for (got, want) in sobol_5.iter().zip([1.0, 0.0, 0.25, 4.0]) {
            assert!((got - want).abs() < 1e-9, "{csv}");
        }
        let (series, guides) = plot_series(&report);
        assert_eq!(series.len(), 2);
        assert_eq!(guides.levels.len(), 3);
        // The slope guide goes through the first series' first point (0.1 s, 1e-2 / 0.1).
        let through = guides.slope.unwrap().through;
        assert!(
            through.0 == 0.1 && (through.1 - 0.1).abs() < 1e-15,
            "{through:?}"
        );
    }
}
