//! The render worker: reads the shot when its files change, and renders what the pages
//! should see next, while a page is open.
//!
//! The chosen frame is rendered first, at 1, 2, 4, ... samples per pixel up to the scene's
//! samples, each pass from the start (a frame at N samples is the same bits whatever was
//! rendered before: the pixels `render --frames F --samples N` writes), so the first image
//! comes after one sample and the last pass takes about as long as all the others together;
//! then the other frames of the shot, each at [`COARSE_SAMPLES`], then at the scene's samples,
//! for the page to play.
//!
//! A pass cannot be stopped once started, so passes run on two lanes (thread pools of a
//! thread per core): when the scene changes, or another frame is chosen, during a pass, the
//! next pass starts at once on the other lane, beside the pass that is no longer wanted, whose
//! image is thrown away. Each change of scene (or of the size the pages want) starts a new
//! *generation*; a pass's image is kept only if its generation is still the board's.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use base64::Engine;

use super::board::{Board, FrameImages, Running, State, event};
use super::render::render_frame;
use super::timeline::{shot_json, view_names};
use super::views::encode_views;
use super::watch::Watch;
use crate::estimated_error::frame_error_note;
use raytrace_core::error::{Error, elide_path};
use raytrace_core::renderer::{FrameResult, ShotTracer};
use raytrace_core::scene::Scene;
use raytrace_render::devices::{Devices, room_for_points, supported};
use raytrace_render::memory::check_memory;
use raytrace_scene::point_cache::{self, PointLoad};
use raytrace_scene::scene_file::{Overrides, SceneSource};

/// The samples per pixel of a frame other than the chosen one, before it takes the scene's.
pub(crate) const COARSE_SAMPLES: u32 = 4;

/// The lanes passes run on.
const LANES: usize = 2;

/// How long the files must stay unchanged before they are read (an editor's save can be a
/// few writes).
const SETTLE: Duration = Duration::from_millis(20);

/// The frames a shot shows: the first [`MAX_TIMELINE_FRAMES`](super::timeline::MAX_TIMELINE_FRAMES) selected (in increasing order)
/// and how many are selected.
pub(crate) type Frames = (Vec<u32>, u64);

/// The frames a validated scene shows, or why it cannot show them.
pub(crate) type Select = Box<dyn Fn(&Scene) -> Result<Frames, Error> + Send>;

/// What the command gives the worker.
pub(crate) struct Setup {
    pub(crate) path: PathBuf,
    /// The command line's values in place of the file's (`--device`).
    pub(crate) overrides: Overrides,
    /// The frames shown of a validated scene (`--frames`), or why they cannot be.
    pub(crate) select: Select,
    /// Threads of each lane.
    pub(crate) threads: usize,
}

/// A shot read and validated, ready to render at one size.
struct Loaded {
    source: SceneSource,
    /// The scene at the file's size and samples.
    scene: Scene,
    overrides: Overrides,
    frames: Arc<[u32]>,
    /// How many frames are selected (`frames` holds the first of them).
    total: u64,
    /// The size rendered (the scene's, or smaller to fit the pages).
    size: (u32, u32),
    /// The most points a frame of the shot holds (with the next snapshots read beside them).
    points: PointLoad,
    generation: u64,
    /// The shot on its device.
    tracer: Box<dyn ShotTracer>,
    /// The devices opened so far: the lanes' passes share them.
    devices: Devices,
}

impl Loaded {
    /// The scene to render at `samples`, at the size rendered.
    fn scene_at(&self, samples: u32) -> Result<Scene, Error> {
        let full = (self.scene.output.width, self.scene.output.height);
        let at = overrides_at(&self.overrides, full, self.size, samples);
        validated(&self.source, &at)
    }
}

/// The scene of `source` with `overrides`, validated, and refused where its device does not
/// render it ([`supported`]: the GPU's limits depend on the size).
fn validated(source: &SceneSource, overrides: &Overrides) -> Result<Scene, Error> {
    supported(source.scene(overrides)?, overrides)
}

/// `base` with the size `size` (of a scene whose own is `full`) and `samples`. A frame is
/// shown finished alone: passes of a frame at growing samples have no history to blend, so
/// `--temporal` is left out of the preview.
fn overrides_at(base: &Overrides, full: (u32, u32), size: (u32, u32), samples: u32) -> Overrides {
    let (width, height) = match size == full {
        true => (None, None),
        false => (Some(size.0), Some(size.1)),
    };
    Overrides {
        width,
        height,
        samples: Some(samples),
        temporal: None,
        ..base.clone()
    }
}

/// What the worker does next.
enum Action {
    Read,
    Resize((u32, u32)),
    Render(Running),
}

/// The lanes passes run on.
type Lanes = [Arc<rayon::ThreadPool>; LANES];

/// Starts the worker on a thread of its own, for ever (the process ends on a signal).
pub(crate) fn start(board: Arc<Board>, setup: Setup) -> Result<(), Error> {
    let fail = |e: &dyn std::fmt::Display| Error::resource(format!("cannot start threads: {e}"));
    let pool = || {
        rayon::ThreadPoolBuilder::new()
            .num_threads(setup.threads)
            .thread_name(|i| format!("preview-{i}"))
            .build()
            .map(Arc::new)
            .map_err(|e| fail(&e))
    };
    let lanes = [pool()?, pool()?];
    let mut watch = Watch::new(Arc::clone(&board))?;
    watch.set([setup.path.clone()]);
    std::thread::Builder::new()
        .name("preview-worker".to_string())
        .spawn(move || work(&board, &setup, &lanes, &mut watch))
        .map(|_| ())
        .map_err(|e| fail(&e))
}

/// The worker's loop.
fn work(board: &Arc<Board>, setup: &Setup, lanes: &Lanes, watch: &mut Watch) {
    let mut devices = Devices::default();
    let mut loaded: Option<Arc<Loaded>> = None;
    let mut generation = 0;
    loop {
        match next_action(board, loaded.as_deref()) {
            Action::Read => {
                generation += 1;
                let size = board.lock().page_size();
                let read = read(setup, size, generation, &mut devices);
                let mut s = board.lock();
                match read {
                    Ok((l, files)) => {
                        watch.set(files);
                        publish_shot(&mut s, &l);
                        s.set_error(None);
                        loaded = Some(Arc::new(l));
                    }
                    Err(e) => {
                        // The last good shot stays, and is rendered on.
                        s.set_error(Some(&e.to_string()));
                    }
                }
                board.changed(&s);
            }
            Action::Resize(size) => {
                let Some(old) = loaded.take() else { continue };
                generation += 1;
                let resized = at_size(
                    old.source.clone(),
                    old.scene.clone(),
                    &old.overrides,
                    (Arc::clone(&old.frames), old.total),
                    (size, old.points),
                    generation,
                    &devices,
                );
                let mut s = board.lock();
                match resized {
                    Ok(l) => {
                        publish_shot(&mut s, &l);
                        loaded = Some(Arc::new(l));
                    }
                    Err(e) => {
                        s.set_error(Some(&e.to_string()));
                        loaded = Some(old);
                    }
                }
                board.changed(&s);
            }
            Action::Render(job) => {
                let l = Arc::clone(loaded.as_ref().expect("a job needs a shot"));
                let (pass_board, lane) = (Arc::clone(board), Arc::clone(&lanes[job.lane]));
                let started = std::thread::Builder::new()
                    .name("preview-pass".to_string())
                    .spawn(move || {
                        let images = lane.install(|| pass(&l, job));
                        finish(&pass_board, job, images);
                    });
                if let Err(e) = started {
                    let e = Error::resource(format!("cannot start a thread: {e}"));
                    finish(board, job, Err(e));
                }
            }
        }
    }
}

/// Waits until there is something to do: read the files (once they have settled), render at
/// another size, or a pass (marked running on the board).
fn next_action(board: &Board, loaded: Option<&Loaded>) -> Action {
    let mut s = board.lock();
    loop {
        if let Some(at) = s.changed_at {
            let left = SETTLE.saturating_sub(at.elapsed());
            if left.is_zero() {
                s.changed_at = None;
                return Action::Read;
            }
            s = board.wait(s, left);
            continue;
        }
        if let Some(l) = loaded.filter(|_| s.pages() > 0) {
            let full = (l.scene.output.width, l.scene.output.height);
            let size = fit(full, s.page_size());
            if size != l.size {
                return Action::Resize(size);
            }
            if let Some(job) = plan(&s, l) {
                s.running.push(job);
                return Action::Render(job);
            }
        }
        s = board.wait(s, Duration::from_secs(60));
    }
}

/// The next pass to start, if any: the chosen frame's next sample count (when no pass of it
/// runs and a lane is free), else, with no pass running, another frame's.
fn plan(s: &State, l: &Loaded) -> Option<Running> {
    let lane = (0..LANES).find(|i| s.running.iter().all(|r| r.lane != *i))?;
    let g = l.generation;
    let target = l.scene.render.samples;
    let have = |f: u32| match s.frames.get(&f) {
        Some(i) if i.value.generation == g => i.value.samples,
        _ => 0,
    };
    let job = |frame, samples| {
        Some(Running {
            generation: g,
            frame,
            samples,
            lane,
        })
    };
    let chosen = s.chosen.value.frame?;
    let failed = |f: u32| s.failed.contains(&(g, f));
    if !failed(chosen) && have(chosen) < target {
        if s.running
            .iter()
            .any(|r| r.generation == g && r.frame == chosen)
        {
            return None;
        }
        return job(chosen, (2 * have(chosen)).clamp(1, target));
    }
    if !s.running.is_empty() || !s.room_for_another() {
        return None;
    }
    let (before, after): (Vec<u32>, Vec<u32>) = l.frames.iter().partition(|f| **f < chosen);
    for level in [COARSE_SAMPLES.min(target), target] {
        if let Some(&f) = (after.iter().chain(&before)).find(|f| !failed(**f) && have(**f) < level)
        {
            return job(f, level);
        }
    }
    None
}

/// `full` scaled down (never up) to fit in `page`, keeping its aspect; `full` itself when it
/// fits or no page said.
pub(crate) fn fit(full: (u32, u32), page: Option<(u32, u32)>) -> (u32, u32) {
    let Some((w, h)) = page else { return full };
    let k = (w as f64 / full.0 as f64).min(h as f64 / full.1 as f64);
    if k >= 1.0 {
        return full;
    }
    let side = |n: u32| ((n as f64 * k).round() as u32).max(1);
    (side(full.0), side(full.1))
}

/// Reads and validates the shot, selects its frames, surveys their point caches and prepares
/// its geometry at the size fitting `page`; with the files to watch.
fn read(
    setup: &Setup,
    page: Option<(u32, u32)>,
    generation: u64,
    devices: &mut Devices,
) -> Result<(Loaded, Vec<PathBuf>), Error> {
    let source = SceneSource::read(&setup.path)?;
    let scene = validated(&source, &setup.overrides)?;
    let (frames, total) = (setup.select)(&scene)?;
    let mut files = vec![setup.path.clone()];
    let span = || point_cache::frame_list(&frames);
    let caches =
        point_cache::ShotPoints::survey(&scene, span(), span(), point_cache::SurveyDepth::Files)?;
    for &f in &frames {
        files.extend(caches.frame_files(&scene, f)?);
    }
    room_for_points(&scene, &setup.overrides, caches.most().points)?;
    devices.open_for([&scene])?;
    let size = fit((scene.output.width, scene.output.height), page);
    let loaded = at_size(
        source,
        scene,
        &setup.overrides,
        (frames.into(), total),
        (size, caches.most()),
        generation,
        devices,
    )?;
    Ok((loaded, files))
}

/// The shot of `source` (validated as `scene`, its frames of at most `points`) ready to
/// render at `size`, as `generation`.
fn at_size(
    source: SceneSource,
    scene: Scene,
    overrides: &Overrides,
    (frames, total): (Arc<[u32]>, u64),
    (size, points): ((u32, u32), PointLoad),
    generation: u64,
    devices: &Devices,
) -> Result<Loaded, Error> {
    let full = (scene.output.width, scene.output.height);
    let sized = validated(
        &source,
        &overrides_at(overrides, full, size, scene.render.samples),
    )?;
    Ok(Loaded {
        tracer: devices.shot(&sized)?,
        source,
        scene,
        overrides: overrides.clone(),
        frames,
        total,
        size,
        points,
        generation,
        devices: devices.clone(),
    })
}

/// Puts a new shot (or size) on the board.
fn publish_shot(s: &mut State, l: &Loaded) {
    let name = elide_path(&l.scene.source).to_string();
    let json = shot_json(&l.scene, &name, &l.frames, l.total, l.size, l.generation);
    s.generation = l.generation;
    s.failed.clear();
    s.set_shot(
        event("shot", &json),
        Arc::clone(&l.frames),
        view_names(&l.scene),
    );
}

/// Renders one pass and encodes its views as `image` events. A frame that would not fit in
/// the memory available at the size rendered is refused before anything of it is allocated,
/// as `check` and `render` refuse it ([`check_memory`]); the page shows why.
fn pass(l: &Loaded, job: Running) -> Result<FrameImages, Error> {
    let scene = l.scene_at(job.samples)?;
    check_memory(&scene, l.points)?;
    let result = render_frame(&scene, &l.devices, l.tracer.as_ref(), job.frame)?;
    let views = encode_views(&scene, &result)?;
    let figures = figures(&result, l.scene.render.samples);
    let events = views
        .into_iter()
        .map(|v| {
            let png = base64::engine::general_purpose::STANDARD.encode(&v.png);
            let data = serde_json::json!({
                "frame": job.frame,
                "generation": job.generation,
                "view": v.name,
                "samples": job.samples,
                "target": l.scene.render.samples,
                "width": result.film.width,
                "height": result.film.height,
                "line": figures,
                "png": format!("data:image/png;base64,{png}"),
            });
            (v.name, event("image", &data.to_string()))
        })
        .collect();
    Ok(FrameImages {
        generation: job.generation,
        samples: job.samples,
        events,
    })
}

/// The frame line of a pass: `frame 3: 8 of 32 spp, est. error 4.210%, 1.93 M samples/s,
/// 0.12 s`.
fn figures(result: &FrameResult, target: u32) -> String {
    let st = &result.stats;
    format!(
        "frame {}: {} of {target} spp, est. error {}, {:.2} M samples/s, {:.2} s",
        result.frame,
        st.samples_per_pixel,
        frame_error_note(result),
        st.samples as f64 / st.render_seconds.max(1e-9) / 1e6,
        st.prepare_seconds + st.render_seconds
    )
}

/// A pass ended: its images go on the board if its generation is still the board's; a
/// failure is shown, and the frame is not tried again in this generation.
fn finish(board: &Board, job: Running, images: Result<FrameImages, Error>) {
    let mut s = board.lock();
    s.running.retain(|r| *r != job);
    if job.generation == s.generation {
        match images {
            Ok(images) => s.set_frame(job.frame, images),
            Err(e) => {
                s.failed.insert((job.generation, job.frame));
                s.set_error(Some(&e.to_string()));
            }
        }
    }
    board.changed(&s);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_page_smaller_than_the_frame_gets_the_frame_scaled_to_fit() {
        assert_eq!(fit((320, 180), None), (320, 180));
        assert_eq!(fit((320, 180), Some((1000, 1000))), (320, 180));
        assert_eq!(fit((320, 180), Some((160, 1000))), (160, 90));
        assert_eq!(fit((320, 180), Some((1000, 45))), (80, 45));
        assert_eq!(fit((1000, 1), Some((10, 10))), (10, 1));
    }
}
