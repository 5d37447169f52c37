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
use raytrace_core::renderer::FrameJob;
use raytrace_core::rng::hash_words;
use raytrace_core::scene::Scene;
use raytrace_render::devices::{Devices, supported};
use raytrace_scene::point_cache;
use raytrace_scene::scene_file::{Overrides, SceneSource};

/// Samples of each frame's reference, unless --reference-samples says otherwise.
const DEFAULT_REFERENCE_SAMPLES: u32 = 1024;

/// One variant's figures over the sequence.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Variant {
    pub(crate) name: &'static str,
    /// The mean over the frames of the true relative error (less the reference's own).
    pub(crate) error: f64,
    /// [`metrics::flicker`].
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

/// One frame as measured: its reference, the reference's variances, and the three finishes.
struct Measured {
    reference: Image,
    variances: Image,
    images: [Image; 3],
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
    let Scenes {
        denoised: scene,
        temporal,
        reference,
    } = scenes;
    let tracer = devices.shot(temporal)?;
    let reference_tracer = devices.shot(reference)?;
    let mut denoised = devices.finishing(scene)?;
    let mut history = devices.finishing(temporal)?;
    let frames = || point_cache::Frames {
        first: selection.first().expect("two frames or more"),
        last: selection.last().expect("two frames or more"),
        each: Box::new(selection.iter()),
    };
    let caches = point_cache::ShotPoints::survey(
        temporal,
        Some(frames()),
        Some(frames()),
        point_cache::Depth::Files,
    )?;
    let mut seconds = [0.0; 3];
    let mut errors = [0.0; 3];
    let mut flicker = [FlickerSum::default(); 3];
    let mut last: Option<Measured> = None;
    for frame in selection.iter() {
        // The frames before the first that its history reads: rendered, not measured.
        for earlier in history.needs(frame) {
            let points = caches.read_frame(temporal, earlier)?;
            history.render(
                FrameJob::new(temporal, earlier).points(&points),
                tracer.as_ref(),
            )?;
        }
        let points = caches.read_frame(temporal, frame)?;
        // Sampled and not finished: a reference is the raw frame.
        let r = FrameJob::new(reference, frame)
            .points(&points)
            .sample(reference_tracer.as_ref())?;
        let own = r.stats.relative_error.powi(2);
        let start = Instant::now();
        let raw = FrameJob::new(temporal, frame)
            .points(&points)
            .reading(history.passes_read())
            .sample(tracer.as_ref())?;
        let sampled = start.elapsed().as_secs_f64();
        seconds[0] += sampled;
        let mut finished = Vec::with_capacity(2);
        for finishing in [&mut denoised, &mut history] {
            let start = Instant::now();
            let result = finishing.finish(raw.clone())?;
            seconds[finished.len() + 1] += sampled + start.elapsed().as_secs_f64();
            finished.push(result.image);
        }
        let [denoised_image, history_image]: [Image; 2] =
            finished.try_into().expect("two finishes");
        let now = Measured {
            variances: r.film.variances(),
            reference: r.image,
            images: [raw.image, denoised_image, history_image],
        };
        for k in 0..3 {
            errors[k] += (metrics::rel_mse(&now.images[k], &now.reference) - own)
                .max(0.0)
                .sqrt();
            if let Some(before) = &last {
                flicker[k].add(
                    (&before.images[k], &before.reference, &before.variances),
                    (&now.images[k], &now.reference, &now.variances),
                );
            }
        }
        last = Some(now);
    }
    let names = ["raw", "denoised", "denoised --temporal"];
    say(&format!(
        "{:<22} {:>11} {:>9} {:>14}",
        "", "rel. error", "flicker", "seconds/frame"
    ));
    let n = selection.len() as f64;
    let variants: Vec<Variant> = (0..3)
        .map(|k| Variant {
            name: names[k],
            error: errors[k] / n,
            flicker: flicker[k].flicker(),
            seconds: seconds[k] / n,
        })
        .collect();
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
