//! The change of a written frame's error from the frame before it, estimated without a
//! reference: the flicker a clip of written frames states (`render`'s frame and summary lines,
//! `converge --flicker`'s "stated" column), by the measure `converge --flicker` reports
//! against references (`metrics::FlickerSum`).
//!
//! A written frame is, per pixel and channel, `W = w D̄ + (1 - w) F` (`denoise::estimate`, whose
//! notation this follows): `D̄ = t_a D(a) + t_b D(b)` with the shares `t` of the samples
//! denoised, `F = s_a a + s_b b` with the shares `s` now. Its error is
//! `e = W - T = w (β + t_a ε_a + t_b ε_b) + (1 - w)(s_a η_a + s_b η_b)`. The viewer of a clip
//! sees the change of the error at a fixed pixel from one frame (primed) to the next:
//!
//! `E[(e - e')^2] = E[e^2] + E[e'^2] - 2 E[e e']`.
//!
//! The first two are the frames' own stated errors (their unbiased per-pixel terms). The last
//! is new: frames sampled with the same sample points (`--temporal`) carry related noise, and a
//! denoiser's bias is shared by neighbouring frames. It is estimable from the two frames'
//! replicates with the assumption the frame's own estimate rests on, carried across frames:
//! **each frame's `a` side (its even samples, `a` and `D(a)`) is independent of the other
//! frame's `b` side (odd samples)**, whatever the sample pattern: new samples make the frames
//! independent, stable ones give the same points to the same sample index, and a sample's
//! index decides its side. Differences of a frame's four images (`a`, `b`, `D(a)`, `D(b)`) hold
//! no true value, so products of one frame's differences with the other's have expectations
//! in the unknown cross-frame moments alone: `ββ'` and, per side, `[εε'] = E[ε_a ε_a']`,
//! `[εη'] = E[ε_a η_a']`, `[ηε']`, `[ηη']` (and the same for `b`):
//!
//! | product | expectation |
//! | --- | --- |
//! | `P1 = (a - b)(a' - b')` | `[ηη']_a + [ηη']_b` |
//! | `P2 = (D(a) - b)(a' - b')` | `[εη']_a + [ηη']_b` |
//! | `P3 = (D(b) - a)(b' - a')` | `[εη']_b + [ηη']_a` |
//! | `P4 = (a - b)(D(a)' - b')` | `[ηε']_a + [ηη']_b` |
//! | `P5 = (b - a)(D(b)' - a')` | `[ηε']_b + [ηη']_a` |
//! | `P6 = (D(a) - b)(D(a)' - b')` | `ββ' + [εε']_a + [ηη']_b` |
//! | `P7 = (D(b) - a)(D(b)' - a')` | `ββ' + [εε']_b + [ηη']_a` |
//! | `P8 = (D(a) - D(b))(D(a)' - D(b)')` | `[εε']_a + [εε']_b` |
//!
//! Every such product has rank 8 in the nine moments: adding a constant to the four `a`
//! moments and taking it from the four `b` ones changes none. `E[e e']` reads that direction
//! with weight `s_a s_a' - s_b s_b'`, zero where the sides hold the same samples (even counts)
//! and at most `1/n` otherwise, so it is fixed by the sides' shares: with `κ` the covariance of
//! one sample's value in the two frames, `[ηη']_a = κ / n_a`, so `[ηη']_a = s_b P1` and
//! `[ηη']_b = s_a P1`. Then
//!
//! - `[εη']_a = P2 - [ηη']_b`, `[εη']_b = P3 - [ηη']_a`, `[ηε']_a = P4 - [ηη']_b`,
//!   `[ηε']_b = P5 - [ηη']_a`;
//! - `ββ' = (P6 + P7 - P8 - P1) / 2`, `[εε']_a = P6 - ββ' - [ηη']_b`,
//!   `[εε']_b = P7 - ββ' - [ηη']_a`;
//! - `E[e e'] = w w' ββ' + Σ_sides (x_D y_D [εε'] + x_D y_R [εη'] + x_R y_D [ηε'] + x_R y_R [ηη'])`
//!   with `x_D = w t`, `x_R = (1 - w) s` of the side in this frame and `y` the same in the
//!   frame before.
//!
//! Each pixel's estimate is unbiased with the weights fixed (they come from the neighbourhood's
//! terms, not the pixel's own, `estimate::box_mean_of_others`) and as noisy as the frame's own
//! error term; the clip's statement is their mean over pixels and pairs of frames, relative as
//! the flicker is measured: over `((m + m') / 2 + 0.01)^2`, `m` the frame's stand-in for its
//! true value (`estimate`'s notes). Checked against the truth on synthetic clips below, and
//! against `converge --flicker`'s references in docs/denoising.md.

use glam::DVec3;

use super::estimate::{DENOISED, DENOISED_A, DenoiseTerms, ERROR, WEIGHT, stand_in};
use raytrace_core::image::{Image, Precision, Rgb, RgbPlanes, Values};
use raytrace_core::metrics::estimated_rel_mse_term;
use raytrace_core::pass::SAMPLES;
use raytrace_core::replicates::{Replicate, Replicates};

/// The raw replicate `a` (now) in a frame's change terms.
const HALF_A: Rgb = Rgb(["rawA.R", "rawA.G", "rawA.B"]);
/// The raw replicate `b` (now).
const HALF_B: Rgb = Rgb(["rawB.R", "rawB.G", "rawB.B"]);
/// The denoised replicate `D(b)` in a frame's change terms.
const DENOISED_B: Rgb = Rgb(["denoisedB.R", "denoisedB.G", "denoisedB.B"]);
/// The stand-in `m` for the true value in the relative change.
const STAND_IN: Rgb = Rgb(["standIn.R", "standIn.G", "standIn.B"]);
/// The share `s_a` of replicate `a` in the raw frame now.
const SHARE_A: &str = "share.a";
/// The share `t_a` of replicate `a` in the denoised frame (at the samples denoised).
const DENOISED_SHARE_A: &str = "share.denoisedA";

/// Float channels of a frame's change terms.
const CHANNELS: usize = 7 * 3 + 2;

/// What the change of the error to or from a written frame reads of it: per pixel, its raw
/// replicates now, its denoised replicates, the denoised frame's weight, its error term, its
/// stand-in for the true value and the replicates' shares: an image of 92 bytes a pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct ChangeTerms {
    terms: Image,
}

impl ChangeTerms {
    /// The terms of the frame written from `snapshot` (its last denoise) and `replicates` (the
    /// film's replicates when written), whose written terms are `written`
    /// (`DenoiseTerms::written`).
    pub fn new(snapshot: &DenoiseTerms, replicates: &Image, written: &Image) -> ChangeTerms {
        let h = Replicates::of(replicates);
        let then = snapshot.terms();
        let (denoised, da) = (planes(then, DENOISED), planes(then, DENOISED_A));
        let (weight, error) = (planes(written, WEIGHT), planes(written, ERROR));
        let m = stand_in(written);
        let taken_then = then.counts(SAMPLES).expect("a snapshot's samples");
        let share = |taken: u32| {
            Replicate {
                taken,
                ..Default::default()
            }
            .shares()
            .0
        };
        let mut terms = Image::new(replicates.width(), replicates.height());
        terms.set_rgbs(
            [
                HALF_A, HALF_B, DENOISED_A, DENOISED_B, WEIGHT, ERROR, STAND_IN,
            ],
            |i| {
                let r = h.at(i);
                // The snapshot keeps D̄ = t_a D(a) + t_b D(b) and D(a), not D(b): in `f32`,
                // D(b) is had back to a few units in the last place of D̄, far below the
                // noise the products read.
                let t_a = share(taken_then[i]);
                let db = match 1.0 - t_a {
                    t_b if t_b > 0.0 => (denoised.at_f64(i) - da.at_f64(i) * t_a) / t_b,
                    _ => denoised.at_f64(i),
                };
                [
                    r.a.as_vec3(),
                    r.b.as_vec3(),
                    da.at(i),
                    db.as_vec3(),
                    weight.at(i),
                    error.at(i),
                    m[i].as_vec3(),
                ]
            },
        );
        terms.set(
            SHARE_A,
            Precision::Float,
            Values::Float(h.taken().iter().map(|&n| share(n) as f32).collect()),
        );
        terms.set(
            DENOISED_SHARE_A,
            Precision::Float,
            Values::Float(taken_then.iter().map(|&n| share(n) as f32).collect()),
        );
        ChangeTerms { terms }
    }

    /// The bytes a frame's change terms hold, for `pixels` pixels.
    pub fn bytes_for(pixels: u64) -> u64 {
        Image::bytes_for(pixels, CHANNELS)
    }

    /// The terms' planes, found once for a pass over the pixels.
    fn planes(&self) -> TermPlanes<'_> {
        let rgb = |names| planes(&self.terms, names);
        let share = |name| self.terms.floats(name).expect("change terms");
        TermPlanes {
            a: rgb(HALF_A),
            b: rgb(HALF_B),
            da: rgb(DENOISED_A),
            db: rgb(DENOISED_B),
            w: rgb(WEIGHT),
            error: rgb(ERROR),
            m: rgb(STAND_IN),
            s_a: share(SHARE_A),
            t_a: share(DENOISED_SHARE_A),
        }
    }
}

/// The planes of a frame's [`ChangeTerms`], each found by its channels' names once. Found
/// again for every pixel, the names' comparisons were most of what stating a clip's flicker
/// cost: `render --denoise --temporal` of the turntable (frames 1-6, 400x225, 16 samples)
/// took 1.081 of plain `--denoise`'s wall time, 1.005 with the planes found once (medians
/// of 7 alternated rounds).
struct TermPlanes<'a> {
    a: RgbPlanes<'a>,
    b: RgbPlanes<'a>,
    da: RgbPlanes<'a>,
    db: RgbPlanes<'a>,
    w: RgbPlanes<'a>,
    error: RgbPlanes<'a>,
    m: RgbPlanes<'a>,
    s_a: &'a [f32],
    t_a: &'a [f32],
}

impl TermPlanes<'_> {
    /// Pixel `i`'s values, in `f64`.
    fn pixel(&self, i: usize) -> Pixel {
        Pixel {
            a: self.a.at_f64(i),
            b: self.b.at_f64(i),
            da: self.da.at_f64(i),
            db: self.db.at_f64(i),
            w: self.w.at_f64(i),
            error: self.error.at_f64(i),
            m: self.m.at_f64(i),
            s_a: self.s_a[i] as f64,
            t_a: self.t_a[i] as f64,
        }
    }
}

/// The planes `names` of a frame's terms.
fn planes(image: &Image, names: Rgb) -> RgbPlanes<'_> {
    image.rgb(names).expect("a frame's terms")
}

/// A pixel of [`ChangeTerms`].
struct Pixel {
    a: DVec3,
    b: DVec3,
    da: DVec3,
    db: DVec3,
    w: DVec3,
    error: DVec3,
    m: DVec3,
    s_a: f64,
    t_a: f64,
}

impl Pixel {
    /// The coefficients of this frame's error on each side's denoised and raw noise:
    /// `(x_D, x_R)` for `a`, then for `b`.
    fn coefficients(&self) -> [(DVec3, DVec3); 2] {
        let r = DVec3::ONE - self.w;
        [
            (self.w * self.t_a, r * self.s_a),
            (self.w * (1.0 - self.t_a), r * (1.0 - self.s_a)),
        ]
    }
}

/// The cross-frame moments of a pixel's noise in the frame `now` and in the frame `before`,
/// unbiased (see the module's notes).
struct Moments {
    /// `ββ'`.
    bias: DVec3,
    /// Per side (`a`, then `b`): `[εε']`, `[εη']`, `[ηε']`, `[ηη']`.
    sides: [[DVec3; 4]; 2],
}

impl Moments {
    fn new(now: &Pixel, before: &Pixel) -> Moments {
        let (x, y) = (now, before);
        let p1 = (x.a - x.b) * (y.a - y.b);
        let p2 = (x.da - x.b) * (y.a - y.b);
        let p3 = (x.db - x.a) * (y.b - y.a);
        let p4 = (x.a - x.b) * (y.da - y.b);
        let p5 = (x.b - x.a) * (y.db - y.a);
        let p6 = (x.da - x.b) * (y.da - y.b);
        let p7 = (x.db - x.a) * (y.db - y.a);
        let p8 = (x.da - x.db) * (y.da - y.db);
        // The direction the products leave open, fixed by the sides' shares (both frames').
        let s_a = 0.5 * (x.s_a + y.s_a);
        let (nn_a, nn_b) = (p1 * (1.0 - s_a), p1 * s_a);
        let bb = (p6 + p7 - p8 - p1) * 0.5;
        Moments {
            bias: bb,
            sides: [
                [p6 - bb - nn_b, p2 - nn_b, p4 - nn_b, nn_a],
                [p7 - bb - nn_a, p3 - nn_a, p5 - nn_a, nn_b],
            ],
        }
    }
}

/// `E[e e']`, unbiased, of the pixel's error in the frame `now` and in the frame `before`
/// (see the module's notes).
fn covariance(now: &Pixel, before: &Pixel) -> DVec3 {
    let m = Moments::new(now, before);
    let mut c = now.w * before.w * m.bias;
    for ((m, (xd, xr)), (yd, yr)) in m
        .sides
        .iter()
        .zip(now.coefficients())
        .zip(before.coefficients())
    {
        c += xd * yd * m[0] + xd * yr * m[1] + xr * yd * m[2] + xr * yr * m[3];
    }
    c
}

/// The estimated relative mean squared change of the error from the frame of `before` to the
/// frame of `now` (of the same size), over pixels and channels, normalised as
/// `metrics::FlickerSum` normalises its references'; unbiased, so possibly negative, and
/// infinite where a pixel's error is unknown (fewer than two samples). A clip's stated
/// flicker is the root of its pairs' mean ([`flicker`]).
pub fn mean_change(before: &ChangeTerms, now: &ChangeTerms) -> f64 {
    let n = now.terms.pixels();
    assert_eq!(n, before.terms.pixels(), "frames of one size");
    let (now, before) = (now.planes(), before.planes());
    let sum: f64 = (0..n)
        .map(|i| {
            let (x, y) = (now.pixel(i), before.pixel(i));
            let change = x.error + y.error - covariance(&x, &y) * 2.0;
            estimated_rel_mse_term((x.m + y.m) * 0.5, change)
        })
        .sum();
    sum / n.max(1) as f64
}

/// A clip's stated flicker from the mean of its pairs' [`mean_change`]s: its root (0 where
/// it is negative), as `metrics::FlickerSum::flicker` takes it; infinite where unknown.
pub fn flicker(mean_change: f64) -> f64 {
    if mean_change.is_nan() {
        f64::INFINITY
    } else {
        mean_change.max(0.0).sqrt()
    }
}
