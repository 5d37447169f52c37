//! `raytrace converge`: how a frame's error falls with run time, per series (a sampler, raw
//! or denoised, every pixel the same samples or adaptive under a noise threshold).
//!
//! Two references of many samples and independent seeds, `A` and `B` (rendered, or EXRs the
//! user gives), stand in for the truth: a render's squared error against the truth is
//! estimated by `(x - A)(x - B)`, which the references' noise does not bias
//! (`metrics::cross_mse`). The frame is then rendered at 1, 2, 4, ... samples per
//! pixel (and at each `--thresholds` adaptively), each point with `--seeds` seeds, its errors
//! the means over them. Every render is timed (wall and process CPU time, no file I/O); the
//! series take turns render by render, so that a change in the machine's load falls on all
//! alike, and a point is rendered again until its times settle or `--repeats` times, its
//! time their median. The module's children make the figures ([`series`]) and print and
//! write them ([`table`]).

mod series;
mod table;

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::args::{ConvergeArgs, DEFAULT_MAX_SAMPLES_FOR_THRESHOLD};
use super::progress::print_line;
use super::seeds::{DEFAULT_SEEDS, measured_seeds};
use crate::analysis::stats::{Figure, settled};
use crate::analysis::{flip, plot};
use raytrace_core::error::Error;
use raytrace_core::format::Format;
use raytrace_core::image::{COLOUR, Image};
use raytrace_core::metrics;
use raytrace_core::points::FramePoints;
use raytrace_core::renderer::{Budget, FrameJob, FrameResult, ShotTracer};
use raytrace_core::rng::hash_words;
use raytrace_core::sampler::SamplerKind;
use raytrace_core::scene::Scene;
use raytrace_io as io;
use raytrace_io::file_kind;
use raytrace_render::devices::{Devices, Needs, room_for_points, supported};
use raytrace_render::output;
use raytrace_scene::scene_file::{Overrides, SceneSource};
use series::{Finish, Point, Report, Sampling, SeriesKind, Setting};

/// Default samples per pixel of each reference render.
pub(crate) const DEFAULT_REFERENCE_SAMPLES: u32 = 4096;
/// Default most renders of a point for its time.
const DEFAULT_REPEATS: u32 = 7;
/// Fewest renders of a point for its time: a median and quartiles need a few.
const MIN_RENDERS: usize = 3;
/// A point's times have settled when their interquartile range is within this fraction of
/// their median.
const SETTLED: f64 = 0.05;
/// A word hashed with the scene's seed into the references' seeds, so that they are
/// independent of the measured renders' (`seeds::measured_seeds`).
const REFERENCE_SEED: u64 = 0x7265_6665_7265_6e63;

/// Runs `raytrace converge`, printing its table to stdout unless `--quiet`.
pub(crate) fn converge(args: &ConvergeArgs) -> Result<Report, Error> {
    let source = SceneSource::read(&args.scene)?;
    let overrides = args.scene_args.overrides();
    let scene = supported(source.scene(&overrides)?, &overrides)?;
    let frame = args.frame.unwrap_or(scene.shot.first_frame);
    if !scene.shot.contains_frame(frame) {
        return Err(Error::Usage(format!(
            "--frame {frame} is outside the shot's frames {}-{}",
            scene.shot.first_frame,
            scene.shot.last_frame()
        )));
    }
    // Every file the run writes is checked before anything is rendered or written: the
    // plot, the CSV and the levels' CSV beside it, and the references.
    if let Some(path) = &args.plot {
        plot::check_path(path).map_err(Error::Usage)?;
        io::check_target(path).map_err(Error::Usage)?;
    }
    if let Some(path) = &args.csv {
        Format::of(path, &[Format::Csv], "measurements").map_err(Error::Usage)?;
        for target in [path.clone(), levels_csv_path(path)] {
            io::check_target(&target).map_err(Error::Usage)?;
        }
    }
    let references = match args.reference.as_slice() {
        [] => ReferenceSource::Render(reference_paths(&scene, frame, args)?),
        paths => ReferenceSource::Read(checked_pair(paths, "--reference", check_readable)?),
    };
    let variant = |samples: u32, seed: u64, sampler: SamplerKind, finish: Finish| {
        source.scene(&Overrides {
            samples: Some(samples),
            seed: Some(seed),
            sampler: Some(sampler),
            denoise: Some(finish == Finish::Denoised),
            ..overrides.clone()
        })
    };
    super::threads::thread_pool(args.scene_args.threads)?
        .install(|| measure(&scene, &variant, frame, &references, args))
}

/// A variant of the measured scene with other samples, seed, sampler and finish, made from the
/// scene file through the validator.
type Variant<'a> = dyn Fn(u32, u64, SamplerKind, Finish) -> Result<Scene, Error> + Sync + 'a;

/// What a frame is rendered with: the run's devices, the shot on its device, and the frame's
/// points.
type Shot<'a> = (&'a Devices, &'a dyn ShotTracer, &'a FramePoints);

/// Where the references come from: two files to read, or two renders to write there.
enum ReferenceSource {
    Read([PathBuf; 2]),
    Render([PathBuf; 2]),
}

/// The two paths of `--reference` or `--write-reference`, each passing `check`, and not the
/// same file twice (the cross-estimate needs two independent images).
fn checked_pair(
    paths: &[PathBuf],
    option: &str,
    check: fn(&Path) -> Result<(), String>,
) -> Result<[PathBuf; 2], Error> {
    let [a, b] = paths else {
        return Err(Error::Usage(format!("{option} takes two files")));
    };
    for path in [a, b] {
        check(path).map_err(|m| Error::Usage(format!("{option} {}: {m}", path.display())))?;
    }
    if a == b {
        return Err(Error::Usage(format!(
            "{option}: {} twice; the two references must be renders of independent seeds",
            a.display()
        )));
    }
    Ok([a.clone(), b.clone()])
}

/// A reference to read: an EXR that exists and is a regular file (a named pipe would block
/// the read for ever, as it would a scene's).
fn check_readable(path: &Path) -> Result<(), String> {
    Format::of(path, &[Format::Exr], "reference")?;
    let meta = std::fs::metadata(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => {
            "no such file (render the references with --reference-samples)".to_string()
        }
        _ => e.to_string(),
    })?;
    if !meta.is_file() {
        return Err(format!(
            "is {}, not a reference image (references are read from regular files only)",
            file_kind(&meta.file_type())
        ));
    }
    Ok(())
}

/// A reference to write: an EXR path that can be written.
fn check_writable(path: &Path) -> Result<(), String> {
    Format::of(path, &[Format::Exr], "reference")?;
    io::check_target(path)
}

/// Where the rendered references go: `--write-reference`, or beside `--csv` or `--plot`,
/// named after the scene, the frame and the samples.
fn reference_paths(scene: &Scene, frame: u32, args: &ConvergeArgs) -> Result<[PathBuf; 2], Error> {
    if !args.write_reference.is_empty() {
        return checked_pair(&args.write_reference, "--write-reference", check_writable);
    }
    let samples = args.reference_samples.unwrap_or(DEFAULT_REFERENCE_SAMPLES);
    let stem = scene
        .source
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let dir = [&args.csv, &args.plot]
        .into_iter()
        .flatten()
        .next()
        .and_then(|p| p.parent())
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let path = |name: &str| {
        dir.join(format!(
            "{stem}_frame{frame}_reference_{samples}spp_{name}.exr"
        ))
    };
    let paths = vec![path("a"), path("b")];
    checked_pair(&paths, "the reference", check_writable)
}

/// The two references, as written (f32), and what the measured renders are compared with.
struct References {
    a: Image,
    b: Image,
    width: u32,
    height: u32,
    /// Their mean as 8-bit sRGB: FLIP's reference.
    mean_srgb: Vec<u8>,
}

/// Measures `frame` of `scene`, rendering the `variant` of each point.
fn measure(
    scene: &Scene,
    variant: &Variant,
    frame: u32,
    references: &ReferenceSource,
    args: &ConvergeArgs,
) -> Result<Report, Error> {
    let say = |s: &str| {
        if !args.scene_args.quiet {
            print_line(s);
        }
    };
    // The frame's points, read once for every render of it; on the GPU, the room for them
    // checked before anything is opened.
    let points = match scene.points.is_empty() {
        true => FramePoints::none(),
        false => raytrace_scene::point_cache::read_frame(scene, frame)?,
    };
    room_for_points(scene, &args.scene_args.overrides(), points.len() as u64)?;
    // The scene's device and, with --denoise, the denoiser, opened before anything is
    // measured: if either cannot start, nothing is written.
    let needs = Needs {
        denoiser: args.denoise,
        ..Needs::of([scene])
    };
    let devices = Devices::opened(needs)?;
    let tracer = devices.shot(scene)?;
    let shot = (&devices, tracer.as_ref(), &points);
    let references = match references {
        ReferenceSource::Read(paths) => read_references(scene, paths, &say)?,
        ReferenceSource::Render(paths) => {
            render_references(scene, variant, shot, frame, paths, args, &say)?
        }
    };
    let plan = SeriesPlan::new(scene, args);
    let mut report = measure_points(&plan, variant, (shot, frame), &references, &say)?;
    for note in report.fit_times() {
        say(&note);
    }
    let levels = series::level_times(&report);
    say(&table::summary(&report, &levels));
    if let Some(path) = &args.csv {
        write_csv(path, &report, &levels, &say)?;
    }
    if let Some(path) = &args.plot {
        write_plot(path, scene, frame, &report, &say)?;
    }
    Ok(report)
}

/// What `converge` measures: the series, each one's settings step by step, the seeds of a
/// point, how many times a point is rendered, and the seconds a series may take.
struct SeriesPlan<'a> {
    kinds: Vec<SeriesKind>,
    /// The uniform series' samples per pixel, step by step.
    uniform: Vec<u32>,
    /// The adaptive series' noise thresholds, step by step.
    thresholds: &'a [f64],
    seeds: Vec<u64>,
    /// The most renders of a point.
    most: usize,
    /// The fewest renders of a point whose times have settled.
    fewest: usize,
    /// `--budget`: seconds of rendering per series, at most.
    budget: Option<f64>,
}

impl<'a> SeriesPlan<'a> {
    /// The plan `args` ask for, of `scene`.
    fn new(scene: &Scene, args: &'a ConvergeArgs) -> SeriesPlan<'a> {
        let max_samples = args.max_samples.unwrap_or(match args.budget {
            Some(_) => u32::MAX,
            None => scene.render.samples,
        });
        let seed_count = args.seeds.unwrap_or(DEFAULT_SEEDS) as usize;
        let most = (args.repeats.unwrap_or(DEFAULT_REPEATS) as usize).max(seed_count);
        SeriesPlan {
            kinds: series_kinds(args),
            uniform: schedule(max_samples),
            thresholds: &args.thresholds,
            seeds: measured_seeds(scene, seed_count),
            most,
            fewest: MIN_RENDERS.max(seed_count).min(most),
            budget: args.budget,
        }
    }

    /// The setting of `kind`'s point at `step`, if its series has one.
    fn setting(&self, kind: &SeriesKind, step: usize) -> Option<Setting> {
        match kind.sampling {
            Sampling::Uniform => self.uniform.get(step).map(|&n| Setting::Samples(n)),
            Sampling::Adaptive => self.thresholds.get(step).map(|&e| Setting::Threshold(e)),
        }
    }
}

/// The series `args` ask for: each sampler (`--sampler`, or all), uniform and with
/// `--thresholds` adaptive, raw and with `--denoise` denoised, in that order.
fn series_kinds(args: &ConvergeArgs) -> Vec<SeriesKind> {
    let samplers = match args.sampler.is_empty() {
        true => SamplerKind::ALL.to_vec(),
        false => args.sampler.clone(),
    };
    let finishes = match args.denoise {
        true => vec![Finish::Raw, Finish::Denoised],
        false => vec![Finish::Raw],
    };
    let samplings = match args.thresholds.is_empty() {
        true => vec![Sampling::Uniform],
        false => vec![Sampling::Uniform, Sampling::Adaptive],
    };
    let mut kinds = Vec::new();
    for &sampler in &samplers {
        for &sampling in &samplings {
            for &finish in &finishes {
                kinds.push(SeriesKind {
                    sampler,
                    sampling,
                    finish,
                });
            }
        }
    }
    kinds
}

/// Measures the points of `plan`, a step at a time (each series' next setting), printing a
/// row per point; a series stops when its settings end, or when its next point would take
/// it over the budget.
fn measure_points(
    plan: &SeriesPlan,
    variant: &Variant,
    (shot, frame): (Shot, u32),
    references: &References,
    say: &dyn Fn(&str),
) -> Result<Report, Error> {
    let mut report = Report::default();
    let mut spent = vec![0.0; plan.kinds.len()];
    let mut active = vec![true; plan.kinds.len()];
    say(&table::header());
    for step in 0.. {
        let mut runs = Vec::new();
        for (i, kind) in plan.kinds.iter().enumerate() {
            if let (true, Some(setting)) = (active[i], plan.setting(kind, step)) {
                let scenes = plan
                    .seeds
                    .iter()
                    .map(|&seed| variant(setting_samples(setting), seed, kind.sampler, kind.finish))
                    .collect::<Result<Vec<Scene>, Error>>()?;
                runs.push(Run::new(i, *kind, setting, scenes));
            }
        }
        if runs.is_empty() {
            break;
        }
        render_in_turns(&mut runs, plan, (shot, frame), references)?;
        for run in runs {
            let point = run.point();
            say(&table::row(&point));
            let i = run.index;
            let total: f64 = run.times.iter().map(|t| t.0).sum();
            spent[i] += total;
            // The next point takes about twice as long as this one.
            if plan.budget.is_some_and(|b| spent[i] + 2.0 * total > b) {
                active[i] = false;
            }
            report.points.push(point);
        }
    }
    Ok(report)
}

/// Renders the points of one step, taking turns render by render, each until its times
/// settle or it has been rendered the most times; each seed's figures are taken once.
fn render_in_turns(
    runs: &mut [Run],
    plan: &SeriesPlan,
    (shot, frame): (Shot, u32),
    references: &References,
) -> Result<(), Error> {
    let seed_count = plan.seeds.len();
    for r in 0..plan.most {
        for run in runs.iter_mut().filter(|run| !run.done) {
            let scene = &run.scenes[r % seed_count];
            let (result, seconds) = render(scene, shot, frame, &run.budget())?;
            run.times.push(seconds);
            // Renders of a seed already measured are bit-identical: only their times count.
            if r < seed_count {
                run.figures.push(figures(&result, references));
            }
            let walls: Vec<f64> = run.times.iter().map(|t| t.0).collect();
            run.done = r + 1 >= plan.most || (r + 1 >= plan.fewest && settled(&walls, SETTLED));
        }
        if runs.iter().all(|run| run.done) {
            break;
        }
    }
    Ok(())
}

/// Writes the points' CSV to `path`, and the times to error levels beside it.
fn write_csv(
    path: &Path,
    report: &Report,
    levels: &[series::LevelTime],
    say: &dyn Fn(&str),
) -> Result<(), Error> {
    io::write_file(path, table::csv(report).as_bytes())?;
    let levels_path = levels_csv_path(path);
    io::write_file(&levels_path, table::levels_csv(levels).as_bytes())?;
    say(&format!(
        "CSV written to {} and {}",
        path.display(),
        levels_path.display()
    ));
    Ok(())
}

/// Draws the error against time of the series of `report`, measured on `frame` of `scene`,
/// to `path`.
fn write_plot(
    path: &Path,
    scene: &Scene,
    frame: u32,
    report: &Report,
    say: &dyn Fn(&str),
) -> Result<(), Error> {
    let (series, guides) = table::plot_series(report);
    let title = format!(
        "{} frame {frame}: error against render time",
        scene
            .source
            .file_name()
            .map_or("scene".into(), |n| n.to_string_lossy())
    );
    plot::write_plot(
        path,
        &title,
        "render time (s): median of alternated repeats",
        "relative MSE against the truth (mean over seeds)",
        &series,
        &guides,
    )
    .map_err(|message| Error::Output {
        path: path.to_path_buf(),
        message,
    })?;
    say(&format!("plot written to {}", path.display()));
    Ok(())
}

/// The samples per pixel of the measured uniform renders: powers of two up to `max_samples`,
/// and `max_samples` itself.
pub(crate) fn schedule(max_samples: u32) -> Vec<u32> {
    let mut v: Vec<u32> = (0..32)
        .map(|k| 1u32 << k)
        .take_while(|&n| n < max_samples)
        .collect();
    v.push(max_samples);
    v
}

/// The samples a render of `setting` is asked for: its count, or under a threshold the cap.
fn setting_samples(setting: Setting) -> u32 {
    match setting {
        Setting::Samples(n) => n,
        Setting::Threshold(_) => DEFAULT_MAX_SAMPLES_FOR_THRESHOLD,
    }
}

/// `c.csv` -> `c_levels.csv`.
fn levels_csv_path(path: &Path) -> PathBuf {
    let stem = path.file_stem().map_or("".into(), |s| s.to_string_lossy());
    let ext = path.extension().map_or("".into(), |s| s.to_string_lossy());
    path.with_file_name(format!("{stem}_levels.{ext}"))
}

/// A point being measured: its renders' times and its seeds' figures so far.
struct Run {
    /// The series' index among the measured series.
    index: usize,
    kind: SeriesKind,
    setting: Setting,
    /// The scene of each seed.
    scenes: Vec<Scene>,
    /// Each render's (wall, CPU) seconds.
    times: Vec<(f64, f64)>,
    /// Each seed's figures.
    figures: Vec<Figures>,
    done: bool,
}

impl Run {
    fn new(index: usize, kind: SeriesKind, setting: Setting, scenes: Vec<Scene>) -> Run {
        Run {
            index,
            kind,
            setting,
            scenes,
            times: Vec::new(),
            figures: Vec::new(),
            done: false,
        }
    }

    /// The budget of a render of this point.
    fn budget(&self) -> Budget {
        match self.setting {
            Setting::Samples(_) => Budget::default(),
            Setting::Threshold(e) => Budget {
                noise_threshold: Some(e),
                max_samples: Some(DEFAULT_MAX_SAMPLES_FOR_THRESHOLD),
                time_limit: None,
            },
        }
    }

    /// The point measured: medians of the times, means over the seeds.
    fn point(&self) -> Point {
        let over_seeds = |f: fn(&Figures) -> f64| {
            Figure::mean_of(&self.figures.iter().map(f).collect::<Vec<_>>())
        };
        let wall = Figure::median_of(&self.times.iter().map(|t| t.0).collect::<Vec<_>>());
        Point {
            series: self.kind,
            setting: self.setting,
            samples: over_seeds(|f| f.samples).value,
            seeds: self.figures.len(),
            renders: self.times.len(),
            seconds: wall.value,
            wall,
            cpu: Figure::median_of(&self.times.iter().map(|t| t.1).collect::<Vec<_>>()),
            mse: over_seeds(|f| f.mse),
            rel_mse: over_seeds(|f| f.rel_mse),
            estimated_mse: over_seeds(|f| f.estimated_mse),
            estimated_rel_mse: over_seeds(|f| f.estimated_rel_mse),
            flip: over_seeds(|f| f.flip),
            rel_mse_by_seed: self.figures.iter().map(|f| f.rel_mse).collect(),
        }
    }
}

/// One render's figures.
struct Figures {
    samples: f64,
    mse: f64,
    rel_mse: f64,
    estimated_mse: f64,
    estimated_rel_mse: f64,
    flip: f64,
}

/// The figures of one measured render against the references.
fn figures(result: &FrameResult, references: &References) -> Figures {
    // The frame as written: denoised when it was denoised.
    let image = &result.image;
    let (a, b) = (&references.a, &references.b);
    let estimated_mse = match result.denoised {
        // A denoised frame states its relative error only.
        Some(_) => f64::NAN,
        None => metrics::estimated_mse(&result.film.variances()),
    };
    Figures {
        samples: result.stats.mean_samples_per_pixel,
        mse: metrics::cross_mse(image, a, b),
        rel_mse: metrics::cross_rel_mse(image, a, b),
        estimated_mse,
        estimated_rel_mse: result.stats.relative_error.powi(2),
        flip: flip::mean_flip(
            references.width,
            references.height,
            &references.mean_srgb,
            &srgb8(image),
        ),
    }
}

/// An image's colour as 8-bit sRGB, as a PNG frame holds it.
fn srgb8(image: &Image) -> Vec<u8> {
    let colour = image.interleaved(COLOUR).expect("a frame's colour");
    colour.into_iter().map(io::linear_to_srgb8).collect()
}

/// Renders one variant of the frame, timed: the one place `converge` calls the renderer.
/// Returns the frame and the wall and process CPU seconds of the call (preparation, tracing,
/// and denoising when the scene asks; no file I/O).
fn render(
    scene: &Scene,
    (devices, tracer, points): Shot,
    frame: u32,
    budget: &Budget,
) -> Result<(FrameResult, (f64, f64)), Error> {
    let (wall, cpu) = (Instant::now(), cpu_seconds());
    let job = FrameJob::new(scene, frame).points(points).budget(*budget);
    let result = devices.finishing(scene)?.render(job, tracer)?;
    let times = (wall.elapsed().as_secs_f64(), cpu_seconds() - cpu);
    Ok((result, times))
}

/// The CPU time this process has used, all its threads (`CLOCK_PROCESS_CPUTIME_ID`).
fn cpu_seconds() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ProcessCPUTime);
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

/// Renders the two references (the default sampler, seeds of their own, so that their noise
/// is independent of each other's and of every measured render's), writes them to EXR and
/// reads them back: the measurements are taken against the f32 values written, exactly as
/// the same files given to `--reference` would give them.
fn render_references(
    scene: &Scene,
    variant: &Variant,
    shot: Shot,
    frame: u32,
    paths: &[PathBuf; 2],
    args: &ConvergeArgs,
    say: &dyn Fn(&str),
) -> Result<References, Error> {
    let samples = args.reference_samples.unwrap_or(DEFAULT_REFERENCE_SAMPLES);
    for (k, path) in paths.iter().enumerate() {
        // 63 bits, as every seed a scene file or --seed can give.
        let seed = hash_words(&[scene.render.seed, REFERENCE_SEED, k as u64]) >> 1;
        let reference = variant(samples, seed, SamplerKind::default(), Finish::Raw)?;
        say(&format!(
            "reference {}: frame {frame}, {samples} samples per pixel, {} sampler...",
            ["A", "B"][k],
            reference.render.sampler
        ));
        let (result, (seconds, _)) = render(&reference, shot, frame, &Budget::default())?;
        let budget = Budget::default();
        let non_finite = output::write_frame(path, Format::Exr, &reference, &result, &budget)?;
        if non_finite > 0 {
            say(&format!(
                "reference: {non_finite} non-finite pixels written as 0"
            ));
        }
        say(&format!(
            "reference {}: {seconds:.2} s, estimated error {:.3}%, written to {}",
            ["A", "B"][k],
            100.0 * result.stats.relative_error,
            path.display()
        ));
    }
    read_references(scene, paths, say)
}

/// Reads the two references and checks them against the frame and each other.
fn read_references(
    scene: &Scene,
    paths: &[PathBuf; 2],
    say: &dyn Fn(&str),
) -> Result<References, Error> {
    let (width, height) = (scene.output.width, scene.output.height);
    let a = read_reference(&paths[0], width, height)?;
    let b = read_reference(&paths[1], width, height)?;
    let mut mean = Image::new(width, height);
    let (ca, cb) = (a.rgb(COLOUR), b.rgb(COLOUR));
    let (ca, cb) = (ca.expect("a colour read"), cb.expect("a colour read"));
    mean.set_rgb(
        COLOUR,
        (0..a.pixels()).map(|i| ((ca.at_f64(i) + cb.at_f64(i)) * 0.5).as_vec3()),
    );
    // Their difference tells their own error: E[(A - B)^2] = 2 var, and the mean of the two
    // has half the variance of one.
    let own = metrics::rel_mse(&a, &b) / 4.0;
    say(&format!(
        "errors against the truth, estimated from the two references (their mean's own \
         relative error {:.3}%, which the estimate leaves out)",
        100.0 * own.sqrt()
    ));
    Ok(References {
        mean_srgb: srgb8(&mean),
        a,
        b,
        width,
        height,
    })
}

/// Reads the colour of an EXR reference of the given size, as linear radiance.
pub(crate) fn read_reference(path: &Path, width: u32, height: u32) -> Result<Image, Error> {
    let bad = |message: String| Error::Usage(format!("reference {}: {message}", path.display()));
    check_readable(path).map_err(bad)?;
    let image = io::read_exr_colour(path).map_err(bad)?;
    let (w, h) = (image.width(), image.height());
    if (w, h) != (width, height) {
        return Err(bad(format!("is {w}x{h}, the frame is {width}x{height}")));
    }
    let colour = image.interleaved(COLOUR).expect("a colour read");
    if colour.iter().any(|v| !v.is_finite()) {
        return Err(bad("has pixels that are not finite".into()));
    }
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedules_are_powers_of_two_then_the_maximum() {
        assert_eq!(schedule(1), [1]);
        assert_eq!(schedule(8), [1, 2, 4, 8]);
        assert_eq!(schedule(12), [1, 2, 4, 8, 12]);
        assert_eq!(schedule(u32::MAX).len(), 33);
    }

    #[test]
    fn the_levels_csv_sits_beside_the_points_csv() {
        assert_eq!(
            levels_csv_path(Path::new("data/c.csv")),
            Path::new("data/c_levels.csv")
        );
    }

    #[test]
    fn cpu_time_counts_work() {
        let start = cpu_seconds();
        let mut x = 0u64;
        for i in 0..20_000_000u64 {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(i));
        }
        assert!(x != 1);
        assert!(cpu_seconds() > start);
    }
}
