//! `converge --flicker FRAMES`: how far a sequence is from the truth and how much it
//! flickers, by each route a clip can be finished by ([`Route`]), against a reference of
//! every frame (`metrics::flicker`), every render on the scene's device (`--device`). Each
//! frame is sampled once with each sample pattern, keeping what history reads, and finished
//! by every route of that pattern; with `--seeds K` the whole is repeated with K seeds (the
//! references are shared) and every figure is given as its mean and its spread over them.
//! With `--thresholds E` every frame is sampled to the noise threshold `E` instead (up to
//! `--max-samples`, else 65536 samples a pixel), each route's frame stopped by its own
//! written frame's estimate as `render --noise-threshold E` stops it, so each route samples
//! a frame of its own. The `--temporal` route's frames state their flicker without
//! references (`raytrace_denoise::change`), given beside the measured one.

use std::time::Instant;

use raytrace_core::image::Image;

use super::args::{BudgetArgs, ConvergeArgs};
use super::frames::Selection;
use super::jobs::survey_frames;
use super::progress::print_line;
use super::seeds::{DEFAULT_SEEDS, measured_seeds};
use raytrace_core::error::Error;
use raytrace_core::metrics::{self, FlickerSum};
use raytrace_core::renderer::{Budget, FrameJob, FrameResult, ShotTracer};
use raytrace_core::rng::hash_words;
use raytrace_core::sampler::SamplePattern;
use raytrace_core::scene::{Carry, Scene};
use raytrace_denoise::change;
use raytrace_render::devices::{Devices, room_for_points, supported};
use raytrace_render::finish::Finishing;
use raytrace_scene::point_cache::{self, ShotPoints};
use raytrace_scene::scene_file::{Overrides, SceneSource};

/// Samples of each frame's reference, unless --reference-samples says otherwise.
const DEFAULT_REFERENCE_SAMPLES: u32 = 1024;

/// A way of making a clip's frames: a sample pattern and the stages that finish a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Route {
    /// New samples every frame, not denoised.
    Raw,
    /// New samples every frame, each frame denoised alone (`--denoise`).
    Denoised,
    /// New samples every frame, denoised and combined with the two frames before it
    /// (`Carry::Written`).
    History,
    /// The same sample points every frame, denoised and combined with the two frames before
    /// it.
    StableHistory,
    /// The same sample points every frame, each frame denoised alone: `--temporal`.
    Temporal,
    /// New samples every frame, each frame's raw film pooled with the two frames' before it
    /// where they agree, then denoised (`Carry::Raw`).
    Accumulated,
    /// New samples every frame, denoised and combined with the frame before it and the frame
    /// after it (`Carry::Centred`).
    Centred,
    /// The same sample points every frame, denoised and combined with the frame before it
    /// and the frame after it.
    StableCentred,
}

/// How many routes [`Route::ALL`] lists.
const ROUTES: usize = 8;

/// How many scenes a seed's routes are rendered and finished with ([`SeedRenders::scenes`]).
const SCENES: usize = 5;

impl Route {
    /// Every route, in the order the table lists them.
    pub(crate) const ALL: [Route; ROUTES] = [
        Route::Raw,
        Route::Denoised,
        Route::History,
        Route::StableHistory,
        Route::Temporal,
        Route::Accumulated,
        Route::Centred,
        Route::StableCentred,
    ];

    /// The route's name in the table.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Route::Raw => "raw",
            Route::Denoised => "denoised",
            Route::History => "history",
            Route::StableHistory => "stable + history",
            Route::Temporal => "--temporal",
            Route::Accumulated => "accumulated",
            Route::Centred => "centred",
            Route::StableCentred => "stable + centred",
        }
    }

    /// The sample pattern the route's frames are sampled with.
    fn pattern(self) -> SamplePattern {
        match self {
            Route::Raw | Route::Denoised | Route::History | Route::Accumulated | Route::Centred => {
                SamplePattern::PerFrame
            }
            Route::StableHistory | Route::Temporal | Route::StableCentred => SamplePattern::Stable,
        }
    }

    /// Which of a seed's scenes ([`SeedRenders::scenes`]) gives the route's finishing.
    fn finishing_scene(self) -> usize {
        match self {
            Route::History | Route::StableHistory => 2,
            Route::Accumulated => 3,
            Route::Centred | Route::StableCentred => 4,
            // `--temporal`'s own, whose frames state their flicker.
            Route::Temporal => 1,
            _ => 0,
        }
    }
}

/// One route's figures over the sequence: means over the seeds, and their spread.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Variant {
    pub(crate) route: Route,
    /// The mean over the frames of the true relative error (less the reference's own).
    pub(crate) error: Spread,
    /// The flicker of the frames: [`FlickerSum::flicker`](raytrace_core::metrics::FlickerSum::flicker).
    pub(crate) flicker: Spread,
    /// The flicker the frames state, without references (`raytrace_denoise::change`), for
    /// the route whose frames state it (`--temporal`).
    pub(crate) stated_flicker: Option<Spread>,
    /// Wall seconds a frame, on average: its sampling and its finishing.
    pub(crate) seconds: f64,
}

/// A figure's mean over the seeds and its sample standard deviation (0 with one seed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Spread {
    pub(crate) mean: f64,
    pub(crate) sd: f64,
}

impl Spread {
    fn of(values: impl Iterator<Item = f64> + Clone) -> Spread {
        let n = values.clone().count() as f64;
        let mean = values.clone().sum::<f64>() / n;
        let squares: f64 = values.map(|v| (v - mean).powi(2)).sum();
        let sd = if n > 1.0 {
            (squares / (n - 1.0)).sqrt()
        } else {
            0.0
        };
        Spread { mean, sd }
    }
}

/// Measures the frames `spec` of the scene of `args` (see the module's notes), printing the
/// table unless --quiet; returns the routes' figures in [`Route::ALL`]'s order. Frames are
/// taken one at a time, their reference rendered beside them, so that a sequence of any
/// length is measured holding two frames a seed.
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
    let budget = match args.thresholds[..] {
        [] => Budget::default(),
        // `render --noise-threshold E --max-samples N`'s budget, by its own rule.
        [e] => BudgetArgs {
            time_limit: None,
            noise_threshold: Some(e),
            max_samples: args.max_samples,
        }
        .budget(),
        _ => {
            return Err(bad(
                "give one noise threshold (--thresholds E) at a time".to_string()
            ));
        }
    };
    let with = |samples: u32, seed: u64, temporal: bool| {
        source.scene(&Overrides {
            samples: Some(samples),
            seed: Some(seed),
            denoise: Some(true),
            temporal: Some(temporal),
            ..overrides.clone()
        })
    };
    let seeds = measured_seeds(&base, args.seeds.unwrap_or(DEFAULT_SEEDS) as usize);
    // Per seed, the scene of each pattern, per frame (--denoise) and stable (--temporal),
    // and one for each way of carrying other frames ([`Route::finishing_scene`]).
    let scenes = seeds
        .iter()
        .map(|&seed| {
            let denoised = with(samples, seed, false)?;
            let carrying = |carry: Carry| {
                let mut scene = denoised.clone();
                if let Some(d) = &mut scene.output.denoise {
                    d.carry = carry;
                }
                scene
            };
            Ok([
                carrying(Carry::Nothing),
                with(samples, seed, true)?,
                carrying(Carry::Written),
                carrying(Carry::Raw),
                carrying(Carry::Centred),
            ])
        })
        .collect::<Result<Vec<[Scene; SCENES]>, Error>>()?;
    let reference_samples = args.reference_samples.unwrap_or(DEFAULT_REFERENCE_SAMPLES);
    // A seed of its own, so the references' noise is independent of the measured renders'.
    let reference_seed = hash_words(&[base.render.seed, 0x0066_6c69_636b_6572]) >> 1;
    let reference = with(reference_samples, reference_seed, false)?;
    let say = |s: &str| {
        if !args.scene_args.quiet {
            print_line(s);
        }
    };
    // The frames' point caches surveyed, and on the GPU the room for their most points
    // checked, before anything is opened.
    let caches = ShotPoints::survey(
        &scenes[0][1],
        survey_frames(&selection),
        survey_frames(&selection),
        point_cache::SurveyDepth::Files,
    )?;
    room_for_points(&base, &overrides, caches.most().points)?;
    super::threads::thread_pool(args.scene_args.threads)?.install(|| {
        // The scene's device and the denoiser, opened before anything is measured.
        let devices = Devices::for_scenes(scenes.iter().flatten().chain([&reference]))?;
        let sampled = match budget.noise_threshold {
            Some(e) => format!(
                "to a noise threshold of {e} (at most {} samples a pixel)",
                budget.max_samples.unwrap_or(u32::MAX)
            ),
            None => format!("at {samples} samples a pixel"),
        };
        say(&format!(
            "flicker: frames {spec} {sampled}, {} seed{}, against references of {reference_samples}",
            seeds.len(),
            if seeds.len() == 1 { "" } else { "s" }
        ));
        measure(&scenes, budget, &reference, (&selection, caches), &devices, &say)
    })
}

/// One seed's renders: a tracer and a scene for each sample pattern, and each route's
/// finishing.
struct SeedRenders<'a> {
    /// The scenes of [`SamplePattern::PerFrame`] (`--denoise`), [`SamplePattern::Stable`]
    /// (`--temporal`), then those that carry other frames, with history (which finishes
    /// the routes with history), accumulation and a centred window, in that order
    /// ([`Route::finishing_scene`]).
    scenes: &'a [Scene; SCENES],
    tracers: [Box<dyn ShotTracer>; 2],
    /// Each route's finishing, in [`Route::ALL`]'s order (`None` for the raw route).
    finishings: Vec<Option<Finishing<'a>>>,
    /// When a frame stops sampling: at the scenes' samples, or at a noise threshold.
    budget: Budget,
}

/// Index of a pattern's scene and tracer.
fn slot(pattern: SamplePattern) -> usize {
    match pattern {
        SamplePattern::PerFrame => 0,
        SamplePattern::Stable => 1,
    }
}

impl<'a> SeedRenders<'a> {
    fn open(
        scenes: &'a [Scene; SCENES],
        budget: Budget,
        devices: &'a Devices,
    ) -> Result<SeedRenders<'a>, Error> {
        let finishings = Route::ALL
            .iter()
            .map(|route| match route {
                Route::Raw => Ok(None),
                // Which pattern a frame was sampled with is the route's; the stages are the
                // scene's.
                r => devices.finishing(&scenes[r.finishing_scene()]).map(Some),
            })
            .collect::<Result<_, Error>>()?;
        Ok(SeedRenders {
            scenes,
            tracers: [devices.shot(&scenes[0])?, devices.shot(&scenes[1])?],
            finishings,
            budget,
        })
    }

    /// `frame`'s job with `pattern`, under the budget, keeping what history reads.
    fn job<'j>(
        &self,
        pattern: SamplePattern,
        frame: u32,
        points: &'j raytrace_core::points::FramePoints,
    ) -> FrameJob<'j>
    where
        'a: 'j,
    {
        // The job borrows the scenes, not `self`, whose finishing then finishes it.
        let scenes: &'a [Scene; SCENES] = self.scenes;
        let read = raytrace_render::finish::passes_read(&scenes[2]);
        FrameJob::new(&scenes[slot(pattern)], frame)
            .points(points)
            .reading(read)
            .budget(self.budget)
    }

    /// `frame` sampled and finished by route `r` alone, stopped (under a noise threshold) by
    /// its own written frame's estimate.
    fn render(
        &mut self,
        r: usize,
        frame: u32,
        points: &raytrace_core::points::FramePoints,
    ) -> Result<FrameResult, Error> {
        let pattern = Route::ALL[r].pattern();
        let job = self.job(pattern, frame, points);
        let tracer = self.tracers[slot(pattern)].as_ref();
        match &mut self.finishings[r] {
            None => job.sample(tracer),
            Some(f) => f.render(job, tracer),
        }
    }

    /// `frame` finished by every route, with each route's seconds (first, the frames before
    /// it that a route's history reads and has not, and the frame after it that a centred
    /// window reads: rendered, not measured). At the scenes' samples, the frame is sampled
    /// once with each pattern and the routes of a pattern finish the same samples; under a
    /// noise threshold, each route samples its own.
    fn measure(&mut self, frame: u32, caches: &mut ShotPoints) -> Result<Measured, Error> {
        for r in 0..ROUTES {
            let Some(finishing) = &self.finishings[r] else {
                continue;
            };
            let (needs, ahead) = (finishing.needs(frame), finishing.ahead(frame));
            for earlier in needs {
                let points = caches.read_frame(&self.scenes[1], earlier)?;
                self.render(r, earlier, &points)?;
            }
            if let Some(next) = ahead {
                let points = caches.read_frame(&self.scenes[1], next)?;
                let pattern = Route::ALL[r].pattern();
                let job = self.job(pattern, next, &points);
                let tracer = self.tracers[slot(pattern)].as_ref();
                if let Some(f) = &mut self.finishings[r] {
                    f.render_ahead(job, tracer)?;
                }
            }
        }
        let points = caches.read_frame(&self.scenes[1], frame)?;
        let mut results = Vec::with_capacity(ROUTES);
        let mut seconds = [0.0; ROUTES];
        if self.budget.is_set() {
            for (r, s) in seconds.iter_mut().enumerate() {
                let start = Instant::now();
                results.push(self.render(r, frame, &points)?);
                *s = start.elapsed().as_secs_f64();
            }
        } else {
            let mut sampled = Vec::with_capacity(2);
            for pattern in [SamplePattern::PerFrame, SamplePattern::Stable] {
                let start = Instant::now();
                let tracer = self.tracers[slot(pattern)].as_ref();
                let raw = self.job(pattern, frame, &points).sample(tracer)?;
                sampled.push((raw, start.elapsed().as_secs_f64()));
            }
            for (r, route) in Route::ALL.into_iter().enumerate() {
                let (raw, sampling) = &sampled[slot(route.pattern())];
                let start = Instant::now();
                results.push(match &mut self.finishings[r] {
                    None => raw.clone(),
                    Some(f) => f.finish(raw.clone())?,
                });
                seconds[r] = sampling + start.elapsed().as_secs_f64();
            }
        }
        let changes = std::array::from_fn(|r| results[r].denoised.and_then(|d| d.change));
        let images = results.into_iter().map(|r| r.image).collect::<Vec<_>>();
        Ok(Measured {
            images: images.try_into().expect("an image a route"),
            seconds,
            changes,
        })
    }
}

/// A frame's reference: its colour, its pixels' variances and its own relative MSE, which
/// the routes' errors leave out.
struct Reference {
    image: Image,
    variances: Image,
    own: f64,
}

/// One seed's frame as measured: every route's image, its seconds, and the change of its
/// error from the frame before that it states, where it states one.
struct Measured {
    images: [Image; ROUTES],
    seconds: [f64; ROUTES],
    changes: [Option<f64>; ROUTES],
}

/// One seed's sums over the frames measured so far, a route at a time.
#[derive(Default)]
struct Sums {
    seconds: [f64; ROUTES],
    errors: [f64; ROUTES],
    flicker: [FlickerSum; ROUTES],
    /// Each route's stated changes of the error from one frame to the next.
    changes: [Vec<f64>; ROUTES],
}

impl Sums {
    /// Adds frame `now` of reference `reference`: its seconds, its true errors (less the
    /// reference's own), and its flicker from the frame measured before it, `last`.
    fn add(&mut self, now: (&Measured, &Reference), last: Option<(&Measured, &Reference)>) {
        let (m, r) = now;
        for k in 0..Route::ALL.len() {
            self.seconds[k] += m.seconds[k];
            self.changes[k].extend(m.changes[k]);
            self.errors[k] += (metrics::rel_mse(&m.images[k], &r.image) - r.own)
                .max(0.0)
                .sqrt();
            if let Some((bm, br)) = last {
                self.flicker[k].add(
                    (&bm.images[k], &br.image, &br.variances),
                    (&m.images[k], &r.image, &r.variances),
                );
            }
        }
    }
}

/// The routes' figures from every seed's sums over `frames` frames.
fn variants(sums: &[Sums], frames: u64) -> Vec<Variant> {
    let n = frames as f64;
    Route::ALL
        .into_iter()
        .enumerate()
        .map(|(k, route)| Variant {
            route,
            error: Spread::of(sums.iter().map(move |s| s.errors[k] / n)),
            flicker: Spread::of(sums.iter().map(move |s| s.flicker[k].flicker())),
            // Stated where every seed's every pair of frames states it.
            stated_flicker: sums
                .iter()
                .all(|s| s.changes[k].len() as u64 + 1 == frames)
                .then(|| {
                    Spread::of(sums.iter().map(move |s| {
                        let pairs = &s.changes[k];
                        change::flicker(pairs.iter().sum::<f64>() / pairs.len() as f64)
                    }))
                }),
            seconds: sums.iter().map(|s| s.seconds[k] / n).sum::<f64>() / sums.len() as f64,
        })
        .collect()
}

/// Renders the frames of `selection` with every seed's scenes, and measures every route
/// against a reference of each frame rendered from `reference`; the frames' points are read
/// from `caches`, surveyed over `selection`.
fn measure(
    scenes: &[[Scene; SCENES]],
    budget: Budget,
    reference: &Scene,
    (selection, mut caches): (&Selection, ShotPoints),
    devices: &Devices,
    say: &dyn Fn(&str),
) -> Result<Vec<Variant>, Error> {
    let reference_tracer = devices.shot(reference)?;
    let mut renders = scenes
        .iter()
        .map(|s| SeedRenders::open(s, budget, devices))
        .collect::<Result<Vec<_>, Error>>()?;
    let mut sums: Vec<Sums> = scenes.iter().map(|_| Sums::default()).collect();
    let mut last: Option<(Vec<Measured>, Reference)> = None;
    for frame in selection.iter() {
        let points = caches.read_frame(reference, frame)?;
        // Sampled and not finished: a reference is the raw frame.
        let r = FrameJob::new(reference, frame)
            .points(&points)
            .sample(reference_tracer.as_ref())?;
        drop(points);
        let now_ref = Reference {
            own: r.stats.relative_error.powi(2),
            variances: r.film.variances(),
            image: r.image,
        };
        let mut now = Vec::with_capacity(renders.len());
        for (s, seed) in renders.iter_mut().enumerate() {
            let m = seed.measure(frame, &mut caches)?;
            sums[s].add((&m, &now_ref), last.as_ref().map(|(ms, lr)| (&ms[s], lr)));
            now.push(m);
        }
        last = Some((now, now_ref));
    }
    say(&format!(
        "{:<16} {:>19} {:>19} {:>19} {:>14}",
        "", "rel. error (sd)", "flicker (sd)", "stated (sd)", "seconds/frame"
    ));
    let variants = variants(&sums, selection.len());
    let cell = |s: Spread| format!("{:>9.3}% ({:.3}%)", 100.0 * s.mean, 100.0 * s.sd);
    for v in &variants {
        say(&format!(
            "{:<16} {} {} {:>19} {:>14.3}",
            v.route.name(),
            cell(v.error),
            cell(v.flicker),
            v.stated_flicker.map_or("-".to_string(), cell),
            v.seconds
        ));
    }
    Ok(variants)
}
