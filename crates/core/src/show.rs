//! Numbers as messages quote them.

/// Formats a number as the scene file would, shortest first: `2`, `0.25`, `-0`, and in
/// scientific form when very large or small (`1e-300`, `1.8446744073709552e19`), never as
/// hundreds of digits.
pub fn show(x: f64) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    let debug = format!("{x:?}");
    if debug.contains('e') || x.is_infinite() {
        debug
    } else {
        format!("{x}")
    }
}

/// Formats a computed number (not one written in the file) to 4 significant digits:
/// `5e299`, `1.98e39`, `0.02083`.
pub fn show_approx(x: f64) -> String {
    if !x.is_finite() || x == 0.0 {
        return show(x);
    }
    let sci = format!("{x:.3e}");
    let (mantissa, exp) = sci.split_once('e').unwrap_or((&sci, "0"));
    let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
    match exp.parse::<i32>() {
        Ok(e) if (-4..16).contains(&e) => show(format!("{mantissa}e{e}").parse().unwrap_or(x)),
        _ => format!("{mantissa}e{exp}"),
    }
}
