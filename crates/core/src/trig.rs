//! The sine and cosine of a fraction of a turn, without branches: what sampling a direction
//! or a lens position needs, at a fraction of the library `sin_cos`'s cost (which reduces
//! any argument, with branches whose outcome is a coin toss per sample).
//!
//! The argument is reduced exactly in turns (to the nearest quarter turn), the remainder is
//! turned into radians in [-pi/4, pi/4] with one rounding, and the polynomials there are the
//! kernels of FreeBSD's msun and musl (`__sin`, `__cos`: errors below one unit in the last
//! place on [-pi/4, pi/4]). A test checks the results against the library's within 2^-52.

// The coefficients keep every digit their source prints, so they can be checked against it;
// each rounds to the same `f64` as the shorter form clippy would suggest.
#![allow(clippy::excessive_precision)]

/// Coefficients of `__sin` (musl, src/math/__sin.c; from FreeBSD msun's k_sin.c).
const S1: f64 = -1.666_666_666_666_663_243_48e-1;
const S2: f64 = 8.333_333_333_322_489_461_24e-3;
const S3: f64 = -1.984_126_982_985_794_931_34e-4;
const S4: f64 = 2.755_731_370_707_006_767_89e-6;
const S5: f64 = -2.505_076_025_340_686_341_95e-8;
const S6: f64 = 1.589_690_995_211_550_102_21e-10;

/// Coefficients of `__cos` (musl, src/math/__cos.c; from FreeBSD msun's k_cos.c).
const C1: f64 = 4.166_666_666_666_660_190_37e-2;
const C2: f64 = -1.388_888_888_887_410_957_49e-3;
const C3: f64 = 2.480_158_728_947_672_941_78e-5;
const C4: f64 = -2.755_731_435_139_066_330_35e-7;
const C5: f64 = 2.087_572_321_298_174_827_90e-9;
const C6: f64 = -1.135_964_755_778_819_482_65e-11;

/// `(sin x, cos x)` for `|x| <= pi/4` (musl's `__sin(x, 0, 0)` and `__cos(x, 0)`).
#[inline]
fn kernel(x: f64) -> (f64, f64) {
    let z = x * x;
    let w = z * z;
    let r = S2 + z * (S3 + z * S4) + z * w * (S5 + z * S6);
    let sin = x + z * x * (S1 + z * r);
    let r = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    let cos = w + (((1.0 - w) - hz) + z * r);
    (sin, cos)
}

/// `(sin 2 pi t, cos 2 pi t)` for `|t|` below 2^48 (a sample's turns: [0, 1) and the like).
#[inline]
pub(crate) fn sin_cos_turns(t: f64) -> (f64, f64) {
    // The nearest quarter turn `q`, exactly, and what remains in [-1/2, 1/2] quarter turns.
    let quarters = 4.0 * t;
    // Rounded to the nearest integer (ties to even) by adding and taking away 1.5 * 2^52,
    // past which an `f64` holds integers only: exact for |quarters| below 2^51. `round` is a
    // call into the C library where the processor lacks SSE4.1 (the x86-64 baseline): 1.3%
    // of a render of the books' scene. A tie (an odd eighth of a turn) may go either way:
    // the remainder is then -pi/4 or pi/4, both within the kernel's range.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let q = (quarters + ROUND) - ROUND;
    let (s, c) = kernel((quarters - q) * std::f64::consts::FRAC_PI_2);
    // Turned by q quarter turns: sin(x + q pi/2) is sin, cos, -sin, -cos for q = 0, 1, 2, 3
    // (mod 4), and cos(x + q pi/2) is cos, -sin, -cos, sin.
    let q = q as i64;
    let (a, b) = if q & 1 == 0 { (s, c) } else { (c, s) };
    let sign = |negative: bool| if negative { -1.0 } else { 1.0 };
    (a * sign(q & 2 != 0), b * sign((q + 1) & 2 != 0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// Within 2^-52 of the library's `sin_cos` of the argument in radians (which rounds
    /// `2 pi t` once more, by up to 2^-53 relative) over [-1, 2) turns, at the quarter turns
    /// exactly, and on [-1/8, 3/8] (the concentric disk's range).
    #[test]
    fn agrees_with_the_library() {
        let mut r = Pcg32::new(17, 1);
        let mut worst: f64 = 0.0;
        for i in 0..400_000 {
            let t = match i % 3 {
                0 => r.next_f64() * 3.0 - 1.0,
                1 => r.next_f64() * 0.5 - 0.125,
                _ => (i % 16) as f64 / 8.0 - 0.5 + (r.next_f64() - 0.5) * 1e-12,
            };
            let (s, c) = sin_cos_turns(t);
            let (ws, wc) = (std::f64::consts::TAU * t).sin_cos();
            let err = (s - ws).abs().max((c - wc).abs());
            worst = worst.max(err);
            assert!(
                err <= 2f64.powi(-52) * (1.0 + 8.0 * t.abs()),
                "{t}: {s} {c} / {ws} {wc}"
            );
            assert!((s * s + c * c - 1.0).abs() < 4.0 * f64::EPSILON);
        }
        assert!(worst > 0.0);
        // Quarter turns: exact.
        let quarters: [(f64, (f64, f64)); 5] = [
            (0.0, (0.0, 1.0)),
            (0.25, (1.0, 0.0)),
            (0.5, (0.0, -1.0)),
            (0.75, (-1.0, 0.0)),
            (-0.25, (-1.0, 0.0)),
        ];
        for (t, want) in quarters {
            let (s, c) = sin_cos_turns(t);
            assert_eq!((s.abs(), c), (want.0.abs(), want.1), "{t}");
            assert_eq!(s, want.0, "{t}");
        }
    }
}
