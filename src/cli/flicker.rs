//! `converge --flicker FRAMES`: how far a sequence is from the truth and how much it
//! flickers, rendered raw, denoised frame by frame, and denoised with `--temporal`, against a
//! reference of every frame (`metrics::flicker`), every render on the scene's
//! device (`--device`). Each frame is sampled once, keeping what `--temporal` reads, and
//! finished three ways: raw, denoised, and denoised with its history.

use std::time::Instant;

use raytrace_core::image::Image;

use super::args::ConvergeArgs;
use super::frames::Selection;
use super::progress::print_line;
use raytrace_core::error::Error;
use raytrace_core::metrics::{self, FlickerSum};
use raytrace_core::renderer::{FrameJob, ShotTracer};
use raytrace_core::rng::hash_words;
use raytrace_core::scene::Scene;
use raytrace_render::devices::{Devices, supported};
use raytrace_render::finish::Finishing;
use raytrace_scene::point_cache::{self, ShotPoints};
use raytrace_scene::scene_file::{Overrides, SceneSource};

/// Samples of each frame's reference, unless --reference-samples says otherwise.
const DEFAULT_REFERENCE_SAMPLES: u32 = 1024;

/// One variant's figures over the sequence.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Variant {
    pub(crate) name: &'static str,
    /// The mean over the frames of the true relative error (less the reference's own).
    pub(crate) error: f64,
    /// The flicker of the frames: [`FlickerSum::flicker`](raytrace_core::metrics::FlickerSum::flicker).
    pub(crate) flicker: f64,
    /// Wall seconds a frame, on average.
    pub(crate) seconds: f64,
}

/// Measures the frames `spec` of the scene of `args` (see the module's notes), printing the
/// table unless --quiet; returns raw, denoised and temporal, in that order. Frames are taken
/// one at a time, their reference rendered beside them, so that a sequence of any length is
/// measured holding two frames.
pub(crate) fn measure_flicker(args: &ConvergeArgs, spec: &str) -> Result<Vec<Variant>, Error> {
    let source = SceneSource::read(&args.scene)?;
    let overrides = args.scene_args.overrides();
    let base = supported(source.scene(&overrides)?, &overrides)?;
    let shot = &base.shot;
    let bad = |why: String| Error::Usage(format!("--flicker {spec}: {why}"));
    let selection = Selection::parse(spec, shot.first_frame, shot.last_frame()).map_err(bad)?;
    if selection.len() < 2 {
        return Err(bad(
            "flicker is measured between frames: give at least two".to_string()
        ));
    }
    let samples = args.max_samples.unwrap_or(base.render.samples);
    let with = |samples: u32, seed: Option<u64>, temporal: Option<bool>| {
        source.scene(&Overrides {
            samples: Some(samples),
            seed: seed.or(overrides.seed),
            denoise: Some(true),
            temporal,
            ..overrides.clone()
        })
    };
    let scene = with(samples, None, None)?;
    let temporal = with(samples, None, Some(true))?;
    let reference_samples = args.reference_samples.unwrap_or(DEFAULT_REFERENCE_SAMPLES);
    // A seed of its own, so the references' noise is independent of the measured renders'.
    let reference_seed = hash_words(&[scene.render.seed, 0x0066_6c69_636b_6572]) >> 1;
    let reference = with(reference_samples, Some(reference_seed), None)?;
    let say = |s: &str| {
        if !args.scene_args.quiet {
            print_line(s);
        }
    };
    super::threads::thread_pool(args.scene_args.threads)?.install(|| {
        // The scene's device and the denoiser, opened before anything is measured.
        let devices = Devices::for_scenes([&scene, &temporal, &reference])?;
        say(&format!(
            "flicker: frames {spec} at {samples} samples a pixel, against references of {reference_samples}"
        ));
        let scenes = Scenes {
            denoised: &scene,
            temporal: &temporal,
            reference: &reference,
        };
        measure(scenes, &selection, &devices, &say)
    })
}

/// The scenes a flicker measurement renders.
struct Scenes<'a> {
    /// Denoised frame by frame.
    denoised: &'a Scene,
    /// The same with `--temporal`: every frame is sampled from it, keeping what history reads.
    temporal: &'a Scene,
    /// Many samples and a seed of its own.
    reference: &'a Scene,
}

/// One frame as measured: its reference, the reference's variances and its own error, and
/// the three finishes with the seconds each took.
struct Measured {
    reference: Image,
    variances: Image,
    /// The reference's own relative MSE, which the finishes' errors leave out.
    own: f64,
    images: [Image; 3],
    seconds: [f64; 3],
}

/// What a flicker measurement renders with: the scenes on their device, the two ways the
/// sampled frames are finished, and the sequence's point caches, surveyed.
struct Renders<'a> {
    scenes: Scenes<'a>,
    /// The shot of `scenes.temporal`, which every frame is sampled from.
    tracer: Box<dyn ShotTracer>,
    /// The shot of `scenes.reference`.
    reference_tracer: Box<dyn ShotTracer>,
    /// As `scenes.denoised` finishes a frame.
    denoised: Finishing<'a>,
    /// As `scenes.temporal` finishes a frame, with its history.
    history: Finishing<'a>,
    caches: ShotPoints,
}

impl<'a> Renders<'a> {
    /// The renders of `scenes` on `devices`, with the point caches of the frames of
    /// `selection` surveyed.
    fn open(
        scenes: Scenes<'a>,
        selection: &Selection,
        devices: &'a Devices,
    ) -> Result<Renders<'a>, Error> {
        let tracer = devices.shot(scenes.temporal)?;
        let reference_tracer = devices.shot(scenes.reference)?;
        let denoised = devices.finishing(scenes.denoised)?;
        let history = devices.finishing(scenes.temporal)?;
        let frames = || point_cache::Frames {
            first: selection.first().expect("two frames or more"),
            last: selection.last().expect("two frames or more"),
            each: Box::new(selection.iter()),
        };
        let caches = ShotPoints::survey(
            scenes.temporal,
            Some(frames()),
            Some(frames()),
            point_cache::SurveyDepth::Files,
        )?;
        Ok(Renders {
            scenes,
            tracer,
            reference_tracer,
            denoised,
            history,
            caches,
        })
    }

    /// `frame` sampled once, finished raw, denoised and with its history, and its reference
    /// (first, the frames before it that its history reads and has not: rendered, not
    /// measured).
    fn measure_frame(&mut self, frame: u32) -> Result<Measured, Error> {
        let Scenes {
            temporal,
            reference,
            ..
        } = self.scenes;
        for earlier in self.history.needs(frame) {
            let points = self.caches.read_frame(temporal, earlier)?;
            self.history.render(
                FrameJob::new(temporal, earlier).points(&points),
                self.tracer.as_ref(),
            )?;
        }
        let points = self.caches.read_frame(temporal, frame)?;
        // Sampled and not finished: a reference is the raw frame.
        let r = FrameJob::new(reference, frame)
            .points(&points)
            .sample(self.reference_tracer.as_ref())?;
        let start = Instant::now();
        let raw = FrameJob::new(temporal, frame)
            .points(&points)
            .reading(self.history.passes_read())
            .sample(self.tracer.as_ref())?;
        let sampled = start.elapsed().as_secs_f64();
        let mut seconds = [sampled, 0.0, 0.0];
        let mut finished = Vec::with_capacity(2);
        for finishing in [&mut self.denoised, &mut self.history] {
            let start = Instant::now();
            let result = finishing.finish(raw.clone())?;
            seconds[finished.len() + 1] = sampled + start.elapsed().as_secs_f64();
            finished.push(result.image);
        }
        let [denoised_image, history_image]: [Image; 2] =
            finished.try_into().expect("two finishes");
        Ok(Measured {
            own: r.stats.relative_error.powi(2),
            variances: r.film.variances(),
            reference: r.image,
            images: [raw.image, denoised_image, history_image],
            seconds,
        })
    }
}

/// The three finishes' sums over the frames measured so far, raw, denoised and temporal in
/// that order.
#[derive(Default)]
struct Sums {
    seconds: [f64; 3],
    errors: [f64; 3],
    flicker: [FlickerSum; 3],
}

impl Sums {
    /// Adds frame `now`: its seconds, its true errors (less its reference's own), and its
    /// flicker from the frame measured before it, `last`.
    fn add(&mut self, now: &Measured, last: Option<&Measured>) {
        for k in 0..3 {
            self.seconds[k] += now.seconds[k];
            self.errors[k] += (metrics::rel_mse(&now.images[k], &now.reference) - now.own)
                .max(0.0)
                .sqrt();
            if let Some(before) = last {
                self.flicker[k].add(
                    (&before.images[k], &before.reference, &before.variances),
                    (&now.images[k], &now.reference, &now.variances),
                );
            }
        }
    }

    /// The variants' figures: the means over `frames` frames, and the flicker.
    fn variants(&self, frames: u64) -> Vec<Variant> {
        let names = ["raw", "denoised", "denoised --temporal"];
        let n = frames as f64;
        (0..3)
            .map(|k| Variant {
                name: names[k],
                error: self.errors[k] / n,
                flicker: self.flicker[k].flicker(),
                seconds: self.seconds[k] / n,
            })
            .collect()
    }
}

/// Renders the frames of `selection`, each sampled once from `scenes.temporal`, and measures
/// them finished raw, as `scenes.denoised` finishes them and as `scenes.temporal` does,
/// against a reference of each.
fn measure(
    scenes: Scenes<'_>,
    selection: &Selection,
    devices: &Devices,
    say: &dyn Fn(&str),
) -> Result<Vec<Variant>, Error> {
    let mut renders = Renders::open(scenes, selection, devices)?;
    let mut sums = Sums::default();
    let mut last: Option<Measured> = None;
    for frame in selection.iter() {
        let now = renders.measure_frame(frame)?;
        sums.add(&now, last.as_ref());
        last = Some(now);
    }
    say(&format!(
        "{:<22} {:>11} {:>9} {:>14}",
        "", "rel. error", "flicker", "seconds/frame"
    ));
    let variants = sums.variants(selection.len());
    for v in &variants {
        say(&format!(
            "{:<22} {:>10.3}% {:>8.3}% {:>14.3}",
            v.name,
            100.0 * v.error,
            100.0 * v.flicker,
            v.seconds
        ));
    }
    Ok(variants)
}
