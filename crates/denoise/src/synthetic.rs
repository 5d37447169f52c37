//! Test images with a known truth: a true image and two replicates with seeded noise of known
//! variance. For the denoiser's and the estimate's tests.

use glam::DVec3;
use raytrace_core::image::{COLOUR, Image, Precision, Values};
use raytrace_core::pass::{SAMPLES, VARIANCE};
use raytrace_core::replicates::{REPLICATE_A, REPLICATE_B};
use raytrace_core::rng::Pcg32;

/// A synthetic frame: the truth and what a film would hold for it.
pub(crate) struct Frame {
    pub width: usize,
    pub height: usize,
    pub truth: Vec<DVec3>,
    /// The replicates' means (`a`: even samples, `b`: odd).
    pub a: Vec<DVec3>,
    pub b: Vec<DVec3>,
    /// Samples per pixel (half in each replicate).
    pub samples: u32,
}

/// A smooth image: slow waves between about 0.1 and 0.7.
pub(crate) fn smooth(x: usize, y: usize) -> DVec3 {
    let (u, v) = (x as f64 / 64.0, y as f64 / 48.0);
    let w = (std::f64::consts::TAU * u).sin() * (std::f64::consts::TAU * v).cos();
    DVec3::new(0.4 + 0.3 * w, 0.35 + 0.2 * w, 0.3 - 0.15 * w)
}

/// An image with edges: a checkerboard of 16-pixel squares (0.1 and 0.8) and a bright disk
/// (2.0, beyond 1 as HDR radiance is).
pub(crate) fn edges(x: usize, y: usize) -> DVec3 {
    let (dx, dy) = (x as f64 - 80.0, y as f64 - 48.0);
    if dx * dx + dy * dy < 20.0 * 20.0 {
        return DVec3::new(2.0, 1.8, 1.2);
    }
    if (x / 16 + y / 16).is_multiple_of(2) {
        DVec3::new(0.8, 0.7, 0.6)
    } else {
        DVec3::new(0.1, 0.12, 0.15)
    }
}

/// A standard normal number (Box-Muller).
fn gaussian(rng: &mut Pcg32) -> f64 {
    let u1 = 1.0 - rng.next_f64(); // in (0, 1]
    let u2 = rng.next_f64();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A `width` x `height` frame of `truth` whose replicates each carry noise of standard
/// deviation `noise * truth` per channel (noise growing with brightness, as a path tracer's):
/// the truth times seeded log-normal factors.
pub(crate) fn frame(
    width: usize,
    height: usize,
    truth_at: fn(usize, usize) -> DVec3,
    noise: f64,
    seed: u64,
) -> Frame {
    let mut rng = Pcg32::new(seed, 7);
    let truth = image_of(width, height, truth_at);
    let mut draw = |_| gaussians(&mut rng);
    let (za, zb): (Vec<_>, Vec<_>) = (
        truth.iter().map(&mut draw).collect(),
        truth.iter().map(&mut draw).collect(),
    );
    Frame::new(width, height, truth, noise, &za, &zb)
}

/// Two consecutive frames of a clip of `width` x `height`: the truth of `truth_at`, moved
/// `shift` pixels to the left in the second, with noise as [`frame`]'s whose normal numbers
/// have correlation `correlation` between the frames on each side (replicate `a` with `a`,
/// `b` with `b`; the sides independent): 1 is the same samples in both frames (stable sample
/// points), 0 new samples.
pub(crate) fn clip(
    width: usize,
    height: usize,
    (truth_at, shift): (fn(usize, usize) -> DVec3, usize),
    noise: f64,
    correlation: f64,
    seed: u64,
) -> [Frame; 2] {
    let mut rng = Pcg32::new(seed, 11);
    let first = image_of(width, height, truth_at);
    let second = image_of(width, height, |x, y| truth_at(x + shift, y));
    let mut draw = |_| gaussians(&mut rng);
    let (za, zb): (Vec<_>, Vec<_>) = (
        first.iter().map(&mut draw).collect(),
        first.iter().map(&mut draw).collect(),
    );
    let keep = (1.0 - correlation * correlation).sqrt();
    let mut next = |z: &[DVec3]| -> Vec<DVec3> {
        z.iter()
            .map(|z| *z * correlation + gaussians(&mut rng) * keep)
            .collect()
    };
    let (za2, zb2) = (next(&za), next(&zb));
    [
        Frame::new(width, height, first, noise, &za, &zb),
        Frame::new(width, height, second, noise, &za2, &zb2),
    ]
}

/// The values of `at` over a `width` x `height` image, row-major.
fn image_of(width: usize, height: usize, at: impl Fn(usize, usize) -> DVec3) -> Vec<DVec3> {
    (0..width * height)
        .map(|i| at(i % width, i / width))
        .collect()
}

/// Three standard normal numbers.
fn gaussians(rng: &mut Pcg32) -> DVec3 {
    let x = gaussian(rng);
    let y = gaussian(rng);
    DVec3::new(x, y, gaussian(rng))
}

impl Frame {
    /// The frame of `truth` whose replicates are the truth times log-normal factors of mean 1
    /// and standard deviation `noise` made from the normal numbers `za` and `zb`:
    /// `exp(s z - s^2 / 2)` with `s^2 = ln(1 + noise^2)`. Non-negative and skewed, as a path
    /// tracer's samples; 16 samples a pixel.
    fn new(
        width: usize,
        height: usize,
        truth: Vec<DVec3>,
        noise: f64,
        za: &[DVec3],
        zb: &[DVec3],
    ) -> Frame {
        let s2 = (1.0 + noise * noise).ln();
        let noisy = |z: &[DVec3]| -> Vec<DVec3> {
            truth
                .iter()
                .zip(z)
                .map(|(t, z)| *t * (*z * s2.sqrt() - DVec3::splat(s2 / 2.0)).exp())
                .collect()
        };
        let (a, b) = (noisy(za), noisy(zb));
        Frame {
            width,
            height,
            truth,
            a,
            b,
            samples: 16,
        }
    }

    /// An image of this frame's size whose colour is `values`.
    pub(crate) fn image(&self, values: &[DVec3]) -> Image {
        let mut image = Image::new(self.width as u32, self.height as u32);
        image.set_rgb(COLOUR, values.iter().map(|v| v.as_vec3()));
        image
    }

    /// The truth as an image.
    pub(crate) fn truth(&self) -> Image {
        self.image(&self.truth)
    }

    /// The full frame's means: the replicates' mean (equal halves), as an image.
    pub(crate) fn full(&self) -> Image {
        let full: Vec<DVec3> = self
            .a
            .iter()
            .zip(&self.b)
            .map(|(a, b)| (*a + *b) * 0.5)
            .collect();
        self.image(&full)
    }

    /// The replicates image a film would give ([`raytrace_core::film::Film::replicates`]).
    pub(crate) fn replicates(&self) -> Image {
        let mut image = Image::new(self.width as u32, self.height as u32);
        image.set_rgb(REPLICATE_A, self.a.iter().map(|v| v.as_vec3()));
        image.set_rgb(REPLICATE_B, self.b.iter().map(|v| v.as_vec3()));
        image.set_rgb(VARIANCE, self.variances().into_iter().map(|v| v.as_vec3()));
        let samples = vec![self.samples; self.width * self.height];
        image.set(SAMPLES, Precision::Float, Values::Count(samples));
        image
    }

    /// The film's estimated variance of the full mean, as `film::Pixel` forms it from the
    /// replicates' difference: `(a - b)^2 / ((1/n_a + 1/n_b) n)`.
    pub(crate) fn variances(&self) -> Vec<DVec3> {
        let n = self.samples as f64;
        let half = n / 2.0;
        self.a
            .iter()
            .zip(&self.b)
            .map(|(a, b)| (*a - *b) * (*a - *b) / ((2.0 / half) * n))
            .collect()
    }
}
