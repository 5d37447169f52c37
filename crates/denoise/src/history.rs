//! A written frame combined with its earlier frames' written colours, carried to its pixels
//! along the motion vectors (`denoise::reproject`), so that a denoised sequence flickers less:
//! the history route `converge --flicker` measures beside `--temporal`'s stable samples.
//!
//! Per pixel and channel there are up to three estimates of the frame's true value `T`: the
//! written frame `X_0 = W = w D̄ + (1 - w) F` (`denoise::estimate`) and the earlier frames'
//! written colours `X_1`, `X_2` where the pixel's surface is found in them. The earlier frames
//! were rendered from samples of their own, so they are independent of this frame's raw
//! frame `F`, which is unbiased: `F` is a probe that makes every entry of the estimates' error
//! covariance `Σ_ij = E[(X_i - T)(X_j - T)]` estimable without a reference, biases included
//! (a moved shadow, a blurred reprojection, the denoiser's own):
//!
//! - `Σ_00`: the written frame's own estimate.
//! - `Σ_jk = E[(X_j - F)(X_k - F)] - var(F)` for `j, k >= 1` (`F` independent of both, so the
//!   cross terms vanish and `var(F)` is left).
//! - `Σ_0j = E[(W - F)(X_j - F)] + w (c - var(F))`: `W - T = (W - F) + (F - T)`, and
//!   `E[(F - T)(X_j - T)] = 0`; `E[(W - F)(F - T)] = w (c - var(F))` with `c = cov(D̄, F)`.
//!
//! The combination `Y = Σ λ_i X_i` with `Σ λ_i = 1` of least expected squared error has
//! `λ ∝ Σ^-1 1`; the weights come from the terms' means over the pixel's neighbourhood (the
//! square of side `2 WEIGHT_RADIUS + 1` but for the pixel itself, over the pixels where each
//! earlier frame is found: `estimate::box_mean_of_others` says why the pixel is left out),
//! never negative (the best combination of the estimates whose weights are not), and the
//! written frame always among them. With the weights fixed, the pixel's own terms give an
//! unbiased estimate of `Y`'s squared error, `λ^T Σ λ`, so the frame still states its error.
//! Where an earlier frame shows something else than this one (shading changed, a reflection
//! moved), its error term is large and its weight falls; where the scene holds still, two
//! earlier frames of independent noise divide the noise's variance by up to three, and the
//! noise left is shared by consecutive frames: it no longer flickers.
//!
//! The other frames need not come before: a **centred window** (`Carry::Centred`) gives the
//! frame before and the frame after, each carried along the motion vectors that lead to it
//! (`reproject::Along`). The derivation asks only that they were rendered from samples of
//! their own, independent of this frame's `F`, which the frame after is too.

use glam::{DVec3, Vec3};

use super::estimate::{
    Blend, CROSS, ERROR, RAW, RAW_VARIANCE, SMOOTH_ERROR, WEIGHT, WEIGHT_RADIUS, WRITTEN,
    box_mean_of_others, denoised_share,
};
use super::reproject::Reprojected;
use raytrace_core::image::{COLOUR, Image, RgbPlanes};

/// Estimates a pixel may combine: its own and [`super::reproject::HISTORY`] earlier frames'.
const MOST: usize = 1 + super::reproject::HISTORY;

/// The frame of `written` (a written frame's terms, `estimate::DenoiseTerms::written`) combined
/// with `earlier`, other frames' colours carried to its pixels (at most
/// [`super::reproject::HISTORY`]; the frames before it, or the frame before and the frame
/// after): see the module's notes.
pub fn combine(written: &Image, earlier: &[Reprojected]) -> Blend {
    assert!(earlier.len() < MOST, "at most {} other frames", MOST - 1);
    let n = written.pixels();
    let estimates = Estimates::new(written, earlier);
    let smoothed = estimates.smoothed(n, written.width() as usize);
    let mut values = Vec::with_capacity(n);
    let mut history = 0.0;
    for i in 0..n {
        values.push(estimates.combined(i, &smoothed, &mut history));
    }
    // The combined frame's terms, with the raw frame that stands in for the true value.
    let mut terms = written.select(&RAW.0);
    for (k, names) in [WRITTEN, ERROR, SMOOTH_ERROR].into_iter().enumerate() {
        terms.set_rgb(names, values.iter().map(|v: &[Vec3; 3]| v[k]));
    }
    let mut blend = Blend::new(&terms);
    blend.denoised_share = denoised_share(written);
    blend.history_share = history / (3 * n.max(1)) as f64;
    blend
}

/// A pixel's entries `Σ_ab` for every pair `a <= b` of its estimates, at `a * MOST + b`;
/// `None` where an estimate is missing.
type Entries = [Option<DVec3>; MOST * MOST];

/// The estimates a pixel may combine (the written frame's and the earlier frames' colours)
/// with the written frame's terms that make their error covariance estimable.
struct Estimates<'a> {
    value: RgbPlanes<'a>,
    raw: RgbPlanes<'a>,
    raw_variance: RgbPlanes<'a>,
    error: RgbPlanes<'a>,
    weight: RgbPlanes<'a>,
    cross: RgbPlanes<'a>,
    earlier: &'a [Reprojected],
    earlier_colours: Vec<RgbPlanes<'a>>,
    /// The pairs `(a, b)`, `a <= b`, of the estimates.
    pairs: Vec<(usize, usize)>,
}

impl<'a> Estimates<'a> {
    fn new(written: &'a Image, earlier: &'a [Reprojected]) -> Self {
        let planes = |names| written.rgb(names).expect("a written frame's terms");
        let k = 1 + earlier.len();
        Estimates {
            value: planes(WRITTEN),
            raw: planes(RAW),
            raw_variance: planes(RAW_VARIANCE),
            error: planes(ERROR),
            weight: planes(WEIGHT),
            cross: planes(CROSS),
            earlier,
            earlier_colours: earlier
                .iter()
                .map(|e| e.image.rgb(COLOUR).expect("an earlier frame's colour"))
                .collect(),
            pairs: (0..k).flat_map(|a| (a..k).map(move |b| (a, b))).collect(),
        }
    }

    /// How many estimates a pixel may combine.
    fn count(&self) -> usize {
        1 + self.earlier.len()
    }

    /// Estimate `j`'s colour at pixel `i` (the written frame's for `j = 0`); `None` where the
    /// earlier frame does not show the pixel's surface.
    fn colour(&self, j: usize, i: usize) -> Option<DVec3> {
        if j == 0 {
            return Some(self.value.at_f64(i));
        }
        self.earlier[j - 1].found[i].then(|| self.earlier_colours[j - 1].at_f64(i))
    }

    /// Pixel `i`'s unbiased term `Σ_ab` (see the module's notes), `None` where an estimate
    /// is missing.
    fn entry(&self, i: usize, a: usize, b: usize) -> Option<DVec3> {
        let (f, v) = (self.raw.at_f64(i), self.raw_variance.at_f64(i));
        let (xa, xb) = (self.colour(a, i)?, self.colour(b, i)?);
        Some(match (a, b) {
            (0, 0) => self.error.at_f64(i),
            (0, _) => (xa - f) * (xb - f) + self.weight.at_f64(i) * (self.cross.at_f64(i) - v),
            _ => (xa - f) * (xb - f) - v,
        })
    }

    /// For each pair, every pixel's (of `n`, in rows of `width`) neighbourhood mean of the entry over the pixels that have
    /// it (`None` where none has).
    fn smoothed(&self, n: usize, width: usize) -> Vec<Vec<Option<DVec3>>> {
        self.pairs
            .iter()
            .map(|&(a, b)| {
                let (sums, counts): (Vec<DVec3>, Vec<f64>) = (0..n)
                    .map(|i| match self.entry(i, a, b) {
                        Some(e) if e.is_finite() => (e, 1.0),
                        _ => (DVec3::ZERO, 0.0),
                    })
                    .unzip();
                let (sums, counts) = (
                    box_mean_of_others(&sums, width, WEIGHT_RADIUS),
                    box_mean_of_others(&counts, width, WEIGHT_RADIUS),
                );
                sums.into_iter()
                    .zip(counts)
                    .map(|(s, c)| (c > 0.0).then(|| s / c))
                    .collect()
            })
            .collect()
    }

    /// Pixel `i`'s combination: its value, the unbiased estimate of its squared error and
    /// that estimate's neighbourhood mean; the earlier frames' weights are added to `history`.
    fn combined(&self, i: usize, smoothed: &[Vec<Option<DVec3>>], history: &mut f64) -> [Vec3; 3] {
        let (mut own, mut smooth): (Entries, Entries) = ([None; MOST * MOST], [None; MOST * MOST]);
        for (p, &(a, b)) in self.pairs.iter().enumerate() {
            own[a * MOST + b] = self.entry(i, a, b);
            smooth[a * MOST + b] = smoothed[p][i];
        }
        let at = |m: &Entries, a: usize, b: usize| m[a.min(b) * MOST + a.max(b)];
        let k = self.count();
        let mut value = DVec3::ZERO;
        let (mut error, mut smooth_error) = (DVec3::ZERO, DVec3::ZERO);
        for c in 0..3 {
            let lambda = best_weights(k, |a, b| {
                at(&own, a, b).and(at(&smooth, a, b)).map(|v| v[c])
            });
            for (a, la) in lambda.iter().enumerate().take(k) {
                if *la == 0.0 {
                    continue;
                }
                value[c] += la * self.colour(a, i).expect("weighted only where present")[c];
                *history += if a > 0 { *la } else { 0.0 };
                for (b, lb) in lambda.iter().enumerate().take(k) {
                    if *lb == 0.0 {
                        continue;
                    }
                    // Weights beyond the frame's own were solved where both are present;
                    // the frame alone (λ_0 = 1) may have no neighbour with a finite term
                    // (a tiny frame, one sample a pixel): its own term stands in.
                    let own_term = at(&own, a, b).expect("the frame's own term is always present");
                    error[c] += la * lb * own_term[c];
                    smooth_error[c] += la * lb * at(&smooth, a, b).unwrap_or(own_term)[c];
                }
            }
        }
        [
            value.as_vec3(),
            error.as_vec3(),
            smooth_error.max(DVec3::ZERO).as_vec3(),
        ]
    }
}

/// The bytes [`combine`] holds at its peak beyond its inputs, for a frame of `pixels` pixels
/// with a full history: each pair of estimates' smoothed entry (six pairs of three estimates,
/// an `Option<DVec3>` each a pixel), the combined values (three `Vec3`s), the combined
/// frame's terms (12 channels) and their blend's working memory (the raw frame and its 3x3
/// means, three `DVec3`s, and each pixel's error); smoothing an entry holds less.
pub fn bytes_for(pixels: u64) -> u64 {
    use std::mem::size_of;
    let entries = (MOST * (MOST + 1) / 2 * size_of::<Option<DVec3>>()) as u64;
    let values = size_of::<[Vec3; 3]>() as u64;
    let blend = (3 * size_of::<DVec3>() + size_of::<f64>()) as u64;
    pixels * (entries + values + blend) + raytrace_core::image::Image::bytes_for(pixels, 12 + 3)
}

/// The weights `λ` (summing to 1, none negative, `λ_0` above 0) over the estimates `0..k`
/// that minimise `λ^T Σ λ`, with `sigma(a, b)` the smoothed covariance (`None` where an
/// estimate is missing). Every subset holding estimate 0 is tried: at most three estimates,
/// so four subsets.
fn best_weights(k: usize, sigma: impl Fn(usize, usize) -> Option<f64>) -> [f64; MOST] {
    let mut best = [0.0; MOST];
    best[0] = 1.0;
    let Some(s00) = sigma(0, 0) else {
        return best;
    };
    let mut best_error = s00;
    for mask in 1..(1usize << (k - 1)) {
        let set: Vec<usize> = std::iter::once(0)
            .chain((1..k).filter(|j| mask & (1 << (j - 1)) != 0))
            .collect();
        let Some(lambda) = solve(&set, &sigma) else {
            continue;
        };
        if lambda.iter().any(|&l| l < 0.0) || lambda[0] <= 0.0 {
            continue;
        }
        let mut error = 0.0;
        for (x, &a) in set.iter().enumerate() {
            for (y, &b) in set.iter().enumerate() {
                error += lambda[x] * lambda[y] * sigma(a, b).expect("solved");
            }
        }
        if error < best_error {
            best_error = error;
            best = [0.0; MOST];
            for (x, &a) in set.iter().enumerate() {
                best[a] = lambda[x];
            }
        }
    }
    best
}

/// `Σ^-1 1 / (1^T Σ^-1 1)` over the estimates `set` (two or three), if `Σ` is positive
/// definite there.
fn solve(set: &[usize], sigma: &impl Fn(usize, usize) -> Option<f64>) -> Option<Vec<f64>> {
    let m = set.len();
    let mut s = [[0.0; MOST]; MOST];
    for x in 0..m {
        for y in 0..m {
            s[x][y] = sigma(set[x], set[y])?;
        }
    }
    // Σ^-1 1 by the adjugate of a 2x2 or 3x3 matrix; positive definite by its leading minors.
    let u: Vec<f64> = match m {
        2 => {
            let det = s[0][0] * s[1][1] - s[0][1] * s[1][0];
            if !(s[0][0] > 0.0 && det > 0.0) {
                return None;
            }
            vec![s[1][1] - s[0][1], s[0][0] - s[1][0]]
        }
        3 => {
            let minor2 = s[0][0] * s[1][1] - s[0][1] * s[1][0];
            let cof = |r: usize, c: usize| {
                let rows: Vec<usize> = (0..3).filter(|&i| i != r).collect();
                let cols: Vec<usize> = (0..3).filter(|&i| i != c).collect();
                let d = s[rows[0]][cols[0]] * s[rows[1]][cols[1]]
                    - s[rows[0]][cols[1]] * s[rows[1]][cols[0]];
                if (r + c).is_multiple_of(2) { d } else { -d }
            };
            let det: f64 = (0..3).map(|c| s[0][c] * cof(0, c)).sum();
            if !(s[0][0] > 0.0 && minor2 > 0.0 && det > 0.0) {
                return None;
            }
            // (adj Σ) 1: row x sums the cofactors of column x.
            (0..3).map(|x| (0..3).map(|y| cof(y, x)).sum()).collect()
        }
        _ => return None,
    };
    let total: f64 = u.iter().sum();
    (total > 0.0 && total.is_finite()).then(|| u.iter().map(|v| v / total).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use raytrace_core::rng::Pcg32;

    /// A raw frame's written terms (`w` = 0, no denoised part), `width` pixels a row, of
    /// values and variances `pixels`.
    fn raw_frame(width: usize, pixels: &[(f64, f64)]) -> Image {
        let mut image = Image::new(width as u32, (pixels.len() / width) as u32);
        let splat =
            |f: fn(&(f64, f64)) -> f64| pixels.iter().map(move |p| Vec3::splat(f(p) as f32));
        image.set_rgb(WRITTEN, splat(|p| p.0));
        image.set_rgb(RAW, splat(|p| p.0));
        image.set_rgb(WEIGHT, splat(|_| 0.0));
        image.set_rgb(ERROR, splat(|p| p.1));
        image.set_rgb(SMOOTH_ERROR, splat(|p| p.1));
        image.set_rgb(RAW_VARIANCE, splat(|p| p.1));
        image.set_rgb(CROSS, splat(|_| 0.0));
        image
    }

    /// An earlier frame found at every pixel, of colour `values` (grey).
    fn earlier_frame(width: usize, values: impl Iterator<Item = f32>) -> Reprojected {
        let values: Vec<f32> = values.collect();
        let mut image = Image::new(width as u32, (values.len() / width) as u32);
        image.set_rgb(COLOUR, values.iter().map(|&v| Vec3::splat(v)));
        Reprojected {
            found: vec![true; values.len()],
            image,
        }
    }

    /// An image's colour, interleaved.
    fn rgb(image: &Image) -> Vec<f32> {
        image.interleaved(COLOUR).unwrap()
    }

    #[test]
    fn a_frame_whose_terms_are_all_unknown_is_written_alone() {
        // One sample a pixel: no variance, every term infinite, so no neighbour has a finite
        // term to smooth. The frame keeps its own value and states its own (unknown) error.
        let pixels = raw_frame(2, &[(0.5, f64::INFINITY); 4]);
        let earlier = earlier_frame(2, [0.25; 4].into_iter());
        let blend = combine(&pixels, &[earlier]);
        let written = rgb(&blend.image);
        assert!(written.iter().all(|&x| x == 0.5), "{written:?}");
        assert_eq!(blend.history_share, 0.0);
    }

    #[test]
    fn two_positive_definite_solutions_are_exact() {
        // Σ = [[1, 0], [0, 1]]: equal weights. Σ = [[1, 0], [0, 3]]: 3/4 and 1/4.
        let l = solve(&[0, 1], &|a, b| Some(if a == b { 1.0 } else { 0.0 })).unwrap();
        assert_eq!(l, vec![0.5, 0.5]);
        let l = solve(&[0, 1], &|a, b| {
            Some(if a != b {
                0.0
            } else if a == 0 {
                1.0
            } else {
                3.0
            })
        })
        .unwrap();
        assert_eq!(l, vec![0.75, 0.25]);
        // Three independent estimates of variances 1, 2, 2: weights 1/2, 1/4, 1/4.
        let l = solve(&[0, 1, 2], &|a, b| {
            Some(if a != b {
                0.0
            } else if a == 0 {
                1.0
            } else {
                2.0
            })
        })
        .unwrap();
        assert!((l[0] - 0.5).abs() < 1e-12 && (l[1] - 0.25).abs() < 1e-12);
        // Not positive definite: no solution.
        assert!(solve(&[0, 1], &|a, b| Some(if a == b { 1.0 } else { 2.0 })).is_none());
    }

    #[test]
    fn still_frames_of_independent_noise_average_and_state_it() {
        // A flat truth of 1 and three frames of independent noise of the same variance: the
        // combination takes all three nearly equally, its true error is about a third of one
        // frame's, and its statement agrees with the truth.
        let (w, n) = (64, 64 * 48);
        let mut rng = Pcg32::new(5, 2);
        let sd = 0.1f64;
        let mut noisy = || 1.0 + sd * (12.0f64).sqrt() * (rng.next_f64() - 0.5);
        // The raw frame's own variance estimate, as the film's: one degree of freedom a pixel.
        let pixels: Vec<(f64, f64)> = (0..n)
            .map(|_| {
                let (a, b) = (noisy(), noisy());
                (0.5 * (a + b), (a - b) * (a - b) / 4.0)
            })
            .collect();
        let pixels = raw_frame(w, &pixels);
        // Earlier frames of two samples too.
        let earlier: Vec<Reprojected> = (0..2)
            .map(|_| earlier_frame(w, (0..n).map(|_| (0.5 * (noisy() + noisy())) as f32)))
            .collect();
        let blend = combine(&pixels, &earlier);
        let truth = |rgb: &[f32]| -> f64 {
            rgb.iter().map(|&c| (c as f64 - 1.0).powi(2)).sum::<f64>() / rgb.len() as f64
        };
        let (before, after) = (truth(&rgb(&pixels)), truth(&rgb(&blend.image)));
        assert!(after < 0.45 * before, "{after} vs {before}");
        // Relative terms with m ~ 1 (1.01 with the 0.01 offset).
        let stated = blend.relative_error.powi(2) * 1.01f64.powi(2);
        assert!(
            (stated / after - 1.0).abs() < 0.15,
            "stated {stated}, true {after}"
        );
        assert!(blend.history_share > 0.5, "{}", blend.history_share);
    }

    #[test]
    fn an_earlier_frame_showing_something_else_gets_no_weight() {
        // The frame before shows 2 where this one shows 1 (a shadow moved off the surface):
        // its bias is far beyond the noise, and the combination keeps this frame's value.
        let (w, n) = (32, 32 * 32);
        let mut rng = Pcg32::new(9, 4);
        let mut noisy = |t: f64| t + 0.01 * (12.0f64).sqrt() * (rng.next_f64() - 0.5);
        let pixels: Vec<(f64, f64)> = (0..n)
            .map(|_| {
                let (a, b) = (noisy(1.0), noisy(1.0));
                (0.5 * (a + b), (a - b) * (a - b) / 4.0)
            })
            .collect();
        let pixels = raw_frame(w, &pixels);
        let moved = earlier_frame(w, (0..n).map(|_| noisy(2.0) as f32));
        let blend = combine(&pixels, &[moved]);
        assert!(blend.history_share < 0.01, "{}", blend.history_share);
        let moved = rgb(&blend.image)
            .iter()
            .zip(&rgb(&pixels))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(moved < 1e-3, "{moved}");
    }
}
