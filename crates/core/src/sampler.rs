//! Sample generation behind one small interface.
//!
//! A [`Sampler`] is positioned at one (pixel, sample index) of one frame and then hands out
//! the numbers of that sample's path in a layout of dimensions that is the same for every
//! scene and every path (as pbrt-v4's integrators draw theirs):
//!
//! | dimensions | numbers |
//! | --- | --- |
//! | 0, 1 | the position inside the pixel ([`CameraSample::pixel`]) |
//! | 2, 3, 4 | the lens position and the time, one joint sample ([`CameraSample`]) |
//! | 5 + 3k, 6 + 3k, 7 + 3k | bounce k: `uc` and `u` ([`BounceSample`]) |
//!
//! So bounce k of a sample gets the same numbers whether or not the camera has a lens or
//! samples time, and whatever the materials of the bounces before it: every bounce takes its
//! three numbers, and a material uses those it needs. Camera numbers a frame does not use (a
//! pinhole's lens, a still scene's time) are skipped, not computed. Every number depends on
//! (seed, frame, pixel, sample index) alone, never on the order samples are computed in.
//!
//! Two samplers implement it, chosen per scene with [`SamplerKind`]:
//! - [`IndependentSampler`]: independent uniform random numbers, as the books use: dimension
//!   d is number d of a PCG32 stream of the sample.
//! - [`SobolSampler`]: an Owen-scrambled Sobol sequence for the pixel position, the lens
//!   position and time, and the first bounce, so each of them is well stratified over a
//!   pixel's samples; later bounces draw independent numbers.
//!
//! Both split a pixel's samples into [`REPLICATES`] interleaved *replicates* (sample `i`
//! belongs to replicate `i % 2`) whose numbers are independent of each other: independent
//! streams for [`IndependentSampler`], independently scrambled sequences for
//! [`SobolSampler`]. The difference between the replicates' means is what the film estimates
//! a pixel's error from (`film::Pixel::variance_of_mean`): unlike the spread of the samples,
//! it does not assume the samples themselves are independent, which stratified ones are not.

use std::fmt;
use std::str::FromStr;

use std::sync::OnceLock;

use sobol_burley::parts::{
    Int4, hash, hash_int4, owen_scramble_int4_rev, owen_scramble_rev, sobol_int4_rev,
};

use crate::rng::{Pcg32, hash_words, mix64};

/// Which of the camera's numbers a frame uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CameraUse {
    /// The lens position (a lens of non-zero aperture).
    pub lens: bool,
    /// The time (something moves during the frame's exposure).
    pub time: bool,
}

impl CameraUse {
    /// Every combination, for tests and measurements.
    pub const ALL: [CameraUse; 4] = [
        CameraUse {
            lens: false,
            time: false,
        },
        CameraUse {
            lens: true,
            time: false,
        },
        CameraUse {
            lens: false,
            time: true,
        },
        CameraUse {
            lens: true,
            time: true,
        },
    ];
}

/// The numbers of a camera ray, each in [0, 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSample {
    /// The position inside the pixel (dimensions 0 and 1).
    pub pixel: (f64, f64),
    /// The lens position (dimensions 2 and 3); 0.5, 0.5 when not used.
    pub lens: (f64, f64),
    /// The time number (dimension 4); 0.5 when not used. The renderer maps it to a time
    /// through the shutter curve and the sample's row (`FrameTimes::time`).
    pub time: f64,
}

/// The numbers of one bounce, each in [0, 1): pbrt-v4's `uc` (1-D, for a discrete choice)
/// and `u` (2-D, for a direction). Every bounce gets all three, whatever its material uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BounceSample {
    /// A 1-D number: the glass's choice between reflection and refraction, a fuzzy metal's
    /// radius in the unit ball.
    pub uc: f64,
    /// A 2-D sample: a direction on the unit sphere.
    pub u: (f64, f64),
}

/// The interface the renderer and the tracer draw their numbers from.
pub trait Sampler {
    /// Positions the sampler at sample `index` of pixel (`x`, `y`).
    fn start_sample(&mut self, x: u32, y: u32, index: u32);
    /// The numbers of the current sample's camera ray: the pixel position, and the lens
    /// position and time where `uses` asks for them (the others are 0.5 and not computed).
    /// At most once per sample, before its bounces.
    fn camera(&mut self, uses: CameraUse) -> CameraSample;
    /// The numbers of the current sample's next bounce: the k-th call since
    /// [`start_sample`](Sampler::start_sample) is bounce k (counting from 0), with the same
    /// numbers whether or not [`camera`](Sampler::camera) was called and with what.
    fn next_bounce(&mut self) -> BounceSample;
}

/// Dimension of the lens position (two dimensions) in every sample's layout.
const LENS_DIMENSION: u64 = 2;
/// Dimension of the time.
const TIME_DIMENSION: u64 = 4;
/// Dimension of the first bounce's numbers.
const FIRST_BOUNCE_DIMENSION: u64 = 5;
/// Dimensions a bounce takes: `uc` and `u`.
const BOUNCE_DIMENSIONS: u64 = 3;

/// The samplers a scene can choose from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplerKind {
    /// Independent uniform random numbers (the books' renderer; the baseline).
    Independent,
    /// Owen-scrambled Sobol points. The default: it reaches a given error in less time
    /// (docs/convergence.md).
    #[default]
    Sobol,
}

impl SamplerKind {
    /// Every sampler, in the order they are listed to users.
    pub const ALL: [SamplerKind; 2] = [SamplerKind::Independent, SamplerKind::Sobol];

    /// The name used in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Sobol => "sobol",
        }
    }

    /// The key this sampler starts every hash of frame `frame` of a render with seed `seed`
    /// from: the one place it is made, for the CPU's samplers ([`IndependentSampler::from_key`],
    /// [`SobolSampler::from_key`]) and the GPU's, which draw the same numbers.
    pub fn key(self, seed: u64, frame: u32) -> u64 {
        self.key_of_words(seed, frame as u64)
    }

    /// The key of [`key`](Self::key) with `frame_word` in the frame's place
    /// ([`SamplePattern::key`] gives a stable pattern's).
    fn key_of_words(self, seed: u64, frame_word: u64) -> u64 {
        match self {
            SamplerKind::Independent => hash_words(&[seed, frame_word]),
            // Distinct from the independent sampler's key, so the two never share numbers.
            SamplerKind::Sobol => hash_words(&[seed, frame_word, 0x0005_0b01]),
        }
    }
}

impl fmt::Display for SamplerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for SamplerKind {
    type Err = String;
    fn from_str(s: &str) -> Result<SamplerKind, String> {
        SamplerKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                let names: Vec<_> = SamplerKind::ALL.iter().map(|k| k.name()).collect();
                format!(
                    "unknown sampler \"{s}\" (expected one of: {})",
                    names.join(", ")
                )
            })
    }
}

/// Whether a frame's sample points change from frame to frame.
///
/// With [`SamplePattern::Stable`] every frame of a shot draws the same numbers at the same
/// (pixel, sample index): randomness still derives from the seed, the pixel and the sample,
/// deterministically, but not from the frame. A region that holds still then carries the same
/// noise in every frame, and the denoiser sees the same input there, so it does not flicker
/// (the advice of Blender's studio for denoised clips); where things move, the pattern stays
/// fixed to the screen. `--temporal` takes it ([`SamplePattern::of`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplePattern {
    /// New sample points every frame: the frame is one of the sampler's key's words.
    #[default]
    PerFrame,
    /// The same sample points every frame.
    Stable,
}

/// The word a stable pattern's key takes in place of the frame: no frame's number, so a
/// stable pattern shares no numbers with any frame of a per-frame one (frames are `u32`).
const STABLE_WORD: u64 = 1 << 40;

impl SamplePattern {
    /// The pattern a frame of `scene` samples with: stable with `--temporal`, per frame
    /// otherwise (the one place that decides it).
    pub fn of(scene: &crate::scene::Scene) -> SamplePattern {
        match scene.output.denoise {
            Some(d) if d.temporal => SamplePattern::Stable,
            _ => SamplePattern::PerFrame,
        }
    }

    /// The key `kind` starts every hash of frame `frame` of a render with seed `seed` from,
    /// under this pattern: [`SamplerKind::key`] of the frame, or of no frame when stable.
    pub fn key(self, kind: SamplerKind, seed: u64, frame: u32) -> u64 {
        match self {
            SamplePattern::PerFrame => kind.key(seed, frame),
            SamplePattern::Stable => kind.key_of_words(seed, STABLE_WORD),
        }
    }
}

/// Independent uniform random numbers (as the books use): a PCG32 stream per sample, seeded by
/// a hash of (seed, frame, pixel, sample index). Dimension d of the layout is number d of the
/// stream: numbers not used are stepped over, one step of the generator each.
#[derive(Clone, Debug)]
pub struct IndependentSampler {
    key: u64,
    rng: Pcg32,
    /// The dimension the stream's next number is.
    next_dimension: u64,
    /// The next bounce of the current sample.
    bounce: u64,
}

impl IndependentSampler {
    /// A sampler for frame `frame` of a render with seed `seed`.
    pub fn new(seed: u64, frame: u32) -> IndependentSampler {
        IndependentSampler::from_key(SamplerKind::Independent.key(seed, frame))
    }

    /// A sampler starting from `key` ([`SamplerKind::key`]).
    pub(crate) fn from_key(key: u64) -> IndependentSampler {
        IndependentSampler {
            key,
            rng: Pcg32::new(0, 0),
            next_dimension: 0,
            bounce: 0,
        }
    }

    /// The number of dimension `d` (not before the last one taken).
    #[inline]
    fn at(&mut self, d: u64) -> f64 {
        debug_assert!(d >= self.next_dimension, "dimension {d} asked for too late");
        // Step over the dimensions not used; a step without its output is one multiply-add.
        for _ in self.next_dimension..d {
            self.rng.next_u32();
        }
        self.next_dimension = d + 1;
        self.rng.next_f64()
    }
}

impl Sampler for IndependentSampler {
    #[inline]
    fn start_sample(&mut self, x: u32, y: u32, index: u32) {
        let pixel = ((y as u64) << 32) | x as u64;
        let h = hash_words(&[self.key, pixel, index as u64]);
        self.rng = Pcg32::new(h, h >> 17);
        self.next_dimension = 0;
        self.bounce = 0;
    }

    #[inline]
    fn camera(&mut self, uses: CameraUse) -> CameraSample {
        let pixel = (self.at(0), self.at(1));
        let lens = if uses.lens {
            (self.at(LENS_DIMENSION), self.at(LENS_DIMENSION + 1))
        } else {
            (0.5, 0.5)
        };
        let time = if uses.time {
            self.at(TIME_DIMENSION)
        } else {
            0.5
        };
        CameraSample { pixel, lens, time }
    }

    #[inline]
    fn next_bounce(&mut self) -> BounceSample {
        let d = FIRST_BOUNCE_DIMENSION + BOUNCE_DIMENSIONS * self.bounce;
        self.bounce += 1;
        let uc = self.at(d);
        BounceSample {
            uc,
            u: (self.at(d + 1), self.at(d + 2)),
        }
    }
}

/// The independent replicates a pixel's samples are split into: sample `i` is number `i / 2`
/// of replicate `i % 2`.
pub(crate) const REPLICATES: u32 = 2;

/// The number of points in one Owen-scrambled Sobol sequence of the `sobol_burley` crate.
/// Beyond it the crate returns unspecified numbers in release builds, so
/// [`SobolSampler`] never asks for an index at or above it (see [`SobolSampler`]).
pub(crate) const SOBOL_SEQUENCE_LENGTH: u32 = 1 << 16;

/// The bounces drawn from the Sobol sequence: the first. Later bounces use independent
/// numbers: their stratification lowered the error of `scenes/bouncing_spheres.toml` by under
/// 4 percent at equal samples, less than each domain's cost (docs/convergence.md).
pub(crate) const SOBOL_BOUNCES: u64 = 1;

/// The domain of the position inside the pixel.
const PIXEL_DOMAIN: usize = 0;
/// The domain of the lens position and the time.
const CAMERA_DOMAIN: usize = 1;
/// The domain of the first bounce; bounce k has domain `FIRST_BOUNCE_DOMAIN + k`.
const FIRST_BOUNCE_DOMAIN: usize = 2;
/// The domains drawn from the Sobol sequence: the pixel position, the lens position and time,
/// and the first [`SOBOL_BOUNCES`] bounces.
pub(crate) const SOBOL_DOMAINS: u64 = FIRST_BOUNCE_DOMAIN as u64 + SOBOL_BOUNCES;

/// Owen-scrambled Sobol points (the `sobol_burley` crate: Burley, "Practical Hash-based Owen
/// Scrambling", JCGT 2020, with Joe and Kuo's direction numbers), padded to more dimensions.
///
/// The layout's dimensions are grouped in fixed *domains*, each the first two or three
/// dimensions of a Sobol point, Owen-scrambled with a seed hashed from (seed, frame, pixel,
/// domain): domain 0 the pixel position, domain 1 the lens position and time (one joint 3-D
/// sample), domain 2 the first bounce (`u` in dimensions 0 and 1 of its point, `uc` in
/// dimension 2). The pixel position takes the point of the sample's index; every later domain
/// takes the point of the index shuffled by its seed (Burley's padding). So over a pixel's
/// samples each domain is a (0, m, 2)-net in every pair of its dimensions; the domains are
/// independent of each other, and each pixel's scrambles are independent of every other
/// pixel's: no pattern across the image. A domain is found by its index, so one a frame does
/// not use (the camera's, for a still pinhole) is not computed and moves no other. Bounces
/// past the first [`SOBOL_BOUNCES`] take three numbers each, in order, from a PCG32 stream of
/// the sample.
///
/// A pixel's samples form [`REPLICATES`] independently scrambled sequences, interleaved:
/// sample `i` is point `i / 2` of replicate `i % 2`, each replicate with seeds of its own. So
/// each replicate's samples are stratified on their own, and the two replicates' means are
/// independent estimates of the pixel, from which its error can be estimated without bias
/// (Owen, "Monte Carlo theory, methods and examples", ch. 17: randomized quasi-Monte Carlo
/// needs independent replicates for a variance estimate). The price is that the pixel's
/// samples are two nets of half the size instead of one.
///
/// A sequence has [`SOBOL_SEQUENCE_LENGTH`] points. A replicate's indices past it start
/// another sequence with another seed: each block of 2^16 points is well stratified on its
/// own and independent of the others, so the estimate stays unbiased at any sample count.
#[derive(Clone, Debug)]
pub struct SobolSampler {
    key: u64,
    /// The current sample's replicate.
    replicate: usize,
    /// The current sample's index within its replicate's block.
    index: u32,
    /// The next bounce of the current sample.
    bounce: u64,
    /// Independent numbers for the bounces past [`SOBOL_BOUNCES`].
    rng: Pcg32,
    /// Each replicate's seed (frame, pixel, replicate and block of 2^16 indices).
    seeds: [u64; REPLICATES as usize],
    /// Each replicate's scrambles of the current pixel's Sobol domains, which do not depend
    /// on the sample index: computed once for all of a pixel's samples.
    scrambles: [[Scramble; SOBOL_DOMAINS as usize]; REPLICATES as usize],
    /// The (pixel, block) the scrambles are for.
    scrambles_for: Option<(u64, u64)>,
}

impl SobolSampler {
    /// A sampler for frame `frame` of a render with seed `seed`.
    pub fn new(seed: u64, frame: u32) -> SobolSampler {
        SobolSampler::from_key(SamplerKind::Sobol.key(seed, frame))
    }

    /// A sampler starting from `key` ([`SamplerKind::key`]).
    pub(crate) fn from_key(key: u64) -> SobolSampler {
        SobolSampler {
            key,
            replicate: 0,
            index: 0,
            bounce: 0,
            rng: Pcg32::new(0, 0),
            seeds: [0; REPLICATES as usize],
            scrambles: [[Scramble::new(0, false); SOBOL_DOMAINS as usize]; REPLICATES as usize],
            scrambles_for: None,
        }
    }

    /// The current sample's point of Sobol domain `domain`: its first four dimensions, in
    /// [0, 1).
    #[inline]
    fn point(&self, domain: usize) -> [f64; 4] {
        self.scrambles[self.replicate][domain]
            .point(self.index)
            .map(f64::from)
    }
}

/// The first four dimensions of the Sobol sequence for 16-bit indices, as two tables of 256
/// entries, one per byte of the index: the sequence is linear over GF(2) in the index bits,
/// so a point is the XOR of its two bytes' entries. Two lookups replace the crate's loop over
/// the index bits (16 steps for a shuffled index), which halves the cost of a point.
struct SobolTables {
    low: [Int4; 256],
    high: [Int4; 256],
}

fn sobol_tables() -> &'static SobolTables {
    static TABLES: OnceLock<SobolTables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let zero = Int4::from([0u32; 4]);
        let mut t = SobolTables {
            low: [zero; 256],
            high: [zero; 256],
        };
        for b in 0..256u32 {
            t.low[b as usize] = sobol_int4_rev(b.reverse_bits(), 0);
            t.high[b as usize] = sobol_int4_rev((b << 8).reverse_bits(), 0);
        }
        t
    })
}

/// One Owen scramble (and optionally shuffle) of the Sobol sequence, from a 32-bit seed, with
/// the hashes of the seed done once.
#[derive(Clone, Copy, Debug)]
struct Scramble {
    /// The hashed seed of the index shuffle, if shuffled.
    shuffle: Option<u32>,
    /// The hashed seeds of the four dimensions' Owen scrambles.
    owen: Int4,
}

impl Scramble {
    /// The scramble of `seed`: with `shuffle`, the points are exactly
    /// `sobol_burley::sample_4d(index, 0, seed)` (a test checks every index); without, the same
    /// scramble of the points in their own order.
    fn new(seed: u32, shuffle: bool) -> Scramble {
        // The crate's constants (sobol_burley 0.5, `sample_4d`), so that the points are its own.
        let scrambled = seed.wrapping_mul(0x9c8f_2d3b);
        let owen: Int4 = [
            scrambled ^ 0x912f_69ba,
            scrambled ^ 0x174f_18ab,
            scrambled ^ 0x691e_72ca,
            scrambled ^ 0xb40c_c1b8,
        ]
        .into();
        Scramble {
            shuffle: shuffle.then(|| hash(seed ^ 0x79c6_8e4a)),
            owen: hash_int4(owen),
        }
    }

    /// Dimensions 0-3 of point `index` (< 2^16).
    #[inline]
    fn point(&self, index: u32) -> [f32; 4] {
        let index = match self.shuffle {
            Some(h) => owen_scramble_rev(index.reverse_bits(), h).reverse_bits(),
            None => index,
        };
        let t = sobol_tables();
        let sobol = t.low[(index & 0xff) as usize] ^ t.high[((index >> 8) & 0xff) as usize];
        owen_scramble_int4_rev(sobol, self.owen)
            .reverse_bits()
            .to_f32_norm()
    }
}

impl Sampler for SobolSampler {
    #[inline]
    fn start_sample(&mut self, x: u32, y: u32, index: u32) {
        let pixel = ((y as u64) << 32) | x as u64;
        self.replicate = (index % REPLICATES) as usize;
        let point = index / REPLICATES;
        let block = (point / SOBOL_SEQUENCE_LENGTH) as u64;
        self.index = point % SOBOL_SEQUENCE_LENGTH;
        self.bounce = 0;
        if self.scrambles_for != Some((pixel, block)) {
            self.scrambles_for = Some((pixel, block));
            for (r, (seed, scrambles)) in self.seeds.iter_mut().zip(&mut self.scrambles).enumerate()
            {
                *seed = hash_words(&[self.key, pixel, block * REPLICATES as u64 + r as u64]);
                for (d, scramble) in scrambles.iter_mut().enumerate() {
                    let h = mix64(*seed ^ d as u64);
                    // The pixel position takes the sequence in its own order (the first
                    // domain needs no shuffle); later domains are padded: the index shuffled
                    // by the domain's seed (a nested uniform scramble), which makes them
                    // independent of each other.
                    *scramble = Scramble::new((h ^ (h >> 32)) as u32, d != PIXEL_DOMAIN);
                }
            }
        }
    }

    #[inline]
    fn camera(&mut self, uses: CameraUse) -> CameraSample {
        let p = self.point(PIXEL_DOMAIN);
        let mut sample = CameraSample {
            pixel: (p[0], p[1]),
            lens: (0.5, 0.5),
            time: 0.5,
        };
        if uses.lens || uses.time {
            let c = self.point(CAMERA_DOMAIN);
            if uses.lens {
                sample.lens = (c[0], c[1]);
            }
            if uses.time {
                sample.time = c[2];
            }
        }
        sample
    }

    #[inline]
    fn next_bounce(&mut self) -> BounceSample {
        let k = self.bounce;
        self.bounce += 1;
        if k < SOBOL_BOUNCES {
            let p = self.point(FIRST_BOUNCE_DOMAIN + k as usize);
            return BounceSample {
                uc: p[2],
                u: (p[0], p[1]),
            };
        }
        if k == SOBOL_BOUNCES {
            let h = mix64(self.seeds[self.replicate] ^ mix64(self.index as u64));
            self.rng = Pcg32::new(h, h >> 17);
        }
        let uc = self.rng.next_f64();
        BounceSample {
            uc,
            u: (self.rng.next_f64(), self.rng.next_f64()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EVERYTHING: CameraUse = CameraUse {
        lens: true,
        time: true,
    };

    /// The numbers of `bounces` bounces of the current sample, in order.
    fn bounces(s: &mut (impl Sampler + ?Sized), bounces: usize) -> Vec<BounceSample> {
        (0..bounces).map(|_| s.next_bounce()).collect()
    }

    /// Every number of one sample at (x, y, i) with a lens and time, and 4 bounces.
    fn draw(s: &mut impl Sampler, x: u32, y: u32, i: u32) -> Vec<f64> {
        s.start_sample(x, y, i);
        let c = s.camera(EVERYTHING);
        let mut v = vec![c.pixel.0, c.pixel.1, c.lens.0, c.lens.1, c.time];
        for b in bounces(s, 4) {
            v.extend([b.uc, b.u.0, b.u.1]);
        }
        v
    }

    /// Draws the numbers of one sample at (x, y, index).
    type Draw = Box<dyn FnMut(u32, u32, u32) -> Vec<f64>>;

    /// The two samplers for a seed and frame.
    fn both(seed: u64, frame: u32) -> [Draw; 2] {
        let mut a = IndependentSampler::new(seed, frame);
        let mut b = SobolSampler::new(seed, frame);
        [
            Box::new(move |x, y, i| draw(&mut a, x, y, i)),
            Box::new(move |x, y, i| draw(&mut b, x, y, i)),
        ]
    }

    /// The two samplers for a seed and frame, as trait objects.
    fn samplers(seed: u64, frame: u32) -> [Box<dyn Sampler>; 2] {
        [
            Box::new(IndependentSampler::new(seed, frame)),
            Box::new(SobolSampler::new(seed, frame)),
        ]
    }

    #[test]
    fn numbers_depend_only_on_the_sample_coordinates() {
        for (mut a, mut b) in both(5, 10).into_iter().zip(both(5, 10)) {
            let first = a(3, 4, 7);
            // Other samples drawn in between change nothing.
            b(9, 9, 0);
            b(3, 4, 6);
            assert_eq!(b(3, 4, 7), first);
            assert!(first.iter().all(|&u| (0.0..1.0).contains(&u)));
        }
    }

    #[test]
    fn seed_frame_pixel_and_index_all_matter() {
        for k in 0..2 {
            let base = both(5, 10)[k](3, 4, 7);
            assert_ne!(both(6, 10)[k](3, 4, 7), base);
            assert_ne!(both(5, 11)[k](3, 4, 7), base);
            assert_ne!(both(5, 10)[k](4, 3, 7), base);
            assert_ne!(both(5, 10)[k](3, 4, 8), base);
        }
    }

    #[test]
    fn bounce_numbers_do_not_depend_on_what_the_camera_uses() {
        // Bounce k gets the same numbers with a pinhole or a lens, with or without time, and
        // when the camera's numbers were not asked for at all.
        for mut s in samplers(5, 10) {
            for (x, y, i) in [(3, 4, 7), (0, 0, 0), (100, 2, 70_000)] {
                s.start_sample(x, y, i);
                let want = bounces(s.as_mut(), 8);
                for uses in CameraUse::ALL {
                    s.start_sample(x, y, i);
                    s.camera(uses);
                    assert_eq!(bounces(s.as_mut(), 8), want, "{uses:?}");
                }
                // Bounces differ from each other.
                for k in 1..want.len() {
                    assert_ne!(want[k], want[k - 1]);
                }
            }
        }
    }

    #[test]
    fn camera_numbers_do_not_depend_on_which_others_are_used() {
        // The pixel position is the same whatever the camera uses, the lens position the same
        // with or without time, the time the same with or without a lens; unused numbers are
        // 0.5.
        for mut s in samplers(2, 3) {
            s.start_sample(9, 8, 7);
            let all = s.camera(EVERYTHING);
            for uses in CameraUse::ALL {
                s.start_sample(9, 8, 7);
                let c = s.camera(uses);
                assert_eq!(c.pixel, all.pixel);
                assert_eq!(c.lens, if uses.lens { all.lens } else { (0.5, 0.5) });
                assert_eq!(c.time, if uses.time { all.time } else { 0.5 });
            }
        }
    }

    #[test]
    fn independent_dimensions_are_the_streams_numbers_in_order() {
        // Dimension d of the layout is number d of the sample's stream, with a full camera
        // and with none (the numbers skipped are stepped over, not redrawn).
        let mut s = IndependentSampler::new(1, 2);
        let numbers = draw(&mut s, 1, 1, 1);
        let h = hash_words(&[s.key, (1 << 32) | 1, 1]);
        let mut rng = Pcg32::new(h, h >> 17);
        let stream: Vec<f64> = (0..numbers.len()).map(|_| rng.next_f64()).collect();
        assert_eq!(numbers, stream);
        s.start_sample(1, 1, 1);
        s.camera(CameraUse::default());
        let b = s.next_bounce();
        assert_eq!([b.uc, b.u.0, b.u.1], stream[5..8]);
    }

    /// The points of domain `domain` of pixel `pixel` (0 the pixel position, 1 the lens
    /// position and time, 2 the first bounce as (u, uc)), for the first `n` samples of
    /// replicate `replicate`.
    fn domain_points(pixel: (u32, u32), replicate: u32, domain: usize, n: u32) -> Vec<[f64; 3]> {
        let mut s = SobolSampler::new(42, 3);
        (0..n)
            .map(|i| {
                s.start_sample(pixel.0, pixel.1, REPLICATES * i + replicate);
                let c = s.camera(EVERYTHING);
                match domain {
                    0 => [c.pixel.0, c.pixel.1, 0.0],
                    1 => [c.lens.0, c.lens.1, c.time],
                    _ => {
                        let b = s.next_bounce();
                        [b.u.0, b.u.1, b.uc]
                    }
                }
            })
            .collect()
    }

    /// True when exactly one of `points` falls in each of the `cells` x `cells` squares of
    /// dimensions `a` and `b`.
    fn one_per_square(points: &[[f64; 3]], a: usize, b: usize, cells: usize) -> bool {
        let mut counts = vec![0u32; cells * cells];
        for p in points {
            counts[(p[a] * cells as f64) as usize * cells + (p[b] * cells as f64) as usize] += 1;
        }
        counts.iter().all(|&c| c == 1)
    }

    #[test]
    fn sobol_domains_are_stratified_over_each_replicate() {
        for (pixel, r) in [((0, 0), 0), ((17, 3), 1)] {
            // The pixel position: 256 points of a (0, m, 2)-net, one in each of 16 x 16
            // squares, and also one in each 256 x 1 and 1 x 256 strip.
            let p = domain_points(pixel, r, 0, 256);
            assert!(one_per_square(&p, 0, 1, 16));
            for dim in 0..2 {
                let mut strips = vec![0; 256];
                p.iter()
                    .for_each(|q| strips[(q[dim] * 256.0) as usize] += 1);
                assert!(strips.iter().all(|&c| c == 1));
            }
            // The lens position and time, and the first bounce: every 2-D projection of 256
            // points is stratified in 16 x 16 squares.
            for domain in 1..SOBOL_DOMAINS as usize {
                let p = domain_points(pixel, r, domain, 256);
                for (a, b) in [(0, 1), (0, 2), (1, 2)] {
                    assert!(one_per_square(&p, a, b, 16), "domain {domain} dims {a},{b}");
                }
            }
        }
    }

    #[test]
    fn independent_numbers_are_not_stratified() {
        // The same count for independent numbers: some of 256 squares are empty (the chance
        // that none is, with 256 points, is astronomically small).
        let mut s = IndependentSampler::new(42, 3);
        let mut counts = [0u32; 256];
        for i in 0..256 {
            s.start_sample(0, 0, i);
            let (a, b) = s.camera(CameraUse::default()).pixel;
            counts[(a * 16.0) as usize * 16 + (b * 16.0) as usize] += 1;
        }
        assert!(counts.contains(&0));
    }

    /// The sample correlation of two equally long series.
    fn correlation(a: &[f64], b: &[f64]) -> f64 {
        let m = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let (ma, mb) = (m(a), m(b));
        let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
        let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
        let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
        cov / (va * vb).sqrt()
    }

    #[test]
    fn domains_are_uncorrelated() {
        // Within a sample, numbers of different domains (the pixel position, the camera, the
        // first bounce, later bounces) are as uncorrelated as independent ones: |r| < 4 /
        // sqrt(n) (four standard errors).
        let n = 4096;
        let mut s = SobolSampler::new(9, 1);
        let mut by_domain = vec![vec![]; 5];
        for i in 0..n {
            s.start_sample(5, 5, i);
            let c = s.camera(EVERYTHING);
            let b = bounces(&mut s, 3);
            for (d, u) in by_domain
                .iter_mut()
                .zip([c.pixel.0, c.lens.0, b[0].uc, b[1].uc, b[2].uc])
            {
                d.push(u);
            }
        }
        let bound = 4.0 / (n as f64).sqrt();
        for a in 0..5 {
            for b in a + 1..5 {
                let r = correlation(&by_domain[a], &by_domain[b]);
                assert!(r.abs() < bound, "domains {a} and {b}: r = {r}");
            }
        }
    }

    /// The 8-sample estimate, over samples `indices` of pixel (`x`, 7), of a smooth integrand
    /// of the first bounce: x y z, exactly 1/8.
    fn smooth_estimate(s: &mut SobolSampler, x: u32, indices: impl Iterator<Item = u32>) -> f64 {
        indices
            .map(|i| {
                s.start_sample(x, 7, i);
                s.camera(EVERYTHING);
                let b = s.next_bounce();
                b.u.0 * b.u.1 * b.uc
            })
            .sum::<f64>()
            / 8.0
    }

    #[test]
    fn pixel_estimates_are_uncorrelated() {
        // The 8-sample estimates in horizontally neighbouring pixels are uncorrelated over
        // 4096 pairs.
        let mut s = SobolSampler::new(9, 1);
        let (left, right): (Vec<f64>, Vec<f64>) = (0..4096)
            .map(|k| {
                (
                    smooth_estimate(&mut s, 2 * k, 0..8),
                    smooth_estimate(&mut s, 2 * k + 1, 0..8),
                )
            })
            .unzip();
        let r = correlation(&left, &right);
        assert!(r.abs() < 4.0 / 64.0, "r = {r}");
        let mean = left.iter().sum::<f64>() / 4096.0;
        assert!((mean - 0.125).abs() < 0.002, "{mean}");
    }

    #[test]
    fn replicate_estimates_are_independent() {
        // A pixel's two replicates: their 8-point estimates of the smooth integrand are
        // uncorrelated over 4096 pixels, and each is unbiased. Between the halves of one
        // scrambled sequence (samples 0-7 against 8-15 of one replicate) the correlation is
        // strongly negative: the halves stratify each other, which is why an error estimate
        // needs independent replicates.
        let mut s = SobolSampler::new(9, 1);
        let mut pairs = |a: fn(u32) -> u32, b: fn(u32) -> u32| -> (Vec<f64>, Vec<f64>) {
            (0..4096)
                .map(|x| {
                    (
                        smooth_estimate(&mut s, x, (0..8).map(a)),
                        smooth_estimate(&mut s, x, (0..8).map(b)),
                    )
                })
                .unzip()
        };
        let (even, odd) = pairs(|i| REPLICATES * i, |i| REPLICATES * i + 1);
        let r = correlation(&even, &odd);
        assert!(r.abs() < 4.0 / 64.0, "r = {r}");
        for v in [&even, &odd] {
            let mean = v.iter().sum::<f64>() / 4096.0;
            assert!((mean - 0.125).abs() < 0.002, "{mean}");
        }
        let (first, second) = pairs(|i| REPLICATES * i, |i| REPLICATES * (i + 8));
        let r = correlation(&first, &second);
        assert!(r < -0.3, "r = {r}");
    }

    #[test]
    fn indices_past_one_sequence_start_a_new_stratified_block() {
        // A replicate's points 2^16 .. 2^16 + 256 are a stratified set of their own, not
        // garbage and not a repeat of the first block.
        let mut s = SobolSampler::new(42, 3);
        let mut counts = [0u32; 256];
        let mut first = vec![];
        let past = REPLICATES * SOBOL_SEQUENCE_LENGTH;
        for i in 0..256 {
            s.start_sample(2, 2, past + REPLICATES * i);
            let (a, b) = s.camera(CameraUse::default()).pixel;
            counts[(a * 16.0) as usize * 16 + (b * 16.0) as usize] += 1;
            s.start_sample(2, 2, REPLICATES * i);
            first.push(s.camera(CameraUse::default()).pixel);
        }
        assert!(counts.iter().all(|&c| c == 1));
        s.start_sample(2, 2, past);
        assert_ne!(s.camera(CameraUse::default()).pixel, first[0]);
        // The largest index works too.
        s.start_sample(2, 2, u32::MAX);
        let (a, b) = s.camera(CameraUse::default()).pixel;
        assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
    }

    #[test]
    fn table_points_are_the_crates_points() {
        // Two computations of the same numbers: the byte tables against the crate's own
        // `sample_4d`, at every index of a sequence and several seeds.
        for seed in [0, 1, 0x9e37_79b9, u32::MAX] {
            for index in 0..SOBOL_SEQUENCE_LENGTH {
                let seed = seed ^ index.wrapping_mul(0x85eb_ca6b);
                assert_eq!(
                    Scramble::new(seed, true).point(index),
                    sobol_burley::sample_4d(index, 0, seed),
                    "index {index}, seed {seed}"
                );
            }
        }
        // The tables alone against the crate's loop over the index bits, at every index (the
        // path without the shuffle uses them directly).
        let t = sobol_tables();
        for index in 0..SOBOL_SEQUENCE_LENGTH {
            let table = t.low[(index & 0xff) as usize] ^ t.high[(index >> 8) as usize];
            let direct = sobol_int4_rev(index.reverse_bits(), 0);
            assert_eq!(
                table.reverse_bits().to_f32_norm(),
                direct.reverse_bits().to_f32_norm()
            );
        }
    }

    #[test]
    fn a_stable_pattern_draws_the_same_numbers_every_frame() {
        // Per frame: the key is the sampler's own, so frames without --temporal are the bytes
        // they were, and frames differ. Stable: one key for every frame, none of a per-frame
        // one, and the numbers at a (pixel, sample) are the same in any frame.
        for kind in SamplerKind::ALL {
            let per_frame = |f| SamplePattern::PerFrame.key(kind, 7, f);
            let stable = |f| SamplePattern::Stable.key(kind, 7, f);
            assert_eq!(per_frame(3), kind.key(7, 3));
            assert_ne!(per_frame(3), per_frame(4));
            assert_eq!(stable(1), stable(u32::MAX));
            assert_ne!(stable(1), SamplePattern::Stable.key(kind, 8, 1));
            assert!((0..1000).all(|f| per_frame(f) != stable(f)));
        }
        let draw_in = |key| {
            let mut s = SobolSampler::from_key(key);
            draw(&mut s, 5, 6, 9)
        };
        let stable = |f| SamplePattern::Stable.key(SamplerKind::Sobol, 7, f);
        assert_eq!(draw_in(stable(1)), draw_in(stable(2)));
        let per_frame = |f| SamplePattern::PerFrame.key(SamplerKind::Sobol, 7, f);
        assert_ne!(draw_in(per_frame(1)), draw_in(per_frame(2)));
    }

    #[test]
    fn names_round_trip() {
        for k in SamplerKind::ALL {
            assert_eq!(k.name().parse::<SamplerKind>(), Ok(k));
        }
        let err = "halton".parse::<SamplerKind>().unwrap_err();
        assert!(
            err.contains("halton") && err.contains("independent, sobol"),
            "{err}"
        );
        assert_eq!(SamplerKind::default(), SamplerKind::Sobol);
    }
}
