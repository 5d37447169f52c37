//! Messages about a cache's files: the scene, the cache, the frame and the file named
//! before what is wrong; a frame's limit on what it holds.

use std::path::Path;

use crate::sim::ReadError;
use raytrace_core::error::{Error, elide_path};
use raytrace_core::scene::Scene;

/// Most spheres and points a frame may hold: what one hierarchy indexes (2^28 primitives).
pub(crate) const MAX_FRAME_SPHERES: u64 = 1 << 28;

/// Most snapshots a cache may hold (its file's, or its series' together): 2^20, each
/// indexed ([`super::PointLoad::INDEX_BYTES_PER_SNAPSHOT`], about 170 MiB for them all)
/// before anything renders. A file past it is refused when its index reaches it, before it
/// is read on: gzipped snapshots of one atom (a few bytes each) cannot grow the index past
/// memory.
pub(crate) const MAX_SNAPSHOTS: usize = 1 << 20;

/// A message about cache `index` of `scene` in `frame`'s file `path`.
pub(super) fn about(scene: &Scene, index: usize, frame: u32, path: &Path, what: &str) -> String {
    format!(
        "{}: points[{index}]: frame {frame}: {}: {what}",
        elide_path(&scene.source),
        elide_path(path)
    )
}

/// A reading's error, worded for cache `index` of `scene` in `frame`'s file `path`.
pub(super) fn error(scene: &Scene, index: usize, frame: u32, path: &Path, e: ReadError) -> Error {
    match e {
        ReadError::Bad(m) => Error::Scene(about(scene, index, frame, path, &m)),
        ReadError::Io(source) => Error::io(path, source),
    }
}

/// A frame may hold at most [`MAX_FRAME_SPHERES`] spheres and points.
pub(super) fn check_total(scene: &Scene, frame: u32, points: u64) -> Result<(), Error> {
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
