//! The commands of the `raytrace` binary, as library functions: `main.rs` only parses the
//! command line into these options and reports the result.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::error::Error;
use crate::frames;
use crate::output::{self, FrameInfo};
use crate::render::{Budget, FrameRequest, FrameStats, render_frame};
use crate::sampler::SamplerKind;
use crate::scene::Scene;
use crate::world::StaticGeometry;

/// Age after which a temporary frame file of a process that no longer runs is removed.
pub const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(60);

/// Largest image side accepted from the command line (as from scene files).
pub const MAX_SIDE: u32 = 65536;

/// Options of `raytrace render`.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    pub scene: PathBuf,
    /// A frame spec (`12`, `1-48`, `1-48:4`, `1,5,10-20`); `None` or empty: every frame.
    pub frames: Option<String>,
    pub output: Option<String>,
    pub samples: Option<u32>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub seed: Option<u64>,
    /// Worker threads; `None`: one per core.
    pub threads: Option<usize>,
    /// Leave frames whose file already exists untouched.
    pub skip_existing: bool,
    /// Print nothing but errors.
    pub quiet: bool,
    /// Print a line of figures per frame: preparation and render time, rays, rates, memory.
    pub stats: bool,
    /// Render only chunk `chunk` of `chunk_size` consecutive selected frames.
    pub chunk: Option<(usize, usize)>,
    /// The sampler, instead of the scene's.
    pub sampler: Option<SamplerKind>,
    /// A time limit or noise threshold per frame, instead of the scene's exact samples.
    pub budget: Budget,
}

/// What a render run did.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    /// Frames rendered and written.
    pub rendered: Vec<u32>,
    /// Frames left alone because their file existed.
    pub skipped: Vec<u32>,
    pub seconds: f64,
    pub samples: u64,
    pub dropped: u64,
    /// The estimated relative error of each rendered frame.
    pub relative_errors: Vec<f64>,
}

/// Loads the scene and applies the command-line overrides, validating them.
pub fn load_scene(opts: &RenderOptions) -> Result<Scene, Error> {
    let mut scene = Scene::load(&opts.scene)?;
    if let Some(s) = opts.samples {
        if s == 0 {
            return Err(Error::Usage("--samples must be >= 1, got 0".into()));
        }
        scene.render.samples = s;
    }
    for (name, value, target) in [
        ("--width", opts.width, &mut scene.output.width),
        ("--height", opts.height, &mut scene.output.height),
    ] {
        if let Some(v) = value {
            if v == 0 || v > MAX_SIDE {
                return Err(Error::Usage(format!(
                    "{name} must be in 1..={MAX_SIDE}, got {v}"
                )));
            }
            *target = v;
        }
    }
    if let Some(seed) = opts.seed {
        scene.render.seed = seed;
    }
    if let Some(path) = &opts.output {
        scene.output.path = path.clone();
    }
    if let Some(sampler) = opts.sampler {
        scene.render.sampler = sampler;
    }
    check_budget(&opts.budget)?;
    Ok(scene)
}

/// Rejects an option's value that is not a finite number above zero.
pub fn check_positive(name: &str, value: Option<f64>) -> Result<(), Error> {
    match value {
        Some(v) if !(v.is_finite() && v > 0.0) => Err(Error::Usage(format!(
            "{name} must be a number > 0, got {v}"
        ))),
        _ => Ok(()),
    }
}

/// Rejects budgets that cannot be met or make no sense.
pub fn check_budget(budget: &Budget) -> Result<(), Error> {
    check_positive("--time-limit", budget.time_limit)?;
    check_positive("--noise-threshold", budget.noise_threshold)?;
    match budget.max_samples {
        Some(0) => Err(Error::Usage("--max-samples must be >= 1, got 0".into())),
        Some(_) if !budget.is_set() => Err(Error::Usage(
            "--max-samples needs --time-limit or --noise-threshold (without them a frame takes exactly --samples)".into(),
        )),
        _ => Ok(()),
    }
}

/// The frames a run renders: the `--frames` selection (or the whole shot), then the chunk.
pub fn select_frames(scene: &Scene, opts: &RenderOptions) -> Result<Vec<u32>, Error> {
    let (first, last) = (scene.shot.first_frame, scene.shot.last_frame());
    let all = match opts.frames.as_deref().map(str::trim) {
        None | Some("") => (first..=last).collect(),
        Some(spec) => frames::parse_frames(spec, first, last)
            .map_err(|e| Error::Usage(format!("--frames: {e}")))?,
    };
    match opts.chunk {
        None => Ok(all),
        Some((size, index)) => Ok(frames::chunk(&all, size, index)
            .map_err(Error::Usage)?
            .to_vec()),
    }
}

/// Renders the selected frames of a scene and writes them. Everything that can be checked
/// before rendering (scene, arguments, output names) is checked before anything is written.
pub fn render(opts: &RenderOptions) -> Result<RunSummary, Error> {
    let scene = load_scene(opts)?;
    let selected = select_frames(&scene, opts)?;
    let pattern = scene.output.path.clone();
    if selected.len() > 1 && !output::pattern_has_frame_number(&pattern) {
        return Err(Error::Usage(format!(
            "output path \"{pattern}\" has no '#' for the frame number, so {} frames would overwrite one file",
            selected.len()
        )));
    }
    let targets: Vec<(u32, PathBuf)> = selected
        .iter()
        .map(|&f| (f, output::frame_path(&pattern, f)))
        .collect();
    for (_, path) in &targets {
        output::format_for(path).map_err(Error::Usage)?;
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::Usage(format!("--threads: {e}")))?;
    pool.install(|| render_targets(&scene, &targets, opts))
}

fn render_targets(
    scene: &Scene,
    targets: &[(u32, PathBuf)],
    opts: &RenderOptions,
) -> Result<RunSummary, Error> {
    let start = Instant::now();
    let progress = Progress::new(targets.len() as u64, opts.quiet);
    let statics = StaticGeometry::new(scene);
    let mut summary = RunSummary::default();
    for (frame, path) in targets {
        // A frame's temporary file lives only while the frame is encoded and written (seconds),
        // so one a minute old whose writer is gone was left by a killed run. The age also
        // protects files another machine is writing into a shared folder (its pid means
        // nothing here).
        output::remove_stale_temp_files(path, STALE_TEMP_AGE)?;
        if opts.skip_existing && path.exists() {
            progress.line(&format!(
                "frame {frame}: {} exists, skipped",
                path.display()
            ));
            summary.skipped.push(*frame);
            progress.frame_done();
            continue;
        }
        let req = FrameRequest::from_scene(scene, *frame);
        let planned = (!opts.budget.is_set())
            .then(|| req.width as u64 * req.height as u64 * req.samples as u64);
        let bar = progress.start_frame(*frame, planned);
        let result = render_frame(scene, &statics, &req, &opts.budget, &|n| bar.inc(n));
        bar.finish_and_clear();
        let st = &result.stats;
        let mut extra = Vec::new();
        if st.relative_error.is_finite() {
            extra.push(("estimatedRelativeError".to_string(), st.relative_error));
        }
        if let Some(t) = opts.budget.noise_threshold {
            extra.push(("noiseThreshold".to_string(), t));
        }
        if let Some(t) = opts.budget.time_limit {
            extra.push(("timeLimit".to_string(), t));
        }
        let info = frame_info(scene, &req, st.samples_per_pixel, extra);
        output::write_frame(
            path,
            req.width,
            req.height,
            &result.film.to_rgb_f32(),
            &info,
        )?;
        let seconds = st.prepare_seconds + st.render_seconds;
        let stop = if opts.budget.is_set() {
            format!(" ({})", st.stop.describe())
        } else {
            String::new()
        };
        progress.line(&format!(
            "frame {frame}: {seconds:.2} s, {} spp{stop}, est. error {}, {:.2} M samples/s, {} dropped, {}",
            st.samples_per_pixel,
            percent(st.relative_error),
            st.samples as f64 / st.render_seconds.max(1e-9) / 1e6,
            st.dropped,
            path.display()
        ));
        if opts.stats {
            progress.line(&stats_line(*frame, st));
        }
        summary.relative_errors.push(st.relative_error);
        summary.rendered.push(*frame);
        summary.samples += st.samples;
        summary.dropped += st.dropped;
        progress.frame_done();
    }
    summary.seconds = start.elapsed().as_secs_f64();
    let errors = &summary.relative_errors;
    let error = if errors.is_empty() {
        String::new()
    } else {
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        let max = errors.iter().copied().fold(0.0, f64::max);
        format!(", est. error mean {} max {}", percent(mean), percent(max))
    };
    progress.line(&format!(
        "{} frames rendered, {} skipped, in {:.2} s ({:.2} M samples/s){error}",
        summary.rendered.len(),
        summary.skipped.len(),
        summary.seconds,
        summary.samples as f64 / summary.seconds.max(1e-9) / 1e6
    ));
    progress.finish();
    Ok(summary)
}

/// The attributes of a rendered frame of `scene`: `req` with the samples per pixel it took.
pub fn frame_info(
    scene: &Scene,
    req: &FrameRequest,
    samples: u32,
    extra: Vec<(String, f64)>,
) -> FrameInfo {
    let interval = scene.shot.interval(req.frame);
    FrameInfo {
        frame: req.frame,
        fps: scene.shot.fps,
        shutter_open: interval.open,
        shutter_close: interval.close,
        samples,
        seed: req.seed,
        sampler: req.sampler.name().to_string(),
        extra,
    }
}

/// An estimated relative error as a percentage, or why there is none.
fn percent(relative_error: f64) -> String {
    if relative_error.is_finite() {
        format!("{:.3}%", relative_error * 100.0)
    } else {
        "unknown (1 sample)".to_string()
    }
}

/// The `--stats` line of a frame.
fn stats_line(frame: u32, st: &FrameStats) -> String {
    let per_s = |n: u64| n as f64 / st.render_seconds.max(1e-9) / 1e6;
    let memory = peak_memory_bytes().map_or("unknown".to_string(), |b| {
        format!("{:.1} MiB", b as f64 / 1048576.0)
    });
    // The share of the render time the worker threads spent in tiles: what is missing is
    // time a core sat idle (waiting for the last tile) or spent scheduling.
    let busy = st.tile_seconds / (st.render_seconds * rayon::current_num_threads() as f64);
    format!(
        "frame {frame} stats: prepare {:.4} s ({} moving spheres), render {:.3} s in {} passes, cores busy {:.1}%, rays {} ({:.2} M/s), samples {} ({:.2} M/s), peak memory {memory}",
        st.prepare_seconds,
        st.moving_spheres,
        st.render_seconds,
        st.passes,
        busy.min(1.0) * 100.0,
        st.rays,
        per_s(st.rays),
        st.samples,
        per_s(st.samples),
    )
}

/// Prints a line to stdout. A closed stdout (`raytrace render ... | head -1`) is not an error:
/// the lines are for whoever reads them, and the frames are still rendered and written.
pub fn print_line(text: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stdout().lock(), "{text}");
}

/// The process's peak resident memory so far (Linux: `VmHWM` in `/proc/self/status`).
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Progress bars on a terminal's stderr, and one summary line per frame on stdout.
struct Progress {
    multi: MultiProgress,
    frames: ProgressBar,
    quiet: bool,
}

impl Progress {
    fn new(frames: u64, quiet: bool) -> Progress {
        let target = if quiet || !std::io::stderr().is_terminal() {
            ProgressDrawTarget::hidden()
        } else {
            ProgressDrawTarget::stderr()
        };
        let multi = MultiProgress::with_draw_target(target);
        let bar = multi.add(ProgressBar::new(frames));
        bar.set_style(
            ProgressStyle::with_template(
                "frames {pos}/{len} [{wide_bar}] {elapsed_precise} eta {eta_precise}",
            )
            .expect("valid template"),
        );
        Progress {
            multi,
            frames: bar,
            quiet,
        }
    }

    /// A bar for one frame's samples; without a planned count (a budget), a spinner.
    fn start_frame(&self, frame: u32, planned: Option<u64>) -> ProgressBar {
        let (bar, template) = match planned {
            Some(samples) => (
                ProgressBar::new(samples),
                "frame {msg} [{wide_bar}] {percent}% {per_sec} eta {eta}",
            ),
            None => (
                ProgressBar::no_length(),
                "frame {msg} {spinner} {human_pos} samples {per_sec} {elapsed}",
            ),
        };
        let bar = self.multi.add(bar);
        bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
        bar.set_message(frame.to_string());
        bar
    }

    fn frame_done(&self) {
        self.frames.inc(1);
    }

    fn line(&self, text: &str) {
        if !self.quiet {
            self.multi.suspend(|| print_line(text));
        }
    }

    fn finish(&self) {
        self.frames.finish_and_clear();
    }
}

/// `raytrace check`: validates a scene and describes it.
pub fn check(scene_path: &Path, chunk_size: Option<usize>) -> Result<String, Error> {
    use std::fmt::Write;
    let scene = Scene::load(scene_path)?;
    let shot = &scene.shot;
    let mut s = String::new();
    let _ = writeln!(s, "{}: ok", scene_path.display());
    let _ = writeln!(
        s,
        "shot: {} frames ({}-{}) at {} fps, shutter {} s ({}), start time {} s",
        shot.frames,
        shot.first_frame,
        shot.last_frame(),
        shot.fps,
        shot.shutter,
        shot.position.name(),
        shot.start_time
    );
    let moving = scene
        .spheres
        .iter()
        .filter(|s| s.motion.is_animated())
        .count();
    let _ = writeln!(
        s,
        "spheres: {} ({} moving, {} static)",
        scene.spheres.len(),
        moving,
        scene.spheres.len() - moving
    );
    let cam = match (&scene.camera.look_from, &scene.camera.look_at) {
        (crate::motion::Motion::Orbit { orbit, .. }, _) => {
            format!("orbit at {} degrees/s", orbit.degrees_per_second)
        }
        (crate::motion::Motion::Keyframes(k), _) => format!("{} keyframes", k.len()),
        (_, crate::motion::Motion::Keyframes(k)) => format!("{} keyframes", k.len()),
        _ => "still".to_string(),
    };
    let lens = if scene.camera.aperture > 0.0 {
        format!("thin lens, aperture {}", scene.camera.aperture)
    } else {
        "pinhole".to_string()
    };
    let _ = writeln!(s, "camera: {cam}, {lens}, vfov {}", scene.camera.vfov);
    let per_frame =
        scene.output.width as u64 * scene.output.height as u64 * scene.render.samples as u64;
    let _ = writeln!(
        s,
        "image: {}x{}, {} samples/pixel, max depth {}, seed {}, output {}",
        scene.output.width,
        scene.output.height,
        scene.render.samples,
        scene.render.max_depth,
        scene.render.seed,
        scene.output.path
    );
    let _ = writeln!(
        s,
        "total samples: {} ({} per frame)",
        per_frame * shot.frames as u64,
        per_frame
    );
    if let Some(size) = chunk_size {
        if size == 0 {
            return Err(Error::Usage("--chunk-size must be >= 1".into()));
        }
        let _ = writeln!(
            s,
            "chunks: {} of up to {size} frames",
            frames::chunk_count(shot.frames as usize, size)
        );
    }
    let _ = writeln!(s, "frames:");
    let all: Vec<u32> = (shot.first_frame..=shot.last_frame()).collect();
    let listed: Vec<Option<u32>> = if all.len() <= 50 {
        all.iter().map(|&f| Some(f)).collect()
    } else {
        all[..20]
            .iter()
            .map(|&f| Some(f))
            .chain([None])
            .chain(all[all.len() - 5..].iter().map(|&f| Some(f)))
            .collect()
    };
    for f in listed {
        match f {
            Some(f) => {
                let i = shot.interval(f);
                let moving_now = scene
                    .spheres
                    .iter()
                    .filter(|s| s.prepare(i).motion.is_moving())
                    .count();
                let _ = writeln!(
                    s,
                    "  {f}: shutter [{}, {}] s, {moving_now} moving",
                    i.open, i.close
                );
            }
            None => {
                let _ = writeln!(s, "  ...");
            }
        }
    }
    Ok(s)
}
