//! What a frame's points hold in memory, for the estimate checked before anything renders.

use super::files::{Key, Located};
use super::survey::Figures;
use crate::ply::{PART_BYTES, READ_BUFFER_BYTES};
use raytrace_core::points::PointMotion;
use raytrace_core::scene::Scene;

/// Bytes per point of a point cache in a frame at the peak: the larger of what reading holds
/// (the file's values as read, position, velocity and radius in `f64` and colour, beside
/// the sets' `f32` columns made from them) and what tracing holds (the sets' columns, `f32`
/// position, velocity and radius and colour, with the tracer's records and hierarchy,
/// [`raytrace_core::traced_points::BYTES_PER_POINT`]; reading is now the larger). Measured:
/// 0.957 GB at the peak of a frame of 1.009e7 points (docs/performance.md), film and process
/// included.
const BYTES_PER_POINT: u64 = {
    use std::mem::size_of;
    let columns = 2 * size_of::<glam::Vec3>() + size_of::<f32>() + size_of::<[f32; 3]>();
    let read = 2 * size_of::<glam::DVec3>() + size_of::<f64>() + size_of::<[f32; 3]>();
    let reading = (read + columns) as u64;
    let tracing = columns as u64 + raytrace_core::traced_points::BYTES_PER_POINT;
    if reading > tracing { reading } else { tracing }
};

/// What interpolating adds per point of the frame's own snapshot: its id, and the ids sorted
/// with their indices.
const INTERPOLATE_BYTES_PER_POINT: u64 = 8 + 16;

/// What interpolating holds per point of the next snapshot, read beside the frame's own: its
/// position and id, and its ids sorted with their indices.
const NEXT_BYTES_PER_POINT: u64 = 24 + 8 + 16;

/// The points a frame of a shot with point caches holds: its own, and those of the next
/// snapshots read beside them to interpolate towards; and the snapshots the shot's caches
/// index, held for the whole run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PointLoad {
    pub points: u64,
    pub next: u64,
    pub snapshots: u64,
}

impl PointLoad {
    /// The bytes these points hold in a frame of `scene` at the peak: [`BYTES_PER_POINT`]
    /// each (and [`INTERPOLATE_BYTES_PER_POINT`] where a cache interpolates),
    /// [`NEXT_BYTES_PER_POINT`] for each of the next snapshots', the index's
    /// [`PointLoad::INDEX_BYTES_PER_SNAPSHOT`] for each snapshot, and with point caches what
    /// reading one of their files holds (a file is read through bounded buffers, one file at a
    /// time: [`READ_BUFFER_BYTES`], and [`PointLoad::READ_BYTES_PER_THREAD`] for each thread
    /// of the pool this is called in, which read a file's rows in parts).
    pub fn bytes(&self, scene: &Scene) -> u64 {
        if scene.points.is_empty() {
            return 0;
        }
        let interpolates = scene
            .points
            .iter()
            .any(|p| p.motion == Some(PointMotion::Interpolate));
        let per_point = BYTES_PER_POINT
            + if interpolates {
                INTERPOLATE_BYTES_PER_POINT
            } else {
                0
            };
        READ_BUFFER_BYTES
            + rayon::current_num_threads() as u64 * Self::READ_BYTES_PER_THREAD
            + self.points * per_point
            + self.next * NEXT_BYTES_PER_POINT
            + self.snapshots * Self::INDEX_BYTES_PER_SNAPSHOT
    }

    /// What each thread reading a point cache's rows in parts holds: a part's rows (a PLY
    /// file's binary rows of fixed size, on the CPU whatever device traces the frame).
    pub const READ_BYTES_PER_THREAD: u64 = PART_BYTES;

    /// What the index holds per snapshot of a file of several: where it is and its header
    /// (`Located`), and its figures twice: listed as the file is read, then the map built
    /// from the list (both held at the peak).
    pub(crate) const INDEX_BYTES_PER_SNAPSHOT: u64 =
        (std::mem::size_of::<Located>() + 2 * std::mem::size_of::<(Key, Figures)>()) as u64;
}

impl From<u64> for PointLoad {
    fn from(points: u64) -> PointLoad {
        PointLoad {
            points,
            ..PointLoad::default()
        }
    }
}
