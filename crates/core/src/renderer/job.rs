//! One frame: its world and camera prepared for the frame's interval, then rounds of samples
//! over the film's tiles until the requested samples are taken or the budget stops it.

use std::time::Instant;

use super::adaptive::{RoundPlan, Weights, plan_adaptive};
use super::budget::{Budget, MIN_SAMPLES_FOR_THRESHOLD, StopReason, next_round};
use super::stop::{RawStop, StopRule, relative_error};
use super::tiles::FrameRequest;
use super::tracers::{RoundCounts, ShotTracer};

use crate::error::Error;
use crate::film::{Film, Pixel};
use crate::image::Image;
use crate::pass::PassSet;
use crate::passes::{SumLayout, add_pass_channels};
use crate::points::FramePoints;
use crate::prepared::PreparedFrame;
use crate::scene::DenoiseQuality;
use crate::scene::Scene;
use crate::shutter::Interval;

/// Figures of one rendered frame.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    /// Seconds spent preparing the frame's world (motion bounds, hierarchy build).
    pub prepare_seconds: f64,
    /// Seconds spent tracing, and denoising the frame when it is denoised.
    pub render_seconds: f64,
    /// Seconds the tiles took, summed over all threads: with `render_seconds` and the thread
    /// count, how busy the cores were. On the GPU: seconds the host waited for the device,
    /// so that the frame's time less these is the host's work.
    pub tile_seconds: f64,
    /// Bytes read back from the device (on the GPU: its film once a round and each
    /// dispatch's counts; 0 on the CPU).
    pub readback_bytes: u64,
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
    /// Rounds the samples were taken in (one without a budget).
    pub rounds: u32,
    /// Why sampling stopped.
    pub stop: StopReason,
    /// Samples that were not finite (a NaN or infinite component), counted as black.
    pub non_finite: u64,
    /// Spheres moving during the frame's shutter.
    pub moving_spheres: usize,
    /// The relative error estimated from the pixels' replicates
    /// ([`relative_error`]): the square root of the estimated relative
    /// mean squared error. Infinite with fewer than two samples per pixel. Of the frame
    /// written: when the frame is denoised, the raw and denoised frames blended, bias
    /// included (`denoise::estimate`).
    pub relative_error: f64,
    /// The raw (noisy) frame's estimated relative error: [`relative_error`](Self::relative_error)
    /// before denoising.
    pub noisy_relative_error: f64,
    /// Seconds spent denoising (every run of the denoiser, estimates included), within
    /// [`render_seconds`](Self::render_seconds) when the stop rule denoised.
    pub denoise_seconds: f64,
    /// Times the frame was denoised: at most two under a noise threshold, one otherwise.
    pub denoises: u32,
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// The frame number.
    pub frame: u32,
    /// The frame's interval: its whole exposure (see [`crate::shutter::Shot::interval`]), which the frame's
    /// file records as its shutter's opening and closing.
    pub interval: Interval,
    /// The pixels' sums (their means, sample counts and estimated errors), and the sums of
    /// the scene's `[output] passes`, if it asks for any.
    pub film: Film,
    /// Where the film keeps which pass sums.
    pub layout: SumLayout,
    /// The frame as it is written: its colour ([`crate::image::COLOUR`]: the film's means as
    /// sampled, or the written frame's once finishing has denoised it) and the channels of the
    /// passes written; the colour premultiplied by the alpha pass where the background is
    /// transparent.
    pub image: Image,
    /// What finishing did when the scene asks for denoising (`raytrace_render::finish`);
    /// `None` for a raw frame.
    pub denoised: Option<Denoised>,
    pub stats: FrameStats,
}

impl FrameResult {
    /// The bytes a sampled frame of `scene` holds whose film keeps the sums `layout` says:
    /// its film ([`Film::bytes_for`]) and its image, the colour and the channels of the passes
    /// written ([`Image::bytes_for`]).
    pub fn bytes_for(scene: &Scene, layout: &SumLayout) -> u64 {
        let pixels = scene.output.width as u64 * scene.output.height as u64;
        let channels: usize = layout.passes().iter().map(|p| p.channels().len()).sum();
        Film::bytes_for(pixels, layout.stride) + Image::bytes_for(pixels, 3 + channels)
    }
}

/// What finishing tells of a frame it denoised (its colour is the frame's image's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Denoised {
    /// The written colour's estimated relative error, bias included.
    pub relative_error: f64,
    /// The mean weight of the denoised frame in the written one, in [0, 1].
    pub denoised_share: f64,
    /// With `--temporal`: the mean weight of the earlier frames in the written one, in
    /// [0, 1].
    pub history_share: Option<f64>,
    /// The filter's quality.
    pub quality: DenoiseQuality,
    /// With `--temporal`, the estimated relative mean squared change of the written frame's
    /// error from the frame before it (`raytrace_denoise::change`), where that frame was
    /// finished just before this one by the same stages: a clip's stated flicker is the root
    /// of the mean of its frames'. `None` for a run's first frame and without `--temporal`.
    pub change: Option<f64>,
}

/// One frame to sample: frame `frame` of a scene, with the scene's settings (`[output]` size,
/// `[render]` samples, depth, seed and sampler), built up and then sampled
/// ([`FrameJob::sample`]).
///
/// Without a budget, every pixel takes exactly the scene's samples, in one round. Under a
/// budget, every pixel first takes the same samples, in rounds that double them
/// ([`next_round`]), up to [`MIN_SAMPLES_FOR_THRESHOLD`]; then rounds are adaptive: each pixel
/// doubles its samples or stops by its weight ([`StopRule::weights`]), until the stop rule
/// finds the frame within the noise threshold, the time runs out or no pixel may take more.
///
/// Sample `i` of a pixel is the same whichever round takes it, and each pixel's mean is the
/// plain sum of its samples over their count: a pixel that stopped at N samples is
/// bit-identical to the same pixel rendered with exactly N samples.
///
/// The frame comes out raw: finishing it (denoising, history) is `raytrace_render`'s `Finishing`.
/// The scene's point caches are not read here (reading files is not the frame's business):
/// the frame's points are given ([`FrameJob::points`]).
pub struct FrameJob<'a> {
    scene: &'a Scene,
    frame: u32,
    points: &'a FramePoints,
    budget: Budget,
    progress: &'a (dyn Fn(u64) + Sync),
    read: PassSet,
}

/// The points of a frame without point caches.
static NO_POINTS: FramePoints = FramePoints { sets: Vec::new() };

impl<'a> FrameJob<'a> {
    /// Frame `frame` of `scene`: no points, no budget, no progress, the raw stop rule.
    pub fn new(scene: &'a Scene, frame: u32) -> FrameJob<'a> {
        FrameJob {
            scene,
            frame,
            points: &NO_POINTS,
            budget: Budget::default(),
            progress: &|_| {},
            read: PassSet::EMPTY,
        }
    }

    /// Also samples `read`, the passes the frame's finishing reads without writing them
    /// (`Finishing::passes_read` in `raytrace_render`).
    pub fn reading(self, read: PassSet) -> FrameJob<'a> {
        FrameJob { read, ..self }
    }

    /// The frame's points of the scene's point caches (as `point_cache::read_frame` reads
    /// them), among its spheres.
    pub fn points(self, points: &'a FramePoints) -> FrameJob<'a> {
        FrameJob { points, ..self }
    }

    /// Samples in rounds until `budget` stops them, instead of exactly the scene's samples.
    pub fn budget(self, budget: Budget) -> FrameJob<'a> {
        FrameJob { budget, ..self }
    }

    /// Called with the number of samples of each finished tile (or GPU batch), from worker
    /// threads.
    pub fn progress(self, progress: &'a (dyn Fn(u64) + Sync)) -> FrameJob<'a> {
        FrameJob { progress, ..self }
    }

    /// Samples the frame on `tracer`'s device, judged under a noise threshold by the raw
    /// film's own estimate ([`RawStop`]): see [`sample_with`](Self::sample_with).
    pub fn sample(self, tracer: &dyn ShotTracer) -> Result<FrameResult, Error> {
        self.sample_with(tracer, &mut RawStop)
    }

    /// Samples the frame on `tracer`'s device, judged under a noise threshold by `stop` (the
    /// frame that will be written: `Finishing::stop_rule`): the same rounds, budgets and
    /// film whichever device traces the samples. A device that fails mid-frame (lost, out of
    /// memory), or a denoiser that fails while the stop rule judges the frame, is an
    /// [`Error::Frame`] naming the frame, and nothing of the frame is kept. Runs on the
    /// current rayon pool.
    pub fn sample_with(
        self,
        tracer: &dyn ShotTracer,
        stop: &mut dyn StopRule,
    ) -> Result<FrameResult, Error> {
        let frame = self.frame;
        sample(self, tracer, stop).map_err(|e| e.in_frame(frame))
    }
}

fn sample(
    job: FrameJob<'_>,
    tracer: &dyn ShotTracer,
    stop: &mut dyn StopRule,
) -> Result<FrameResult, Error> {
    let FrameJob {
        scene,
        frame,
        points,
        budget,
        progress,
        read,
    } = job;
    let frame_start = Instant::now();
    let req = &FrameRequest::from_scene(scene);
    let layout = SumLayout::keeping(scene.output.passes, read);
    // One prepared frame, whichever device traces it.
    let prepared = PreparedFrame::new(scene, tracer.statics(), points, frame);
    let interval = prepared.interval();
    let mut device = tracer.frame(prepared, points, &layout)?;
    let mut stats = FrameStats {
        prepare_seconds: frame_start.elapsed().as_secs_f64(),
        moving_spheres: device.moving_spheres(),
        ..FrameStats::default()
    };

    let render_start = Instant::now();
    let mut film = Film::with_pass_sums(req.width, req.height, layout.stride);
    let mut schedule = RoundSchedule::new(&budget, req.samples);
    stop.begin();
    loop {
        let weights = stop.weights();
        let elapsed = frame_start.elapsed().as_secs_f64();
        let plan = match schedule.next(&budget, &film, weights, elapsed) {
            Ok(Some(plan)) => plan,
            Ok(None) => break,
            Err(reason) => {
                stats.stop = reason;
                break;
            }
        };
        let round_start = Instant::now();
        let counts = device.round(&mut film, &plan, progress)?;
        let round_seconds = round_start.elapsed().as_secs_f64();
        schedule.took(&plan, round_seconds, &counts);
        stats.add(&counts);
        if let Some(threshold) = budget.noise_threshold
            && schedule.warmed_up()
            && stop.reached(&film, threshold, counts.samples)?
        {
            stats.stop = StopReason::NoiseThreshold;
            break;
        }
    }
    stats.sampled(&film, device.readback_bytes());
    stats.render_seconds = render_start.elapsed().as_secs_f64();
    let mut image = film.colour();
    add_pass_channels(&mut image, layout.passes(), &layout, &film);
    image.premultiplied = scene.transparent && !layout.passes().is_empty();
    Ok(FrameResult {
        frame,
        interval,
        film,
        layout,
        image,
        denoised: None,
        stats,
    })
}

impl FrameStats {
    /// Adds a round's counts.
    fn add(&mut self, counts: &RoundCounts) {
        self.rays += counts.rays;
        self.samples += counts.samples;
        self.non_finite += counts.non_finite;
        self.tile_seconds += counts.busy_seconds;
        self.rounds += 1;
    }

    /// Fills in what a sampled `film` tells: its estimated error, its pixels' fewest, most and
    /// mean samples; and the bytes read back from its device.
    fn sampled(&mut self, film: &Film, readback_bytes: u64) {
        self.noisy_relative_error = relative_error(film);
        self.relative_error = self.noisy_relative_error;
        let taken = film.all_pixels().iter().map(Pixel::taken);
        self.samples_per_pixel = taken.clone().max().unwrap_or(0);
        self.min_samples_per_pixel = taken.min().unwrap_or(0);
        let pixels = film.width as f64 * film.height as f64;
        self.mean_samples_per_pixel = self.samples as f64 / pixels;
        self.readback_bytes = readback_bytes;
    }
}

/// Where a frame's rounds stand, and so what the next one takes: without a budget, one round
/// of the scene's samples; under one, uniform rounds that double the samples
/// ([`next_round`]) up to [`MIN_SAMPLES_FOR_THRESHOLD`] (or the cap), timed, then adaptive
/// rounds ([`plan_adaptive`]) paced by the time a pixel's sample took.
struct RoundSchedule {
    /// The scene's samples, which a frame without a budget takes.
    samples: u32,
    /// The samples every pixel has taken in the uniform rounds.
    done: u32,
    /// The samples after which rounds are adaptive.
    warm_up: u32,
    /// Seconds the last uniform round took per sample of every pixel.
    seconds_per_sample: Option<f64>,
    /// Seconds the last round took per sample of one pixel.
    seconds_per_pixel_sample: f64,
}

impl RoundSchedule {
    fn new(budget: &Budget, samples: u32) -> RoundSchedule {
        RoundSchedule {
            samples,
            done: 0,
            warm_up: MIN_SAMPLES_FOR_THRESHOLD.min(budget.max_samples.unwrap_or(u32::MAX)),
            seconds_per_sample: None,
            seconds_per_pixel_sample: f64::INFINITY,
        }
    }

    /// The next round of a frame under `budget` whose `film` is as it is after `elapsed`
    /// seconds, its pixels weighed by `weights`; `None` when a frame without a budget has its
    /// samples; why sampling stops, when the budget says.
    fn next<'w>(
        &self,
        budget: &Budget,
        film: &Film,
        weights: Weights<'w>,
        elapsed: f64,
    ) -> Result<Option<RoundPlan<'w>>, StopReason> {
        if !budget.is_set() {
            return Ok((self.done < self.samples).then_some(RoundPlan::Uniform(self.samples)));
        }
        if !self.warmed_up() {
            let size = next_round(budget, self.done, elapsed, self.seconds_per_sample)?;
            return Ok(Some(RoundPlan::Uniform(self.done + size)));
        }
        let a = plan_adaptive(
            film,
            &weights,
            budget,
            elapsed,
            self.seconds_per_pixel_sample,
        )?;
        Ok(Some(RoundPlan::Adaptive(a, weights)))
    }

    /// Records that the round `plan` took `seconds` and did `counts`.
    fn took(&mut self, plan: &RoundPlan<'_>, seconds: f64, counts: &RoundCounts) {
        if let RoundPlan::Uniform(n) = *plan {
            self.seconds_per_sample = Some(seconds / (n - self.done) as f64);
            self.done = n;
        }
        if counts.samples > 0 {
            self.seconds_per_pixel_sample = seconds / counts.samples as f64;
        }
    }

    /// Whether every pixel has its first samples, after which a noise threshold is judged and
    /// rounds are adaptive.
    fn warmed_up(&self) -> bool {
        self.done >= self.warm_up
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn a_degenerate_camera_counts_every_sample_as_black() {
        use crate::material::Material;
        use crate::motion::Motion;
        use crate::sphere::SphereDesc;
        let sphere = SphereDesc {
            motion: Motion::Velocity {
                origin: DVec3::ZERO,
                velocity: DVec3::X,
            },
            radius: 1.0,
            material: 0,
        };
        let grey = Material::Lambertian {
            albedo: DVec3::splat(0.5),
        };
        let mut scene = crate::testing::scene(vec![sphere], vec![grey]);
        (
            scene.output.width,
            scene.output.height,
            scene.render.samples,
        ) = (8, 4, 3);
        // Looking at where it stands: every camera ray's direction is NaN.
        scene.camera.look_from = Motion::Still(DVec3::new(0.0, 0.0, 5.0));
        scene.camera.look_at = scene.camera.look_from.clone();
        let frame = scene.shot.first_frame;
        let result = FrameJob::new(&scene, frame)
            .sample(&super::super::tracers::CpuShot::new(&scene))
            .unwrap();
        assert_eq!(result.stats.non_finite, 8 * 4 * 3);
        assert_eq!(result.stats.rays, 0);
        assert!(result.film.means().iter().all(|p| *p == glam::DVec3::ZERO));
    }
}
