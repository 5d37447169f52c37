//! A frame's raw film accumulated with its earlier frames' raw films, carried to its pixels
//! along the motion vectors (`denoise::reproject`), before it is denoised: the accumulated
//! route `converge --flicker` measures (after SVGF, Schied et al. 2017, whose history holds
//! the raw samples rather than the written frames).
//!
//! A frame holds its replicates' means `a`, `b` and samples `n` (`a` of `n - n/2` even
//! samples, `b` of `n/2` odd ones, `replicates::replicate_counts`). An earlier frame `j` found
//! at a pixel (same surface, `reproject`) is tested against the frame's own raw mean: with
//! `σ²` the per-sample variance (the frame's `var(F) n`, its 3x3 mean: one pixel's estimate
//! has one degree of freedom), the difference of two independent means of `n` and `n_j`
//! samples of one value has variance `σ² (1/n + 1/n_j)`, and the earlier frame is taken only
//! where every channel's squared difference is within [`REJECT_SIGMAS`]² times that: a shadow
//! or a highlight that moved, which the geometry test does not see, is further off.
//!
//! The frames taken are pooled replicate by replicate, each by its samples: `a = Σ n_a,k a_k /
//! Σ n_a,k`, the same for `b`. Every frame's samples are its own (per-frame sample points), so
//! the pooled `a` and `b` stay independent, and the film's rule gives the pooled mean's
//! variance from their difference, `(a - b)² / ((1/n_a + 1/n_b) n)` (`film::Pixel`): the
//! denoiser and the written frame's estimate (`denoise::estimate`) read the pooled frame as
//! they read a film. An earlier frame read between pixels (bilinearly) carries less noise
//! than its samples would, but `a` and `b` are read alike, so their difference still measures
//! the pooled noise. What the test passes of a change (below three sigmas), and the blur of
//! reading between pixels, is a bias the estimate does not see.

use glam::DVec3;

use super::estimate::box_mean;
use super::reproject::{Along, HISTORY, reproject};
use raytrace_core::image::{Image, Precision, Rgb, Values};
use raytrace_core::pass::{SAMPLES, VARIANCE};
use raytrace_core::replicates::{REPLICATE_A, REPLICATE_B, Replicates, replicate_counts};

/// How many standard deviations of the difference of two raw means an earlier frame may be
/// off a pixel's own and still be pooled with it: a normal difference passes 99.7% of the
/// time, so history is seldom lost to noise alone (the usual three-sigma rule).
pub(crate) const REJECT_SIGMAS: f64 = 3.0;

/// The float channel of a held frame that carries its samples (the replicates image's
/// [`SAMPLES`] are counts, which are not read between pixels).
pub(crate) const TAKEN: &str = "taken";

/// The channels a held frame carries to a later frame: its replicates and samples.
const CARRIED: [&str; 7] = [
    REPLICATE_A.0[0],
    REPLICATE_A.0[1],
    REPLICATE_A.0[2],
    REPLICATE_B.0[0],
    REPLICATE_B.0[1],
    REPLICATE_B.0[2],
    TAKEN,
];

/// A frame as a later frame's accumulation reads it: `frame` (a film's replicates image with
/// the passes `reproject` reads, as [`accumulate`] takes it) with its samples as floats
/// ([`TAKEN`]) in place of counts, and without its variance, which no later frame reads.
pub fn held_frame(frame: &Image) -> Image {
    let kept: Vec<&str> = frame
        .channels()
        .iter()
        .map(|c| c.name)
        .filter(|name| *name != SAMPLES && !VARIANCE.0.contains(name))
        .collect();
    let mut held = frame.select(&kept);
    let taken = Replicates::of(frame).taken();
    held.set(
        TAKEN,
        Precision::Float,
        Values::Float(taken.iter().map(|&n| n as f32).collect()),
    );
    held
}

/// A frame's replicates pooled with its earlier frames' ([`accumulate`]).
pub struct Accumulated {
    /// A replicates image (`film::Film::replicates`'s channels) of the pooled samples.
    pub replicates: Image,
    /// The earlier frames' share of the pooled samples, over the frame.
    pub history_share: f64,
}

/// The replicates of `current` (a film's replicates image with the passes `reproject` reads)
/// pooled with `earlier` (frames made by [`held_frame`], the frame before
/// first, at most [`HISTORY`]) where each is found and passes the test: see the module's
/// notes.
pub fn accumulate(current: &Image, earlier: &[&Image]) -> Accumulated {
    assert!(earlier.len() <= HISTORY, "at most {HISTORY} earlier frames");
    let n = current.pixels();
    let width = current.width() as usize;
    let own = Replicates::of(current);
    let carried = reproject(current, earlier, &CARRIED, Along::Backward);
    let carried_planes: Vec<[&[f32]; 7]> = carried
        .iter()
        .map(|r| CARRIED.map(|name| r.image.floats(name).expect("carried")))
        .collect();
    // The per-sample variance, 3x3 mean of the finite estimates.
    let per_sample: Vec<DVec3> = own
        .iter()
        .map(|p| {
            let s = p.variance_of_mean * p.taken as f64;
            if s.is_finite() { s } else { DVec3::ZERO }
        })
        .collect();
    let per_sample = box_mean(&per_sample, width, 1);
    // Each earlier frame's raw mean less the frame's own, and its 3x3 mean where found.
    let earlier_mean = |planes: &[&[f32]; 7], i: usize| {
        let at = |k: usize| planes[k][i] as f64;
        let (ja, jb) = replicate_counts(at(6).round().max(0.0) as u32);
        let a = DVec3::new(at(0), at(1), at(2));
        let b = DVec3::new(at(3), at(4), at(5));
        (a * ja as f64 + b * jb as f64) / (ja + jb).max(1) as f64
    };
    let local_differences: Vec<Vec<(DVec3, f64)>> = carried
        .iter()
        .zip(&carried_planes)
        .map(|(r, planes)| {
            let (d, found): (Vec<DVec3>, Vec<f64>) = (0..n)
                .map(|i| match r.found[i] {
                    true => (earlier_mean(planes, i) - own.at(i).full(), 1.0),
                    false => (DVec3::ZERO, 0.0),
                })
                .unzip();
            box_mean(&d, width, 1)
                .into_iter()
                .zip(box_mean(&found, width, 1))
                .map(|(d, f)| (if f > 0.0 { d / f } else { DVec3::ZERO }, f * 9.0))
                .collect()
        })
        .collect();
    let (mut a_out, mut b_out, mut v_out) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let mut taken_out = Vec::with_capacity(n);
    let (mut pooled_total, mut earlier_total) = (0.0, 0.0);
    for i in 0..n {
        let p = own.at(i);
        let (na, nb) = replicate_counts(p.taken);
        let (mut sum_a, mut sum_b) = (p.a * na as f64, p.b * nb as f64);
        let (mut count_a, mut count_b) = (na as f64, nb as f64);
        let mean = p.full();
        for ((r, planes), local) in carried.iter().zip(&carried_planes).zip(&local_differences) {
            if !r.found[i] {
                continue;
            }
            let at = |k: usize| planes[k][i] as f64;
            let taken = at(6).round().max(0.0) as u32;
            let (ja, jb) = replicate_counts(taken);
            if ja == 0 || jb == 0 {
                continue;
            }
            let (a, b) = (
                DVec3::new(at(0), at(1), at(2)),
                DVec3::new(at(3), at(4), at(5)),
            );
            let their = (a * ja as f64 + b * jb as f64) / taken as f64;
            let d = their - mean;
            let allowed = per_sample[i]
                * (1.0 / p.taken.max(1) as f64 + 1.0 / taken as f64)
                * (REJECT_SIGMAS * REJECT_SIGMAS);
            // The 3x3 mean of the differences, over the `k` pixels found there, has a k-th
            // of that variance (the pixels' noises are independent): a shift of an edge or a
            // blur too small to show in one pixel's noise shows there.
            let (local, k) = local[i];
            if (d * d).cmpgt(allowed).any() || (local * local).cmpgt(allowed / k.max(1.0)).any() {
                continue;
            }
            sum_a += a * ja as f64;
            sum_b += b * jb as f64;
            count_a += ja as f64;
            count_b += jb as f64;
            earlier_total += (ja + jb) as f64;
        }
        pooled_total += count_a + count_b;
        let mean_of = |s: DVec3, c: f64| if c > 0.0 { s / c } else { DVec3::ZERO };
        let (a, b) = (mean_of(sum_a, count_a), mean_of(sum_b, count_b));
        let total = count_a + count_b;
        // The film's rule (`film::Pixel::variance_of_mean`).
        let v = if count_a > 0.0 && count_b > 0.0 {
            (a - b) * (a - b) / ((1.0 / count_a + 1.0 / count_b) * total)
        } else {
            DVec3::INFINITY
        };
        a_out.push(a.as_vec3());
        b_out.push(b.as_vec3());
        v_out.push(v.as_vec3());
        taken_out.push(total as u32);
    }
    let mut replicates = Image::new(current.width(), current.height());
    let set = |image: &mut Image, names: Rgb, values: Vec<glam::Vec3>| {
        image.set_rgb(names, values.into_iter())
    };
    set(&mut replicates, REPLICATE_A, a_out);
    set(&mut replicates, REPLICATE_B, b_out);
    set(&mut replicates, VARIANCE, v_out);
    replicates.set(SAMPLES, Precision::Float, Values::Count(taken_out));
    Accumulated {
        replicates,
        history_share: if pooled_total > 0.0 {
            earlier_total / pooled_total
        } else {
            0.0
        },
    }
}

/// The bytes accumulating a frame of `pixels` pixels holds at its peak beyond its inputs: the
/// frames held (each a [`held_frame`]: 7 channels and the 6 of the passes `reproject` reads; the
/// frame's own too), the earlier frames carried to it (7 channels and where each was found),
/// the per-sample variance (a `DVec3` a pixel, twice while smoothed), the pooled replicates
/// as they are made (three `Vec3`s and a count) and the image made of them (10 channels).
pub fn bytes_for(pixels: u64) -> u64 {
    use std::mem::size_of;
    let held = (HISTORY as u64 + 1) * Image::bytes_for(pixels, 13);
    let carried = HISTORY as u64 * (Image::bytes_for(pixels, 7) + pixels);
    let working = pixels * (2 * size_of::<DVec3>() + 3 * size_of::<glam::Vec3>() + 4) as u64;
    held + carried + working + Image::bytes_for(pixels, 10)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use raytrace_core::pass::{BACKWARD, DEPTH, NORMAL};
    use raytrace_core::rng::Pcg32;

    /// Samples a pixel takes in every frame.
    const N: u32 = 16;

    /// A still frame of `w` x `h` (depth 5, normal +z, no motion) whose pixels' `N` samples
    /// are `truth` plus uniform noise of standard deviation `sd`: its replicates image with
    /// the passes, as a film gives them.
    fn frame(w: usize, h: usize, truth: f64, sd: f64, rng: &mut Pcg32) -> Image {
        let n = w * h;
        let (na, nb) = replicate_counts(N);
        let mut mean = |k: u32| {
            (0..k)
                .map(|_| truth + sd * 12f64.sqrt() * (rng.next_f64() - 0.5))
                .sum::<f64>()
                / k as f64
        };
        let (mut a, mut b, mut v) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..n {
            let (x, y) = (mean(na), mean(nb));
            a.push(Vec3::splat(x as f32));
            b.push(Vec3::splat(y as f32));
            // The film's rule.
            let d = x - y;
            v.push(Vec3::splat(
                (d * d / ((1.0 / na as f64 + 1.0 / nb as f64) * N as f64)) as f32,
            ));
        }
        let mut image = Image::new(w as u32, h as u32);
        image.set_rgb(REPLICATE_A, a.into_iter());
        image.set_rgb(REPLICATE_B, b.into_iter());
        image.set_rgb(VARIANCE, v.into_iter());
        image.set(SAMPLES, Precision::Float, Values::Count(vec![N; n]));
        image.set(DEPTH, Precision::Float, Values::Float(vec![5.0; n]));
        image.set_rgb(NORMAL, (0..n).map(|_| Vec3::Z));
        for name in BACKWARD {
            image.set(name, Precision::Float, Values::Float(vec![0.0; n]));
        }
        image
    }

    /// The mean over the pixels and channels of the squared difference of the pooled mean
    /// from `truth`, and of its stated variance.
    fn squared_error_and_stated(pooled: &Image, truth: f64) -> (f64, f64) {
        let r = Replicates::of(pooled);
        let n = pooled.pixels() as f64;
        let error = r.iter().map(|p| (p.full().x - truth).powi(2)).sum::<f64>() / n;
        let stated = r.iter().map(|p| p.variance_of_mean.x).sum::<f64>() / n;
        (error, stated)
    }

    #[test]
    fn a_still_frame_pools_three_frames_of_samples_and_states_their_variance() {
        // Three frames of independent noise of one value: the pooled mean is a mean of 48
        // samples, its squared error a third of one frame's (analytic: sd^2 / 48), and the
        // variance the film's rule gives of the pooled replicates agrees with it.
        let (w, h, sd) = (64, 48, 0.1);
        let mut rng = Pcg32::new(3, 7);
        let frames: Vec<Image> = (0..3).map(|_| frame(w, h, 1.0, sd, &mut rng)).collect();
        let earlier = [held_frame(&frames[1]), held_frame(&frames[2])];
        let pooled = accumulate(&frames[0], &[&earlier[0], &earlier[1]]);
        assert!(pooled.history_share > 0.6, "{}", pooled.history_share);
        // Noise alone rejects an earlier frame at few pixels: each of the two tests passes a
        // normal difference 99.7% of the time a channel, and the 3x3 variance is itself noisy
        // (measured: 5% of the pixels lose a frame).
        let taken = Replicates::of(&pooled.replicates).taken();
        let all = taken.iter().filter(|&&n| n == 3 * N).count() as f64 / taken.len() as f64;
        assert!(all > 0.9, "{all}");
        let (error, stated) = squared_error_and_stated(&pooled.replicates, 1.0);
        // sd^2 / n at each pixel's pooled count n (48 where it pooled all three).
        let expected = taken.iter().map(|&n| sd * sd / n as f64).sum::<f64>() / taken.len() as f64;
        assert!(
            (error / expected - 1.0).abs() < 0.1,
            "{error} vs {expected}"
        );
        assert!(
            (stated / expected - 1.0).abs() < 0.1,
            "{stated} vs {expected}"
        );
        let (alone, _) = squared_error_and_stated(&frames[0], 1.0);
        assert!(error < 0.4 * alone, "{error} vs {alone}");
    }

    #[test]
    fn an_earlier_frame_showing_something_else_is_not_pooled() {
        // The frame before shows 2 where this one shows 1 (a shadow moved off a still
        // surface: the geometry agrees, the colour does not, by far more than the noise).
        // The frame is its own replicates, bit for bit.
        let (w, h) = (32, 32);
        let mut rng = Pcg32::new(11, 2);
        let now = frame(w, h, 1.0, 0.05, &mut rng);
        let before = held_frame(&frame(w, h, 2.0, 0.05, &mut rng));
        let pooled = accumulate(&now, &[&before]);
        assert_eq!(pooled.history_share, 0.0);
        let own = Replicates::of(&now);
        let out = Replicates::of(&pooled.replicates);
        for i in 0..w * h {
            let (p, q) = (own.at(i), out.at(i));
            assert_eq!((p.a, p.b, p.taken), (q.a, q.b, q.taken), "pixel {i}");
        }
    }
}
