//! The written frame of a denoised render, and its error estimated without a reference.
//!
//! Every pixel's samples alternate between two replicates (`replicates::Halves`): `a`, the mean
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
//! denoise ([`Snapshot::blend`]).
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

use raytrace_core::metrics::estimated_rel_mse_term;
use raytrace_core::replicates::Halves;

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
    pub(crate) fn new(h: &Halves, da: DVec3, db: DVec3) -> PixelTerms {
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
        let (a, b, v) = (h.a(), h.b(), h.variance_of_mean());
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
pub fn weight(e_d: DVec3, v: DVec3, c: DVec3) -> DVec3 {
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

/// One pixel of a [`Snapshot`]: its [`PixelTerms`] in `f32` and the samples they were made
/// from (40 bytes).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct SnapshotPixel {
    denoised: Vec3,
    denoised_error: Vec3,
    cross: Vec3,
    taken: u32,
}

/// One denoise of a film: every pixel's [`PixelTerms`] and the samples they were made from,
/// row-major. It blends with the film as it is then or after more samples
/// ([`Snapshot::blend`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    width: usize,
    pixels: Vec<SnapshotPixel>,
}

/// One pixel of the written frame, with what a later stage that combines it with other
/// estimates of the same pixel needs (`denoise::history`): per channel, `f32`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WrittenPixel {
    /// `W = w D̄ + (1 - w) F`.
    pub written: Vec3,
    /// The raw frame `F`.
    pub raw: Vec3,
    /// The denoised frame's weight `w`.
    pub weight: Vec3,
    /// `E[(W - T)^2]`, unbiased (possibly negative; infinite where nothing is known).
    pub error: Vec3,
    /// The same from the neighbourhood's means: smooth, never negative.
    pub(crate) smooth_error: Vec3,
    /// The raw frame's variance `v`.
    pub(crate) raw_variance: Vec3,
    /// `cov(D̄ - T, F - T)` now.
    pub cross: Vec3,
}

/// The written frame ([`Snapshot::blend`]), or the written frame combined with earlier
/// frames (`denoise::history`).
#[derive(Clone, Debug, PartialEq)]
pub struct Blend {
    /// The written colour, interleaved RGB, row-major (every value finite).
    pub rgb: Vec<f32>,
    /// The frame's estimated relative error (infinite where a pixel has fewer than two
    /// samples).
    pub relative_error: f64,
    /// Each pixel's estimated relative squared error from its neighbourhood's means: smooth,
    /// for deciding where samples go (row-major).
    pub pixel_errors: Vec<f64>,
    /// The mean weight of the denoised frame over pixels and channels, in [0, 1].
    pub denoised_share: f64,
    /// The mean weight of earlier frames over pixels and channels, in [0, 1].
    pub history_share: f64,
}

impl Blend {
    /// The written frame of `pixels` (row-major, `width` pixels a row).
    pub fn from_written(width: usize, pixels: &[WrittenPixel]) -> Blend {
        let values: Vec<[Vec3; 3]> = pixels
            .iter()
            .map(|p| [p.written, p.error, p.smooth_error])
            .collect();
        let raw: Vec<Vec3> = pixels.iter().map(|p| p.raw).collect();
        let mut blend = Blend::new(width, &values, &raw);
        blend.denoised_share = pixels
            .iter()
            .map(|p| p.weight.element_sum() as f64 / 3.0)
            .sum::<f64>()
            / pixels.len().max(1) as f64;
        blend
    }

    /// The frame of `values` (row-major, `width` pixels a row): each pixel's value, its
    /// unbiased and smooth squared errors, per channel, and the raw frame `raw` to stand in
    /// for the true value (with the value itself: the smaller of the value and the raw
    /// frame's 3x3 mean, see the module's notes).
    pub fn new(width: usize, values: &[[Vec3; 3]], raw: &[Vec3]) -> Blend {
        let n = values.len();
        let raw: Vec<DVec3> = raw.iter().map(|r| r.as_dvec3()).collect();
        let around = box_mean(&raw, width, 1);
        let mut rgb = Vec::with_capacity(3 * n);
        let mut pixel_errors = Vec::with_capacity(n);
        let mut sum = 0.0;
        for (i, [value, error, smooth]) in values.iter().enumerate() {
            let value = value.as_dvec3();
            let m = value.max(DVec3::ZERO).min(around[i].max(DVec3::ZERO));
            sum += estimated_rel_mse_term(m, error.as_dvec3());
            pixel_errors.push(estimated_rel_mse_term(m, smooth.as_dvec3()));
            rgb.extend_from_slice(&to_f32(value).to_array());
        }
        let mean = sum / n.max(1) as f64;
        Blend {
            rgb,
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

fn to_f32(v: DVec3) -> Vec3 {
    let c = v.as_vec3();
    if c.is_finite() { c } else { Vec3::ZERO }
}

impl Snapshot {
    /// The snapshot of a film whose pixels' replicates are `halves` and whose replicates
    /// denoised are `da` and `db` (interleaved RGB); all row-major, `width` pixels a row.
    pub fn new(width: usize, halves: &[Halves], da: &[f32], db: &[f32]) -> Snapshot {
        assert_eq!(da.len(), 3 * halves.len(), "a denoised half per pixel");
        assert_eq!(db.len(), 3 * halves.len(), "a denoised half per pixel");
        let at = |v: &[f32], i: usize| Vec3::from_slice(&v[3 * i..3 * i + 3]).as_dvec3();
        let pixels = halves
            .iter()
            .enumerate()
            .map(|(i, h)| {
                let t = PixelTerms::new(h, at(da, i), at(db, i));
                SnapshotPixel {
                    denoised: to_f32(t.denoised),
                    // Kept infinite where nothing is known.
                    denoised_error: t.denoised_error.as_vec3(),
                    cross: to_f32(t.cross),
                    taken: h.taken,
                }
            })
            .collect();
        Snapshot { width, pixels }
    }

    /// The frame written from this denoise and the film's replicates now, `halves`
    /// (row-major, the same pixels with at least the samples denoised): see the module's
    /// notes.
    pub fn blend(&self, halves: &[Halves]) -> Blend {
        let pixels = self.written(halves);
        Blend::from_written(self.width, &pixels)
    }

    /// [`blend`](Self::blend)'s pixels, with what combining them with earlier frames needs.
    pub fn written(&self, halves: &[Halves]) -> Vec<WrittenPixel> {
        assert_eq!(halves.len(), self.pixels.len(), "the film denoised");
        // The pixel's terms now: the covariance falls with the samples added since.
        let terms: Vec<[DVec3; 3]> = self
            .pixels
            .iter()
            .zip(halves)
            .map(|(p, h)| {
                let fall = if h.taken > 0 {
                    p.taken as f64 / h.taken as f64
                } else {
                    1.0
                };
                [
                    p.denoised_error.as_dvec3(),
                    h.variance_of_mean(),
                    p.cross.as_dvec3() * fall,
                ]
            })
            .collect();
        let finite = |v: DVec3| if v.is_finite() { v } else { DVec3::ZERO };
        let smoothed: Vec<Vec<DVec3>> = (0..3)
            .map(|k| {
                let map: Vec<DVec3> = terms.iter().map(|t| finite(t[k])).collect();
                box_mean_of_others(&map, self.width, WEIGHT_RADIUS)
            })
            .collect();
        terms
            .iter()
            .zip(halves)
            .enumerate()
            .map(|(i, ([e_d, v, c], h))| {
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
                let raw = h.full();
                WrittenPixel {
                    written: to_f32(
                        self.pixels[i].denoised.as_dvec3() * w + raw * (DVec3::ONE - w),
                    ),
                    raw: to_f32(raw),
                    weight: w.as_vec3(),
                    error: blended_error(w, *e_d, *v, *c).as_vec3(),
                    smooth_error: to_f32(blended_error(w, se, sv, sc).max(DVec3::ZERO)),
                    raw_variance: v.as_vec3(),
                    cross: to_f32(*c),
                }
            })
            .collect()
    }

    /// The denoised frame `D̄`, interleaved RGB, row-major.
    #[cfg(test)]
    pub(crate) fn denoised_rgb(&self) -> Vec<f32> {
        self.pixels
            .iter()
            .flat_map(|p| p.denoised.to_array())
            .collect()
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

    fn halves(a: f64, b: f64, taken: u32, v: f64) -> Halves {
        Halves::new(DVec3::splat(a), DVec3::splat(b), taken, DVec3::splat(v))
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
        let s = Snapshot::new(1, &[h], &[0.9; 3], &[1.1; 3]);
        let now = s.blend(&[h]);
        // Four times the samples: a quarter of the covariance, a new variance.
        let later = halves(1.05, 1.1, 16, 0.002);
        let then = s.blend(&[later]);
        let t = PixelTerms::new(&h, DVec3::splat(0.9), DVec3::splat(1.1));
        let w = weight(t.denoised_error, DVec3::splat(0.002), t.cross / 4.0);
        let e = blended_error(w, t.denoised_error, DVec3::splat(0.002), t.cross / 4.0);
        let written = t.denoised * w + later.full() * (DVec3::ONE - w);
        assert!((then.rgb[0] as f64 - written.x).abs() < 1e-6);
        let m = written.min(later.full()).max(DVec3::ZERO);
        assert!((then.relative_error.powi(2) - estimated_rel_mse_term(m, e)).abs() < 1e-9);
        assert_ne!(now.rgb, then.rgb);
    }

    #[test]
    fn box_means_agree_with_direct_sums() {
        let (w, h) = (7, 5);
        let values: Vec<f64> = (0..w * h).map(|i| ((i * 37) % 11) as f64).collect();
        let boxed = box_mean(&values, w, 1);
        for y in 0..h {
            for x in 0..w {
                let (mut s, mut n) = (0.0, 0.0);
                for ny in y.saturating_sub(1)..(y + 2).min(h) {
                    for nx in x.saturating_sub(1)..(x + 2).min(w) {
                        s += values[ny * w + nx];
                        n += 1.0;
                    }
                }
                assert!((boxed[y * w + x] - s / n).abs() < 1e-12);
            }
        }
    }
}
