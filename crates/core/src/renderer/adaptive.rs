//! Adaptive sampling under a budget: which pixels take more samples in a round. Every pixel
//! doubles its samples while its own estimated error, smoothed over its neighbours, calls for
//! it ([`Adaptive`]).

use rayon::prelude::*;

use super::budget::{Budget, StopReason};
use crate::film::{Film, Pixel, TileRect};

/// What a round does: which samples each pixel takes.
#[derive(Clone, Copy, Debug)]
pub enum RoundPlan<'w> {
    /// Every pixel takes samples up to this count.
    Uniform(u32),
    /// Pixels chosen by [`Adaptive::target`] double their samples, weighed by `Weights`.
    Adaptive(Adaptive, Weights<'w>),
}

/// What weighs a pixel in an adaptive round: its estimated relative variance per sample.
#[derive(Clone, Copy, Debug)]
pub enum Weights<'w> {
    /// The raw frame's, from the film ([`smoothed_variances`]).
    Raw,
    /// Given for every pixel, row-major, `width` pixels a row: the written frame's when it
    /// is denoised (`finish::Denoising`), so samples go where the frame written is still
    /// wrong.
    Map { width: u32, values: &'w [f64] },
}

impl Weights<'_> {
    /// The weights of the tile `pixels` at `rect`, in the tile's order.
    fn of_tile(&self, rect: &TileRect, pixels: &[Pixel]) -> Vec<f64> {
        match *self {
            Weights::Raw => smoothed_variances(rect, pixels),
            Weights::Map { width, values } => (0..pixels.len())
                .map(|i| {
                    let (x, y) = rect.position(i);
                    values[y as usize * width as usize + x as usize]
                })
                .collect(),
        }
    }
}

impl RoundPlan<'_> {
    /// The sample count pixel `i` of the tile `pixels` (at `rect`) goes to in this round.
    pub fn targets(&self, rect: &TileRect, pixels: &[Pixel], out: &mut Vec<u32>) {
        out.clear();
        match self {
            RoundPlan::Uniform(n) => out.extend(pixels.iter().map(|p| p.taken().max(*n))),
            RoundPlan::Adaptive(a, w) => {
                let weights = w.of_tile(rect, pixels);
                out.extend(
                    pixels
                        .iter()
                        .zip(weights)
                        .map(|(p, v)| a.target(p.taken(), v)),
                );
            }
        }
    }
}

/// Each pixel's estimated relative variance *per sample* (its
/// [`film::relative_variances`](crate::film::relative_variances) term times its samples),
/// averaged over its 3x3 neighbourhood inside the tile (fewer neighbours at the tile's edges):
/// a pixel's own estimate has one degree of freedom (see [`Pixel::variance_of_mean`]) and is
/// near zero for one pixel in sixteen by chance alone, while its neighbours see nearly the
/// same integrand. Read from the tile only, so the tiles of a round can decide in parallel and
/// alike on any thread count.
fn smoothed_variances(rect: &TileRect, pixels: &[Pixel]) -> Vec<f64> {
    let own: Vec<f64> = crate::film::relative_variances(rect, pixels)
        .into_iter()
        .zip(pixels)
        .map(|(r, p)| {
            let v = r * p.taken() as f64;
            if v.is_finite() { v } else { f64::MAX }
        })
        .collect();
    rect.neighbourhood_means(&own)
        .into_iter()
        .map(|v| if v.is_finite() { v } else { f64::MAX })
        .collect()
}

/// Buckets of a pixel's priority (its target over its samples) on a log scale: four to an
/// octave, bucket [`PRIORITY_ONE`] for a priority of one.
const PRIORITY_BUCKETS: usize = 160;
const PRIORITY_ONE: usize = 64;

fn priority_bucket(priority: f64) -> usize {
    if priority.is_nan() || priority <= 0.0 {
        return 0;
    }
    let b = (priority.log2() * 4.0).floor() + PRIORITY_ONE as f64;
    b.clamp(0.0, (PRIORITY_BUCKETS - 1) as f64) as usize
}

/// An adaptive round: which pixels double their samples.
///
/// With `v` a pixel's estimated relative variance per sample ([`smoothed_variances`]), the
/// frame's relative MSE is the mean of `v / n` over its pixels, and the sample counts that
/// reach a given value with the fewest samples are proportional to `sqrt(v)` (minimise the sum
/// of `n` under a fixed sum of `v / n`: a Lagrange multiplier gives `n ∝ sqrt(v)`). So each
/// pixel has a target `scale * sqrt(v)`: for a noise threshold `t`, `scale` is
/// `sum(sqrt(v)) / (pixels * t^2)`, the counts that make the estimate `t^2`; under a time
/// limit alone, the counts that spend the time left. A pixel below its target doubles its
/// samples (counts stay powers of two, where Sobol points are best stratified); a pixel at its
/// target stops. When the round would not fit the time left, only the pixels farthest below
/// their targets take it: those whose priority (target over samples) is in bucket
/// `min_bucket` or above.
#[derive(Clone, Copy, Debug)]
pub struct Adaptive {
    scale: f64,
    min_bucket: usize,
    max_samples: u32,
}

impl Adaptive {
    /// The priority of a pixel of `n` samples and relative variance per sample `v`.
    fn priority(&self, n: u32, v: f64) -> f64 {
        self.scale * v.sqrt() / n.max(1) as f64
    }

    /// The samples a pixel of `n` samples and relative variance per sample `v` goes to.
    fn target(&self, n: u32, v: f64) -> u32 {
        let p = self.priority(n, v);
        if p > 1.0 && priority_bucket(p) >= self.min_bucket {
            n.saturating_mul(2).clamp(1, self.max_samples.max(n))
        } else {
            n
        }
    }
}

/// The figures of the film that plan an adaptive round, summed over its tiles in order.
struct FilmSums {
    pixels: f64,
    /// The sum of the pixels' `sqrt(v)`.
    sqrt_v: f64,
    /// The samples taken.
    samples: f64,
}

/// [`FilmSums`] of `film`, tile by tile in parallel and summed in the tiles' order (so the
/// same bits on any thread count).
fn film_sums(film: &Film, weights: &Weights) -> FilmSums {
    let per_tile: Vec<(f64, f64)> = film
        .tiles()
        .into_par_iter()
        .map(|(rect, pixels)| {
            let v = weights.of_tile(&rect, pixels);
            let sqrt_v = v.iter().map(|v| v.sqrt()).sum::<f64>();
            let samples = pixels.iter().map(|p| p.taken() as f64).sum::<f64>();
            (sqrt_v, samples)
        })
        .collect();
    FilmSums {
        pixels: film.width as f64 * film.height as f64,
        sqrt_v: per_tile.iter().map(|t| t.0).sum(),
        samples: per_tile.iter().map(|t| t.1).sum(),
    }
}

/// The samples an adaptive round `a` would take, by priority bucket (summed in tile order).
fn round_cost_by_bucket(film: &Film, a: &Adaptive, weights: &Weights) -> Vec<f64> {
    let per_tile: Vec<Vec<f64>> = film
        .tiles()
        .into_par_iter()
        .map(|(rect, pixels)| {
            let mut cost = vec![0.0; PRIORITY_BUCKETS];
            let v = weights.of_tile(&rect, pixels);
            for (p, v) in pixels.iter().zip(v) {
                let gain = a.target(p.taken(), v) - p.taken();
                if gain > 0 {
                    cost[priority_bucket(a.priority(p.taken(), v))] += gain as f64;
                }
            }
            cost
        })
        .collect();
    let mut total = vec![0.0; PRIORITY_BUCKETS];
    for t in per_tile {
        for (a, b) in total.iter_mut().zip(t) {
            *a += b;
        }
    }
    total
}

/// The next adaptive round, or why to stop: see [`Adaptive`]. `seconds_per_sample` is the time
/// one pixel's sample took in the last round, `elapsed` the frame's time so far.
pub(super) fn plan_adaptive(
    film: &Film,
    weights: &Weights,
    budget: &Budget,
    elapsed: f64,
    seconds_per_sample: f64,
) -> Result<Adaptive, StopReason> {
    let sums = film_sums(film, weights);
    let left = budget.time_limit.map(|t| t - elapsed);
    let scale = match (budget.noise_threshold, left) {
        (Some(t), _) => sums.sqrt_v / (sums.pixels * t * t),
        (None, Some(left)) => (sums.samples + left / seconds_per_sample) / sums.sqrt_v,
        (None, None) => f64::INFINITY,
    };
    let max_samples = budget.max_samples.unwrap_or(u32::MAX);
    let mut plan = Adaptive {
        scale: if scale.is_nan() { 0.0 } else { scale },
        min_bucket: 0,
        max_samples,
    };
    let mut cost = round_cost_by_bucket(film, &plan, weights);
    if cost.iter().all(|&c| c == 0.0) {
        // Every pixel is at its target, yet the frame's estimate is above the threshold (the
        // estimates moved with the last samples): every pixel takes the round.
        plan.scale = f64::INFINITY;
        cost = round_cost_by_bucket(film, &plan, weights);
        if cost.iter().all(|&c| c == 0.0) {
            return Err(StopReason::MaxSamples);
        }
    }
    if let Some(left) = left {
        // The pixels of the highest priorities whose samples fit half the time left, or 90
        // percent of it for the last round (as `next_round`).
        let mut taken = 0.0;
        let mut min_bucket = PRIORITY_BUCKETS;
        for b in (0..PRIORITY_BUCKETS).rev() {
            if cost[b] == 0.0 {
                continue;
            }
            if (taken + cost[b]) * seconds_per_sample > 0.5 * left {
                break;
            }
            taken += cost[b];
            min_bucket = b;
        }
        if min_bucket == PRIORITY_BUCKETS {
            let top = cost.iter().rposition(|&c| c > 0.0).expect("some cost");
            if cost[top] * seconds_per_sample > 0.9 * left {
                return Err(StopReason::TimeLimit);
            }
            min_bucket = top;
        }
        plan.min_bucket = min_bucket;
    }
    Ok(plan)
}
