//! Fits of measured convergence: the slope of a power law through log-log points.

/// Whether a point has a place on log-log axes: both coordinates finite and positive.
pub(crate) fn usable((x, y): (f64, f64)) -> bool {
    x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0
}

/// Least-squares slope of log(error) against log(seconds) over the finite positive points;
/// `None` with fewer than two distinct x.
///
/// For a power law `error = c · seconds^k` this is `k`: about -0.5 for plain Monte Carlo
/// convergence, steeper for better samplers. Also `None` when the logarithms of the distinct
/// x are too close to tell apart in floating point.
pub(crate) fn log_log_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|&&p| usable(p))
        .map(|&(x, y)| (x.ln(), y.ln()))
        .collect();
    let first_x = logs.first()?.0;
    if logs.iter().all(|&(lx, _)| lx == first_x) {
        return None;
    }
    let n = logs.len() as f64;
    let mean_x = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let (sxx, sxy) = logs.iter().fold((0.0, 0.0), |(sxx, sxy), &(lx, ly)| {
        let dx = lx - mean_x;
        (sxx + dx * dx, sxy + dx * (ly - mean_y))
    });
    let slope = sxy / sxx;
    (sxx > 0.0 && slope.is_finite()).then_some(slope)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn power_law(c: f64, k: f64, xs: &[f64]) -> Vec<(f64, f64)> {
        xs.iter().map(|&x| (x, c * x.powf(k))).collect()
    }

    #[test]
    fn slope_of_an_exact_power_law() {
        let xs = [0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 100.0];
        let slope = log_log_slope(&power_law(3.0, -1.0, &xs)).unwrap();
        assert!((slope + 1.0).abs() < 1e-12, "{slope}");
        let slope = log_log_slope(&power_law(0.2, -0.5, &xs)).unwrap();
        assert!((slope + 0.5).abs() < 1e-12, "{slope}");
        let slope = log_log_slope(&power_law(7.0, 2.0, &[1e-3, 1e3])).unwrap();
        assert!((slope - 2.0).abs() < 1e-12, "{slope}");
    }

    #[test]
    fn slope_ignores_unusable_points() {
        let mut points = power_law(3.0, -1.0, &[1.0, 2.0, 4.0, 8.0]);
        points.extend([
            (0.0, 1.0),
            (-2.0, 5.0),
            (3.0, 0.0),
            (3.0, -1.0),
            (f64::NAN, 1.0),
            (1.0, f64::NAN),
            (f64::INFINITY, 1.0),
            (5.0, f64::INFINITY),
            (f64::NEG_INFINITY, 2.0),
        ]);
        let slope = log_log_slope(&points).unwrap();
        assert!((slope + 1.0).abs() < 1e-12, "{slope}");
    }

    #[test]
    fn slope_needs_two_distinct_x() {
        assert_eq!(log_log_slope(&[]), None);
        assert_eq!(log_log_slope(&[(1.0, 1.0)]), None);
        assert_eq!(log_log_slope(&[(2.0, 1.0), (2.0, 5.0), (2.0, 0.1)]), None);
        // Only one usable x once the others are skipped.
        assert_eq!(
            log_log_slope(&[(2.0, 1.0), (0.0, 5.0), (f64::NAN, 0.1), (3.0, -1.0)]),
            None
        );
        assert!(log_log_slope(&[(2.0, 1.0), (2.0, 5.0), (3.0, 0.1)]).is_some());
    }

    #[test]
    fn slope_of_repeated_measurements_is_the_least_squares_fit() {
        // ln-ln points (0, 0), (0, 2), (ln 10, ln 10 - 1 ... ): built so the answer is known:
        // two y per x, symmetric about the power law y = x^-1, so the fit is exactly -1.
        let e = std::f64::consts::E;
        let points = [(1.0, e), (1.0, 1.0 / e), (10.0, e / 10.0), (10.0, 0.1 / e)];
        let slope = log_log_slope(&points).unwrap();
        assert!((slope + 1.0).abs() < 1e-12, "{slope}");
    }
}
