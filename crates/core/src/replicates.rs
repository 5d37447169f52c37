//! A pixel's two replicates: its samples alternate between them by index (even samples in
//! `a`, odd in `b`), each an unbiased, independent estimate of the pixel's true value. The
//! film keeps them (`film::Pixel`) and gives them as an image of named channels
//! ([`crate::film::Film::replicates`]); its variance estimate, the denoiser's inputs and the
//! written frame's error estimate (`raytrace_denoise::estimate`) read them from that image, a
//! pixel at a time ([`Replicates`]).

use glam::DVec3;

use crate::image::{Image, Rgb, RgbPlanes};
use crate::pass::{SAMPLES, VARIANCE};

/// How `n` samples split between a pixel's two replicates, `(n_a, n_b)`: `n_a = n - n/2`
/// samples of even index (replicate `a`) and `n_b = n/2` of odd index (`b`). The one place
/// the split is written.
#[inline]
pub fn replicate_counts(n: u32) -> (u32, u32) {
    let n_b = n / 2;
    (n - n_b, n_b)
}

/// The channels of replicate `a`'s mean in a film's replicates image
/// ([`crate::film::Film::replicates`]).
pub const REPLICATE_A: Rgb = Rgb(["a.R", "a.G", "a.B"]);

/// The channels of replicate `b`'s mean in a film's replicates image.
pub const REPLICATE_B: Rgb = Rgb(["b.R", "b.G", "b.B"]);

/// One pixel of a replicates image, widened to `f64` for the estimators that read it (its
/// values are the image's `f32`s: a replicate's mean, and the whole mean's estimated variance,
/// rounded once, where the image was made).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Replicate {
    /// The mean of the even samples (replicate `a`; black without samples).
    pub a: DVec3,
    /// The mean of the odd samples (replicate `b`; black without samples).
    pub b: DVec3,
    /// The estimated variance of the whole mean (infinite with fewer than two samples).
    pub variance_of_mean: DVec3,
    /// The samples taken, `n`: `a` holds `n - n/2`, `b` holds `n/2` ([`replicate_counts`]).
    pub taken: u32,
}

impl Replicate {
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
        self.a * s_a + self.b * s_b
    }
}

/// A film's replicates image ([`crate::film::Film::replicates`]) read a pixel at a time.
#[derive(Clone, Copy, Debug)]
pub struct Replicates<'a> {
    a: RgbPlanes<'a>,
    b: RgbPlanes<'a>,
    variance: RgbPlanes<'a>,
    taken: &'a [u32],
}

impl<'a> Replicates<'a> {
    /// The replicates of `image`, which must hold a film's replicates channels.
    pub fn of(image: &'a Image) -> Replicates<'a> {
        let planes = |names| image.rgb(names).expect("a film's replicates image");
        Replicates {
            a: planes(REPLICATE_A),
            b: planes(REPLICATE_B),
            variance: planes(VARIANCE),
            taken: image.counts(SAMPLES).expect("a film's replicates image"),
        }
    }

    /// Pixel `i`.
    #[inline]
    pub fn at(&self, i: usize) -> Replicate {
        Replicate {
            a: self.a.at_f64(i),
            b: self.b.at_f64(i),
            variance_of_mean: self.variance.at_f64(i),
            taken: self.taken[i],
        }
    }

    /// Every pixel's samples.
    pub fn taken(&self) -> &'a [u32] {
        self.taken
    }

    /// Every pixel, in the image's order.
    pub fn iter(&self) -> impl Iterator<Item = Replicate> + '_ {
        (0..self.taken.len()).map(|i| self.at(i))
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
        let h = Replicate {
            a: DVec3::ONE,
            b: DVec3::splat(4.0),
            variance_of_mean: DVec3::ZERO,
            taken: 3,
        };
        assert_eq!(h.shares(), (2.0 / 3.0, 1.0 / 3.0));
        assert!((h.full() - DVec3::splat(2.0)).abs().max_element() < 1e-12);
    }
}
