//! Summaries of repeated measurements: medians and quartiles of timings, means and standard
//! errors over seeds, a non-decreasing fit of times along a series, and where a convergence
//! curve crosses an error level.

/// A measured figure and its spread (what `converge` prints as `value ± spread`): for a
/// timing, its median and half its interquartile range over the repeats; for an error, its
/// mean and the standard error of that mean over the seeds. The spread is NaN when there is
/// too little to tell (one seed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Figure {
    pub(crate) value: f64,
    pub(crate) spread: f64,
}

impl Figure {
    /// The median of `values` and half their interquartile range.
    pub(crate) fn median_of(values: &[f64]) -> Figure {
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        Figure {
            value: quantile(&sorted, 0.5),
            spread: 0.5 * (quantile(&sorted, 0.75) - quantile(&sorted, 0.25)),
        }
    }

    /// The mean of `values` and its standard error (`s / sqrt(n)`, with `s` the sample
    /// standard deviation; NaN for fewer than two values).
    pub(crate) fn mean_of(values: &[f64]) -> Figure {
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let spread = if values.len() < 2 {
            f64::NAN
        } else {
            let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
            (var / n).sqrt()
        };
        Figure {
            value: mean,
            spread,
        }
    }

    /// The figure of `f(value)` for a monotone `f`, its spread carried to first order by the
    /// derivative `df` at the value.
    pub(crate) fn map(self, f: impl Fn(f64) -> f64, df: impl Fn(f64) -> f64) -> Figure {
        Figure {
            value: f(self.value),
            spread: (df(self.value) * self.spread).abs(),
        }
    }
}

/// The `q` quantile of `sorted` (ascending, not empty), linearly interpolated between the
/// closest ranks (the "type 7" definition of R and NumPy's default).
pub(crate) fn quantile(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// Whether the timings' spread is small enough to stop repeating: their interquartile range
/// at most `tolerance` times their median.
pub(crate) fn settled(times: &[f64], tolerance: f64) -> bool {
    let f = Figure::median_of(times);
    2.0 * f.spread <= tolerance * f.value
}

/// The non-decreasing sequence closest to `values` in least squares (isotonic regression, by
/// pooling adjacent violators: Barlow et al., *Statistical inference under order
/// restrictions*, 1972). Where `values` already never decrease it returns them unchanged;
/// where a later value falls below an earlier one, the run of values involved is replaced by
/// its mean.
pub(crate) fn nondecreasing(values: &[f64]) -> Vec<f64> {
    // Blocks of pooled values: (sum, count).
    let mut blocks: Vec<(f64, usize)> = Vec::with_capacity(values.len());
    for &v in values {
        blocks.push((v, 1));
        while blocks.len() >= 2 {
            let (s1, n1) = blocks[blocks.len() - 1];
            let (s0, n0) = blocks[blocks.len() - 2];
            if s0 / n0 as f64 <= s1 / n1 as f64 {
                break;
            }
            blocks.pop();
            *blocks.last_mut().expect("two blocks") = (s0 + s1, n0 + n1);
        }
    }
    blocks
        .into_iter()
        .flat_map(|(s, n)| std::iter::repeat_n(s / n as f64, n))
        .collect()
}

/// Where a convergence curve first falls to `level`: the `x` (seconds) at which the
/// piecewise-linear curve through `points` on log-log axes (in order of `x`) reaches `level`,
/// interpolated between the last point above it and the first at or below it. `None` when no
/// point is at or below it, or the first usable one already is (the curve starts below the
/// level: when it got there is not measured). Points that log axes cannot show are skipped.
pub(crate) fn crossing(points: &[(f64, f64)], level: f64) -> Option<f64> {
    let usable: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|&(x, y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite())
        .collect();
    let first_below = usable.iter().position(|&(_, y)| y <= level)?;
    if first_below == 0 {
        return None;
    }
    let ((x0, y0), (x1, y1)) = (usable[first_below - 1], usable[first_below]);
    let f = (level.ln() - y0.ln()) / (y1.ln() - y0.ln());
    Some((x0.ln() + f * (x1.ln() - x0.ln())).exp())
}

/// The value of the curve through `points` (on log-log axes, in order of `x`) at `x`,
/// interpolated between its neighbours; `None` outside the curve's range of `x`.
pub(crate) fn value_at(points: &[(f64, f64)], x: f64) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|&(x, y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let t = x.ln();
    let i = logs.windows(2).position(|w| w[0].0 <= t && t <= w[1].0)?;
    let (p, q) = (logs[i], logs[i + 1]);
    let f = if q.0 > p.0 {
        (t - p.0) / (q.0 - p.0)
    } else {
        0.0
    };
    Some((p.1 + f * (q.1 - p.1)).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_quartiles_means_and_standard_errors() {
        let f = Figure::median_of(&[5.0, 1.0, 3.0, 2.0, 4.0]);
        assert_eq!(f.value, 3.0);
        // Quartiles 2 and 4.
        assert_eq!(f.spread, 1.0);
        assert_eq!(Figure::median_of(&[2.0, 1.0]).value, 1.5);
        let f = Figure::median_of(&[7.0]);
        assert_eq!((f.value, f.spread), (7.0, 0.0));
        // Mean 2, sample variance 1, standard error 1 / sqrt(3).
        let f = Figure::mean_of(&[1.0, 2.0, 3.0]);
        assert_eq!(f.value, 2.0);
        assert!((f.spread - 1.0 / 3f64.sqrt()).abs() < 1e-15);
        assert!(Figure::mean_of(&[4.0]).spread.is_nan());
        // sqrt of 4 +- 1: 2 +- 0.25.
        let f = Figure {
            value: 4.0,
            spread: 1.0,
        }
        .map(f64::sqrt, |v| 0.5 / v.sqrt());
        assert_eq!((f.value, f.spread), (2.0, 0.25));
    }

    #[test]
    fn timings_settle_when_their_quartiles_are_close() {
        assert!(settled(&[1.0, 1.01, 0.99], 0.05));
        assert!(!settled(&[1.0, 1.2, 0.8], 0.05));
        assert!(settled(&[3.0], 0.05));
    }

    #[test]
    fn isotonic_fit_pools_what_runs_backwards_and_keeps_the_rest() {
        assert_eq!(nondecreasing(&[1.0, 2.0, 2.0, 5.0]), [1.0, 2.0, 2.0, 5.0]);
        assert_eq!(nondecreasing(&[1.0, 3.0, 2.0, 5.0]), [1.0, 2.5, 2.5, 5.0]);
        // A violation that spreads back over two earlier values.
        assert_eq!(nondecreasing(&[2.0, 4.0, 4.0, 1.0]), [2.0, 3.0, 3.0, 3.0]);
        assert_eq!(nondecreasing(&[]), Vec::<f64>::new());
        // The least-squares property: the pooled mean keeps the sum.
        let v = [0.5, 0.4, 0.45, 2.0, 1.0, 3.0];
        let fit = nondecreasing(&v);
        assert!(fit.windows(2).all(|w| w[0] <= w[1]), "{fit:?}");
        assert!((fit.iter().sum::<f64>() - v.iter().sum::<f64>()).abs() < 1e-12);
    }

    #[test]
    fn crossings_and_values_on_log_log_axes() {
        // error = 1 / t: reaches 0.25 at t = 4, whatever points bracket it.
        let curve: Vec<(f64, f64)> = [1.0, 2.0, 8.0, 16.0].map(|t| (t, 1.0 / t)).to_vec();
        assert!((crossing(&curve, 0.25).unwrap() - 4.0).abs() < 1e-12);
        assert!((crossing(&curve, 0.5).unwrap() - 2.0).abs() < 1e-12);
        // Never reached, or reached before the first point.
        assert_eq!(crossing(&curve, 0.01), None);
        assert_eq!(crossing(&curve, 2.0), None);
        // A curve that wiggles: the first crossing counts.
        let wiggle = [(1.0, 1.0), (2.0, 0.2), (4.0, 0.3), (8.0, 0.05)];
        assert!((crossing(&wiggle, 0.2).unwrap() - 2.0).abs() < 1e-12);
        // Unusable points are skipped.
        let holes = [(1.0, 1.0), (2.0, -0.1), (4.0, 0.25)];
        assert!((crossing(&holes, 0.5).unwrap() - 2.0).abs() < 1e-12);
        assert!((value_at(&curve, 4.0).unwrap() - 0.25).abs() < 1e-12);
        assert_eq!(value_at(&curve, 0.5), None);
        assert_eq!(value_at(&curve, 32.0), None);
    }
}
