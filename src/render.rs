//! Rendering one frame: the frame's world, its camera rays, in parallel over tiles, in one
//! pass of the requested samples or, under a time or noise budget, in passes until the budget
//! is met.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::camera::View;
use crate::film::{Film, Pixel, TileRect};
use crate::passes::{PassContext, PassImages};
use crate::ray::Ray;
use crate::sampler::{IndependentSampler, Sampler, SamplerKind, SobolSampler};
use crate::scene::Scene;
use crate::shutter::{FrameTimes, Interval};
use crate::tracer::{TraceStats, camera_radiance, radiance};
use crate::world::{StaticGeometry, World};

pub use crate::film::TILE;

/// The settings of one frame, copied from the scene's (`[output]` size, `[render]`) so the
/// per-sample loop reads them from one small struct.
#[derive(Clone, Debug)]
struct FrameRequest {
    frame: u32,
    width: u32,
    height: u32,
    /// Samples per pixel (without a budget: exactly these).
    samples: u32,
    max_depth: u32,
    seed: u64,
    sampler: SamplerKind,
}

impl FrameRequest {
    /// The frame `frame` with the scene's settings.
    fn from_scene(scene: &Scene, frame: u32) -> FrameRequest {
        FrameRequest {
            frame,
            width: scene.output.width,
            height: scene.output.height,
            samples: scene.render.samples,
            max_depth: scene.render.max_depth,
            seed: scene.render.seed,
            sampler: scene.render.sampler,
        }
    }
}

/// When to stop sampling a frame, instead of at exactly its requested samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Budget {
    /// Stop once this many seconds (preparation included) would be exceeded.
    pub time_limit: Option<f64>,
    /// Stop once the estimated relative error ([`FrameStats::relative_error`]) is at or below
    /// this.
    pub noise_threshold: Option<f64>,
    /// Never take more samples per pixel than this.
    pub max_samples: Option<u32>,
}

impl Budget {
    /// True when a time limit or noise threshold is set: the frame is rendered in passes.
    pub fn is_set(&self) -> bool {
        self.time_limit.is_some() || self.noise_threshold.is_some()
    }
}

/// The samples every pixel takes before a budget's passes become adaptive, and the fewest
/// whose estimate may stop a render at its noise threshold. Below it, a pixel's estimate
/// misses rare bright paths too often.
pub const MIN_SAMPLES_FOR_THRESHOLD: u32 = 16;

/// Why a frame stopped sampling.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StopReason {
    /// It took exactly the requested samples (no budget).
    #[default]
    Samples,
    /// The estimated error reached the noise threshold.
    NoiseThreshold,
    /// Another pass would have passed the time limit.
    TimeLimit,
    /// It reached the budget's largest sample count.
    MaxSamples,
}

impl StopReason {
    /// A short description for summaries.
    pub fn describe(self) -> &'static str {
        match self {
            StopReason::Samples => "requested samples",
            StopReason::NoiseThreshold => "noise threshold reached",
            StopReason::TimeLimit => "time limit",
            StopReason::MaxSamples => "max samples",
        }
    }
}

/// Figures of one rendered frame.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    /// Seconds spent preparing the frame's world (motion bounds, hierarchy build).
    pub prepare_seconds: f64,
    /// Seconds spent tracing.
    pub render_seconds: f64,
    /// Seconds the tiles took, summed over all threads: with `render_seconds` and the thread
    /// count, how busy the cores were.
    pub tile_seconds: f64,
    /// Rays intersected with the scene.
    pub rays: u64,
    /// Camera samples taken, over the whole frame.
    pub samples: u64,
    /// The most samples a pixel took.
    pub samples_per_pixel: u32,
    /// The fewest samples a pixel took: below [`samples_per_pixel`](Self::samples_per_pixel)
    /// when adaptive sampling gave some pixels more than others.
    pub min_samples_per_pixel: u32,
    /// The samples a pixel took on average.
    pub mean_samples_per_pixel: f64,
    /// Passes the samples were taken in.
    pub passes: u32,
    /// Why sampling stopped.
    pub stop: StopReason,
    /// Samples that were not finite (a NaN or infinite component), counted as black.
    pub non_finite: u64,
    /// Spheres moving during the frame's shutter.
    pub moving_spheres: usize,
    /// The relative error estimated from the pixels' replicates ([`relative_error`]): the
    /// square root of the estimated relative mean squared error. Infinite with fewer than two
    /// samples per pixel.
    pub relative_error: f64,
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// The pixels' sums: their means, sample counts and estimated errors.
    pub film: Film,
    /// The scene's `[output] passes`, if it asks for any.
    pub passes: Option<PassImages>,
    pub stats: FrameStats,
}

/// Everything about a frame that is fixed before its first sample.
struct FrameSetup<'a> {
    scene: &'a Scene,
    world: World<'a>,
    req: &'a FrameRequest,
    interval: Interval,
    /// The sample times: the shutter curve and a rolling shutter's rows.
    times: FrameTimes,
    camera_moves: bool,
    fixed_view: View,
    sample_time: bool,
    has_lens: bool,
    /// The passes' context when the scene asks for passes.
    passes: Option<PassContext<'a>>,
    /// `[background] transparent`: camera rays that miss add black.
    transparent: bool,
}

/// One tile of the frame: its rectangle, its pixels in the film, and its passes' sums.
struct Tile<'f> {
    rect: TileRect,
    pixels: &'f mut [Pixel],
    /// The passes' sums, `Layout::stride` numbers per pixel (empty without passes).
    pass_sums: &'f mut [f64],
}

/// What a pass does: which samples each pixel takes.
#[derive(Clone, Copy, Debug)]
enum Plan {
    /// Every pixel takes samples up to this count.
    Uniform(u32),
    /// Pixels chosen by [`Adaptive::target`] double their samples.
    Adaptive(Adaptive),
}

impl Plan {
    /// The sample count pixel `i` of the tile `pixels` (at `rect`) goes to in this pass.
    fn targets(&self, rect: &TileRect, pixels: &[Pixel], out: &mut Vec<u32>) {
        out.clear();
        match self {
            Plan::Uniform(n) => out.extend(pixels.iter().map(|p| p.taken().max(*n))),
            Plan::Adaptive(a) => {
                let weights = smoothed_variances(rect, pixels);
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

impl FrameSetup<'_> {
    /// Takes `tile`'s samples of this pass (`plan`); returns the rays traced, the samples taken
    /// and those that were not finite.
    fn sample_tile<S: Sampler>(&self, sampler: &mut S, tile: &mut Tile, plan: &Plan) -> TileCounts {
        let req = self.req;
        let interval = self.interval;
        let uses = crate::sampler::CameraUse {
            lens: self.has_lens,
            time: self.sample_time,
        };
        // Frames with passes or a transparent background take each camera ray's first hit
        // from the tracer, in a function of its own (`observed_sample`), so that this loop
        // is compiled for frames without them as it would be without passes at all.
        let observed = self.passes.is_some() || self.transparent;
        let stride = self.passes.as_ref().map_or(0, |p| p.layout.stride);
        let mut targets = Vec::with_capacity(tile.pixels.len());
        plan.targets(&tile.rect, tile.pixels, &mut targets);
        let mut stats = TraceStats::default();
        let mut counts = TileCounts::default();
        let mut sums = tile.pass_sums.chunks_mut(stride.max(1));
        for (i, (acc, &target)) in tile.pixels.iter_mut().zip(&targets).enumerate() {
            let (x, y) = tile.rect.position(i);
            counts.samples += target.saturating_sub(acc.taken()) as u64;
            let sums = if stride > 0 { sums.next() } else { None };
            let sums = sums.unwrap_or_default();
            for s in acc.taken()..target {
                sampler.start_sample(x, y, s);
                // The pixel position, and the lens position and the time (one joint
                // sample) where used; the bounces' numbers do not depend on which are.
                let camera = sampler.camera(uses);
                let time = if self.sample_time {
                    // The row of a rolling shutter: the sample's continuous y over the
                    // height (0 at the top edge), as the camera places it.
                    let row = (y as f64 + camera.pixel.1) / req.height as f64;
                    self.times.time(camera.time, row)
                } else {
                    interval.open
                };
                let view = if self.camera_moves {
                    self.scene.camera.view_at(time, req.width, req.height)
                } else {
                    self.fixed_view
                };
                let ray = view.ray(x, y, camera.pixel, camera.lens, time);
                let v = if observed {
                    self.observed_sample(ray, &view, sampler, &mut stats, sums)
                } else {
                    radiance(&self.world, ray, req.max_depth, sampler, &mut stats)
                };
                if !acc.add(v) {
                    counts.non_finite += 1;
                }
            }
        }
        counts.rays = stats.rays;
        counts
    }

    /// One camera sample of a frame with passes or a transparent background: its radiance,
    /// and its passes into the pixel's sums `sums`.
    #[inline(never)]
    fn observed_sample<S: Sampler>(
        &self,
        ray: Ray,
        view: &View,
        sampler: &mut S,
        stats: &mut TraceStats,
        sums: &mut [f64],
    ) -> DVec3 {
        let mut first = None;
        let v = camera_radiance(
            &self.world,
            ray,
            self.req.max_depth,
            sampler,
            stats,
            self.transparent,
            |hit| first = hit.copied(),
        );
        if let Some(passes) = &self.passes {
            passes.record(sums, &ray, view, first.as_ref());
        }
        v
    }

    /// Takes the samples of one pass (`plan`) in every tile, in parallel.
    fn pass(
        &self,
        film: &mut Film,
        pass_sums: &mut [f64],
        plan: &Plan,
        progress: &(dyn Fn(u64) + Sync),
    ) -> TileCounts {
        let req = self.req;
        let stride = self.passes.as_ref().map_or(0, |p| p.layout.stride);
        let mut sums_left = pass_sums;
        let mut tiles: Vec<Tile> = film
            .tiles_mut()
            .into_iter()
            .map(|(rect, pixels)| {
                let (sums, rest) = std::mem::take(&mut sums_left).split_at_mut(rect.len() * stride);
                sums_left = rest;
                Tile {
                    rect,
                    pixels,
                    pass_sums: sums,
                }
            })
            .collect();
        tiles
            .par_iter_mut()
            // One tile at a time: rayon otherwise hands out runs of tiles, and a run of
            // costly ones left a core idle for up to a tenth of a short frame.
            .with_max_len(1)
            .map(|tile| {
                let start = Instant::now();
                let mut counts = match req.sampler {
                    SamplerKind::Independent => self.sample_tile(
                        &mut IndependentSampler::new(req.seed, req.frame),
                        tile,
                        plan,
                    ),
                    SamplerKind::Sobol => {
                        self.sample_tile(&mut SobolSampler::new(req.seed, req.frame), tile, plan)
                    }
                };
                progress(counts.samples);
                counts.seconds = start.elapsed().as_secs_f64();
                counts
            })
            .reduce(TileCounts::default, TileCounts::plus)
    }
}

/// What the tiles of a pass did.
#[derive(Clone, Copy, Debug, Default)]
struct TileCounts {
    rays: u64,
    samples: u64,
    non_finite: u64,
    /// Seconds the tiles took, summed over threads.
    seconds: f64,
}

impl TileCounts {
    fn plus(self, o: TileCounts) -> TileCounts {
        TileCounts {
            rays: self.rays + o.rays,
            samples: self.samples + o.samples,
            non_finite: self.non_finite + o.non_finite,
            seconds: self.seconds + o.seconds,
        }
    }
}

/// Each pixel's estimated relative variance *per sample* (its
/// [`film::relative_variances`](crate::film::relative_variances) term times its samples),
/// averaged over its 3x3 neighbourhood inside the tile (fewer neighbours at the tile's edges):
/// a pixel's own estimate has one degree of freedom (see [`Pixel::variance_of_mean`]) and is
/// near zero for one pixel in sixteen by chance alone, while its neighbours see nearly the
/// same integrand. Read from the tile only, so the tiles of a pass can decide in parallel and
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

/// An adaptive pass: which pixels double their samples.
///
/// With `v` a pixel's estimated relative variance per sample ([`smoothed_variances`]), the
/// frame's relative MSE is the mean of `v / n` over its pixels, and the sample counts that
/// reach a given value with the fewest samples are proportional to `sqrt(v)` (minimise the sum
/// of `n` under a fixed sum of `v / n`: a Lagrange multiplier gives `n ∝ sqrt(v)`). So each
/// pixel has a target `scale * sqrt(v)`: for a noise threshold `t`, `scale` is
/// `sum(sqrt(v)) / (pixels * t^2)`, the counts that make the estimate `t^2`; under a time
/// limit alone, the counts that spend the time left. A pixel below its target doubles its
/// samples (counts stay powers of two, where Sobol points are best stratified); a pixel at its
/// target stops. When the pass would not fit the time left, only the pixels farthest below
/// their targets take it: those whose priority (target over samples) is in bucket
/// `min_bucket` or above.
#[derive(Clone, Copy, Debug)]
struct Adaptive {
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

/// The figures of the film that plan an adaptive pass, summed over its tiles in order.
struct FilmSums {
    pixels: f64,
    /// The sum of the pixels' `sqrt(v)`.
    sqrt_v: f64,
    /// The samples taken.
    samples: f64,
}

/// [`FilmSums`] of `film`, tile by tile in parallel and summed in the tiles' order (so the
/// same bits on any thread count).
fn film_sums(film: &Film) -> FilmSums {
    let per_tile: Vec<(f64, f64)> = film
        .tiles()
        .into_par_iter()
        .map(|(rect, pixels)| {
            let v = smoothed_variances(&rect, pixels);
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

/// The samples an adaptive pass `a` would take, by priority bucket (summed in tile order).
fn pass_cost_by_bucket(film: &Film, a: &Adaptive) -> Vec<f64> {
    let per_tile: Vec<Vec<f64>> = film
        .tiles()
        .into_par_iter()
        .map(|(rect, pixels)| {
            let mut cost = vec![0.0; PRIORITY_BUCKETS];
            let v = smoothed_variances(&rect, pixels);
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

/// The next adaptive pass, or why to stop: see [`Adaptive`]. `seconds_per_sample` is the time
/// one pixel's sample took in the last pass, `elapsed` the frame's time so far.
fn plan_adaptive(
    film: &Film,
    budget: &Budget,
    elapsed: f64,
    seconds_per_sample: f64,
) -> Result<Adaptive, StopReason> {
    let sums = film_sums(film);
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
    let mut cost = pass_cost_by_bucket(film, &plan);
    if cost.iter().all(|&c| c == 0.0) {
        // Every pixel is at its target, yet the frame's estimate is above the threshold (the
        // estimates moved with the last samples): every pixel takes the pass.
        plan.scale = f64::INFINITY;
        cost = pass_cost_by_bucket(film, &plan);
        if cost.iter().all(|&c| c == 0.0) {
            return Err(StopReason::MaxSamples);
        }
    }
    if let Some(left) = left {
        // The pixels of the highest priorities whose samples fit half the time left, or 90
        // percent of it for the last pass (as `next_pass`).
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

/// The samples per pixel of the next pass, or why to stop.
///
/// Passes double the samples taken so far (1, 1, 2, 4, ...: totals at powers of two, where
/// Sobol points are best stratified). Under a time limit, a pass takes at most half of the time
/// left, at the speed of the previous pass: the passes shrink toward the limit, so a pass that
/// runs slower than the one before (a busy machine) still ends before it. The last pass is a
/// single sample when 90 percent of the time left fits one.
pub fn next_pass(
    budget: &Budget,
    done: u32,
    elapsed: f64,
    seconds_per_sample: Option<f64>,
) -> Result<u32, StopReason> {
    let cap = budget.max_samples.unwrap_or(u32::MAX);
    if done >= cap {
        return Err(StopReason::MaxSamples);
    }
    let mut size = done.max(1).min(cap - done);
    if let (Some(limit), Some(per_sample)) = (budget.time_limit, seconds_per_sample) {
        let left = limit - elapsed;
        let half = (0.5 * left / per_sample).floor();
        if half >= 1.0 {
            size = size.min(half.min(u32::MAX as f64) as u32);
        } else if 0.9 * left >= per_sample {
            size = 1;
        } else {
            return Err(StopReason::TimeLimit);
        }
    }
    Ok(size)
}

/// Renders frame `frame` of `scene` with the scene's settings (`[output]` size, `[render]`
/// samples, depth, seed and sampler): exactly its samples in every pixel, in one pass, when
/// `budget` is not set; else in passes until the budget stops it. `progress` is called with
/// the number of samples of each finished tile, from worker threads. Runs on the current rayon
/// pool.
///
/// Under a budget, every pixel first takes the same samples, in passes that double them
/// ([`next_pass`]), up to [`MIN_SAMPLES_FOR_THRESHOLD`]; then passes are adaptive: each pixel
/// doubles its samples or stops by its own estimated error ([`Adaptive`]), until the frame's
/// estimate meets the noise threshold, the time runs out or no pixel may take more.
///
/// Sample `i` of a pixel is the same whichever pass takes it, and each pixel's mean is the
/// plain sum of its samples over their count: a pixel that stopped at N samples is
/// bit-identical to the same pixel rendered with exactly N samples.
pub fn render_frame(
    scene: &Scene,
    statics: &StaticGeometry,
    frame: u32,
    budget: &Budget,
    progress: &(dyn Fn(u64) + Sync),
) -> FrameResult {
    let frame_start = Instant::now();
    let req = &FrameRequest::from_scene(scene, frame);
    let times = scene.shot.frame_times(req.frame);
    let interval = times.interval;
    let world = World::prepare(scene, statics, interval);
    let camera_moves = scene.camera.moves_in(interval);
    let fixed_view = scene.camera.view_at(interval.open, req.width, req.height);
    let passes = (!scene.output.passes.is_empty()).then(|| {
        PassContext::new(
            scene.output.passes,
            &scene.spheres,
            scene.background,
            &scene.camera,
            scene.shot.fps,
            req.width,
            req.height,
        )
    });
    let stride = passes.as_ref().map_or(0, |p| p.layout.stride);
    let setup = FrameSetup {
        scene,
        // Sample time only when something moves during the frame's whole exposure (so a still
        // scene renders the same under any shutter); sample the lens only for a lens with an
        // aperture (which does not change over time, so any instant's view answers).
        sample_time: world.has_motion() || camera_moves,
        has_lens: fixed_view.has_lens(),
        world,
        req,
        interval,
        times,
        camera_moves,
        fixed_view,
        passes,
        transparent: scene.transparent,
    };
    let prepare_seconds = frame_start.elapsed().as_secs_f64();

    let render_start = Instant::now();
    let mut film = Film::new(req.width, req.height);
    let mut pass_sums = vec![0.0; req.width as usize * req.height as usize * stride];
    let pixels = req.width as f64 * req.height as f64;

    let mut stats = FrameStats {
        prepare_seconds,
        moving_spheres: setup.world.moving,
        ..FrameStats::default()
    };
    // Samples every pixel has taken in the uniform passes.
    let mut done = 0u32;
    // Seconds a pass took per sample of every pixel, and per sample of one pixel.
    let mut seconds_per_sample = None;
    let mut seconds_per_pixel_sample = f64::INFINITY;
    let warm_up = MIN_SAMPLES_FOR_THRESHOLD.min(budget.max_samples.unwrap_or(u32::MAX));
    loop {
        let plan = if !budget.is_set() {
            if done >= req.samples {
                break;
            }
            Plan::Uniform(req.samples)
        } else if done < warm_up {
            match next_pass(
                budget,
                done,
                frame_start.elapsed().as_secs_f64(),
                seconds_per_sample,
            ) {
                Ok(size) => Plan::Uniform(done + size),
                Err(reason) => {
                    stats.stop = reason;
                    break;
                }
            }
        } else {
            match plan_adaptive(
                &film,
                budget,
                frame_start.elapsed().as_secs_f64(),
                seconds_per_pixel_sample,
            ) {
                Ok(a) => Plan::Adaptive(a),
                Err(reason) => {
                    stats.stop = reason;
                    break;
                }
            }
        };
        let pass_start = Instant::now();
        let counts = setup.pass(&mut film, &mut pass_sums, &plan, progress);
        let seconds = pass_start.elapsed().as_secs_f64();
        if let Plan::Uniform(n) = plan {
            seconds_per_sample = Some(seconds / (n - done) as f64);
            done = n;
        }
        if counts.samples > 0 {
            seconds_per_pixel_sample = seconds / counts.samples as f64;
        }
        stats.rays += counts.rays;
        stats.samples += counts.samples;
        stats.non_finite += counts.non_finite;
        stats.tile_seconds += counts.seconds;
        stats.passes += 1;
        if let Some(threshold) = budget.noise_threshold
            && done >= warm_up
            && relative_error(&film) <= threshold
        {
            stats.stop = StopReason::NoiseThreshold;
            break;
        }
    }

    let passes = setup.passes.as_ref().map(|p| {
        let mut images = PassImages::new(scene.output.passes, req.width, req.height);
        let mut sums_left = &pass_sums[..];
        for (rect, pixels) in film.tiles() {
            let (sums, rest) = sums_left.split_at(rect.len() * stride);
            sums_left = rest;
            for (i, pixel) in pixels.iter().enumerate() {
                let (x, y) = rect.position(i);
                let sums = &sums[i * stride..(i + 1) * stride];
                images.set(
                    &p.layout,
                    x,
                    y,
                    sums,
                    pixel.taken(),
                    pixel.variance_of_mean(),
                );
            }
        }
        images
    });
    stats.relative_error = relative_error(&film);
    let taken = film.all_pixels().iter().map(Pixel::taken);
    stats.samples_per_pixel = taken.clone().max().unwrap_or(0);
    stats.min_samples_per_pixel = taken.min().unwrap_or(0);
    stats.mean_samples_per_pixel = stats.samples as f64 / pixels;
    stats.render_seconds = render_start.elapsed().as_secs_f64();
    FrameResult {
        film,
        passes,
        stats,
    }
}

/// Resident bytes of the process with a scene of a few spheres and no image to speak of:
/// code, the thread pool, the allocator's arenas. Measured: the peak of a 1x1 render of
/// `scenes/quick.toml` (5.6 MiB).
const FLOOR_BYTES: u64 = 11 << 19;

/// Bytes per sphere while the scene file is read, beyond the [`Scene`] itself: the file's
/// text and its parsed form are gone once the scene is validated, but they set the peak of a
/// large scene. Calibrated on generated scenes of 10^4 to 10^6 spheres.
const LOAD_BYTES_PER_SPHERE: u64 = 300;

/// The bytes a frame of `scene` holds per pixel: the film's [`Pixel`] sums (40 bytes), which
/// an EXR file's colour is encoded from directly, with no copy; a PNG file's 8-bit copy (3
/// bytes, 4 with alpha); and with passes, their sums, their channels, the channels' copy as
/// encoded and the colour's (`f32` RGB).
pub fn bytes_per_pixel(scene: &Scene) -> u64 {
    use std::mem::size_of;
    let passes = scene.output.passes;
    let pass_channels: usize = passes.iter().map(|p| p.channels().len()).sum();
    let png = crate::io::Format::from_extension(
        std::path::Path::new(&scene.output.path),
        &[crate::io::Format::Png],
    )
    .is_some();
    let encoded_copy = match (png, pass_channels) {
        (true, 0) => 3,
        (true, _) => 4,
        (false, 0) => 0,
        (false, _) => 3 * size_of::<f32>() as u64,
    };
    size_of::<Pixel>() as u64
        + encoded_copy
        + (crate::passes::Layout::new(passes).stride * size_of::<f64>()) as u64
        + (2 * pass_channels * size_of::<f32>()) as u64
}

/// An estimate of the most memory a render of one frame of `scene` at a time holds, in
/// bytes: the process's floor; per pixel, [`bytes_per_pixel`]; per sphere, the scene's
/// description, the shot's static geometry, one frame's prepared spheres with their boxes, a
/// hierarchy build's working arrays and the hierarchy, and the scene file while it is read. It
/// grows linearly in pixels and spheres, and errs high for scenes whose spheres are mostly
/// still.
pub fn memory_estimate(scene: &Scene) -> u64 {
    use std::mem::size_of;
    let pixels = scene.output.width as u64 * scene.output.height as u64;
    let per_pixel = bytes_per_pixel(scene);
    let n = scene.spheres.len() as u64;
    // Keyframed paths hold their keys in the description and again in each frame's path.
    let keys: u64 = scene
        .spheres
        .iter()
        .map(|s| match &s.motion {
            crate::motion::Motion::Keyframes(k) => k.len() as u64,
            _ => 0,
        })
        .sum();
    let per_sphere = size_of::<crate::sphere::SphereDesc>()
        + size_of::<crate::sphere::PreparedSphere>()
        // A frame's boxes at the shutter's opening and closing, and a build's copy of each
        // with its centroid (the build takes the union, then the per-leaf boxes).
        + 2 * size_of::<crate::aabb::Aabb>()
        + crate::world::PRIM_BYTES
        + crate::bvh::BUILD_BYTES_PER_PRIMITIVE
        + crate::bvh::BYTES_PER_PRIMITIVE;
    FLOOR_BYTES
        + pixels * per_pixel
        + n * (per_sphere as u64 + LOAD_BYTES_PER_SPHERE)
        + keys * 2 * size_of::<crate::motion::Key>() as u64
}

/// The relative error estimated from the film's pixels ([`FrameStats::relative_error`]):
/// the square root of the mean of their
/// [`film::relative_variances`](crate::film::relative_variances), summed in storage order.
pub fn relative_error(film: &Film) -> f64 {
    let sum: f64 = film
        .tiles()
        .iter()
        .flat_map(|(rect, pixels)| crate::film::relative_variances(rect, pixels))
        .sum();
    (sum / film.all_pixels().len().max(1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_memory_estimate_grows_linearly_with_pixels_and_spheres() {
        let scene = |w: u32, h: u32, spheres: usize| {
            let mut text = format!("[output]\nwidth = {w}\nheight = {h}\n");
            for i in 0..spheres {
                text += &format!(
                    "[[sphere]]\ncenter = [{i}.0, 0.0, 0.0]\nradius = 0.5\nvelocity = [0.0, 1.0, 0.0]\nmaterial = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\n"
                );
            }
            memory_estimate(&Scene::parse(&text, std::path::Path::new("m.toml")).unwrap())
        };
        let base = scene(100, 100, 10);
        let pixels = scene(200, 100, 10) - base;
        assert_eq!(scene(300, 100, 10) - base, 2 * pixels);
        let spheres = scene(100, 100, 20) - base;
        assert!(spheres > 0);
        assert_eq!(scene(100, 100, 30) - base, 2 * spheres);
        // 2^32 pixels need 160 GiB: 40 bytes each, the film alone.
        assert!(scene(65536, 65536, 1) > 160 << 30);
        let png = Scene::parse("", std::path::Path::new("m.toml")).unwrap();
        assert!(png.output.path.ends_with(".png"));
        assert_eq!(pixels, 100 * 100 * bytes_per_pixel(&png));
        assert_eq!(bytes_per_pixel(&png), 43);
    }

    #[test]
    fn passes_take_memory_only_when_requested() {
        let scene = |passes: &str| {
            let text = format!(
                "[output]\npath = \"o.exr\"\nwidth = 20\nheight = 10\npasses = {passes}\n[render]\nsamples = 2\n"
            );
            Scene::parse(&text, std::path::Path::new("p.toml")).unwrap()
        };
        let (none, alpha, all) = (
            scene("[]"),
            scene("[\"alpha\"]"),
            scene("[\"alpha\", \"depth\", \"normal\", \"albedo\", \"motion\", \"variance\"]"),
        );
        let pixels = 200;
        // The film alone, its colour encoded with no copy.
        assert_eq!(bytes_per_pixel(&none), 40);
        // Alpha: one sum and one channel (and its copy as written) per pixel, and the
        // colour's copy as written beside it.
        assert_eq!(
            memory_estimate(&alpha) - memory_estimate(&none),
            pixels * (8 + 2 * 4 + 12)
        );
        assert_eq!(
            memory_estimate(&all) - memory_estimate(&none),
            pixels * (12 * 8 + 2 * 15 * 4 + 12)
        );
        let statics = StaticGeometry::new(&none);
        let r = render_frame(&none, &statics, 1, &Budget::default(), &|_| {});
        assert!(r.passes.is_none());
        let statics = StaticGeometry::new(&all);
        let r = render_frame(&all, &statics, 1, &Budget::default(), &|_| {});
        assert_eq!(r.passes.map(|p| p.channels.len()), Some(15));
    }

    #[test]
    fn a_degenerate_camera_counts_every_sample_as_black() {
        let text = r#"
[output]
width = 8
height = 4
[render]
samples = 3
[camera]
look_from = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
velocity = [1.0, 0.0, 0.0]
material = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
"#;
        let mut scene = Scene::parse(text, std::path::Path::new("degenerate.toml")).unwrap();
        // Looking at where it stands: every camera ray's direction is NaN.
        scene.camera.look_at = scene.camera.look_from.clone();
        let statics = StaticGeometry::new(&scene);
        let frame = scene.shot.first_frame;
        let result = render_frame(&scene, &statics, frame, &Budget::default(), &|_| {});
        assert_eq!(result.stats.non_finite, 8 * 4 * 3);
        assert_eq!(result.stats.rays, 0);
        assert!(result.film.means().iter().all(|p| *p == DVec3::ZERO));
    }

    #[test]
    fn passes_double_the_samples_taken() {
        let b = Budget {
            noise_threshold: Some(0.01),
            ..Budget::default()
        };
        let mut done = 0;
        let mut totals = vec![];
        for _ in 0..6 {
            done += next_pass(&b, done, 0.0, Some(1.0)).unwrap();
            totals.push(done);
        }
        assert_eq!(totals, [1, 2, 4, 8, 16, 32]);
    }

    #[test]
    fn passes_stop_at_the_largest_sample_count() {
        let b = Budget {
            noise_threshold: Some(0.01),
            max_samples: Some(12),
            ..Budget::default()
        };
        assert_eq!(next_pass(&b, 8, 0.0, None), Ok(4));
        assert_eq!(next_pass(&b, 12, 0.0, None), Err(StopReason::MaxSamples));
    }

    #[test]
    fn passes_fit_in_half_the_time_left() {
        let b = Budget {
            time_limit: Some(10.0),
            ..Budget::default()
        };
        // No speed known yet: the first pass is one sample.
        assert_eq!(next_pass(&b, 0, 0.5, None), Ok(1));
        // 16 samples taken by 1 s at 0.05 s a sample: 16 more take 0.8 s, under half of 9 s.
        assert_eq!(next_pass(&b, 16, 1.0, Some(0.05)), Ok(16));
        // 64 taken by 4 s: half of the 6 s left fits 60.
        assert_eq!(next_pass(&b, 64, 4.0, Some(0.05)), Ok(60));
        // By 9.94 s: half of 0.06 s fits no sample, but 90 percent of it fits one.
        assert_eq!(next_pass(&b, 200, 9.94, Some(0.05)), Ok(1));
        // By 9.96 s: not even that.
        assert_eq!(
            next_pass(&b, 201, 9.96, Some(0.05)),
            Err(StopReason::TimeLimit)
        );
    }
}
