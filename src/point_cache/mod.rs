//! Point caches read for a shot: the files a shot's frames need, surveyed once before
//! anything renders ([`ShotPoints::survey`]), and each frame's points read from them when it
//! renders ([`ShotPoints::read_frame`]) into the core's [`crate::points::FramePoints`].
//!
//! Formats: PLY ([`crate::ply`]), LAMMPS text dumps, extended XYZ and VTK point data
//! ([`crate::sim`]); a cache's file is one file for every frame, a sequence (`#`: a file per
//! frame) or a series (`*`: one file a snapshot, as LAMMPS names them).
//!
//! The rooms: `files` (which snapshot each frame shows, and when), `table` (a file's
//! snapshots in any format: indexing, reading rows), `layout` (which columns mean what),
//! `read` (values read and checked), `motion` (interpolation by id, periodic copies),
//! `survey` (the shot's survey, check's figures), `frame` (a frame's points).

mod files;
mod frame;
mod layout;
mod motion;
mod read;
mod survey;
mod table;

use std::path::Path;

pub use survey::{Depth, FrameSurvey, Frames, ShotPoints};

use crate::error::{Error, elide_path};
use crate::points::FramePoints;
use crate::scene::Scene;
use crate::sim::ReadError;

/// Most spheres and points a frame may hold: what one hierarchy indexes (2^28 primitives).
pub const MAX_FRAME_SPHERES: u64 = 1 << 28;

/// A message about cache `index` of `scene` in `frame`'s file `path`.
fn about(scene: &Scene, index: usize, frame: u32, path: &Path, what: &str) -> String {
    format!(
        "{}: points[{index}]: frame {frame}: {}: {what}",
        elide_path(&scene.source),
        elide_path(path)
    )
}

/// A reading's error, worded for cache `index` of `scene` in `frame`'s file `path`.
fn error(scene: &Scene, index: usize, frame: u32, path: &Path, e: ReadError) -> Error {
    match e {
        ReadError::Bad(m) => Error::Scene(about(scene, index, frame, path, &m)),
        ReadError::Io(source) => Error::io(path, source),
    }
}

/// A frame may hold at most [`MAX_FRAME_SPHERES`] spheres and points.
fn check_total(scene: &Scene, frame: u32, points: u64) -> Result<(), Error> {
    let all = points + scene.spheres.len() as u64;
    if all > MAX_FRAME_SPHERES {
        return Err(Error::Scene(format!(
            "{}: frame {frame} holds {points} points and {} spheres, more than the {MAX_FRAME_SPHERES} a frame can hold",
            elide_path(&scene.source),
            scene.spheres.len()
        )));
    }
    Ok(())
}

/// The frames `first..=last`, each.
pub fn frame_range<'a>(first: u32, last: u32) -> Frames<'a> {
    Frames {
        first,
        last,
        each: Box::new(first..=last),
    }
}

/// Reads frame `frame`'s points of every cache of `scene`, surveying that frame alone first
/// (its colour range, where not given, is the frame's own): for commands that render a
/// frame by itself.
pub fn read_frame(scene: &Scene, frame: u32) -> Result<FramePoints, Error> {
    if scene.points.is_empty() {
        return Ok(FramePoints::none());
    }
    let shot = ShotPoints::survey(
        scene,
        Some(frame_range(frame, frame)),
        Some(frame_range(frame, frame)),
        Depth::Files,
    )?;
    shot.read_frame(scene, frame)
}
