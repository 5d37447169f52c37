//! The film: per-pixel estimates of one frame, in linear radiance.

use glam::DVec3;

/// A frame's pixels, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pixels: Vec<DVec3>,
}

impl Film {
    /// A black film.
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![DVec3::ZERO; width as usize * height as usize],
        }
    }

    /// The value of pixel (`x`, `y`).
    pub fn get(&self, x: u32, y: u32) -> DVec3 {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Sets pixel (`x`, `y`).
    pub fn set(&mut self, x: u32, y: u32, v: DVec3) {
        self.pixels[y as usize * self.width as usize + x as usize] = v;
    }

    /// All pixels, row-major.
    pub fn pixels(&self) -> &[DVec3] {
        &self.pixels
    }

    /// Interleaved RGB as `f32`, the layout the writers take, and the number of pixels
    /// written as black because a component was not finite as an `f32`: NaN, infinite, or a
    /// mean beyond `f32::MAX` that the conversion rounds to infinity. Every value returned is
    /// finite.
    pub fn to_rgb_f32(&self) -> (Vec<f32>, u64) {
        let mut non_finite = 0;
        let mut rgb = Vec::with_capacity(self.pixels.len() * 3);
        for p in &self.pixels {
            let v = [p.x as f32, p.y as f32, p.z as f32];
            if v.iter().all(|c| c.is_finite()) {
                rgb.extend_from_slice(&v);
            } else {
                non_finite += 1;
                rgb.extend_from_slice(&[0.0; 3]);
            }
        }
        (rgb, non_finite)
    }
}

/// The running estimate of one pixel: the mean of its samples, their variance, and the
/// samples it dropped because they were not finite.
///
/// The mean is the plain sum over the count, so it is the same bits however the samples were
/// split into passes. The variance uses Welford's update (Welford 1962; Knuth, TAOCP vol. 2,
/// 4.2.2), which stays accurate where the naive sum of squares cancels.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelAccumulator {
    sum: DVec3,
    kept: u32,
    /// Welford's running mean and sum of squared deviations.
    w_mean: DVec3,
    w_m2: DVec3,
    /// Samples dropped because a component was NaN or infinite.
    pub dropped: u32,
}

impl PixelAccumulator {
    /// Adds one sample's radiance.
    #[inline]
    pub fn add(&mut self, v: DVec3) {
        if v.is_finite() {
            self.sum += v;
            self.kept += 1;
            let delta = v - self.w_mean;
            self.w_mean += delta / self.kept as f64;
            self.w_m2 += delta * (v - self.w_mean);
        } else {
            self.dropped += 1;
        }
    }

    /// The mean of the kept samples (black if none was kept).
    pub fn mean(&self) -> DVec3 {
        if self.kept == 0 {
            DVec3::ZERO
        } else {
            self.sum / self.kept as f64
        }
    }

    /// The estimated variance of [`mean`](Self::mean) per channel: the unbiased sample
    /// variance over the count, `s^2 / n`. Exact in expectation for independent samples; for
    /// stratified (Sobol) samples it overestimates the error. Infinite with fewer than two
    /// samples (nothing is known).
    pub fn variance_of_mean(&self) -> DVec3 {
        if self.kept < 2 {
            DVec3::INFINITY
        } else {
            let n = self.kept as f64;
            self.w_m2 / ((n - 1.0) * n)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accumulator_drops_non_finite_samples() {
        let mut a = PixelAccumulator::default();
        a.add(DVec3::splat(1.0));
        a.add(DVec3::new(f64::NAN, 0.0, 0.0));
        a.add(DVec3::splat(3.0));
        a.add(DVec3::new(0.0, f64::INFINITY, 0.0));
        assert_eq!(a.mean(), DVec3::splat(2.0));
        assert_eq!(a.dropped, 2);
        assert_eq!(PixelAccumulator::default().mean(), DVec3::ZERO);
        // The variance ignores the dropped samples: {1, 3} has s^2 = 2, so s^2 / n = 1.
        assert_eq!(a.variance_of_mean(), DVec3::ONE);
    }

    #[test]
    fn variance_matches_the_two_pass_formula_far_from_zero() {
        // Samples 1e8 + {0, 1, 2, 3, 4} (mean 1e8 + 2, s^2 = 2.5): the naive sum of squares
        // loses every digit here (1e16 against a spread of 10); Welford's update is exact.
        let mut a = PixelAccumulator::default();
        for i in 0..5 {
            a.add(DVec3::splat(1e8 + i as f64));
        }
        assert_eq!(a.kept, 5);
        assert_eq!(a.mean(), DVec3::splat(1e8 + 2.0));
        assert_eq!(a.variance_of_mean(), DVec3::splat(2.5 / 5.0));
        let mut one = PixelAccumulator::default();
        one.add(DVec3::ONE);
        assert_eq!(one.variance_of_mean(), DVec3::INFINITY);
    }

    #[test]
    fn film_layout_is_row_major_top_first() {
        let mut f = Film::new(3, 2);
        f.set(2, 1, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(f.get(2, 1), DVec3::new(1.0, 2.0, 3.0));
        let (rgb, non_finite) = f.to_rgb_f32();
        assert_eq!(&rgb[15..18], &[1.0, 2.0, 3.0]);
        assert_eq!(non_finite, 0);
    }

    #[test]
    fn values_beyond_f32_are_written_as_black_and_counted() {
        let mut f = Film::new(2, 2);
        // A finite f64 mean that overflows f32, a NaN and an infinity; one pixel fine.
        f.set(0, 0, DVec3::new(1.0, 1e300, 1.0));
        f.set(1, 0, DVec3::new(f64::NAN, 0.0, 0.0));
        f.set(0, 1, DVec3::new(0.0, 0.0, f64::NEG_INFINITY));
        f.set(1, 1, DVec3::new(0.5, f32::MAX as f64, 0.25));
        let (rgb, non_finite) = f.to_rgb_f32();
        assert_eq!(non_finite, 3);
        assert!(rgb.iter().all(|c| c.is_finite()));
        assert_eq!(&rgb[..9], &[0.0; 9]);
        assert_eq!(&rgb[9..], &[0.5, f32::MAX, 0.25]);
    }
}
