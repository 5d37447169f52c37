//! The log-log axes' ranges, ticks and tick labels.

use std::ops::Range;

/// Exponent bounds of the axes, well inside the range of `f64`.
const MAX_EXPONENT: f64 = 300.0;

/// Axis range covering `values` (all finite and positive) with a margin of 6% of the
/// logarithmic span on each side, widened symmetrically to at least one decade.
/// With no values, the decade [1, 10].
pub(super) fn axis_range(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        let l = v.log10();
        (lo.min(l), hi.max(l))
    });
    if lo > hi {
        return 1.0..10.0;
    }
    let span = hi - lo;
    let pad = ((span * 1.12).max(1.0) - span) / 2.0;
    let lo = (lo - pad).clamp(-MAX_EXPONENT, MAX_EXPONENT - 1.0);
    let hi = (hi + pad).clamp(lo + 1.0, MAX_EXPONENT);
    10f64.powf(lo)..10f64.powf(hi)
}

/// Most labelled ticks on an axis.
pub(super) const MAX_MAJOR_TICKS: usize = 10;

/// Tick positions on a log axis over `range`: labelled (major) and grid-only (minor).
///
/// Major ticks are the powers of ten when at least three fall in the range (every n-th power
/// when there are too many); otherwise 1, 2 and 5 times powers of ten. Minor ticks fill
/// in the other integer multiples of powers of ten, or the skipped powers of ten.
pub(super) fn log_ticks(range: &Range<f64>) -> (Vec<f64>, Vec<f64>) {
    const EPS: f64 = 1e-9;
    let (lo, hi) = (range.start, range.end);
    let k_min = (lo.log10() - EPS).floor() as i32;
    let k_max = (hi.log10() + EPS).ceil() as i32;
    let inside = |v: f64| v >= lo * (1.0 - EPS) && v <= hi * (1.0 + EPS);
    let multiples = |ms: &[u32]| -> Vec<f64> {
        (k_min..=k_max)
            .flat_map(|k| ms.iter().map(move |&m| f64::from(m) * 10f64.powi(k)))
            .filter(|&v| inside(v))
            .collect()
    };
    let decades = multiples(&[1]);
    if decades.len() >= 3 {
        let step = decades.len().div_ceil(MAX_MAJOR_TICKS);
        if step > 1 {
            let (major, minor) = decades
                .iter()
                .partition(|&&v| decade_of(v).rem_euclid(step as i32) == 0);
            (major, minor)
        } else if decades.len() <= 8 {
            (decades, multiples(&[2, 3, 4, 5, 6, 7, 8, 9]))
        } else {
            (decades, Vec::new())
        }
    } else {
        let major = multiples(&[1, 2, 5]);
        let minor = multiples(&[3, 4, 6, 7, 8, 9]);
        (major, minor)
    }
}

/// The power of ten of the leading digit of `v` (positive), robust to rounding of
/// values built as `m · 10^k`.
pub(super) fn decade_of(v: f64) -> i32 {
    (v.log10() + 1e-9).floor() as i32
}

/// How an axis writes its tick values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum TickFormat {
    /// Decimal numbers, such as 0.01 or 200.
    Plain,
    /// Powers of ten with superscript exponents, such as 10⁻⁴ or 2×10⁶.
    Power,
}

/// Plain numbers when every tick lies between 0.001 and 10⁴ (short enough to read),
/// powers of ten otherwise.
pub(super) fn tick_format(ticks: &[f64]) -> TickFormat {
    if ticks.iter().all(|&v| (-3..=4).contains(&decade_of(v))) {
        TickFormat::Plain
    } else {
        TickFormat::Power
    }
}

/// The label of the tick at `v`, in `format`.
pub(super) fn tick_label(v: f64, format: TickFormat) -> String {
    let k = decade_of(v);
    match format {
        TickFormat::Plain => format!("{:.*}", (-k).max(0) as usize, v),
        TickFormat::Power => {
            let mantissa = (v / 10f64.powi(k)).round();
            let power = format!("10{}", superscript(k));
            if mantissa == 1.0 {
                power
            } else {
                format!("{mantissa}×{power}")
            }
        }
    }
}

/// `k` in Unicode superscript digits, such as ⁻¹².
pub(super) fn superscript(k: i32) -> String {
    k.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        })
        .collect()
}
