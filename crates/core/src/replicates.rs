//! A pixel's two replicates: its samples alternate between them by index (even samples in
//! `a`, odd in `b`), each an unbiased, independent estimate of the pixel's true value. The
//! film keeps them (`film::Pixel`); its variance estimate, the denoiser's inputs and the
//! denoised frame's error estimate (`denoise::estimate`) read them through [`Halves`].

use glam::{DVec3, Vec3};

/// How `n` samples split between a pixel's two replicates, `(n_a, n_b)`: `n_a = n - n/2`
/// samples of even index (replicate `a`) and `n_b = n/2` of odd index (`b`). The one place
/// the split is written.
#[inline]
pub(crate) fn replicate_counts(n: u32) -> (u32, u32) {
    let n_b = n / 2;
    (n - n_b, n_b)
}

/// A pixel's two replicates' means, its samples and the estimated variance of its whole
/// mean, as a denoiser reads them (`f32`: 40 bytes a pixel).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Halves {
    a: Vec3,
    b: Vec3,
    variance_of_mean: Vec3,
    /// The samples taken, `n`: `a` holds `n - n/2`, `b` holds `n/2` ([`replicate_counts`]).
    pub taken: u32,
}

impl Halves {
    /// A pixel of `taken` samples whose replicates' means are `a` and `b` and whose whole
    /// mean's estimated variance is `variance_of_mean`. Values an `f32` cannot hold are kept
    /// as it rounds them (infinite), so that nothing unknown looks known.
    pub fn new(a: DVec3, b: DVec3, taken: u32, variance_of_mean: DVec3) -> Halves {
        Halves {
            a: a.as_vec3(),
            b: b.as_vec3(),
            variance_of_mean: variance_of_mean.as_vec3(),
            taken,
        }
    }

    /// The mean of the even samples (replicate `a`; black without samples).
    pub fn a(&self) -> DVec3 {
        self.a.as_dvec3()
    }

    /// The mean of the odd samples (replicate `b`; black without samples).
    pub fn b(&self) -> DVec3 {
        self.b.as_dvec3()
    }

    /// The estimated variance of the whole mean (infinite with fewer than two samples).
    pub fn variance_of_mean(&self) -> DVec3 {
        self.variance_of_mean.as_dvec3()
    }

    /// The shares of the two replicates in the whole mean, `(n_a / n, n_b / n)` (halves
    /// without samples).
    pub fn shares(&self) -> (f64, f64) {
        if self.taken == 0 {
            return (0.5, 0.5);
        }
        let (n_a, n_b) = replicate_counts(self.taken);
        let n = self.taken as f64;
        (n_a as f64 / n, n_b as f64 / n)
    }

    /// The whole mean, `s_a a + s_b b` (black without samples).
    pub fn full(&self) -> DVec3 {
        let (s_a, s_b) = self.shares();
        self.a() * s_a + self.b() * s_b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_odd_samples_are_the_smaller_half() {
        assert_eq!(replicate_counts(0), (0, 0));
        assert_eq!(replicate_counts(1), (1, 0));
        assert_eq!(replicate_counts(7), (4, 3));
        assert_eq!(replicate_counts(16), (8, 8));
        let h = Halves::new(DVec3::ONE, DVec3::splat(4.0), 3, DVec3::ZERO);
        assert_eq!(h.shares(), (2.0 / 3.0, 1.0 / 3.0));
        assert!((h.full() - DVec3::splat(2.0)).abs().max_element() < 1e-12);
    }
}
