//! Sample generation behind one small interface.
//!
//! A [`Sampler`] is positioned at one (pixel, sample index) of one frame and then hands out
//! the numbers of that sample's path in a fixed order of dimensions: the position inside the
//! pixel, the lens position (only for a lens of non-zero aperture), the time (only when
//! something moves during the frame), then the numbers of each bounce. Every number depends on
//! (seed, frame, pixel, sample index) alone, never on the order samples are computed in.

use crate::rng::{Pcg32, hash_words};

/// The interface the tracer draws its random numbers from.
pub trait Sampler {
    /// Positions the sampler at sample `index` of pixel (`x`, `y`).
    fn start_sample(&mut self, x: u32, y: u32, index: u32);
    /// The next number in [0, 1).
    fn next_1d(&mut self) -> f64;
    /// The next pair of numbers in [0, 1)^2.
    fn next_2d(&mut self) -> (f64, f64) {
        let a = self.next_1d();
        let b = self.next_1d();
        (a, b)
    }
}

/// Independent uniform random numbers (as the books use): a PCG32 stream per sample, seeded by
/// a hash of (seed, frame, pixel, sample index).
#[derive(Clone, Debug)]
pub struct IndependentSampler {
    key: u64,
    rng: Pcg32,
}

impl IndependentSampler {
    /// A sampler for frame `frame` of a render with seed `seed`.
    pub fn new(seed: u64, frame: u32) -> IndependentSampler {
        IndependentSampler {
            key: hash_words(&[seed, frame as u64]),
            rng: Pcg32::new(0, 0),
        }
    }
}

impl Sampler for IndependentSampler {
    #[inline]
    fn start_sample(&mut self, x: u32, y: u32, index: u32) {
        let pixel = ((y as u64) << 32) | x as u64;
        let h = hash_words(&[self.key, pixel, index as u64]);
        self.rng = Pcg32::new(h, h >> 17);
    }

    #[inline]
    fn next_1d(&mut self) -> f64 {
        self.rng.next_f64()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn draw(s: &mut IndependentSampler, x: u32, y: u32, i: u32) -> Vec<f64> {
        s.start_sample(x, y, i);
        (0..8).map(|_| s.next_1d()).collect()
    }

    #[test]
    fn numbers_depend_only_on_the_sample_coordinates() {
        let mut a = IndependentSampler::new(5, 10);
        let mut b = IndependentSampler::new(5, 10);
        let first = draw(&mut a, 3, 4, 7);
        // Other samples drawn in between change nothing.
        draw(&mut b, 9, 9, 0);
        draw(&mut b, 3, 4, 6);
        assert_eq!(draw(&mut b, 3, 4, 7), first);
    }

    #[test]
    fn seed_frame_pixel_and_index_all_matter() {
        let base = draw(&mut IndependentSampler::new(5, 10), 3, 4, 7);
        assert_ne!(draw(&mut IndependentSampler::new(6, 10), 3, 4, 7), base);
        assert_ne!(draw(&mut IndependentSampler::new(5, 11), 3, 4, 7), base);
        assert_ne!(draw(&mut IndependentSampler::new(5, 10), 4, 3, 7), base);
        assert_ne!(draw(&mut IndependentSampler::new(5, 10), 3, 4, 8), base);
    }
}
