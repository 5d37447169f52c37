//! Rendering one frame: the frame's world, its camera rays, in parallel over tiles, in one
//! pass of the requested samples or, under a time or noise budget, in passes until the budget
//! is met.

use std::ops::Range;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::analysis::metrics;
use crate::camera::View;
use crate::film::{Film, PixelAccumulator};
use crate::passes::{PassContext, PassImages};
use crate::ray::Ray;
use crate::sampler::{IndependentSampler, Sampler, SamplerKind, SobolSampler};
use crate::scene::Scene;
use crate::shutter::{FrameTimes, Interval};
use crate::tracer::{TraceStats, camera_radiance, radiance};
use crate::world::{StaticGeometry, World};

/// Side of the square tiles the image is split into for parallel work: a 400x225 frame has
/// 375, handed to the threads one at a time (see `pass`), so every thread has work until the
/// frame's last tiles.
pub const TILE: u32 = 16;

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

/// The fewest samples per pixel whose variance estimate may stop a render at its noise
/// threshold. Below it, a pixel's sample variance misses rare bright paths too often.
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
    /// Samples per pixel taken.
    pub samples_per_pixel: u32,
    /// Passes the samples were taken in.
    pub passes: u32,
    /// Why sampling stopped.
    pub stop: StopReason,
    /// Samples dropped because they were not finite.
    pub dropped: u64,
    /// Spheres moving during the frame's shutter.
    pub moving_spheres: usize,
    /// The relative error estimated from the pixels' sample variances: the square root of
    /// the estimated relative mean squared error ([`metrics::estimated_rel_mse`]). Infinite
    /// with fewer than two samples per pixel.
    pub relative_error: f64,
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// The pixels' means.
    pub film: Film,
    /// Each pixel's estimated variance of its mean, row-major like the film.
    pub variance: Vec<DVec3>,
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

/// One tile of the image and its pixels' running estimates.
struct Tile {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
    pixels: Vec<PixelAccumulator>,
    /// The passes' sums, `Layout::stride` numbers per pixel (empty without passes).
    pass_sums: Vec<f64>,
}

impl FrameSetup<'_> {
    /// Adds samples `range` of every pixel of `tile`; returns the rays traced.
    fn sample_tile<S: Sampler>(&self, sampler: &mut S, tile: &mut Tile, range: Range<u32>) -> u64 {
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
        let mut stats = TraceStats::default();
        let mut acc = tile.pixels.iter_mut();
        let mut sums = tile.pass_sums.chunks_mut(stride.max(1));
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                let acc = acc.next().expect("one accumulator per pixel");
                let sums = if stride > 0 { sums.next() } else { None };
                let sums = sums.unwrap_or_default();
                for s in range.clone() {
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
                    if observed {
                        self.observed_sample(ray, &view, sampler, &mut stats, acc, sums);
                    } else {
                        acc.add(radiance(
                            &self.world,
                            ray,
                            req.max_depth,
                            sampler,
                            &mut stats,
                        ));
                    }
                }
            }
        }
        stats.rays
    }

    /// One camera sample of a frame with passes or a transparent background: its radiance
    /// into `acc` and its passes into the pixel's sums `sums`.
    #[inline(never)]
    fn observed_sample<S: Sampler>(
        &self,
        ray: Ray,
        view: &View,
        sampler: &mut S,
        stats: &mut TraceStats,
        acc: &mut PixelAccumulator,
        sums: &mut [f64],
    ) {
        let mut first = None;
        acc.add(camera_radiance(
            &self.world,
            ray,
            self.req.max_depth,
            sampler,
            stats,
            self.transparent,
            |hit| first = hit.copied(),
        ));
        if let Some(passes) = &self.passes {
            passes.record(sums, &ray, view, first.as_ref());
        }
    }

    /// Adds samples `range` to every tile, in parallel; returns (rays, tile seconds).
    fn pass(
        &self,
        tiles: &mut [Tile],
        range: Range<u32>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> (u64, f64) {
        let req = self.req;
        tiles
            .par_iter_mut()
            // One tile at a time: rayon otherwise hands out runs of tiles, and a run of
            // costly ones left a core idle for up to a tenth of a short frame.
            .with_max_len(1)
            .map(|tile| {
                let start = Instant::now();
                let rays = match req.sampler {
                    SamplerKind::Independent => self.sample_tile(
                        &mut IndependentSampler::new(req.seed, req.frame),
                        tile,
                        range.clone(),
                    ),
                    SamplerKind::Sobol => self.sample_tile(
                        &mut SobolSampler::new(req.seed, req.frame),
                        tile,
                        range.clone(),
                    ),
                };
                progress(tile.pixels.len() as u64 * range.len() as u64);
                (rays, start.elapsed().as_secs_f64())
            })
            .reduce(|| (0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1))
    }
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
/// samples, depth, seed and sampler): exactly its samples per pixel in one pass when `budget`
/// is not set, else in passes until the budget stops it. `progress` is called with the number of samples
/// of each finished tile, from worker threads. Runs on the current rayon pool.
///
/// Sample `i` of a pixel is the same whichever pass takes it, and each pixel's mean is the
/// plain sum of its samples over their count: a frame that stopped at N samples per pixel
/// is bit-identical to one rendered with exactly N samples.
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
    let tiles_x = req.width.div_ceil(TILE);
    let tiles_y = req.height.div_ceil(TILE);
    let mut tiles: Vec<Tile> = (0..tiles_x * tiles_y)
        .map(|t| {
            let (x0, y0) = ((t % tiles_x) * TILE, (t / tiles_x) * TILE);
            let (x1, y1) = ((x0 + TILE).min(req.width), (y0 + TILE).min(req.height));
            let n = ((x1 - x0) * (y1 - y0)) as usize;
            Tile {
                x0,
                y0,
                x1,
                y1,
                pixels: vec![PixelAccumulator::default(); n],
                pass_sums: vec![0.0; n * stride],
            }
        })
        .collect();

    let mut stats = FrameStats {
        prepare_seconds,
        moving_spheres: setup.world.moving,
        ..FrameStats::default()
    };
    let mut done = 0u32;
    let mut seconds_per_sample = None;
    loop {
        let size = if budget.is_set() {
            match next_pass(
                budget,
                done,
                frame_start.elapsed().as_secs_f64(),
                seconds_per_sample,
            ) {
                Ok(size) => size,
                Err(reason) => {
                    stats.stop = reason;
                    break;
                }
            }
        } else if done < req.samples {
            req.samples
        } else {
            break;
        };
        let pass_start = Instant::now();
        let (rays, tile_seconds) = setup.pass(&mut tiles, done..done + size, progress);
        seconds_per_sample = Some(pass_start.elapsed().as_secs_f64() / size as f64);
        done += size;
        stats.rays += rays;
        stats.tile_seconds += tile_seconds;
        stats.passes += 1;
        if let Some(threshold) = budget.noise_threshold
            && done >= MIN_SAMPLES_FOR_THRESHOLD.min(budget.max_samples.unwrap_or(u32::MAX))
            && relative_error(&tiles) <= threshold
        {
            stats.stop = StopReason::NoiseThreshold;
            break;
        }
    }

    let (film, variance) = assemble(&tiles, req);
    let passes = setup.passes.as_ref().map(|p| {
        let mut images = PassImages::new(scene.output.passes, req.width, req.height);
        for tile in &tiles {
            let w = tile.x1 - tile.x0;
            for i in 0..tile.pixels.len() {
                let (x, y) = (tile.x0 + i as u32 % w, tile.y0 + i as u32 / w);
                let sums = &tile.pass_sums[i * stride..(i + 1) * stride];
                let v = variance[y as usize * req.width as usize + x as usize];
                images.set(&p.layout, x, y, sums, done, v);
            }
        }
        images
    });
    stats.relative_error = relative_error(&tiles);
    stats.samples_per_pixel = done;
    stats.samples = req.width as u64 * req.height as u64 * done as u64;
    stats.dropped = tiles
        .iter()
        .flat_map(|t| &t.pixels)
        .map(|p| p.dropped as u64)
        .sum();
    stats.render_seconds = render_start.elapsed().as_secs_f64();
    FrameResult {
        film,
        variance,
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

/// An estimate of the most memory a render of one frame of `scene` at a time holds, in
/// bytes: the process's floor; per pixel, the accumulators, the film, the variances and the
/// `f32` copy written; per sphere, the scene's description, the shot's static geometry, one
/// frame's prepared spheres with their boxes, a hierarchy build's working arrays and the
/// hierarchy, and the scene file while it is read. It grows linearly in pixels and spheres,
/// and errs high for scenes whose spheres are mostly still.
pub fn memory_estimate(scene: &Scene) -> u64 {
    use std::mem::size_of;
    let pixels = scene.output.width as u64 * scene.output.height as u64;
    // With passes: their sums, and their channels as written.
    let passes = scene.output.passes;
    let pass_channels: usize = passes.iter().map(|p| p.channels().len()).sum();
    let per_pixel = size_of::<PixelAccumulator>() as u64
        + 2 * size_of::<DVec3>() as u64
        + 3 * size_of::<f32>() as u64
        + (crate::passes::Layout::new(passes).stride * size_of::<f64>()) as u64
        + (2 * pass_channels * size_of::<f32>()) as u64;
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

/// The film of the tiles' means, and each pixel's variance of its mean.
fn assemble(tiles: &[Tile], req: &FrameRequest) -> (Film, Vec<DVec3>) {
    let mut film = Film::new(req.width, req.height);
    let mut variance = vec![DVec3::ZERO; req.width as usize * req.height as usize];
    for tile in tiles {
        let w = tile.x1 - tile.x0;
        for (i, p) in tile.pixels.iter().enumerate() {
            let (x, y) = (tile.x0 + i as u32 % w, tile.y0 + i as u32 / w);
            film.set(x, y, p.mean());
            variance[y as usize * req.width as usize + x as usize] = p.variance_of_mean();
        }
    }
    (film, variance)
}

/// The relative error estimated from the tiles' pixels ([`FrameStats::relative_error`]).
fn relative_error(tiles: &[Tile]) -> f64 {
    let pixels = tiles.iter().flat_map(|t| &t.pixels);
    metrics::estimated_rel_mse(pixels.map(|p| (p.mean(), p.variance_of_mean()))).sqrt()
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
        // 2^32 pixels need hundreds of gigabytes.
        assert!(scene(65536, 65536, 1) > 400 << 30);
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
        // Alpha: one sum and one channel (and its copy as written) per pixel.
        assert_eq!(
            memory_estimate(&alpha) - memory_estimate(&none),
            pixels * (8 + 2 * 4)
        );
        assert_eq!(
            memory_estimate(&all) - memory_estimate(&none),
            pixels * (12 * 8 + 2 * 15 * 4)
        );
        let statics = StaticGeometry::new(&none);
        let r = render_frame(&none, &statics, 1, &Budget::default(), &|_| {});
        assert!(r.passes.is_none());
        let statics = StaticGeometry::new(&all);
        let r = render_frame(&all, &statics, 1, &Budget::default(), &|_| {});
        assert_eq!(r.passes.map(|p| p.channels.len()), Some(15));
    }

    #[test]
    fn a_degenerate_camera_drops_and_counts_every_sample() {
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
        assert_eq!(result.stats.dropped, 8 * 4 * 3);
        assert_eq!(result.stats.rays, 0);
        assert!(result.film.pixels().iter().all(|p| *p == DVec3::ZERO));
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
