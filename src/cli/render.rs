//! `raytrace render`: loads and validates the scene with the command line's overrides,
//! selects the frames, renders each and writes it atomically, with a progress bar and a line
//! per frame.

use std::path::PathBuf;
use std::time::Instant;

use super::progress::Progress;
use super::{RenderArgs, frames};
use crate::error::Error;
use crate::io::{self, FrameInfo};
use crate::render::{FrameStats, render_frame};
use crate::scene::Scene;
use crate::world::StaticGeometry;

/// Age after which a temporary frame file of a process that no longer runs is removed.
pub(crate) const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(60);

/// What a render run did.
#[derive(Clone, Debug, Default)]
pub(crate) struct RunSummary {
    /// Frames rendered and written.
    pub(crate) rendered: Vec<u32>,
    /// Frames left alone because their file existed.
    pub(crate) skipped: Vec<u32>,
    pub(crate) seconds: f64,
    pub(crate) samples: u64,
    pub(crate) dropped: u64,
    /// The estimated relative error of each rendered frame.
    pub(crate) relative_errors: Vec<f64>,
}

/// The frames a run renders: the `--frames` selection (or the whole shot), then the chunk.
pub(crate) fn select_frames(scene: &Scene, args: &RenderArgs) -> Result<Vec<u32>, Error> {
    let (first, last) = (scene.shot.first_frame, scene.shot.last_frame());
    let all = match args.frames.as_deref().map(str::trim) {
        None | Some("") => (first..=last).collect(),
        Some(spec) => frames::parse_frames(spec, first, last)
            .map_err(|e| Error::Usage(format!("--frames: {e}")))?,
    };
    match args.chunk_size.zip(args.chunk) {
        None => Ok(all),
        Some((size, index)) => Ok(frames::chunk(&all, size, index)
            .map_err(Error::Usage)?
            .to_vec()),
    }
}

/// The frames a run renders and the file of each, checked before anything is rendered: one
/// file per frame.
pub(crate) fn targets(scene: &Scene, args: &RenderArgs) -> Result<Vec<(u32, PathBuf)>, Error> {
    let selected = select_frames(scene, args)?;
    let pattern = &scene.output.path;
    if selected.len() > 1 && !io::pattern_has_frame_number(pattern) {
        return Err(Error::Usage(format!(
            "output path \"{pattern}\" has no '#' for the frame number, so {} frames would overwrite one file",
            selected.len()
        )));
    }
    Ok(selected
        .iter()
        .map(|&f| (f, io::frame_path(pattern, f)))
        .collect())
}

/// Renders the selected frames of a scene and writes them. Everything that can be checked
/// before rendering (scene, arguments, output names) is checked before anything is written.
pub(crate) fn render(args: &RenderArgs) -> Result<RunSummary, Error> {
    let scene = Scene::load_with(&args.scene, &args.overrides())?;
    let targets = targets(&scene, args)?;
    super::thread_pool(args.scene_args.threads)?.install(|| render_targets(&scene, &targets, args))
}

fn render_targets(
    scene: &Scene,
    targets: &[(u32, PathBuf)],
    args: &RenderArgs,
) -> Result<RunSummary, Error> {
    let start = Instant::now();
    let budget = args.budget.budget();
    let progress = Progress::new(targets.len() as u64, args.scene_args.quiet);
    let statics = StaticGeometry::new(scene);
    let mut summary = RunSummary::default();
    for (frame, path) in targets {
        // A frame's temporary file lives only while the frame is encoded and written (seconds),
        // so one a minute old whose writer is gone was left by a killed run. The age also
        // protects files another machine is writing into a shared folder (its pid means
        // nothing here).
        io::remove_stale_temp_files(path, STALE_TEMP_AGE)?;
        if args.skip_existing && path.exists() {
            progress.line(&format!(
                "frame {frame}: {} exists, skipped",
                path.display()
            ));
            summary.skipped.push(*frame);
            progress.frame_done();
            continue;
        }
        let planned = (!budget.is_set()).then(|| {
            scene.output.width as u64 * scene.output.height as u64 * scene.render.samples as u64
        });
        let bar = progress.start_frame(*frame, planned);
        let result = render_frame(scene, &statics, *frame, &budget, &|n| bar.inc(n));
        bar.finish_and_clear();
        let st = &result.stats;
        let mut info = frame_info(scene, *frame, st.samples_per_pixel);
        if st.relative_error.is_finite() {
            info.extra
                .push(("estimatedRelativeError".to_string(), st.relative_error));
        }
        if let Some(t) = budget.noise_threshold {
            info.extra.push(("noiseThreshold".to_string(), t));
        }
        if let Some(t) = budget.time_limit {
            info.extra.push(("timeLimit".to_string(), t));
        }
        io::write_frame(
            path,
            scene.output.width,
            scene.output.height,
            &result.film.to_rgb_f32(),
            &info,
        )?;
        let seconds = st.prepare_seconds + st.render_seconds;
        let stop = if budget.is_set() {
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
        if args.stats {
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

/// The attributes of `frame` of `scene`, rendered with `samples` per pixel.
pub(crate) fn frame_info(scene: &Scene, frame: u32, samples: u32) -> FrameInfo {
    let interval = scene.shot.interval(frame);
    FrameInfo {
        frame,
        fps: scene.shot.fps,
        shutter_open: interval.open,
        shutter_close: interval.close,
        samples,
        seed: scene.render.seed,
        sampler: scene.render.sampler.name().to_string(),
        extra: Vec::new(),
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

/// The process's peak resident memory so far (Linux: `VmHWM` in `/proc/self/status`).
pub(crate) fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}
