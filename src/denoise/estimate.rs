//! The estimated true error of a denoised frame, bias included, from the film's two
//! independent replicates.
//!
//! Every pixel's samples alternate between two replicates (`film::Pixel`): `a`, the mean of
//! its `n_a = n - n/2` even samples, and `b`, the mean of its `n_b = n/2` odd ones; the frame
//! is `F = (n_a a + n_b b) / n`. Each is an unbiased, independent estimate of the true value
//! `T`. With `D` the denoiser, per pixel and channel:
//!
//! - **Cross-validation.** `D(a)` depends on `a` only, so it is independent of `b`, and
//!   `E[(D(a) - b)^2] = E[(D(a) - T)^2] + var(b)` (the cross term has mean zero). Hence
//!   `err2(D(a)) ~ (D(a) - b)^2 - var(b)`, and likewise for `D(b)` against `a`. Their mean,
//!   `cv`, estimates the squared error of a denoised half, bias and noise together.
//! - **From a half to the full frame.** `F` has twice a half's samples, so `D(F)`'s error is
//!   smaller than a denoised half's, by a factor that depends on how the denoiser's bias and
//!   left-over noise fall with its input's noise. A filter that keeps its footprint would
//!   halve the noise and keep the bias; a denoiser does not keep its footprint: it smooths
//!   less as its input gets cleaner, trading bias for noise. For a smoother that chooses its
//!   footprint to balance the two on an image with smooth regions (two dimensions), the
//!   squared error falls as `n^(-2/3)` with `n` samples (Stone, "Optimal global rates of
//!   convergence for nonparametric regression", Ann. Statist. 10, 1982: `n^(-4/(4+d))`,
//!   `d = 2`). So `err2(D(F)) ~ 2^(-2/3) cv`.
//!
//!   Measured against 4096-sample references (their own error subtracted) on every shipped
//!   scene at 192x108, 16 to 1024 samples, this reads 0.92 to 1.18 of the true error. The
//!   two rules on either side read further off: taking the half's bias for the full
//!   frame's and halving the noise (`cv - (D(a) - D(b))^2 / 4`) read up to 1.34 (`defocus`,
//!   64 and 128 samples, where the denoiser's bias falls fastest); the other way round,
//!   keeping each pixel's self-weight in `D` from the half to the full frame (a SURE-like
//!   `(D(F) - F)^2 - v + 2 s v`) read as low as 0.75.
//!
//! The replicates' variances come from the film's variance of `F`'s mean `v` (itself
//! estimated from `(a - b)^2`): one sample's variance is `v n`, so `var(a) = v n / n_a` and
//! `var(b) = v n / n_b`.
//!
//! Cross-validation needs `D(a)` free of `b`'s samples: its guides must come from `a`'s own
//! samples (or from samples of neither), not from the whole pixel; guides averaged over both
//! replicates carry some of `b`'s noise into `D(a)` and make the estimate read low.
//!
//! A single pixel's estimate is very noisy and may be negative; it is unbiased, so means over
//! regions ([`box_mean`], [`tile_means`]) or the frame ([`frame_relative_error`]) are what to
//! act on.
//!
//! The relative error is the project's (`analysis::metrics`): the mean over pixels and
//! channels of `err2 / (m + 0.01)^2` and its square root, where `m` stands in for the true
//! value. As in the film's own estimate, `m` is per channel the smaller of two stand-ins:
//! the denoised frame `D(F)`, nearly free of noise but blurred (beside a bright region a dark
//! pixel's `D(F)` is raised, and its term shrinks), and the mean of `F` over the pixel's 3x3
//! neighbourhood, unbiased but noisy. Measured on synthetic frames with path-tracer-like
//! noise (non-negative, skewed): `D(F)` alone read 0.68 to 0.83 of the true error on a frame
//! with edges at 140 percent input noise, the smaller of the two 0.93 to 1.04.

use crate::analysis::metrics::estimated_rel_mse_term;
use glam::DVec3;

/// One pixel's inputs: the film's replicates and the denoised images, as read for the pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelInputs {
    /// The mean of the even samples (replicate `a`).
    pub a: DVec3,
    /// The mean of the odd samples (replicate `b`).
    pub b: DVec3,
    /// The pixel's sample count `n` (`a` holds `n - n/2`, `b` holds `n/2`).
    pub samples: u32,
    /// The film's estimated variance of the full mean `F`.
    pub variance_of_mean: DVec3,
    /// `D(a)`, `D(b)`: the denoised replicates.
    pub denoised_a: DVec3,
    pub denoised_b: DVec3,
}

impl PixelInputs {
    /// The full mean `F = (n_a a + n_b b) / n` (black without samples).
    pub fn full(&self) -> DVec3 {
        if self.samples == 0 {
            return DVec3::ZERO;
        }
        let n_b = (self.samples / 2) as f64;
        let n_a = self.samples as f64 - n_b;
        (self.a * n_a + self.b * n_b) / self.samples as f64
    }
}

/// How a denoised half's squared error carries to the full frame's, `2^(-2/3)`: see the
/// module's notes.
pub const HALF_TO_FULL: f64 = 0.629_960_524_947_436_6;

/// The estimated squared error of the denoised full frame `D(F)` at one pixel, per channel
/// (see the module's derivation). Unbiased for a denoised half's error but noisy; may be
/// negative. Infinite with fewer than two samples (a replicate is empty: nothing is known).
pub fn pixel_squared_error(p: &PixelInputs) -> DVec3 {
    if p.samples < 2 {
        return DVec3::INFINITY;
    }
    let n = p.samples as f64;
    let n_b = (p.samples / 2) as f64;
    let n_a = n - n_b;
    let var_a = p.variance_of_mean * (n / n_a);
    let var_b = p.variance_of_mean * (n / n_b);
    let sq = |v: DVec3| v * v;
    let cross_validated = (sq(p.denoised_a - p.b) - var_b + sq(p.denoised_b - p.a) - var_a) * 0.5;
    cross_validated * HALF_TO_FULL
}

/// Each pixel's estimated relative squared error of `D(F)`: [`pixel_squared_error`] over
/// `(m + 0.01)^2`, averaged over the channels (`metrics::estimated_rel_mse_term`), with `m`
/// the smaller of `D(F)` and `F`'s 3x3 neighbourhood mean (see the module's notes).
/// `pixels` and `denoised_full` are row-major, `width` pixels a row, one entry a pixel.
pub fn relative_squared_errors(
    pixels: &[PixelInputs],
    denoised_full: &[DVec3],
    width: usize,
) -> Vec<f64> {
    assert_eq!(
        pixels.len(),
        denoised_full.len(),
        "images of different sizes"
    );
    let full: Vec<DVec3> = pixels.iter().map(PixelInputs::full).collect();
    let around = box_mean(&full, width, 1);
    pixels
        .iter()
        .zip(denoised_full.iter().zip(around))
        .map(|(p, (d, f))| estimated_rel_mse_term(d.min(f), pixel_squared_error(p)))
        .collect()
}

/// The frame's estimated relative error of `D(F)`: the square root of the mean of
/// [`relative_squared_errors`] (clamped at 0 before the root), as the film's
/// `estimatedRelativeError` is of its own.
pub fn frame_relative_error(pixels: &[PixelInputs], denoised_full: &[DVec3], width: usize) -> f64 {
    let terms = relative_squared_errors(pixels, denoised_full, width);
    let mean = terms.iter().sum::<f64>() / terms.len().max(1) as f64;
    mean.max(0.0).sqrt()
}

/// The mean of `values` (row-major, `width` wide) over each pixel's square of side
/// `2 radius + 1`, cut at the image's edges: a smoothed map of per-pixel estimates.
pub fn box_mean<T>(values: &[T], width: usize, radius: usize) -> Vec<T>
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

/// The mean of `values` (row-major, `width` wide) over each `tile` x `tile` square, the
/// tiles row-major (those at the right and bottom edges cut short).
pub fn tile_means(values: &[f64], width: usize, tile: usize) -> Vec<f64> {
    let height = values.len() / width.max(1);
    let (tiles_x, tiles_y) = (width.div_ceil(tile), height.div_ceil(tile));
    let mut sums = vec![(0.0, 0usize); tiles_x * tiles_y];
    for (i, v) in values.iter().enumerate() {
        let (x, y) = (i % width, i / width);
        let s = &mut sums[(y / tile) * tiles_x + x / tile];
        s.0 += v;
        s.1 += 1;
    }
    sums.into_iter().map(|(s, n)| s / n as f64).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pixel(a: f64, b: f64, samples: u32, var: f64, da: f64, db: f64) -> PixelInputs {
        PixelInputs {
            a: DVec3::splat(a),
            b: DVec3::splat(b),
            samples,
            variance_of_mean: DVec3::splat(var),
            denoised_a: DVec3::splat(da),
            denoised_b: DVec3::splat(db),
        }
    }

    #[test]
    fn a_pixel_s_estimate_follows_the_formula() {
        // n = 4 (2 and 2): var(a) = var(b) = 2 v = 0.02. (D(a) - b)^2 = 0.09,
        // (D(b) - a)^2 = 0.01: (0.09 - 0.02 + 0.01 - 0.02) / 2 = 0.03, times 2^(-2/3).
        assert!((HALF_TO_FULL - 2f64.powf(-2.0 / 3.0)).abs() < 1e-16);
        let p = pixel(1.0, 1.2, 4, 0.01, 0.9, 1.1);
        assert!(
            (pixel_squared_error(&p) - DVec3::splat(0.03 * HALF_TO_FULL))
                .abs()
                .max_element()
                < 1e-12
        );
        // n = 3 (a: 2 samples, b: 1): var(a) = 1.5 v, var(b) = 3 v: (-0.06 - 0.03) / 2.
        let p = pixel(1.0, 1.0, 3, 0.02, 1.0, 1.0);
        assert!(
            (pixel_squared_error(&p) + DVec3::splat(0.045 * HALF_TO_FULL))
                .abs()
                .max_element()
                < 1e-12
        );
        assert_eq!(
            pixel_squared_error(&pixel(1.0, 1.0, 1, 0.0, 1.0, 1.0)),
            DVec3::INFINITY
        );
    }

    #[test]
    fn the_relative_figure_uses_the_metrics_definition() {
        // Squared error e = 0.03 2^(-2/3) everywhere; F = 1.1, D(F) = 0.99, the smaller: each
        // term e / 1.
        let p = pixel(1.0, 1.2, 4, 0.01, 0.9, 1.1);
        assert_eq!(p.full(), DVec3::splat(1.1));
        let d = [DVec3::splat(0.99); 6];
        let e = 0.03 * HALF_TO_FULL;
        assert!((frame_relative_error(&[p; 6], &d, 3) - e.sqrt()).abs() < 1e-12);
        // D(F) = 3: F's neighbourhood mean (1.1) is the smaller, e / 1.11^2 each.
        let d = [DVec3::splat(3.0); 6];
        let expected = (e / 1.2321).sqrt();
        assert!((frame_relative_error(&[p; 6], &d, 3) - expected).abs() < 1e-12);
    }

    #[test]
    fn box_and_tile_means_agree_with_direct_sums() {
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
        let tiles = tile_means(&values, w, 4);
        assert_eq!(tiles.len(), 4);
        // The bottom-right tile: x 4..7, y 4..5.
        let direct = (4..7).map(|x| values[4 * w + x]).sum::<f64>() / 3.0;
        assert!((tiles[3] - direct).abs() < 1e-12);
    }
}
