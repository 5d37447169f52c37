//! The jobs of a run: each scene given, validated, with the frames the run renders of it
//! (`--frames`, then the chunk, counted over every scene) and their files, all checked before
//! anything is rendered. `render` and `check` share them, and `clip` the frame selection.

use std::path::PathBuf;

use super::args::FramesArg;
use super::frames::{Selection, batch_chunk};
use raytrace_core::error::{Error, elide_path};
use raytrace_core::path_pattern::{self, FramePattern};
use raytrace_core::scene::Scene;
use raytrace_io as io;
use raytrace_render::devices::{room_for_points, supported};
use raytrace_scene::point_cache::{Frames, PointLoad, ShotPoints, SurveyDepth};
use raytrace_scene::scene_file::Overrides;
use raytrace_scene::scene_file::SceneFile;

/// The frames of `scene` that `frames` asks for (every frame: the whole shot), before a run's
/// chunk is taken ([`batch_chunk`]). Ranges, never a list: any shot length costs the same.
pub(crate) fn select_frames(scene: &Scene, frames: &FramesArg) -> Result<Selection, Error> {
    let (first, last) = (scene.shot.first_frame, scene.shot.last_frame());
    match frames {
        FramesArg::Every => Ok(Selection::range(first, last)),
        FramesArg::Spec(spec) => {
            Selection::parse(spec, first, last).map_err(|e| Error::Usage(format!("--frames: {e}")))
        }
    }
}

/// The frames a run renders and the file of each.
#[derive(Clone, Debug)]
pub(crate) struct Targets {
    pub(crate) frames: Selection,
    pub(crate) pattern: FramePattern,
}

impl Targets {
    /// Each frame with its file, in order, made as they are asked for.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (u32, PathBuf)> + '_ {
        self.frames
            .iter()
            .map(|f| (f, path_pattern::frame_path(&self.pattern, f)))
    }
}

/// The files of the frames `selected` of `scene` (this run's chunk of `whole`, the frames
/// asked for), checked before anything is rendered: one file per frame of `whole`, which the
/// chunks of a farm write between them, and file names the system can take (the longest is
/// the last frame's). `check`, which takes no chunk, runs the same checks.
fn targets_of(scene: &Scene, selected: Selection, whole: &Selection) -> Result<Targets, Error> {
    let pattern = &scene.output.path;
    if whole.len() > 1 && !path_pattern::pattern_has_frame_number(pattern) {
        return Err(Error::Usage(format!(
            "output path \"{}\" has no '#' for the frame number, so {} frames would overwrite one file",
            raytrace_core::error::elide(pattern),
            whole.len()
        )));
    }
    for frame in [selected.first(), selected.last()].into_iter().flatten() {
        io::check_target(&path_pattern::frame_path(pattern, frame))
            .map_err(|e| Error::Usage(format!("output path: {e}")))?;
    }
    Ok(Targets {
        frames: selected,
        pattern: pattern.clone(),
    })
}

/// One job of a run: a shot's scene and the frames the run renders of it.
pub(crate) struct Job {
    pub(crate) path: PathBuf,
    pub(crate) scene: Scene,
    pub(crate) targets: Targets,
    /// The most points one of the frames holds, over the scene's point caches (0 without),
    /// and the most of the next snapshots read beside them.
    pub(crate) points: PointLoad,
    /// The shot's point caches, surveyed for the frames the run renders: what frames read.
    pub(crate) caches: ShotPoints,
}

/// Surveys the point caches of the frames `targets` renders (each file exists, is a file of
/// its format with the columns its cache needs and the data its header declares: see
/// [`ShotPoints::survey`]), with the colour range found over `selected` (the frames before a
/// chunk is taken, so that every chunk colours alike) at `depth`.
fn survey_points(
    scene: &Scene,
    targets: &Targets,
    selected: &Selection,
    depth: SurveyDepth,
) -> Result<ShotPoints, Error> {
    ShotPoints::survey(
        scene,
        survey_frames(&targets.frames),
        survey_frames(selected),
        depth,
    )
}

/// The frames of `s` as a point caches' survey takes them; `None` for no frames.
pub(crate) fn survey_frames(s: &Selection) -> Option<Frames<'_>> {
    s.first().zip(s.last()).map(|(first, last)| Frames {
        first,
        last,
        each: Box::new(s.iter()),
    })
}

/// Loads and validates every scene of a run, selects the frames of each (`--frames` applies
/// to each scene; a chunk counts over the frames of all of them, in order), and checks their
/// files (and the point caches' files of those frames), before anything is rendered: any bad
/// scene or argument fails the whole run.
/// Several scenes must not write the same files, so with several scenes an `--output` (or a
/// `--clip`) must hold `{scene}`. `depth` is how much of the point caches' files the survey
/// reads (`check` reads every value).
pub(crate) fn load_shots(
    paths: &[PathBuf],
    overrides: &Overrides,
    frames: &FramesArg,
    chunk: Option<(u64, u64)>,
    depth: SurveyDepth,
) -> Result<Vec<Job>, Error> {
    if paths.len() > 1 {
        for (flag, value) in [("--output", &overrides.output), ("--clip", &overrides.clip)] {
            if let Some(v) = value
                && !path_pattern::pattern_has_scene(v)
            {
                return Err(Error::Usage(format!(
                    "{flag} \"{}\" has no {{scene}}, so the {} scenes would write the same files: \
                     put {{scene}} (the scene file's name) in it",
                    raytrace_core::error::elide(v),
                    paths.len()
                )));
            }
        }
    }
    let mut scenes = Vec::with_capacity(paths.len());
    let mut selections = Vec::with_capacity(paths.len());
    for path in paths {
        let scene = supported(Scene::load_with(path, overrides)?, overrides)?;
        selections.push(select_frames(&scene, frames)?);
        scenes.push(scene);
    }
    let whole = selections.clone();
    if let Some((size, index)) = chunk {
        selections = batch_chunk(&selections, size, index).map_err(Error::Usage)?;
    }
    let mut shots = Vec::with_capacity(paths.len());
    for (((path, scene), selected), whole) in paths.iter().zip(scenes).zip(selections).zip(&whole) {
        let targets = targets_of(&scene, selected, whole)?;
        let caches = survey_points(&scene, &targets, whole, depth)?;
        room_for_points(&scene, overrides, caches.most().points)?;
        shots.push(Job {
            path: path.clone(),
            scene,
            targets,
            points: caches.most(),
            caches,
        });
    }
    check_distinct(&shots)?;
    Ok(shots)
}

/// Refuses shots that would write the same frame files or the same clip: the same output
/// pattern with overlapping frame ranges, or the same clip path.
fn check_distinct(shots: &[Job]) -> Result<(), Error> {
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
                Some(format!(
                    "frames \"{}\"",
                    raytrace_core::error::elide(&ta.pattern)
                ))
            } else {
                match (&a.scene.output.clip, &b.scene.output.clip) {
                    (Some(ca), Some(cb)) if ca == cb => {
                        Some(format!("the clip \"{}\"", raytrace_core::error::elide(ca)))
                    }
                    _ => None,
                }
            };
            if let Some(what) = what {
                return Err(Error::Usage(format!(
                    "{} and {} would both write {what}: give them different output paths \
                     (with {{scene}}, the scene file's name)",
                    elide_path(&a.path),
                    elide_path(&b.path)
                )));
            }
        }
    }
    Ok(())
}
