//! `raytrace render`: loads and validates the scene with the command line's overrides,
//! selects the frames, renders each and writes it atomically, with a progress bar and a line
//! per frame.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::frames::{Selection, batch_chunk};
use super::progress::Progress;
use super::{RenderArgs, interrupt};
use crate::clip;
use crate::error::{Error, clip_path};
use crate::film::Film;
use crate::io::{self, FrameInfo};
use crate::passes::PassImages;
use crate::render::{FrameStats, memory_estimate, render_frame};
use crate::scene::{Overrides, Scene};
use crate::shutter::ShutterCurve;
use crate::world::StaticGeometry;

/// Age after which a temporary frame file of another machine (or of an earlier version, whose
/// names record no machine) is removed when its writer is not running here.
pub(crate) const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(60);

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
}

/// The frames a run renders: the `--frames` selection (absent or bare: the whole shot), then
/// the chunk. Ranges, never a list: any shot length costs the same.
pub(crate) fn select_frames(
    scene: &Scene,
    frames: Option<&Option<String>>,
    chunk: Option<(u64, u64)>,
) -> Result<Selection, Error> {
    let (first, last) = (scene.shot.first_frame, scene.shot.last_frame());
    let all = match frames {
        None | Some(None) => Selection::range(first, last),
        Some(Some(spec)) => Selection::parse(spec, first, last)
            .map_err(|e| Error::Usage(format!("--frames: {e}")))?,
    };
    match chunk {
        None => Ok(all),
        Some((size, index)) => all.chunk(size, index).map_err(Error::Usage),
    }
}

/// The frames a run renders and the file of each.
#[derive(Clone, Debug)]
pub(crate) struct Targets {
    pub(crate) frames: Selection,
    pattern: String,
}

impl Targets {
    /// Each frame with its file, in order, made as they are asked for.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (u32, PathBuf)> + '_ {
        self.frames
            .iter()
            .map(|f| (f, io::frame_path(&self.pattern, f)))
    }
}

/// The files of the frames `selected` of `scene`, checked before anything is rendered: one
/// file per frame, and file names the system can take (the longest is the last frame's).
/// `check` runs the same checks.
fn targets_of(scene: &Scene, selected: Selection) -> Result<Targets, Error> {
    let pattern = &scene.output.path;
    if selected.len() > 1 && !io::pattern_has_frame_number(pattern) {
        return Err(Error::Usage(format!(
            "output path \"{}\" has no '#' for the frame number, so {} frames would overwrite one file",
            crate::error::clip(pattern),
            selected.len()
        )));
    }
    for frame in [selected.first(), selected.last()].into_iter().flatten() {
        io::check_target(&io::frame_path(pattern, frame))
            .map_err(|e| Error::Usage(format!("output path: {e}")))?;
    }
    Ok(Targets {
        frames: selected,
        pattern: pattern.clone(),
    })
}

/// One shot of a run: its scene and the frames the run renders of it.
pub(crate) struct Shot {
    pub(crate) path: PathBuf,
    pub(crate) scene: Scene,
    pub(crate) targets: Targets,
}

/// Loads and validates every scene of a run, selects the frames of each (`--frames` applies
/// to each scene; a chunk counts over the frames of all of them, in order), and checks their
/// files, before anything is rendered: any bad scene or argument fails the whole run.
/// Several scenes must not write the same files, so with several scenes an `--output` (or a
/// `--clip`) must hold `{scene}`.
pub(crate) fn load_shots(
    paths: &[PathBuf],
    overrides: &Overrides,
    frames: Option<&Option<String>>,
    chunk: Option<(u64, u64)>,
) -> Result<Vec<Shot>, Error> {
    if paths.len() > 1 {
        for (flag, value) in [("--output", &overrides.output), ("--clip", &overrides.clip)] {
            if let Some(v) = value
                && !io::pattern_has_scene(v)
            {
                return Err(Error::Usage(format!(
                    "{flag} \"{}\" has no {{scene}}, so the {} scenes would write the same files: \
                     put {{scene}} (the scene file's name) in it",
                    crate::error::clip(v),
                    paths.len()
                )));
            }
        }
    }
    let mut scenes = Vec::with_capacity(paths.len());
    let mut selections = Vec::with_capacity(paths.len());
    for path in paths {
        let scene = Scene::load_with(path, overrides)?;
        selections.push(select_frames(&scene, frames, None)?);
        scenes.push(scene);
    }
    if let Some((size, index)) = chunk {
        selections = batch_chunk(&selections, size, index).map_err(Error::Usage)?;
    }
    let mut shots = Vec::with_capacity(paths.len());
    for ((path, scene), selected) in paths.iter().zip(scenes).zip(selections) {
        let targets = targets_of(&scene, selected)?;
        shots.push(Shot {
            path: path.clone(),
            scene,
            targets,
        });
    }
    check_distinct(&shots)?;
    Ok(shots)
}

/// Refuses shots that would write the same frame files or the same clip: the same output
/// pattern with overlapping frame ranges, or the same clip path.
fn check_distinct(shots: &[Shot]) -> Result<(), Error> {
    for (i, a) in shots.iter().enumerate() {
        for b in &shots[i + 1..] {
            let (ta, tb) = (&a.targets, &b.targets);
            let overlap = match (ta.frames.first(), ta.frames.last()) {
                (Some(a0), Some(a1)) => tb
                    .frames
                    .first()
                    .zip(tb.frames.last())
                    .is_some_and(|(b0, b1)| a0 <= b1 && b0 <= a1),
                _ => false,
            };
            let what = if ta.pattern == tb.pattern && overlap {
                Some(format!("frames \"{}\"", crate::error::clip(&ta.pattern)))
            } else {
                match (&a.scene.output.clip, &b.scene.output.clip) {
                    (Some(ca), Some(cb)) if ca == cb => {
                        Some(format!("the clip \"{}\"", crate::error::clip(ca)))
                    }
                    _ => None,
                }
            };
            if let Some(what) = what {
                return Err(Error::Usage(format!(
                    "{} and {} would both write {what}: give them different output paths \
                     (with {{scene}}, the scene file's name)",
                    clip_path(&a.path),
                    clip_path(&b.path)
                )));
            }
        }
    }
    Ok(())
}

/// Renders the selected frames of every scene and writes them, then the clips asked for.
/// Everything that can be checked before rendering (scenes, arguments, output names, clips)
/// is checked before anything is written.
pub(crate) fn render(args: &RenderArgs) -> Result<RunSummary, Error> {
    let chunk = args.chunk_size.zip(args.chunk);
    let shots = load_shots(&args.scenes, &args.overrides(), args.frames.as_ref(), chunk)?;
    let mut estimate = 0;
    for shot in &shots {
        estimate = estimate.max(check_memory(&shot.scene)?);
        if let Some(c) = &shot.scene.output.clip
            && !args.no_clip
        {
            if chunk.is_some() {
                return Err(Error::Usage(format!(
                    "{}: [output] clip asks for the clip {}, which one chunk cannot make: pass --no-clip to render the chunk without it, and make the clip with `raytrace clip` in a job after the array's",
                    clip_path(&shot.path),
                    crate::error::clip(c)
                )));
            }
            clip::check(Path::new(c), shot.scene.shot.fps)?;
        }
    }
    if args.stats && !args.scene_args.quiet {
        super::progress::print_line(&format!("memory: about {}", mib(estimate)));
    }
    super::thread_pool(args.scene_args.threads)?.install(|| render_shots(&shots, args))
}

/// The memory a render of `scene` needs ([`memory_estimate`]), or, if that is more than the
/// machine has available (Linux: `MemAvailable`; elsewhere not checked), a usage error that
/// says what to lower.
pub(crate) fn check_memory(scene: &Scene) -> Result<u64, Error> {
    let estimate = memory_estimate(scene);
    match available_memory_bytes() {
        Some(available) if estimate > available => Err(Error::Usage(format!(
            "a frame of {}x{} pixels with {} spheres needs about {} of memory, and {} is available: lower --width/--height or use fewer spheres",
            scene.output.width,
            scene.output.height,
            scene.spheres.len(),
            mib(estimate),
            mib(available)
        ))),
        _ => Ok(estimate),
    }
}

/// Bytes in MiB, as `12.3 MiB`.
pub(crate) fn mib(bytes: u64) -> String {
    format!("{:.1} MiB", bytes as f64 / 1048576.0)
}

/// The memory available to a new process (Linux: `MemAvailable` in `/proc/meminfo`).
fn available_memory_bytes() -> Option<u64> {
    proc_bytes("/proc/meminfo", "MemAvailable:")
}

/// A figure in kB from a Linux `/proc` file (`KEY: N kB`), in bytes.
fn proc_bytes(file: &str, key: &str) -> Option<u64> {
    let text = std::fs::read_to_string(file).ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// Renders every shot under one progress bar, with a summary line per shot (when there are
/// several) and one for the run; then makes the clips asked for (unless --no-clip).
fn render_shots(shots: &[Shot], args: &RenderArgs) -> Result<RunSummary, Error> {
    let start = Instant::now();
    let total: u64 = shots.iter().map(|s| s.targets.frames.len()).sum();
    let progress = Progress::new(total, args.scene_args.quiet);
    interrupt::frames_selected(total);
    let mut run = RunSummary::default();
    // A shot the run's chunk does not reach is not started (its static geometry not built).
    for shot in shots.iter().filter(|s| s.targets.frames.len() > 0) {
        let summary = render_shot(&shot.scene, &shot.targets, args, &progress)?;
        if shots.len() > 1 {
            progress.line(&format!(
                "{}: {}",
                clip_path(&shot.path),
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
    }
}

/// `12 frames rendered, 0 skipped, in 3.21 s (1.23 M samples/s), est. error mean ... max ...`.
fn summary_text(summary: &RunSummary) -> String {
    let error = if summary.rendered == 0 {
        String::new()
    } else {
        format!(
            ", est. error mean {} max {}",
            percent(summary.error_mean),
            percent(summary.error_max)
        )
    };
    format!(
        "{} frames rendered, {} skipped, in {:.2} s ({:.2} M samples/s){error}",
        summary.rendered,
        summary.skipped,
        summary.seconds,
        summary.samples as f64 / summary.seconds.max(1e-9) / 1e6
    )
}

/// Renders the frames of one shot, with a line per frame.
fn render_shot(
    scene: &Scene,
    targets: &Targets,
    args: &RenderArgs,
    progress: &Progress,
) -> Result<RunSummary, Error> {
    let start = Instant::now();
    let budget = args.budget.budget();
    let statics = StaticGeometry::new(scene);
    let mut summary = RunSummary::default();
    let mut error_sum = 0.0;
    for (frame, path) in targets.iter() {
        // A temporary file whose writer is gone was left by a killed run (see
        // io::remove_stale_temp_files for the rule, and the age for files of other
        // machines writing into a shared folder).
        io::remove_stale_temp_files(&path, STALE_TEMP_AGE)?;
        if args.skip_existing && path.exists() {
            match io::check_frame_file(&path) {
                Ok(()) => {
                    progress.line(&format!(
                        "frame {frame}: {} exists, skipped",
                        clip_path(&path)
                    ));
                    summary.skipped += 1;
                    interrupt::frame_skipped();
                    progress.frame_done();
                    continue;
                }
                Err(why) => progress.line(&format!(
                    "incomplete file {} ({why}): frame {frame} is rendered again",
                    clip_path(&path)
                )),
            }
        }
        let planned = (!budget.is_set()).then(|| {
            scene.output.width as u64 * scene.output.height as u64 * scene.render.samples as u64
        });
        let bar = progress.start_frame(frame, planned);
        let result = render_frame(scene, &statics, frame, &budget, &|n| bar.inc(n));
        bar.finish_and_clear();
        let st = &result.stats;
        let mut info = frame_info(scene, frame, st.samples_per_pixel);
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
        if st.min_samples_per_pixel != st.samples_per_pixel {
            info.extra
                .push(("minSamples".to_string(), st.min_samples_per_pixel as f64));
            info.extra
                .push(("meanSamples".to_string(), st.mean_samples_per_pixel));
        }
        let passes = result.passes.as_ref().map(|p| (p, scene.transparent));
        let non_finite = write_film_with_passes(&path, &result.film, passes, info)?;
        let seconds = st.prepare_seconds + st.render_seconds;
        let stop = if budget.is_set() {
            format!(" ({})", st.stop.describe())
        } else {
            String::new()
        };
        progress.line(&format!(
            "frame {frame}: {seconds:.2} s, {}{stop}, est. error {}, {:.2} M samples/s, {} non-finite, {}{}",
            spp_note(st),
            percent(st.relative_error),
            st.samples as f64 / st.render_seconds.max(1e-9) / 1e6,
            st.non_finite,
            non_finite_note(non_finite),
            clip_path(&path)
        ));
        if args.stats {
            progress.line(&stats_line(frame, st));
        }
        error_sum += st.relative_error;
        summary.error_max = summary.error_max.max(st.relative_error);
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

/// The frame line's samples per pixel: `100 spp`, or with adaptive sampling `mean 37.5 spp
/// (16 to 512)`.
fn spp_note(st: &crate::render::FrameStats) -> String {
    if st.min_samples_per_pixel == st.samples_per_pixel {
        format!("{} spp", st.samples_per_pixel)
    } else {
        format!(
            "mean {:.1} spp ({} to {})",
            st.mean_samples_per_pixel, st.min_samples_per_pixel, st.samples_per_pixel
        )
    }
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
        rolling_shutter_readout: scene.shot.rolling.map(|r| r.readout),
        shutter_curve: (scene.shot.curve != ShutterCurve::Box).then(|| scene.shot.curve.describe()),
        extra: Vec::new(),
    }
}

/// Writes `film` to `path` with the attributes `info`. A pixel that is not finite as an
/// `f32` (NaN, infinite, or a mean beyond `f32::MAX`) is written black; their number is
/// returned and, when not 0, recorded in the file as `nonFinitePixels`.
pub(crate) fn write_film(path: &Path, film: &Film, info: FrameInfo) -> Result<u64, Error> {
    write_film_with_passes(path, film, None, info)
}

/// [`write_film`] with the frame's passes, if any, and whether the colour is premultiplied
/// by their alpha (a transparent background).
pub(crate) fn write_film_with_passes(
    path: &Path,
    film: &Film,
    passes: Option<(&PassImages, bool)>,
    mut info: FrameInfo,
) -> Result<u64, Error> {
    let non_finite = film.non_finite();
    if non_finite > 0 {
        info.extra
            .push(("nonFinitePixels".to_string(), non_finite as f64));
    }
    let (channels, premultiplied) =
        passes.map_or((&[][..], false), |(p, pre)| (&p.channels[..], pre));
    let width = film.width as usize;
    let rgb = |i: usize| film.rgb_f32((i % width) as u32, (i / width) as u32);
    io::write_frame_from(
        path,
        film.width,
        film.height,
        &rgb,
        channels,
        premultiplied,
        &info,
    )?;
    Ok(non_finite)
}

/// The frame line's note of pixels written as black because they were not finite, if any.
fn non_finite_note(pixels: u64) -> String {
    if pixels == 0 {
        String::new()
    } else {
        format!("{pixels} non-finite pixels written as 0, ")
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
    let memory = peak_memory_bytes().map_or("unknown".to_string(), mib);
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
    proc_bytes("/proc/self/status", "VmHWM:")
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

    #[test]
    fn pixels_beyond_f32_are_written_finite_and_counted() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.exr");
        let scene = Scene::parse("", Path::new("empty.toml")).unwrap();
        // Finite means in f64 that no f32 holds.
        let film = Film::from_fn(3, 2, |x, y| match (x, y) {
            (0, 0) => DVec3::splat(0.5),
            (1, 0) => DVec3::new(1e39, 0.0, 0.0),
            (2, 1) => DVec3::new(0.0, -1e300, 1.0),
            _ => DVec3::ZERO,
        });
        let info = frame_info(&scene, 1, 4);
        assert_eq!(write_film(&path, &film, info).unwrap(), 2);
        let (w, h, pixels) = io::read_exr_rgb(&path).unwrap();
        assert_eq!((w, h), (3, 2));
        assert!(pixels.iter().all(|p| p.is_finite()));
        assert_eq!(pixels[0], DVec3::splat(0.5));
        assert_eq!(pixels[1], DVec3::ZERO);
        let image = ::exr::prelude::read_all_data_from_file(&path).unwrap();
        let count = image.layer_data[0]
            .attributes
            .other
            .get(&::exr::meta::attribute::Text::from("nonFinitePixels"))
            .cloned();
        assert_eq!(
            count,
            Some(::exr::meta::attribute::AttributeValue::F64(2.0))
        );
    }
}
