//! A film denoised: the full frame and each of its two replicates through the denoiser, each
//! with guides of its own samples, and from them the denoised frame's estimated error, bias
//! included (`denoise::estimate`), per pixel and for the frame.
//!
//! Seven runs of the filter: each replicate's albedo and normal prefiltered (four), then the
//! two replicates and the full frame. The full frame's guides are the prefiltered replicates'
//! guides averaged by their samples: prefiltering the full frame's own would take two more
//! runs for guides hardly cleaner.

use glam::DVec3;

use crate::denoise::denoiser::{DenoiseError, Denoiser, Guides};
use crate::denoise::estimate::{self, PixelInputs};
use crate::denoise::reproject::Accumulated;
use crate::film::Film;
use crate::passes::Layout;

/// Pixels around each pixel (a square of side `2 SMOOTHING + 1`) whose estimated errors are
/// averaged to steer adaptive sampling: one pixel's estimate is unbiased but very noisy.
const SMOOTHING: usize = 2;

/// The share of a pixel's raw relative variance in its weight under a denoised threshold
/// (see [`Denoised::weights`]).
const RAW_SHARE: f64 = 0.125;

/// A denoised frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Denoised {
    /// The denoised colour, interleaved RGB, row-major, top row first (every value finite).
    pub rgb: Vec<f32>,
    /// The denoised frame's estimated relative error, bias included (as
    /// [`FrameStats::relative_error`](super::FrameStats::relative_error) is of a raw frame).
    pub relative_error: f64,
    /// Each pixel's estimated relative squared error, row-major: unbiased but noisy, possibly
    /// negative.
    pub pixel_errors: Vec<f64>,
    /// With temporal denoising: how many frames a pixel's colour averaged, on average over
    /// the frame (`denoise::reproject`).
    pub frames_averaged: Option<f64>,
}

impl Denoised {
    /// Each pixel's estimated relative variance *per sample* of the denoised frame, as the
    /// adaptive rounds weigh pixels: its error averaged over its neighbourhood (never below
    /// 0), plus [`RAW_SHARE`] of its raw relative variance, times its samples (a denoised
    /// error taken to fall as one over the samples, as a raw one does). Row-major.
    ///
    /// The raw share keeps every noisy pixel sampled. A pixel's denoised estimate is noisy and
    /// may read below zero by chance; with weights from it alone, such a pixel got no more
    /// samples, so its low reading stayed in the frame's estimate while the other pixels'
    /// readings fell with their samples, and the frame's estimate went to 0 while the true
    /// error was 3 percent (the books' scene, `--noise-threshold 0.02`). A reading's noise
    /// scales with the pixel's raw variance, so sampling in proportion to that refreshes the
    /// readings that can be far off.
    pub(super) fn weights(&self, film: &Film) -> Vec<f64> {
        let width = film.width as usize;
        let smoothed = estimate::box_mean(&self.pixel_errors, width, SMOOTHING);
        let raw: Vec<f64> = film
            .means()
            .into_iter()
            .zip(film.variances())
            .map(|(m, v)| crate::analysis::metrics::estimated_rel_mse_term(m, v))
            .collect();
        smoothed
            .iter()
            .zip(raw)
            .enumerate()
            .map(|(i, (e, r))| {
                let (x, y) = ((i % width) as u32, (i / width) as u32);
                let v = (e.max(0.0) + RAW_SHARE * r) * film.pixel(x, y).taken() as f64;
                if v.is_finite() { v } else { f64::MAX }
            })
            .collect()
    }
}

/// The film's images as the denoiser takes them, row-major: the full frame, the two
/// replicates, and each replicate's guides.
struct Images {
    full: Vec<f32>,
    a: Vec<f32>,
    b: Vec<f32>,
    albedo: [Vec<f32>; 2],
    normal: [Vec<f32>; 2],
    /// Each pixel's share of its samples in replicate `a`, `n_a / n` (one half without
    /// samples).
    share_a: Vec<f32>,
    /// The estimate's inputs but for the denoised replicates, filled in later.
    inputs: Vec<PixelInputs>,
}

/// `v` as `f32`, black where not finite as an `f32`.
fn finite_f32(v: DVec3) -> [f32; 3] {
    let c = [v.x as f32, v.y as f32, v.z as f32];
    if c.iter().all(|c| c.is_finite()) {
        c
    } else {
        [0.0; 3]
    }
}

fn images(film: &Film, guides: usize) -> Images {
    let n = film.width as usize * film.height as usize;
    let zeros = || vec![0.0f32; 3 * n];
    let mut im = Images {
        full: zeros(),
        a: zeros(),
        b: zeros(),
        albedo: [zeros(), zeros()],
        normal: [zeros(), zeros()],
        share_a: vec![0.5; n],
        inputs: vec![
            PixelInputs {
                a: DVec3::ZERO,
                b: DVec3::ZERO,
                samples: 0,
                variance_of_mean: DVec3::ZERO,
                denoised_a: DVec3::ZERO,
                denoised_b: DVec3::ZERO,
            };
            n
        ],
    };
    let stride = film.pass_stride();
    for (rect, pixels, sums) in film.tiles_with_pass_sums() {
        for (k, pixel) in pixels.iter().enumerate() {
            let (x, y) = rect.position(k);
            let i = y as usize * film.width as usize + x as usize;
            let g = &sums[k * stride + guides..k * stride + guides + 12];
            let taken = pixel.taken();
            let (n_b, n_a) = ((taken / 2) as f64, (taken - taken / 2) as f64);
            let over = |s: &[f64], n: f64| {
                if n > 0.0 {
                    DVec3::new(s[0], s[1], s[2]) / n
                } else {
                    DVec3::ZERO
                }
            };
            let (a, b) = pixel.replicate_means();
            let at = 3 * i..3 * i + 3;
            im.full[at.clone()].copy_from_slice(&pixel.rgb_f32());
            im.a[at.clone()].copy_from_slice(&finite_f32(a));
            im.b[at.clone()].copy_from_slice(&finite_f32(b));
            if taken > 0 {
                im.share_a[i] = (n_a / (n_a + n_b)) as f32;
            }
            let guide = [
                (over(&g[0..3], n_a), over(&g[3..6], n_a)),
                (over(&g[6..9], n_b), over(&g[9..12], n_b)),
            ];
            for (r, (albedo, normal)) in guide.into_iter().enumerate() {
                im.albedo[r][at.clone()].copy_from_slice(&finite_f32(albedo));
                im.normal[r][at.clone()].copy_from_slice(&finite_f32(normal));
            }
            im.inputs[i] = PixelInputs {
                a,
                b,
                samples: taken,
                variance_of_mean: pixel.variance_of_mean(),
                denoised_a: DVec3::ZERO,
                denoised_b: DVec3::ZERO,
            };
        }
    }
    im
}

/// Denoises `film` (whose pass sums are laid out by `layout`, with guides) and estimates the
/// denoised frame's error.
pub(super) fn denoise(
    film: &Film,
    layout: &Layout,
    denoiser: &Denoiser,
) -> Result<Denoised, DenoiseError> {
    denoise_with(film, layout, denoiser, None)
}

/// [`denoise`], with the replicates' colours `accumulated` over the frames before the film's
/// in place of its own (`denoise::reproject`). The error is still estimated against the
/// film's own replicates: `D(a)`, made from `a` accumulated, is checked against this frame's
/// own `b` (independent of it, and unbiased for this frame), so the estimate sees what
/// borrowing from earlier frames costs as well as what it gains.
pub(super) fn denoise_with(
    film: &Film,
    layout: &Layout,
    denoiser: &Denoiser,
    accumulated: Option<&Accumulated>,
) -> Result<Denoised, DenoiseError> {
    let guides = layout
        .guides()
        .expect("a denoised frame keeps the denoiser's guides");
    let (w, h) = (film.width as usize, film.height as usize);
    let mut im = images(film, guides);
    if let Some(acc) = accumulated {
        im.a.clone_from(&acc.a);
        im.b.clone_from(&acc.b);
        for (k, full) in im.full.iter_mut().enumerate() {
            let s = im.share_a[k / 3];
            *full = s * acc.a[k] + (1.0 - s) * acc.b[k];
        }
    }
    let replicate = |colour: &[f32], r: usize| -> Result<(Vec<f32>, [Vec<f32>; 2]), DenoiseError> {
        let raw = Guides {
            albedo: &im.albedo[r],
            normal: &im.normal[r],
        };
        let (albedo, normal) = denoiser.prefilter(w, h, raw)?;
        let clean = Guides {
            albedo: &albedo,
            normal: &normal,
        };
        let mut out = denoiser.denoise_with_clean_guides(w, h, &[colour], clean)?;
        Ok((out.remove(0), [albedo, normal]))
    };
    let (a, [albedo_a, normal_a]) = replicate(&im.a, 0)?;
    let (b, [albedo_b, normal_b]) = replicate(&im.b, 1)?;
    let mean = |x: &[f32], y: &[f32]| -> Vec<f32> {
        x.iter()
            .zip(y)
            .enumerate()
            .map(|(k, (x, y))| {
                let s = im.share_a[k / 3];
                s * x + (1.0 - s) * y
            })
            .collect()
    };
    let (albedo, normal) = (mean(&albedo_a, &albedo_b), mean(&normal_a, &normal_b));
    let full = denoiser
        .denoise_with_clean_guides(
            w,
            h,
            &[&im.full],
            Guides {
                albedo: &albedo,
                normal: &normal,
            },
        )?
        .remove(0);
    let mut inputs = im.inputs;
    let triple =
        |v: &[f32], i: usize| DVec3::new(v[3 * i] as f64, v[3 * i + 1] as f64, v[3 * i + 2] as f64);
    for (i, p) in inputs.iter_mut().enumerate() {
        p.denoised_a = triple(&a, i);
        p.denoised_b = triple(&b, i);
    }
    // The estimate divides by the denoised frame, clamped at 0 (a denoiser may undershoot).
    let denoised_full: Vec<DVec3> = (0..w * h)
        .map(|i| triple(&full, i).max(DVec3::ZERO))
        .collect();
    let pixel_errors = estimate::relative_squared_errors(&inputs, &denoised_full, w);
    let relative_error = estimate::frame_relative_error(&inputs, &denoised_full, w);
    let rgb = full
        .into_iter()
        .map(|c| if c.is_finite() { c } else { 0.0 })
        .collect();
    Ok(Denoised {
        rgb,
        relative_error,
        pixel_errors,
        frames_averaged: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4x4 film whose every pixel took 16 samples, 0.2 in one replicate and 0.6 in the other (a raw
    /// variance), but pixel (1, 2), which took 16 samples of 0.4 (none).
    fn film() -> Film {
        let mut film = Film::new(4, 4);
        for tile in film.tiles_mut() {
            for (i, p) in tile.pixels.iter_mut().enumerate() {
                let (x, y) = tile.rect.position(i);
                for k in 0..16 {
                    let v = if (x, y) == (1, 2) {
                        0.4
                    } else if k % 2 == 0 {
                        0.2
                    } else {
                        0.6
                    };
                    p.add(DVec3::splat(v));
                }
            }
        }
        film
    }

    #[test]
    fn a_pixel_whose_denoised_reading_is_low_is_still_sampled_by_its_raw_noise() {
        let film = film();
        // Every denoised reading below zero, as noise makes some: alone, no pixel would be
        // sampled again, and the readings would stay.
        let denoised = Denoised {
            rgb: vec![0.4; 3 * 16],
            relative_error: 0.0,
            pixel_errors: vec![-1.0; 16],
            frames_averaged: None,
        };
        let w = denoised.weights(&film);
        // The raw share only: RAW_SHARE of the raw relative variance, times the samples.
        let v = film.pixel(0, 0).variance_of_mean();
        let raw = crate::analysis::metrics::estimated_rel_mse_term(film.pixel(0, 0).mean(), v);
        assert!(raw > 0.0);
        assert_eq!(w[0], RAW_SHARE * raw * 16.0);
        // The pixel without raw noise (but the rounding of its sums) is not sampled for it.
        assert!(w[2 * 4 + 1] < 1e-12 * w[0], "{}", w[2 * 4 + 1]);
        // A positive reading adds to the raw share.
        let denoised = Denoised {
            pixel_errors: vec![0.5; 16],
            ..denoised
        };
        let w = denoised.weights(&film);
        assert!((w[0] / ((0.5 + RAW_SHARE * raw) * 16.0) - 1.0).abs() < 1e-12);
    }
}
