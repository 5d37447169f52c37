//! One frame: its world and camera prepared for the frame's interval, then rounds of samples
//! over the film's tiles until the requested samples are taken or the budget stops it.

use std::time::Instant;

use super::adaptive::{Plan, Weights, plan_adaptive};
use super::budget::{Budget, MIN_SAMPLES_FOR_THRESHOLD, StopReason, next_round};
use super::denoised::{self, Denoised};
use super::device::{FrameError, On, Rounds, ShotGeometry};
use super::tiles::FrameRequest;
use crate::denoise::denoiser::Denoiser;
use crate::error::Error;
use crate::film::{Film, Pixel};
use crate::passes::{Layout, PassImages};
use crate::points::FramePoints;
use crate::prepared::PreparedFrame;
use crate::scene::Scene;
use crate::shutter::Interval;
use crate::world::StaticGeometry;

/// Figures of one rendered frame.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    /// Seconds spent preparing the frame's world (motion bounds, hierarchy build).
    pub prepare_seconds: f64,
    /// Seconds spent tracing.
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
    /// The relative error estimated from the pixels' replicates ([`relative_error`]): the
    /// square root of the estimated relative mean squared error. Infinite with fewer than two
    /// samples per pixel. Of the denoised frame, bias included, when the frame is denoised.
    pub relative_error: f64,
    /// The raw (noisy) frame's estimated relative error: [`relative_error`](Self::relative_error)
    /// before denoising.
    pub noisy_relative_error: f64,
    /// Seconds spent denoising (every run of the denoiser, estimates included), within
    /// [`render_seconds`](Self::render_seconds).
    pub denoise_seconds: f64,
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
    /// the scene's `[output] passes`, if it asks for any, and of the denoiser's guides.
    pub film: Film,
    /// Where the film keeps which pass sums.
    pub layout: Layout,
    /// The denoised frame, when the scene asks for denoising.
    pub denoised: Option<Denoised>,
    pub stats: FrameStats,
}

impl FrameResult {
    /// The images of the frame's passes, made from the film's sums, if it has any.
    pub fn pass_images(&self) -> Option<PassImages> {
        (!self.layout.passes().is_empty()).then(|| PassImages::from_film(&self.layout, &self.film))
    }
}

/// Renders frame `frame` of `scene` with the scene's settings (`[output]` size, `[render]`
/// samples, depth, seed and sampler): exactly its samples in every pixel, in one round, when
/// `budget` is not set; else in rounds until the budget stops it. `progress` is called with
/// the number of samples of each finished tile, from worker threads. Runs on the current rayon
/// pool.
///
/// Under a budget, every pixel first takes the same samples, in rounds that double them
/// ([`next_round`]), up to [`MIN_SAMPLES_FOR_THRESHOLD`]; then rounds are adaptive: each pixel
/// doubles its samples or stops by its own estimated error ([`Adaptive`]), until the frame's
/// estimate meets the noise threshold, the time runs out or no pixel may take more.
///
/// Sample `i` of a pixel is the same whichever round takes it, and each pixel's mean is the
/// plain sum of its samples over their count: a pixel that stopped at N samples is
/// bit-identical to the same pixel rendered with exactly N samples.
///
/// The frame is not denoised, whatever `[output] denoise` says: see [`render_frame_denoised`].
/// The scene's point caches are not read here (reading files is not the frame's business):
/// a scene with `[[points]]` renders through [`render_frame_with`], given the frame's points.
pub fn render_frame(
    scene: &Scene,
    statics: &StaticGeometry,
    frame: u32,
    budget: &Budget,
    progress: &(dyn Fn(u64) + Sync),
) -> FrameResult {
    render_frame_with(
        scene,
        statics,
        &FramePoints::none(),
        frame,
        budget,
        progress,
    )
}

/// [`render_frame`] with `points`, the frame's points of the scene's point caches (as
/// `point_cache::read_frame` reads them), among its spheres.
pub fn render_frame_with(
    scene: &Scene,
    statics: &StaticGeometry,
    points: &FramePoints,
    frame: u32,
    budget: &Budget,
    progress: &(dyn Fn(u64) + Sync),
) -> FrameResult {
    match render(
        scene,
        On::Cpu(statics),
        points,
        frame,
        budget,
        Denoising::Off,
        progress,
    ) {
        Ok(result) => result,
        Err(_) => unreachable!("a frame on the CPU without a denoiser cannot fail"),
    }
}

/// [`render_frame`], and the frame denoised by `denoiser` ([`FrameResult::denoised`]) with its
/// estimated error, bias included, as the frame's [`FrameStats::relative_error`]. Under a
/// noise threshold, sampling stops when the *denoised* estimate meets it, and the adaptive
/// rounds send samples where the denoised frame's estimated error is largest. The raw film
/// and its passes are the same bits as [`render_frame`]'s at the same sample counts.
/// `points`: the frame's points, as for [`render_frame_with`].
pub fn render_frame_denoised(
    scene: &Scene,
    statics: &StaticGeometry,
    points: &FramePoints,
    frame: u32,
    budget: &Budget,
    denoiser: &Denoiser,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<FrameResult, Error> {
    render(
        scene,
        On::Cpu(statics),
        points,
        frame,
        budget,
        Denoising::Frame(denoiser),
        progress,
    )
    .map_err(|e| frame_failed(frame, e))
}

/// [`render_frame`] or [`render_frame_denoised`] on the device `geometry` was made for (the
/// scene's `[render] device`): the same rounds, budgets and film either way, the samples
/// traced by the CPU's threads or by the GPU. A GPU that fails mid-frame (lost, out of
/// memory) is an [`Error::Resource`] naming the frame, and nothing of the frame is kept.
/// The scene's point caches are not read: see [`render_shot_frame_with`].
pub fn render_shot_frame(
    scene: &Scene,
    geometry: &ShotGeometry,
    frame: u32,
    budget: &Budget,
    denoiser: Option<&Denoiser>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<FrameResult, Error> {
    render_shot_frame_with(
        scene,
        geometry,
        &FramePoints::none(),
        frame,
        budget,
        denoiser,
        progress,
    )
}

/// [`render_shot_frame`] with `points`, the frame's points, as for [`render_frame_with`]. The
/// GPU renders no point caches (a scene with `[[points]]` is refused for it when validated,
/// and by [`ShotGeometry::new`]): on the GPU, points are an error.
pub fn render_shot_frame_with(
    scene: &Scene,
    geometry: &ShotGeometry,
    points: &FramePoints,
    frame: u32,
    budget: &Budget,
    denoiser: Option<&Denoiser>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<FrameResult, Error> {
    let denoising = match denoiser {
        Some(d) => Denoising::Frame(d),
        None => Denoising::Off,
    };
    render(
        scene,
        geometry.on(),
        points,
        frame,
        budget,
        denoising,
        progress,
    )
    .map_err(|e| frame_failed(frame, e))
}

/// The error of a frame that failed: its denoising, or its device.
pub(super) fn frame_failed(frame: u32, e: FrameError) -> Error {
    Error::Resource(format!("frame {frame}: {e}"))
}

/// How a frame is denoised.
#[derive(Clone, Copy)]
pub(super) enum Denoising<'d> {
    /// Not at all.
    Off,
    /// On its own.
    Frame(&'d Denoiser),
    /// With the frames before it, by the caller (`renderer::temporal`): the film keeps what
    /// carries its pixels to earlier frames (depth, normal, motion), and the finished frame is
    /// left undenoised (the rounds under a noise threshold still decide by the frame denoised
    /// on its own).
    Temporal(&'d Denoiser),
}

pub(super) fn render(
    scene: &Scene,
    on: On<'_>,
    points: &FramePoints,
    frame: u32,
    budget: &Budget,
    denoising: Denoising<'_>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<FrameResult, FrameError> {
    let denoiser = match denoising {
        Denoising::Off => None,
        Denoising::Frame(d) | Denoising::Temporal(d) => Some(d),
    };
    let frame_start = Instant::now();
    let req = &FrameRequest::from_scene(scene);
    let layout = match denoiser {
        Some(_) => Layout::for_denoising(
            scene.output.passes,
            matches!(denoising, Denoising::Temporal(_)),
        ),
        None => Layout::new(scene.output.passes),
    };
    // One prepared frame, whichever device traces it.
    let prepared = PreparedFrame::new(scene, on.statics(), points, frame);
    let interval = prepared.interval();
    let mut rounds = Rounds::new(on, prepared, points, req, &layout)?;
    let prepare_seconds = frame_start.elapsed().as_secs_f64();

    let render_start = Instant::now();
    let mut film = Film::with_pass_sums(req.width, req.height, layout.stride);
    let pixels = req.width as f64 * req.height as f64;

    let mut stats = FrameStats {
        prepare_seconds,
        moving_spheres: rounds.moving(),
        ..FrameStats::default()
    };

    // Samples every pixel has taken in the uniform rounds.
    let mut done = 0u32;
    // Seconds a round took per sample of every pixel, and per sample of one pixel.
    let mut seconds_per_sample = None;
    let mut seconds_per_pixel_sample = f64::INFINITY;
    let warm_up = MIN_SAMPLES_FOR_THRESHOLD.min(budget.max_samples.unwrap_or(u32::MAX));
    // The denoised frame of the last round, when it was denoised to decide.
    let mut denoised: Option<Denoised> = None;
    let mut weights: Vec<f64>;
    loop {
        let plan = if !budget.is_set() {
            if done >= req.samples {
                break;
            }
            Plan::Uniform(req.samples)
        } else if done < warm_up {
            match next_round(
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
            let w = match &denoised {
                Some(d) => {
                    weights = d.weights(&film);
                    Weights::Denoised {
                        width: film.width,
                        values: &weights,
                    }
                }
                None => Weights::Raw,
            };
            match plan_adaptive(
                &film,
                &w,
                budget,
                frame_start.elapsed().as_secs_f64(),
                seconds_per_pixel_sample,
            ) {
                Ok(a) => Plan::Adaptive(a, w),
                Err(reason) => {
                    stats.stop = reason;
                    break;
                }
            }
        };
        let round_start = Instant::now();
        let counts = rounds.round(&mut film, &plan, progress)?;
        let seconds = round_start.elapsed().as_secs_f64();
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
        stats.rounds += 1;
        denoised = None;
        if let Some(threshold) = budget.noise_threshold
            && done >= warm_up
        {
            let error = match denoiser {
                Some(d) => {
                    let start = Instant::now();
                    let made = denoised::denoise(&film, &layout, d)?;
                    stats.denoise_seconds += start.elapsed().as_secs_f64();
                    let error = made.relative_error;
                    denoised = Some(made);
                    error
                }
                None => relative_error(&film),
            };
            if error <= threshold {
                stats.stop = StopReason::NoiseThreshold;
                break;
            }
        }
    }

    stats.noisy_relative_error = relative_error(&film);
    stats.relative_error = stats.noisy_relative_error;
    if let Denoising::Frame(d) = denoising {
        let made = match denoised {
            // The last round's film, denoised to decide to stop.
            Some(made) if stats.stop == StopReason::NoiseThreshold => made,
            _ => {
                let start = Instant::now();
                let made = denoised::denoise(&film, &layout, d)?;
                stats.denoise_seconds += start.elapsed().as_secs_f64();
                made
            }
        };
        stats.relative_error = made.relative_error;
        denoised = Some(made);
    } else {
        // Denoised by the caller, with the frames before it.
        denoised = None;
    }
    let taken = film.all_pixels().iter().map(Pixel::taken);
    stats.samples_per_pixel = taken.clone().max().unwrap_or(0);
    stats.min_samples_per_pixel = taken.min().unwrap_or(0);
    stats.mean_samples_per_pixel = stats.samples as f64 / pixels;
    stats.readback_bytes = rounds.readback_bytes();
    stats.render_seconds = render_start.elapsed().as_secs_f64();
    Ok(FrameResult {
        frame,
        interval,
        film,
        layout,
        denoised,
        stats,
    })
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
        assert!(result.film.means().iter().all(|p| *p == glam::DVec3::ZERO));
    }
}
