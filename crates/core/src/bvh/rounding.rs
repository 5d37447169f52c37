//! Rounding `f64` box sides to `f32` outward, so a stored box always contains the box it
//! stands for: a still side rounded down (or up), a moving side as a start and a change
//! whose `f32` interpolation stays outside the exact one.

/// The largest `f32` at or below `x`: `x` itself when it is one, and `-inf` below
/// `-f32::MAX`; `f32::MAX` for a finite `x` above it, `+inf` for `+inf`, NaN for NaN.
pub(super) fn f32_below(x: f64) -> f32 {
    // `as` rounds to nearest (to an infinity past the range); one step down undoes a rounding up.
    let y = x as f32;
    if f64::from(y) > x { y.next_down() } else { y }
}

/// The smallest `f32` at or above `x` (the mirror of [`f32_below`]).
pub(super) fn f32_above(x: f64) -> f32 {
    -f32_below(-x)
}

/// A lower side moving from `open` to `close` during the shutter, as `(o, d)` in `f32` such
/// that `o + s * d` is at most `open + s * (close - open)` (exactly) for every `s` in [0, 1],
/// whether evaluated in `f64` (each `f32` converted exactly) or in `f32` (with `s` rounded to
/// `f32`).
///
/// Why (the reasoning of pbrt-v4's error bounds): let `m = max(|open|, |close|)` and
/// `p = m 2^-18 + 2^-146`. Then `o <= open - p + 2^-53 (m + p)` (rounded down from the `f64`
/// subtraction, off by at most that) and so `o <= open - (1 - 2^-34) p`; likewise `c` for
/// `close`. `d` is `c - o` rounded down but for the `f64` rounding of that difference, at most
/// `2^-52 |c - o| <= 2^-50 (m + p)` above. In exact arithmetic, since the interpolation has
/// non-negative weights, `o + s d <= (1 - s) o + s c + 2^-50 (m + p)`, which is at most
/// `open + s (close - open) - (1 - 2^-34) p + 2^-50 (m + p)`. Evaluating `o + s * d` in `f64` costs two roundings of at
/// most `2^-53 (|s d| + |o + s d|) <= 2^-50 (m + p)`; in `f32`, rounding `s` (by `2^-25`), the
/// product and the sum cost at most `2^-24 (2.5 |d| + |o|) <= 2^-21 (m + p)`, plus `2^-149`
/// for each of two underflows. In all the evaluated side lies below the exact interpolation,
/// as `p >= 2^-18 m` and `2^-146` is more than the underflows. A side that is not finite (an
/// empty slot's `+inf`, a NaN, or one beyond the `f32` range after the margin) is stored as
/// the constant `min(open, close)` rounded down with `d = 0`, below the interpolation at every
/// `s`: an empty slot stays `+inf`, never hit.
// Inlined where it is used (the refit, six times a child slot), as it was when they shared a file.
#[inline]
pub(super) fn moving_lower(open: f64, close: f64) -> (f32, f32) {
    let constant = || (f32_below(open.min(close)), 0.0);
    if !(open.is_finite() && close.is_finite()) {
        return constant();
    }
    // 2^-18 and 2^-146, eight times the least positive `f32`.
    let p = open.abs().max(close.abs()) * f64::from(2f32.powi(-18)) + f64::from(f32::from_bits(8));
    let o = f32_below(open - p);
    let c = f32_below(close - p);
    if !(o.is_finite() && c.is_finite()) {
        return constant();
    }
    let d = f32_below(f64::from(c) - f64::from(o));
    if !d.is_finite() {
        return constant();
    }
    (o, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// `f32_below` and `f32_above` bracket every `f64` by adjacent `f32`s (or by one, when
    /// it is an `f32`), past the `f32` range and down to its subnormals.
    #[test]
    fn f32_rounding_is_outward() {
        let (max, tiny) = (f64::from(f32::MAX), f64::from(f32::from_bits(1)));
        let cases: [(f64, f32, f32); 14] = [
            (1.0, 1.0, 1.0),
            (0.0, 0.0, 0.0),
            (-2.5, -2.5, -2.5),
            (1.0 + f64::EPSILON, 1.0, 1.0f32.next_up()),
            (1.0 - f64::EPSILON / 2.0, 1.0f32.next_down(), 1.0),
            (-(1.0 + f64::EPSILON), -1.0f32.next_up(), -1.0),
            (max, f32::MAX, f32::MAX),
            (3.5e38, f32::MAX, f32::INFINITY),
            (-3.5e38, f32::NEG_INFINITY, -f32::MAX),
            (1e-50, 0.0, f32::from_bits(1)),
            (-1e-50, -f32::from_bits(1), -0.0),
            (1.5 * tiny, f32::from_bits(1), f32::from_bits(2)),
            (f64::INFINITY, f32::INFINITY, f32::INFINITY),
            (f64::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY),
        ];
        for (x, lo, hi) in cases {
            assert_eq!((f32_below(x), f32_above(x)), (lo, hi), "{x:e}");
        }
        assert!(f32_below(f64::NAN).is_nan() && f32_above(f64::NAN).is_nan());
        // Any magnitude, any sign: below <= x <= above, adjacent or equal.
        let mut r = Pcg32::new(31, 7);
        for _ in 0..100_000 {
            let x = (r.next_f64() - 0.5) * 2f64.powi((r.next_f64() * 300.0) as i32 - 160);
            let (lo, hi) = (f32_below(x), f32_above(x));
            assert!(f64::from(lo) <= x && x <= f64::from(hi), "{x:e}");
            assert!(lo == hi || lo.next_up() == hi, "{x:e}");
        }
    }

    /// A moving side's `f32` form, evaluated as a traversal does, stays outside the
    /// interpolation of the `f64` sides at every shutter time, at every scale; an empty slot
    /// stays empty.
    #[test]
    fn moving_sides_are_conservative() {
        assert_eq!(
            moving_lower(f64::INFINITY, f64::INFINITY),
            (f32::INFINITY, 0.0)
        );
        assert_eq!(
            moving_lower(f64::NEG_INFINITY, f64::NEG_INFINITY),
            (f32::NEG_INFINITY, 0.0)
        );
        assert_eq!(
            moving_lower(1.0, f64::NEG_INFINITY),
            (f32::NEG_INFINITY, 0.0)
        );
        // Beyond the `f32` range: a side past it is the constant infinity, a change past it
        // the largest `f32`, less than the change.
        assert_eq!(moving_lower(-3.5e38, 0.0), (f32::NEG_INFINITY, 0.0));
        assert_eq!(moving_lower(-3.4e38, 3.4e38).1, f32::MAX);
        let mut r = Pcg32::new(32, 9);
        for _ in 0..20_000 {
            let scale = 2f64.powi((r.next_f64() * 260.0) as i32 - 140);
            let open = (r.next_f64() - 0.5) * scale;
            // Sometimes far apart, sometimes nearly equal, sometimes equal.
            let close = match r.next_f64() {
                x if x < 0.3 => open,
                x if x < 0.6 => open * (1.0 + (r.next_f64() - 0.5) * 1e-7),
                _ => (r.next_f64() - 0.5) * scale * 2f64.powi((r.next_f64() * 40.0) as i32 - 20),
            };
            for (lo, hi) in [(open, close), (-open, -close)] {
                let (o, d) = moving_lower(lo, hi);
                for s in [
                    0.0,
                    1.0,
                    0.5,
                    r.next_f64(),
                    1.0 - f64::EPSILON / 2.0,
                    1e-300,
                ] {
                    let got = f64::from(o) + s * f64::from(d);
                    // Exact at the ends; elsewhere the `f64` interpolation is within a few
                    // ulps of the exact one, far inside the margin.
                    let exact = if s == 0.0 {
                        lo
                    } else if s == 1.0 {
                        hi
                    } else {
                        lo + s * (hi - lo)
                    };
                    assert!(got <= exact, "{lo:e} {hi:e} at {s}: {got:e}");
                }
            }
        }
    }
}
