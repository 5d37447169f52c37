//! `raytrace render`: loads and validates the scene with the command line's overrides,
//! selects the frames, renders each and writes it atomically, with a progress bar and a line
//! per frame.

use std::path::Path;
use std::time::Instant;

use super::args::RenderArgs;
use super::interrupt;
use super::jobs::{Job, Targets, load_shots};
use super::progress::Progress;
use crate::estimated_error::{frame_error_note, relative_error_percent};
use raytrace_core::error::{Error, elide_path};
use raytrace_core::renderer::{Budget, FrameJob, FrameResult, FrameStats, ShotTracer};
use raytrace_core::scene::{Device, Scene};
use raytrace_denoise::change;
use raytrace_io as io;
use raytrace_io::clip;
use raytrace_render::devices::Devices;
use raytrace_render::finish::Finishing;
use raytrace_render::memory::{check_memory, mib, peak_memory_bytes};
use raytrace_render::output;
use raytrace_scene::point_cache::{ShotPoints, SurveyDepth};

/// Age after which a temporary frame file of another machine (or of an earlier version, whose
/// names record no machine) is removed when its writer is not running here.
const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(60);

/// What a render run did.
#[derive(Clone, Debug, Default)]
pub(crate) struct RunSummary {
    /// Frames rendered and written.
    pub(crate) rendered: u64,
    /// Frames left alone because their file existed.
    pub(crate) skipped: u64,
    pub(crate) seconds: f64,
    pub(crate) samples: u64,
    /// Samples that were not finite (counted as black).
    pub(crate) non_finite: u64,
    /// The mean and the largest estimated relative error of the rendered frames.
    pub(crate) error_mean: f64,
    pub(crate) error_max: f64,
    /// The estimated changes of the error from one written frame to the next
    /// ([`Denoised::change`](raytrace_core::renderer::Denoised::change)): their sum and count.
    pub(crate) change_sum: f64,
    pub(crate) changes: u64,
}

/// Renders the selected frames of every scene and writes them, then the clips asked for.
/// Everything that can be checked before rendering (scenes, arguments, output names, clips)
/// is checked before anything is written.
pub(crate) fn render(args: &RenderArgs) -> Result<RunSummary, Error> {
    let chunk = args.chunk_size.zip(args.chunk);
    let shots = load_shots(
        &args.scenes,
        &args.overrides(),
        &args.frames_arg(),
        chunk,
        SurveyDepth::Files,
    )?;
    // The frames render in this pool, whose workers the memory estimate counts.
    let pool = super::threads::thread_pool(args.scene_args.threads)?;
    let mut estimate = 0;
    for shot in &shots {
        estimate = estimate.max(pool.install(|| check_memory(&shot.scene, shot.points))?);
        if let Some(c) = &shot.scene.output.clip
            && !args.no_clip
        {
            if chunk.is_some() {
                return Err(Error::Usage(format!(
                    "{}: [output] clip asks for the clip {}, which one chunk cannot make: pass --no-clip to render the chunk without it, and make the clip with `raytrace clip` in a job after the array's",
                    elide_path(&shot.path),
                    raytrace_core::error::elide(c)
                )));
            }
            clip::check(Path::new(c), shot.scene.shot.fps)?;
        }
    }
    if args.stats && !args.scene_args.quiet {
        super::progress::print_line(&format!("memory: about {}", mib(estimate)));
    }
    pool.install(|| render_shots(&shots, args))
}

/// Renders every shot under one progress bar, with a summary line per shot (when there are
/// several) and one for the run; then makes the clips asked for (unless --no-clip).
fn render_shots(shots: &[Job], args: &RenderArgs) -> Result<RunSummary, Error> {
    let start = Instant::now();
    // The GPU and the denoiser are opened once, before anything is written: without them,
    // nothing is.
    let devices = Devices::for_scenes(shots.iter().map(|s| &s.scene))?;
    let total: u64 = shots.iter().map(|s| s.targets.frames.len()).sum();
    let progress = Progress::new(total, args.scene_args.quiet);
    interrupt::frames_selected(total);
    let mut run = RunSummary::default();
    // A shot the run's chunk does not reach is not started (its static geometry not built).
    for shot in shots.iter().filter(|s| s.targets.frames.len() > 0) {
        let summary = render_shot(
            &shot.scene,
            (&shot.targets, &shot.caches),
            args,
            &devices,
            &progress,
        )?;
        if shots.len() > 1 {
            progress.line(&format!(
                "{}: {}",
                elide_path(&shot.path),
                summary_text(&summary)
            ));
        }
        run.add(&summary);
    }
    run.seconds = start.elapsed().as_secs_f64();
    progress.line(&summary_text(&run));
    progress.finish();
    for shot in shots {
        // A chunk never gets here with a clip to make: `render` refused it, or --no-clip.
        let Some(c) = shot.scene.output.clip.as_ref().filter(|_| !args.no_clip) else {
            continue;
        };
        let t = &shot.targets;
        let source = clip::Source {
            pattern: &t.pattern,
            exposure: 0.0,
        };
        let made = clip::make(
            Path::new(c),
            shot.scene.shot.fps,
            source,
            t.frames.iter(),
            t.frames.len(),
        )?;
        progress.line(&made.line(Path::new(c)));
    }
    Ok(run)
}

impl RunSummary {
    /// Adds a shot's figures to a run's (all but the seconds, which the run measures).
    fn add(&mut self, shot: &RunSummary) {
        let n = (self.rendered + shot.rendered).max(1) as f64;
        self.error_mean =
            (self.error_mean * self.rendered as f64 + shot.error_mean * shot.rendered as f64) / n;
        self.error_max = self.error_max.max(shot.error_max);
        self.rendered += shot.rendered;
        self.skipped += shot.skipped;
        self.samples += shot.samples;
        self.non_finite += shot.non_finite;
        self.change_sum += shot.change_sum;
        self.changes += shot.changes;
    }
}

/// `12 frames rendered, 0 skipped, in 3.21 s (1.23 M samples/s), est. error mean ... max ...`,
/// and for `--temporal` frames rendered in sequence `, est. flicker ...`.
fn summary_text(summary: &RunSummary) -> String {
    let mut error = if summary.rendered == 0 {
        String::new()
    } else {
        format!(
            ", est. error mean {} max {}",
            relative_error_percent(summary.error_mean),
            relative_error_percent(summary.error_max)
        )
    };
    if summary.changes > 0 {
        let flicker = change::flicker(summary.change_sum / summary.changes as f64);
        error += &format!(", est. flicker {}", relative_error_percent(flicker));
    }
    format!(
        "{} frames rendered, {} skipped, in {:.2} s ({:.2} M samples/s){error}",
        summary.rendered,
        summary.skipped,
        summary.seconds,
        summary.samples as f64 / summary.seconds.max(1e-9) / 1e6
    )
}

/// Renders the frames of one shot, with a line per frame, on the run's `devices`; its frames'
/// points are read from its surveyed caches.
fn render_shot(
    scene: &Scene,
    (targets, caches): (&Targets, &ShotPoints),
    args: &RenderArgs,
    devices: &Devices,
    progress: &Progress,
) -> Result<RunSummary, Error> {
    let start = Instant::now();
    let tracer = devices.shot(scene)?;
    // The GPU's start-up is known once its first shot is made: its tracer compiled beside
    // the shot's build.
    if args.stats
        && !args.scene_args.quiet
        && scene.render.device == Device::Gpu
        && let Some(startup) = devices.gpu_startup_once()
    {
        progress.line(&format!("gpu: {startup}"));
    }
    let shot = ShotFrames {
        scene,
        caches,
        tracer: tracer.as_ref(),
        budget: args.budget.budget(),
        progress,
    };
    let mut finishing = devices.finishing(scene)?;
    let mut summary = RunSummary::default();
    let mut error_sum = 0.0;
    for (frame, path) in targets.iter() {
        // A temporary file whose writer is gone was left by a killed run (see
        // io::remove_stale_temp_files for the rule, and the age for files of other
        // machines writing into a shared folder).
        io::remove_stale_temp_files(&path, STALE_TEMP_AGE)?;
        if args.skip_existing && kept_complete(frame, &path, progress) {
            summary.skipped += 1;
            interrupt::frame_skipped();
            progress.frame_done();
            continue;
        }
        shot.render_history(frame, &mut finishing)?;
        let (result, read) = shot.render_frame(frame, &mut finishing)?;
        let st = &result.stats;
        let non_finite =
            output::write_frame(&path, scene.output.format, scene, &result, &shot.budget)?;
        progress.line(&frame_line(
            &result,
            read.seconds,
            &shot.budget,
            non_finite,
            &path,
        ));
        if args.stats {
            let read = (!scene.points.is_empty()).then_some((read.seconds, read.points));
            let denoiser = result.denoised.as_ref().and(devices.denoiser_name());
            progress.line(&stats_line(frame, st, scene.render.device, read, denoiser));
        }
        error_sum += st.relative_error;
        summary.error_max = summary.error_max.max(st.relative_error);
        if let Some(c) = result.denoised.and_then(|d| d.change) {
            summary.change_sum += c;
            summary.changes += 1;
        }
        summary.rendered += 1;
        summary.samples += st.samples;
        summary.non_finite += st.non_finite;
        progress.frame_done();
    }
    summary.seconds = start.elapsed().as_secs_f64();
    if summary.rendered > 0 {
        summary.error_mean = error_sum / summary.rendered as f64;
    }
    Ok(summary)
}

/// Whether `frame`'s file at `path` (with --skip-existing) is complete and left alone, saying
/// so; a file that is not complete is said to be rendered again.
fn kept_complete(frame: u32, path: &Path, progress: &Progress) -> bool {
    if !path.exists() {
        return false;
    }
    match io::check_frame_file(path) {
        Ok(()) => {
            progress.line(&format!(
                "frame {frame}: {} exists, skipped",
                elide_path(path)
            ));
            true
        }
        Err(why) => {
            progress.line(&format!(
                "incomplete file {} ({why}): frame {frame} is rendered again",
                elide_path(path)
            ));
            false
        }
    }
}

/// What renders a shot's frames: its scene and surveyed point caches, the shot on its device,
/// the run's budget, and the progress the frames are shown in.
struct ShotFrames<'a> {
    scene: &'a Scene,
    caches: &'a ShotPoints,
    tracer: &'a dyn ShotTracer,
    budget: Budget,
    progress: &'a Progress,
}

/// How long a frame's points took to read, and how many there were.
struct PointsRead {
    seconds: f64,
    points: usize,
}

impl ShotFrames<'_> {
    /// Renders and finishes, through `finishing`, the frames `frame`'s history reads that this
    /// run has not rendered, as they would be in sequence, and samples the frame after it
    /// that a centred window reads; they are not written.
    fn render_history(&self, frame: u32, finishing: &mut Finishing) -> Result<(), Error> {
        for earlier in finishing.needs(frame) {
            let points = self.caches.read_frame(self.scene, earlier)?;
            let job = FrameJob::new(self.scene, earlier)
                .points(&points)
                .budget(self.budget);
            finishing.render(job, self.tracer)?;
            self.progress.line(&format!(
                "frame {earlier}: rendered for frame {frame}'s history, not written"
            ));
        }
        if let Some(next) = finishing.ahead(frame) {
            let points = self.caches.read_frame(self.scene, next)?;
            let job = FrameJob::new(self.scene, next)
                .points(&points)
                .budget(self.budget);
            finishing.render_ahead(job, self.tracer)?;
        }
        Ok(())
    }

    /// `frame` rendered and finished through `finishing`, under a progress bar of its samples
    /// (a spinner under a budget), with how its points were read (their files were surveyed
    /// before the run: here they are read and checked).
    fn render_frame(
        &self,
        frame: u32,
        finishing: &mut Finishing,
    ) -> Result<(FrameResult, PointsRead), Error> {
        let scene = self.scene;
        let read_start = Instant::now();
        let points = self.caches.read_frame(scene, frame)?;
        let read_seconds = read_start.elapsed().as_secs_f64();
        let planned = (!self.budget.is_set()).then(|| {
            scene.output.width as u64 * scene.output.height as u64 * scene.render.samples as u64
        });
        let bar = self.progress.start_frame(frame, planned);
        let progress_bar = |n| bar.inc(n);
        let job = FrameJob::new(scene, frame)
            .points(&points)
            .budget(self.budget)
            .progress(&progress_bar);
        let result = finishing.render(job, self.tracer);
        let read = PointsRead {
            seconds: read_seconds,
            points: points.len(),
        };
        drop(points);
        bar.finish_and_clear();
        Ok((result?, read))
    }
}

/// The line of a frame written to `path`: its time (with `read_seconds`, its points'), samples,
/// estimated error and speed, and the pixels written as black.
fn frame_line(
    result: &FrameResult,
    read_seconds: f64,
    budget: &Budget,
    non_finite: u64,
    path: &Path,
) -> String {
    let st = &result.stats;
    let seconds = read_seconds + st.prepare_seconds + st.render_seconds;
    let stop = if budget.is_set() {
        format!(" ({})", st.stop.describe())
    } else {
        String::new()
    };
    // The change of the error from the frame before, where it is known.
    let flicker = match result.denoised.and_then(|d| d.change) {
        Some(c) => format!(
            ", est. flicker {} from frame {}",
            relative_error_percent(change::flicker(c)),
            result.frame - 1
        ),
        None => String::new(),
    };
    format!(
        "frame {}: {seconds:.2} s, {}{stop}, est. error {}{flicker}, {:.2} M samples/s, {} non-finite, {}{}",
        result.frame,
        spp_note(st),
        frame_error_note(result),
        st.samples as f64 / st.render_seconds.max(1e-9) / 1e6,
        st.non_finite,
        non_finite_note(non_finite),
        elide_path(path)
    )
}

/// The frame line's samples per pixel: `100 spp`, or with adaptive sampling `mean 37.5 spp
/// (16 to 512)`.
fn spp_note(st: &FrameStats) -> String {
    if st.min_samples_per_pixel == st.samples_per_pixel {
        format!("{} spp", st.samples_per_pixel)
    } else {
        format!(
            "mean {:.1} spp ({} to {})",
            st.mean_samples_per_pixel, st.min_samples_per_pixel, st.samples_per_pixel
        )
    }
}

/// The frame line's note of pixels written as black because they were not finite, if any.
fn non_finite_note(pixels: u64) -> String {
    if pixels == 0 {
        String::new()
    } else {
        format!("{pixels} non-finite pixels written as 0, ")
    }
}

/// The GPU's figures of a frame's `--stats` line: the host's share of the frame's time (the
/// time it did not wait for the device) and per sample, and the bytes read back.
fn gpu_note(st: &FrameStats) -> String {
    let frame = st.prepare_seconds + st.render_seconds;
    let host = (frame - st.tile_seconds).max(0.0);
    format!(
        ", host {:.1}% ({:.2} ns a sample), read back {}",
        100.0 * host / frame.max(1e-9),
        host * 1e9 / st.samples.max(1) as f64,
        mib(st.readback_bytes)
    )
}

/// The `--stats` line of a frame rendered on `device`; `read`: the seconds its point caches
/// took to read, and their points; `denoiser`: the device that denoised it (`cpu`,
/// `cuda (NVIDIA H100 ...)`), if it was.
fn stats_line(
    frame: u32,
    st: &FrameStats,
    device: Device,
    read: Option<(f64, usize)>,
    denoiser: Option<&str>,
) -> String {
    let per_s = |n: u64| n as f64 / st.render_seconds.max(1e-9) / 1e6;
    let memory = peak_memory_bytes().map_or("unknown".to_string(), mib);
    let denoise = match denoiser {
        Some(name) => format!(
            " (denoising {:.3} s, {} denoise{}, denoiser: {name})",
            st.denoise_seconds,
            st.denoises,
            if st.denoises == 1 { "" } else { "s" }
        ),
        None => String::new(),
    };
    // The share of the render time the worker threads spent in tiles: what is missing is
    // time a core sat idle (waiting for the last tile) or spent scheduling. On the GPU, the
    // share spent waiting for the GPU's batches.
    let (busy, what) = match device {
        Device::Cpu => (
            st.tile_seconds / (st.render_seconds * rayon::current_num_threads() as f64),
            "cores",
        ),
        Device::Gpu => (st.tile_seconds / st.render_seconds, "GPU"),
    };
    let read = read.map_or(String::new(), |(s, n)| {
        format!("read {s:.3} s ({n} points), ")
    });
    let host = match device {
        Device::Cpu => String::new(),
        Device::Gpu => gpu_note(st),
    };
    format!(
        "frame {frame} stats: {read}prepare {:.4} s ({} moving spheres), render {:.3} s in {} rounds{denoise}, {what} busy {:.1}%{host}, rays {} ({:.2} M/s), samples {} ({:.2} M/s), peak memory {memory}",
        st.prepare_seconds,
        st.moving_spheres,
        st.render_seconds,
        st.rounds,
        busy.min(1.0) * 100.0,
        st.rays,
        per_s(st.rays),
        st.samples,
        per_s(st.samples),
    )
}
