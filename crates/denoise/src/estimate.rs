//! The written frame of a denoised render, and its error estimated without a reference.
//!
//! Every pixel's samples alternate between two replicates (`replicates::Replicate`): `a`, the mean
//! of its `n_a = n - n/2` even samples, and `b`, the mean of its `n_b = n/2` odd ones, each an
//! unbiased, independent estimate of the true value `T`. The raw frame is
//! `F = s_a a + s_b b` (`s_a = n_a / n`, `s_b = n_b / n`), with the film's estimated variance
//! `v` of its mean. The denoiser `D` is run on each replicate, never on `F`, and the denoised
//! frame is their mean `D̄ = s_a D(a) + s_b D(b)`. Per pixel and channel, write
//! `D(a) = T + β + ε_a`, `D(b) = T + β + ε_b` (β the denoiser's bias, the same for both
//! halves; ε its left-over noise) and `a = T + η_a`, `b = T + η_b`, with `var(η_a) = v n / n_a`
//! and `var(η_b) = v n / n_b`. The two halves' samples are independent, so `(ε_a, η_a)` is
//! independent of `(ε_b, η_b)`. Then, with no model of the denoiser:
//!
//! - **Each denoised half against the other raw half** (cross-validation):
//!   `E[(D(a) - b)^2] - var(η_b) = β^2 + σ_a^2` (σ_a^2 = E[ε_a^2]), and likewise for `b`.
//! - **The denoised halves against each other**: `E[(D(a) - D(b))^2] = σ_a^2 + σ_b^2`.
//! - Three equations in `β^2`, `σ_a^2`, `σ_b^2`, so the denoised frame's error
//!   `E[(D̄ - T)^2] = β^2 + s_a^2 σ_a^2 + s_b^2 σ_b^2` has an unbiased estimate
//!   ([`PixelTerms::denoised_error`]).
//! - **How a denoised half follows its own noise**: `E[(D(a) - b)(a - b)] - var(η_b) =
//!   E[ε_a η_a]`, so `cov(D̄ - T, F - T) = s_a^2 E[ε_a η_a] + s_b^2 E[ε_b η_b]` has one too
//!   ([`PixelTerms::cross`]).
//!
//! **The written frame** is, per pixel and channel, `W = w D̄ + (1 - w) F` with the weight
//! that minimises its expected squared error `w^2 e_D + (1 - w)^2 v + 2 w (1 - w) c`
//! (`e_D` the denoised error, `c` the covariance): `w = (v - c) / (e_D + v - 2c)`, clamped to
//! [0, 1]. One pixel's terms are unbiased but very noisy, so the weight is taken from their
//! means over the pixel's neighbourhood (a square of side `2 WEIGHT_RADIUS + 1`), where the
//! denoiser's error and the raw noise change slowly. Where the denoiser is biased (edges it
//! blurs, detail it removes) the weight leans to the raw frame, where it removes noise to the
//! denoised one: combining the two is what fixes a denoiser's slow convergence at high
//! sample counts (James-Stein-type combiners; Denisova et al., HPG 2024). With the weight
//! fixed, the written pixel's error `w^2 e_D + (1 - w)^2 v + 2 w (1 - w) c` has an unbiased
//! estimate from the pixel's own terms, and the frame's relative error is the square root of
//! the mean of those over `(m + 0.01)^2`, as the raw frame's is (`metrics`).
//!
//! **After more samples** (a noise threshold adds rounds after the last denoise), `D̄` and its
//! error are unchanged, the raw frame's variance is the film's again, and the covariance
//! falls with the samples: `F' = (n F + (n' - n) F_new) / n'`, the new samples independent of
//! `D̄`, so `cov(D̄, F') = c n / n'`. A frame can be re-blended exactly without another
//! denoise ([`DenoiseTerms::blend`]).
//!
//! `m`, standing in for the true value in the relative error's denominator, is per channel
//! the smaller of the written pixel and the mean of `F` over its 3x3 neighbourhood: the
//! written value is nearly free of noise but blurred (beside a bright region a dark pixel is
//! raised, and its term shrinks), the neighbourhood's mean is unbiased but noisy.
//!
//! Measured (docs/denoising.md): the stated error against references of independent seeds on
//! every shipped scene, 16 to 1024 samples a pixel, and the written frame against the raw
//! frame at 16 to 4096.

use glam::{DVec3, Vec3};

use raytrace_core::image::{COLOUR, Image, Precision, Rgb, Values};
use raytrace_core::metrics::estimated_rel_mse_term;
use raytrace_core::pass::SAMPLES;
use raytrace_core::replicates::{REPLICATE_A, REPLICATE_B, Replicate, Replicates};

/// The half-side of the square over which a pixel's terms are averaged to choose its weight:
/// 17x17 pixels. The terms are unbiased but noisy, and a weight chosen from noisy terms is
/// itself a source of error: on the books' scene (200x112, 16 to 1024 samples) 17x17 gave
/// the lowest written error of 5x5, 9x9 and 17x17, the three within 1.5 percent of each
/// other (`converge --denoise`, one build a radius).
pub(crate) const WEIGHT_RADIUS: usize = 8;

/// One pixel's unbiased estimates from one denoise of its replicates, per channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct PixelTerms {
    /// The denoised frame `D̄ = s_a D(a) + s_b D(b)`.
    pub denoised: DVec3,
    /// `E[(D̄ - T)^2]`, unbiased (so possibly negative).
    pub(crate) denoised_error: DVec3,
    /// `cov(D̄ - T, F - T)` at the samples denoised, unbiased.
    pub cross: DVec3,
}

impl PixelTerms {
    /// The terms of a pixel whose replicates are `h` and denoised replicates `da`, `db` (see
    /// the module's derivation). With fewer than two samples nothing is known: the errors are
    /// infinite.
    pub(crate) fn new(h: &Replicate, da: DVec3, db: DVec3) -> PixelTerms {
        let (s_a, s_b) = h.shares();
        let denoised = da * s_a + db * s_b;
        if h.taken < 2 {
            return PixelTerms {
                denoised,
                denoised_error: DVec3::INFINITY,
                cross: DVec3::ZERO,
            };
        }
        // var(η_a) = v n / n_a = v / s_a.
        let (a, b, v) = (h.a, h.b, h.variance_of_mean);
        let (var_a, var_b) = (v / s_a, v / s_b);
        let cv_a = (da - b) * (da - b) - var_b;
        let cv_b = (db - a) * (db - a) - var_a;
        let g = (da - db) * (da - db);
        // σ_a^2 = (g + cv_a - cv_b) / 2, σ_b^2 = (g - cv_a + cv_b) / 2, β^2 = (cv_a + cv_b - g) / 2.
        let bias2 = (cv_a + cv_b - g) * 0.5;
        let sigma_a2 = (g + cv_a - cv_b) * 0.5;
        let sigma_b2 = (g - cv_a + cv_b) * 0.5;
        let c_a = (da - b) * (a - b) - var_b;
        let c_b = (db - a) * (b - a) - var_a;
        PixelTerms {
            denoised,
            denoised_error: bias2 + sigma_a2 * (s_a * s_a) + sigma_b2 * (s_b * s_b),
            cross: c_a * (s_a * s_a) + c_b * (s_b * s_b),
        }
    }
}

/// The weight of the denoised frame that minimises the written pixel's expected squared
/// error, per channel, from (neighbourhood means of) the denoised error `e_d`, the raw
/// variance `v` and their covariance `c`: `(v - c) / (e_d + v - 2c)` in [0, 1]. A raw pixel
/// of unknown variance (fewer than two samples) takes the denoised value.
pub(crate) fn weight(e_d: DVec3, v: DVec3, c: DVec3) -> DVec3 {
    let one = |e_d: f64, v: f64, c: f64| {
        if !v.is_finite() {
            return 1.0;
        }
        let e_d = e_d.max(0.0);
        let den = e_d + v - 2.0 * c;
        if den > 0.0 && den.is_finite() {
            ((v - c) / den).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    DVec3::new(
        one(e_d.x, v.x, c.x),
        one(e_d.y, v.y, c.y),
        one(e_d.z, v.z, c.z),
    )
}

/// The expected squared error of `w D̄ + (1 - w) F` from the denoised error `e_d`, the raw
/// variance `v` and their covariance `c`.
pub(crate) fn blended_error(w: DVec3, e_d: DVec3, v: DVec3, c: DVec3) -> DVec3 {
    let r = DVec3::ONE - w;
    // 0 * inf is NaN: a weight of 0 or 1 takes only its own side's term.
    let part = |k: DVec3, e: DVec3| {
        DVec3::new(
            if k.x == 0.0 { 0.0 } else { k.x * e.x },
            if k.y == 0.0 { 0.0 } else { k.y * e.y },
            if k.z == 0.0 { 0.0 } else { k.z * e.z },
        )
    };
    part(w * w, e_d) + part(r * r, v) + part(2.0 * w * r, c)
}

/// `-n d/dn` of [`blended_error`] at the weight `w` ([`sample_weights`]):
/// `(1 - w)^2 v + 2 w (1 - w) c + (2/3) w^2 e_d`, `e_d` the denoised error at the samples now.
pub(crate) fn reducible(w: DVec3, e_d: DVec3, v: DVec3, c: DVec3) -> DVec3 {
    blended_error(w, e_d * (2.0 / 3.0), v, c)
}

/// The denoised frame `D̄` in a [`DenoiseTerms`]'s terms.
pub(crate) const DENOISED: Rgb = Rgb(["denoised.R", "denoised.G", "denoised.B"]);
/// The denoised replicate `D(a)` in a [`DenoiseTerms`]'s terms (what the clip's change of
/// error reads with [`DENOISED`]: `denoise::change`).
pub(crate) const DENOISED_A: Rgb = Rgb(["denoisedA.R", "denoisedA.G", "denoisedA.B"]);
/// The denoised frame's error `E[(D̄ - T)^2]` in a snapshot's terms (kept infinite where
/// nothing is known).
pub(crate) const DENOISED_ERROR: Rgb =
    Rgb(["denoisedError.R", "denoisedError.G", "denoisedError.B"]);
/// `cov(D̄ - T, F - T)`: in a snapshot's terms at the samples denoised, in a written frame's
/// terms now.
pub(crate) const CROSS: Rgb = Rgb(["cross.R", "cross.G", "cross.B"]);
/// The written frame `W = w D̄ + (1 - w) F`: the colour.
pub(crate) const WRITTEN: Rgb = COLOUR;
/// The raw frame `F` in a written frame's terms.
pub(crate) const RAW: Rgb = Rgb(["raw.R", "raw.G", "raw.B"]);
/// The denoised frame's weight `w` in a written frame's terms.
pub(crate) const WEIGHT: Rgb = Rgb(["weight.R", "weight.G", "weight.B"]);
/// `E[(W - T)^2]`, unbiased (possibly negative; infinite where nothing is known).
pub(crate) const ERROR: Rgb = Rgb(["error.R", "error.G", "error.B"]);
/// The same from the neighbourhood's means: smooth, never negative.
pub(crate) const SMOOTH_ERROR: Rgb = Rgb(["smoothError.R", "smoothError.G", "smoothError.B"]);
/// The raw frame's variance `v` in a written frame's terms.
pub(crate) const RAW_VARIANCE: Rgb = Rgb(["rawVariance.R", "rawVariance.G", "rawVariance.B"]);
/// What more samples remove of the written pixel's squared error, per added sample over its
/// samples now ([`sample_weights`]), from the pixel's own terms at its weight.
pub(crate) const REDUCIBLE: Rgb = Rgb(["reducible.R", "reducible.G", "reducible.B"]);

/// One denoise of a film, its terms: every pixel's [`PixelTerms`] in `f32` ([`DENOISED`],
/// [`DENOISED_ERROR`], [`CROSS`]), the denoised replicate `D(a)` ([`DENOISED_A`]) and the
/// samples they were made from ([`SAMPLES`]), an image of 52 bytes a pixel. It blends with the
/// film as it is then or after more samples ([`DenoiseTerms::blend`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DenoiseTerms {
    terms: Image,
}

/// The written frame ([`DenoiseTerms::blend`]), or the written frame combined with earlier
/// frames (`denoise::history`).
#[derive(Clone, Debug, PartialEq)]
pub struct Blend {
    /// The written colour ([`COLOUR`], every value finite).
    pub image: Image,
    /// The frame's estimated relative error (infinite where a pixel has fewer than two
    /// samples).
    pub relative_error: f64,
    /// Each pixel's estimated relative squared error from its neighbourhood's means: smooth
    /// (row-major). Where samples go is [`sample_weights`]'s.
    pub pixel_errors: Vec<f64>,
    /// The mean weight of the denoised frame over pixels and channels, in [0, 1].
    pub denoised_share: f64,
    /// The mean weight of earlier frames over pixels and channels, in [0, 1].
    pub history_share: f64,
}

impl Blend {
    /// The written frame of `written` (a written frame's terms, [`DenoiseTerms::written`]).
    pub fn from_written(written: &Image) -> Blend {
        let mut blend = Blend::new(written);
        blend.denoised_share = denoised_share(written);
        blend
    }

    /// The frame of `terms`: each pixel's value ([`WRITTEN`]), its unbiased and smooth
    /// squared errors ([`ERROR`], [`SMOOTH_ERROR`]), per channel, and the raw frame ([`RAW`])
    /// to stand in for the true value (with the value itself: the smaller of the value and
    /// the raw frame's 3x3 mean, see the module's notes).
    pub fn new(terms: &Image) -> Blend {
        let n = terms.pixels();
        let planes = |names| terms.rgb(names).expect("a written frame's terms");
        let (value, error, smooth) = (planes(WRITTEN), planes(ERROR), planes(SMOOTH_ERROR));
        let around = raw_around(terms);
        let mut pixel_errors = Vec::with_capacity(n);
        let mut sum = 0.0;
        let mut image = Image::new(terms.width(), terms.height());
        image.set_rgbs([COLOUR], |i| {
            let v = value.at_f64(i);
            let m = true_value_for_error(v, around[i]);
            sum += estimated_rel_mse_term(m, error.at_f64(i));
            pixel_errors.push(estimated_rel_mse_term(m, smooth.at_f64(i)));
            [to_f32(v)]
        });
        let mean = sum / n.max(1) as f64;
        Blend {
            image,
            relative_error: if mean.is_nan() {
                f64::INFINITY
            } else {
                mean.max(0.0).sqrt()
            },
            pixel_errors,
            denoised_share: 0.0,
            history_share: 0.0,
        }
    }
}

/// The raw frame of `terms` (a written frame's, or a combination's), averaged over each
/// pixel's 3x3 neighbourhood.
fn raw_around(terms: &Image) -> Vec<DVec3> {
    let raw = terms.rgb(RAW).expect("a written frame's terms");
    let raw: Vec<DVec3> = (0..terms.pixels()).map(|i| raw.at_f64(i)).collect();
    box_mean(&raw, terms.width() as usize, 1)
}

/// Each pixel's stand-in for its true value in the relative error of `terms` (a written
/// frame's): [`true_value_for_error`] of its value and the raw frame's mean around it.
pub(crate) fn stand_in(terms: &Image) -> Vec<DVec3> {
    let value = terms.rgb(WRITTEN).expect("a written frame's terms");
    raw_around(terms)
        .into_iter()
        .enumerate()
        .map(|(i, around)| true_value_for_error(value.at_f64(i), around))
        .collect()
}

/// What stands in for a pixel's true value in its relative error: the smaller of its value
/// `v` and the raw frame's mean `around` it (see the module's notes).
fn true_value_for_error(v: DVec3, around: DVec3) -> DVec3 {
    v.max(DVec3::ZERO).min(around.max(DVec3::ZERO))
}

/// Each pixel's relative squared error that the next samples remove, per sample: where a
/// round's samples lower the written frame's error most (`finish::Denoising` weighs the
/// adaptive rounds by it, times the pixel's samples, as raw rounds weigh the raw variance
/// per sample). `written` is a written frame's terms ([`DenoiseTerms::written`]).
///
/// With the weight `w` fixed, the written error `w^2 e_D + (1 - w)^2 v + 2 w (1 - w) c` falls
/// with the samples `n` through its raw side (`v` and `c` fall as `1 / n`) and, once the frame
/// is denoised again, its denoised side (`e_D` as `n^(-2/3)`, a smoother's rate: Stone, Ann.
/// Statist. 10, 1982), so `-n d/dn` of it is `(1 - w)^2 v + 2 w (1 - w) c + (2/3) w^2 e_D`,
/// with `e_D` carried from the samples denoised to now at that rate ([`REDUCIBLE`]). The whole
/// error would not do: where the denoised side holds it, a stale denoise's error does not fall
/// with the samples between denoises, and a weight of error times samples would grow without
/// bound there, sending every round's samples to the same pixels. The terms are the pixel's
/// own at its (smooth) weight, averaged over its 3x3 neighbourhood as the raw rounds average
/// the raw variance (`renderer::adaptive`): where the weight is 0 the rounds go exactly where
/// raw rounds would, so the denoiser never sends samples where they do less than raw
/// sampling's.
pub fn sample_weights(written: &Image) -> Vec<f64> {
    let value = written.rgb(WRITTEN).expect("a written frame's terms");
    let reducible = written.rgb(REDUCIBLE).expect("a written frame's terms");
    let around = raw_around(written);
    let own: Vec<f64> = (0..written.pixels())
        .map(|i| {
            let m = true_value_for_error(value.at_f64(i), around[i]);
            estimated_rel_mse_term(m, reducible.at_f64(i))
        })
        .collect();
    mean_3x3(&own, written.width() as usize)
}

/// The mean of `values` (row-major, `width` wide) over each pixel's 3x3 neighbourhood, cut at
/// the image's edges, summed directly: a summed-area table ([`box_mean`]) would lose a small
/// term beside large ones to cancellation, and these span many orders of magnitude. A pixel
/// with a term that is not finite (fewer than two samples) is `f64::MAX`, as its neighbours.
fn mean_3x3(values: &[f64], width: usize) -> Vec<f64> {
    let height = values.len() / width.max(1);
    let mut out = Vec::with_capacity(values.len());
    for y in 0..height {
        for x in 0..width {
            let (mut sum, mut count) = (0.0, 0.0);
            for yy in y.saturating_sub(1)..(y + 2).min(height) {
                for xx in x.saturating_sub(1)..(x + 2).min(width) {
                    sum += values[yy * width + xx];
                    count += 1.0;
                }
            }
            let mean = sum / count;
            out.push(if mean.is_finite() { mean } else { f64::MAX });
        }
    }
    out
}

/// The bytes a snapshot of a frame of `pixels` pixels holds ([`DenoiseTerms`]: its terms'
/// twelve channels and the samples).
pub fn terms_bytes(pixels: u64) -> u64 {
    Image::bytes_for(pixels, 13)
}

/// The bytes a written frame of `pixels` pixels holds once blended: its terms' 24 channels
/// ([`DenoiseTerms::written`]) and its blend (the colour and each pixel's error).
pub fn written_bytes(pixels: u64) -> u64 {
    Image::bytes_for(pixels, WRITTEN_CHANNELS + 3) + pixels * std::mem::size_of::<f64>() as u64
}

/// The channels of a written frame's terms ([`DenoiseTerms::written`]).
const WRITTEN_CHANNELS: usize = 24;

/// The bytes a blend ([`DenoiseTerms::written`], then [`Blend::from_written`]) holds at its peak
/// beyond its inputs, for a frame of `pixels` pixels: each pixel's terms now and their
/// neighbourhood means (three `DVec3`s each) while the written frame's terms are made
/// ([`WRITTEN_CHANNELS`] `f32`s); the blend after them holds less (the terms, and a `DVec3` a
/// pixel for the raw frame and two for its 3x3 means).
pub fn blending_bytes(pixels: u64) -> u64 {
    let dvec3 = std::mem::size_of::<DVec3>() as u64;
    pixels * (3 * dvec3 + 3 * dvec3) + Image::bytes_for(pixels, WRITTEN_CHANNELS)
}

/// The mean weight of the denoised frame in a written frame's terms, over pixels and channels.
pub(crate) fn denoised_share(written: &Image) -> f64 {
    let weight = written.rgb(WEIGHT).expect("a written frame's terms");
    let n = written.pixels();
    (0..n)
        .map(|i| weight.at(i).element_sum() as f64 / 3.0)
        .sum::<f64>()
        / n.max(1) as f64
}

/// `v` as an `f32`, black where that is not finite.
fn to_f32(v: DVec3) -> Vec3 {
    let c = v.as_vec3();
    if c.is_finite() { c } else { Vec3::ZERO }
}

impl DenoiseTerms {
    /// The snapshot of a film whose replicates are `replicates` (a film's replicates image)
    /// and whose replicates denoised are `da` and `db` (each [`REPLICATE_A`]'s and
    /// [`REPLICATE_B`]'s channels as the denoiser gives them back); all of one size.
    pub fn new(replicates: &Image, da: &Image, db: &Image) -> DenoiseTerms {
        let h = Replicates::of(replicates);
        let (da, db) = (
            da.rgb(REPLICATE_A).expect("replicate a, denoised"),
            db.rgb(REPLICATE_B).expect("replicate b, denoised"),
        );
        let mut terms = Image::new(replicates.width(), replicates.height());
        let names = [DENOISED, DENOISED_ERROR, CROSS, DENOISED_A];
        terms.set_rgbs(names, |i| {
            let t = PixelTerms::new(&h.at(i), da.at_f64(i), db.at_f64(i));
            // The error kept infinite where nothing is known.
            [
                to_f32(t.denoised),
                t.denoised_error.as_vec3(),
                to_f32(t.cross),
                da.at(i),
            ]
        });
        terms.set(SAMPLES, Precision::Float, Values::Count(h.taken().to_vec()));
        DenoiseTerms { terms }
    }

    /// The frame written from this denoise and the film's replicates now, `replicates` (the
    /// same pixels with at least the samples denoised): see the module's notes.
    pub fn blend(&self, replicates: &Image) -> Blend {
        Blend::from_written(&self.written(replicates))
    }

    /// [`blend`](Self::blend)'s terms, with what combining them with earlier frames needs:
    /// an image of [`WRITTEN`], [`RAW`], [`WEIGHT`], [`ERROR`], [`SMOOTH_ERROR`],
    /// [`RAW_VARIANCE`], [`CROSS`] (now) and [`REDUCIBLE`], `f32`.
    pub fn written(&self, replicates: &Image) -> Image {
        let h = Replicates::of(replicates);
        let taken_then = self.terms.counts(SAMPLES).expect("a snapshot's samples");
        let planes = |names| self.terms.rgb(names).expect("a snapshot's terms");
        let (denoised, denoised_error, cross) =
            (planes(DENOISED), planes(DENOISED_ERROR), planes(CROSS));
        let n = replicates.pixels();
        assert_eq!(n, taken_then.len(), "the film denoised");
        // The pixel's terms now: the covariance falls with the samples added since.
        let terms: Vec<[DVec3; 4]> = (0..n)
            .map(|i| {
                let h = h.at(i);
                let fall = if h.taken > 0 {
                    taken_then[i] as f64 / h.taken as f64
                } else {
                    1.0
                };
                [
                    denoised_error.at_f64(i),
                    h.variance_of_mean,
                    cross.at_f64(i) * fall,
                    DVec3::splat(fall),
                ]
            })
            .collect();
        let finite = |v: DVec3| if v.is_finite() { v } else { DVec3::ZERO };
        let width = replicates.width() as usize;
        let smoothed: Vec<Vec<DVec3>> = (0..3)
            .map(|k| {
                let map: Vec<DVec3> = terms.iter().map(|t| finite(t[k])).collect();
                box_mean_of_others(&map, width, WEIGHT_RADIUS)
            })
            .collect();
        let mut written = Image::new(replicates.width(), replicates.height());
        let names = [
            WRITTEN,
            RAW,
            WEIGHT,
            ERROR,
            SMOOTH_ERROR,
            RAW_VARIANCE,
            CROSS,
            REDUCIBLE,
        ];
        written.set_rgbs(names, |i| {
            let [e_d, v, c, fall] = &terms[i];
            let (se, sv, sc) = (
                smoothed[0][i].max(DVec3::ZERO),
                smoothed[1][i],
                smoothed[2][i],
            );
            let w = if v.is_finite() {
                weight(se, sv, sc)
            } else {
                DVec3::ONE
            };
            let raw = h.at(i).full();
            [
                to_f32(denoised.at_f64(i) * w + raw * (DVec3::ONE - w)),
                to_f32(raw),
                w.as_vec3(),
                blended_error(w, *e_d, *v, *c).as_vec3(),
                to_f32(blended_error(w, se, sv, sc).max(DVec3::ZERO)),
                v.as_vec3(),
                to_f32(*c),
                to_f32(reducible(
                    w,
                    e_d.max(DVec3::ZERO) * fall.powf(2.0 / 3.0),
                    *v,
                    *c,
                )),
            ]
        });
        written
    }

    /// The terms, as [`DenoiseTerms::new`] made them (for `denoise::change`).
    pub(crate) fn terms(&self) -> &Image {
        &self.terms
    }

    /// The denoised frame `D̄`, interleaved RGB, row-major.
    #[cfg(test)]
    pub(crate) fn denoised_rgb(&self) -> Vec<f32> {
        self.terms
            .interleaved(DENOISED)
            .expect("a snapshot's terms")
    }
}

/// The mean of `values` (row-major, `width` wide) over each pixel's square of side
/// `2 radius + 1`, cut at the image's edges, leaving the pixel itself out (a pixel alone: its
/// own value).
///
/// What a pixel's weight is chosen from must not hold the pixel's own terms: one pixel's
/// term is unbiased but its noise can be fifty times its mean (where the denoiser removes
/// nearly all of the noise, the denoised error is a small difference of the halves' large
/// noise), so a neighbourhood mean that holds it still follows it, the weight follows the term's noise,
/// and the terms weighted by it are no longer unbiased: measured on a smooth synthetic frame,
/// the written frame's statement read 0.23 of the truth with the pixel in its own mean.
pub(crate) fn box_mean_of_others<T>(values: &[T], width: usize, radius: usize) -> Vec<T>
where
    T: Copy
        + Default
        + std::ops::Add<Output = T>
        + std::ops::Sub<Output = T>
        + std::ops::Mul<f64, Output = T>
        + std::ops::Div<f64, Output = T>,
{
    let height = values.len() / width.max(1);
    box_mean(values, width, radius)
        .into_iter()
        .enumerate()
        .map(|(i, mean)| {
            let (x, y) = (i % width, i / width);
            let n = ((x + radius + 1).min(width) - x.saturating_sub(radius))
                * ((y + radius + 1).min(height) - y.saturating_sub(radius));
            if n <= 1 {
                values[i]
            } else {
                (mean * n as f64 - values[i]) / (n - 1) as f64
            }
        })
        .collect()
}

/// The mean of `values` (row-major, `width` wide) over each pixel's square of side
/// `2 radius + 1`, cut at the image's edges: a smoothed map of per-pixel estimates.
pub(crate) fn box_mean<T>(values: &[T], width: usize, radius: usize) -> Vec<T>
where
    T: Copy
        + Default
        + std::ops::Add<Output = T>
        + std::ops::Sub<Output = T>
        + std::ops::Div<f64, Output = T>,
{
    let height = values.len() / width.max(1);
    // A summed-area table: s[y][x] is the sum over rows < y and columns < x.
    let mut sums = vec![T::default(); (width + 1) * (height + 1)];
    for y in 0..height {
        let mut row = T::default();
        for x in 0..width {
            row = row + values[y * width + x];
            sums[(y + 1) * (width + 1) + x + 1] = sums[y * (width + 1) + x + 1] + row;
        }
    }
    let at = |x: usize, y: usize| sums[y * (width + 1) + x];
    let mut out = Vec::with_capacity(values.len());
    for y in 0..height {
        let (y0, y1) = (y.saturating_sub(radius), (y + radius + 1).min(height));
        for x in 0..width {
            let (x0, x1) = (x.saturating_sub(radius), (x + radius + 1).min(width));
            let sum = at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0);
            out.push(sum / ((x1 - x0) * (y1 - y0)) as f64);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn halves(a: f64, b: f64, taken: u32, v: f64) -> Replicate {
        // As a film's replicates image keeps them: in f32.
        let f = |x: f64| DVec3::splat(x).as_vec3().as_dvec3();
        Replicate {
            a: f(a),
            b: f(b),
            variance_of_mean: f(v),
            taken,
        }
    }

    /// A one-pixel replicates image of `h`, and the denoised replicates `da`, `db`.
    fn one_pixel(h: &Replicate, da: f32, db: f32) -> (Image, Image, Image) {
        let mut r = Image::new(1, 1);
        r.set_rgb(REPLICATE_A, [h.a.as_vec3()].into_iter());
        r.set_rgb(REPLICATE_B, [h.b.as_vec3()].into_iter());
        r.set_rgb(
            raytrace_core::pass::VARIANCE,
            [h.variance_of_mean.as_vec3()].into_iter(),
        );
        r.set(SAMPLES, Precision::Float, Values::Count(vec![h.taken]));
        let denoised = |names, v: f32| {
            let mut d = Image::new(1, 1);
            d.set_rgb(names, [Vec3::splat(v)].into_iter());
            d
        };
        (r, denoised(REPLICATE_A, da), denoised(REPLICATE_B, db))
    }

    #[test]
    fn a_pixel_s_terms_follow_the_formulas() {
        // n = 4 (2 and 2): shares 1/2, var(η_a) = var(η_b) = 2 v = 0.02.
        // D(a) = 0.9, D(b) = 1.1, a = 1.0, b = 1.2.
        // cv_a = (0.9 - 1.2)^2 - 0.02 = 0.07, cv_b = (1.1 - 1.0)^2 - 0.02 = -0.01,
        // g = 0.04: β^2 = (0.07 - 0.01 - 0.04) / 2 = 0.01, σ_a^2 = (0.04 + 0.08) / 2 = 0.06,
        // σ_b^2 = (0.04 - 0.08) / 2 = -0.02: e = 0.01 + (0.06 - 0.02) / 4 = 0.02.
        // c_a = (0.9 - 1.2)(1.0 - 1.2) - 0.02 = 0.04, c_b = (1.1 - 1.0)(1.2 - 1.0) - 0.02 = 0:
        // cov = 0.04 / 4 = 0.01.
        let t = PixelTerms::new(
            &halves(1.0, 1.2, 4, 0.01),
            DVec3::splat(0.9),
            DVec3::splat(1.1),
        );
        // (The halves are kept in f32.)
        assert!((t.denoised - DVec3::splat(1.0)).abs().max_element() < 1e-7);
        assert!((t.denoised_error - DVec3::splat(0.02)).abs().max_element() < 1e-7);
        assert!((t.cross - DVec3::splat(0.01)).abs().max_element() < 1e-7);
        // One sample: nothing is known.
        let one = PixelTerms::new(&halves(1.0, 0.0, 1, f64::INFINITY), DVec3::ONE, DVec3::ZERO);
        assert_eq!(one.denoised_error, DVec3::INFINITY);
        assert_eq!(one.denoised, DVec3::ONE);
    }

    #[test]
    fn the_terms_are_unbiased_for_a_linear_smoother() {
        // A "denoiser" that keeps 30 percent of a pixel's own value and takes 70 percent of
        // a fixed, biased neighbourhood value: D(x) = 0.3 x + 0.7 (T + 0.2). Its bias is
        // 0.14, its noise 0.3 η; D̄'s squared error 0.14^2 + 0.09 var(η) / 2, its covariance
        // with F 0.3 var(η) / 2 (equal halves, var(η) a half's variance).
        let mut rng = raytrace_core::rng::Pcg32::new(3, 9);
        let (truth, var_half) = (1.0f64, 0.04f64);
        let d = |x: f64| 0.3 * x + 0.7 * (truth + 0.2);
        let trials = 200_000;
        let (mut e, mut c) = (0.0, 0.0);
        for _ in 0..trials {
            // Uniform noise of variance var_half: half-width sqrt(3 var_half).
            let mut noise = || (2.0 * rng.next_f64() - 1.0) * (3.0 * var_half).sqrt();
            let (a, b) = (truth + noise(), truth + noise());
            // The film's own estimate of the variance of the whole mean.
            let v = (a - b) * (a - b) / 4.0;
            let t = PixelTerms::new(&halves(a, b, 16, v), DVec3::splat(d(a)), DVec3::splat(d(b)));
            e += t.denoised_error.x;
            c += t.cross.x;
        }
        let (e, c) = (e / trials as f64, c / trials as f64);
        let (true_e, true_c) = (
            0.14f64.powi(2) + 0.09 * var_half / 2.0,
            0.3 * var_half / 2.0,
        );
        assert!((e / true_e - 1.0).abs() < 0.02, "{e} against {true_e}");
        assert!((c / true_c - 1.0).abs() < 0.03, "{c} against {true_c}");
    }

    #[test]
    fn the_weight_minimises_the_blended_error() {
        let (e_d, v, c) = (
            DVec3::new(1.0, 4.0, 0.5),
            DVec3::new(3.0, 1.0, 2.0),
            DVec3::splat(0.25),
        );
        let w = weight(e_d, v, c);
        let best = blended_error(w, e_d, v, c);
        for k in 0..=100 {
            let other = DVec3::splat(k as f64 / 100.0);
            let e = blended_error(other, e_d, v, c);
            assert!((best - e).max_element() <= 1e-12, "{other} beats {w}");
        }
        // A raw pixel of unknown variance takes the denoised value; no denoised benefit, raw.
        assert_eq!(weight(DVec3::ONE, DVec3::INFINITY, DVec3::ZERO), DVec3::ONE);
        assert_eq!(weight(DVec3::ONE, DVec3::ZERO, DVec3::ZERO), DVec3::ZERO);
        // An infinite side with a weight of 0 adds nothing.
        assert_eq!(
            blended_error(DVec3::ZERO, DVec3::INFINITY, DVec3::ONE, DVec3::ZERO),
            DVec3::ONE
        );
    }

    #[test]
    fn after_more_samples_the_covariance_falls_with_them() {
        // One pixel wide: its neighbourhood is itself.
        let h = halves(1.0, 1.2, 4, 0.01);
        let (replicates, da, db) = one_pixel(&h, 0.9, 1.1);
        let s = DenoiseTerms::new(&replicates, &da, &db);
        let now = s.blend(&replicates);
        // Four times the samples: a quarter of the covariance, a new variance.
        let later = halves(1.05, 1.1, 16, 0.002);
        let then = s.blend(&one_pixel(&later, 0.0, 0.0).0);
        let t = PixelTerms::new(&h, DVec3::splat(0.9), DVec3::splat(1.1));
        let w = weight(t.denoised_error, DVec3::splat(0.002), t.cross / 4.0);
        let e = blended_error(w, t.denoised_error, DVec3::splat(0.002), t.cross / 4.0);
        let written = t.denoised * w + later.full() * (DVec3::ONE - w);
        let then_rgb = then.image.interleaved(COLOUR).unwrap();
        assert!((then_rgb[0] as f64 - written.x).abs() < 1e-6);
        let m = written.min(later.full()).max(DVec3::ZERO);
        assert!((then.relative_error.powi(2) - estimated_rel_mse_term(m, e)).abs() < 1e-9);
        assert_ne!(now.image, then.image);
    }

    #[test]
    fn a_stale_denoise_s_sample_weight_is_what_more_samples_remove() {
        // One pixel (its 3x3 neighbourhood is itself), denoised at 4 samples, then blended at
        // 4 and at 16: the weight is (1 - w)^2 v + 2 w (1 - w) c + (2/3) w^2 e_D, with e_D
        // carried to the samples now as n^(-2/3) and c falling as 1 / n.
        let h = halves(1.0, 1.2, 4, 0.01);
        let (replicates, da, db) = one_pixel(&h, 0.9, 1.1);
        let s = DenoiseTerms::new(&replicates, &da, &db);
        let t = PixelTerms::new(&h, DVec3::splat(0.9), DVec3::splat(1.1));
        for (later, fall) in [(h, 1.0), (halves(1.05, 1.1, 16, 0.002), 0.25)] {
            let written = s.written(&one_pixel(&later, 0.0, 0.0).0);
            let (v, c) = (later.variance_of_mean, t.cross * fall);
            let w = weight(t.denoised_error, v, c);
            let r = DVec3::ONE - w;
            let e_d = t.denoised_error * f64::powf(fall, 2.0 / 3.0);
            let expected = r * r * v + 2.0 * w * r * c + w * w * e_d * (2.0 / 3.0);
            let value = t.denoised * w + later.full() * r;
            let m = value.max(DVec3::ZERO).min(later.full());
            let got = sample_weights(&written)[0];
            let want = estimated_rel_mse_term(m, expected);
            assert!((got / want - 1.0).abs() < 1e-5, "{got} against {want}");
        }
    }

    #[test]
    fn where_the_denoised_side_holds_the_error_more_samples_do_not_grow_the_weight() {
        // A denoise that is exact in value but biased in its estimate's eyes (a large e_D,
        // no noise of its own): w near 1. Weighed as the whole error times the samples, the
        // pixel would ask for ever more samples as they grow (e n with e fixed); weighed by
        // what more samples remove, times the samples, it grows as n^(1/3) at most.
        let h = halves(1.0, 1.0, 16, 0.01);
        let (replicates, da, db) = one_pixel(&h, 1.3, 0.7);
        let s = DenoiseTerms::new(&replicates, &da, &db);
        let per_sample = |n: u32| {
            let later = halves(1.0, 1.0, n, 0.16 / n as f64);
            sample_weights(&s.written(&one_pixel(&later, 0.0, 0.0).0))[0] * n as f64
        };
        let (at16, at1024) = (per_sample(16), per_sample(1024));
        assert!(
            at1024 / at16 <= 64f64.powf(1.0 / 3.0) * 1.0001,
            "{at16} {at1024}"
        );
    }

    #[test]
    fn a_3x3_mean_is_the_neighbourhood_s_and_keeps_unknown_pixels_unknown() {
        let values = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        // 3 wide, 2 high: the corner (0, 0) sees 1, 2, 4, 5; the middle (1, 0) all six.
        let m = mean_3x3(&values, 3);
        assert_eq!(m[0], 3.0);
        assert_eq!(m[1], 3.5);
        let unknown = mean_3x3(&[1.0, f64::INFINITY, 1.0], 3);
        assert_eq!(unknown, vec![f64::MAX; 3]);
        // Tiny terms beside huge ones are not lost (a summed-area table would cancel them).
        let spread = mean_3x3(&[1e12, 0.0, 0.0, 0.0, 0.0, 3e-9], 6);
        assert_eq!(spread[5], 1.5e-9);
    }

    #[test]
    fn box_means_agree_with_direct_sums() {
        // The summed-area table against the direct 3x3 sums of `mean_3x3`.
        let (w, h) = (7, 5);
        let values: Vec<f64> = (0..w * h).map(|i| ((i * 37) % 11) as f64).collect();
        let boxed = box_mean(&values, w, 1);
        for (b, direct) in boxed.iter().zip(mean_3x3(&values, w)) {
            assert!((b - direct).abs() < 1e-12);
        }
    }
}
