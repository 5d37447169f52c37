//! A frame's points read from a surveyed shot ([`ShotPoints::read_frame`]): each cache's
//! snapshot for the frame read and checked, its motion (the file's velocities, or the line to
//! the same id's place in the next snapshot), its looks (radii, colours from a map, materials
//! per type) and, in a periodic box, the copies of points whose path crosses a face; as the
//! core's [`PointSet`] columns, one set per material.

use std::path::Path;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::columns::{ColumnMap, map_columns};
use super::files::{Files, Key};
use super::message::{about, check_total, error};
use super::motion::{
    Crossing, file_velocities_within_box, images, interpolate, paths_within_box, sorted_ids,
};
use super::read::cell_of;
use super::read::{Read, Wanted, read_values};
use super::survey::{CacheShot, ShotPoints, SurveyDepth, frame_range};
use super::table::{self, Rows, read_snapshot};
use crate::sim::cell::Cell;
use crate::sim::{ReadError, Snapshot};
use raytrace_core::error::Error;
use raytrace_core::points::{FramePoints, PointCacheDesc, PointMotion, PointSet};
use raytrace_core::scene::Scene;
use raytrace_core::shutter::Interval;

/// A snapshot's values, with the layout and box they were read with.
struct Values {
    read: Read,
    layout: ColumnMap,
    cell: Option<Cell>,
}

/// A snapshot's values for cache `desc` of `scene`, checked as `check` checks them.
fn values_of(
    rows: &mut Rows,
    snap: &Snapshot,
    (scene, desc): (&Scene, &PointCacheDesc),
    want: Wanted,
) -> Result<Values, ReadError> {
    let layout = map_columns(&snap.columns, desc).map_err(ReadError::Bad)?;
    let cell = cell_of(snap, desc)?;
    let names: Vec<String> = snap.columns.iter().map(|c| c.label()).collect();
    let read = read_values(rows, snap.count, &names, &layout, cell.as_ref(), desc, want)?;
    file_velocities_within_box(&read, cell.as_ref(), desc, scene.shot.exposure())
        .map_err(ReadError::Bad)?;
    Ok(Values { read, layout, cell })
}

/// Reads snapshot `key` of cache `index` (a file of the frame's own, or one kept open in
/// `slot`: 0 for the frame's snapshot, 1 for the next).
fn read_key(
    scene: &Scene,
    index: usize,
    cache: &CacheShot,
    key: Key,
    frame: u32,
    slot: usize,
    want: Wanted,
) -> Result<Values, Error> {
    let desc = &scene.points[index];
    let path = cache.files.path(desc, key);
    let at = Files::frame_of(key, frame);
    let failed = |e| error(scene, index, at, &path, e);
    match (&cache.files, key) {
        (Files::Snapshots { snaps, .. }, Key::Snap(k)) => {
            let located = &snaps[k];
            let mut open = cache.open.lock().unwrap_or_else(|p| p.into_inner());
            read_snapshot(
                &path,
                desc.format,
                (located.file, located.ordinal, &located.snap),
                &mut open[slot],
                |rows| values_of(rows, &located.snap, (scene, desc), want),
            )
            .map_err(failed)
        }
        _ => {
            // A file per frame: read in the one pass that finds it holds one snapshot.
            let mut out = None;
            let visit = |ordinal, snap: &Snapshot, rows: &mut Rows| {
                if ordinal > 1 {
                    return Err(ReadError::Bad(
                        "holds more than one snapshot, and a sequence ('#') is a file per frame"
                            .into(),
                    ));
                }
                values_of(rows, snap, (scene, desc), want)
            };
            table::index(&path, desc.format, visit, |_, values| {
                out = Some(values);
                Ok(())
            })
            .map_err(failed)?;
            Ok(out.expect("a file's first snapshot is read"))
        }
    }
}

impl ShotPoints {
    /// Reads frame `frame`'s points of every cache (one the survey covered, or any other of
    /// the shot), checked. A bad value is an error naming the frame, the file (and the
    /// snapshot and line where the format has them) and the point.
    pub fn read_frame(&self, scene: &Scene, frame: u32) -> Result<FramePoints, Error> {
        let mut sets = Vec::with_capacity(scene.points.len());
        let mut total = 0;
        for (index, cache) in self.caches.iter().enumerate() {
            for set in read_cache(scene, index, cache, frame)? {
                total += set.len() as u64;
                check_total(scene, frame, total)?;
                sets.push(set);
            }
        }
        Ok(FramePoints { sets })
    }
}

/// One cache's points in `frame`, one set per material.
fn read_cache(
    scene: &Scene,
    index: usize,
    cache: &CacheShot,
    frame: u32,
) -> Result<Vec<PointSet>, Error> {
    let desc = &scene.points[index];
    let placed = cache
        .files
        .place(desc, &scene.shot, frame)
        .map_err(|m| Error::Scene(about(scene, index, frame, Path::new(&desc.file), &m)))?;
    let own_path = cache.files.path(desc, placed.key);
    let own_frame = Files::frame_of(placed.key, frame);
    let own_error = |m: String| Error::Scene(about(scene, index, own_frame, &own_path, &m));
    let mut own = read_key(scene, index, cache, placed.key, frame, 0, own_wanted(desc))?;
    let motion = own.layout.motion(desc);
    // The file's velocities, unless the next snapshot gives them (below).
    let mut velocities = match motion {
        PointMotion::Still => Vec::new(),
        PointMotion::Interpolate if placed.next.is_some() => Vec::new(),
        _ => std::mem::take(&mut own.read.velocities),
    };
    if motion == PointMotion::Interpolate
        && let Some((next_key, next_time)) = placed.next
    {
        sorted_ids(&own.read.ids).map_err(own_error)?;
        let next_want = Wanted {
            positions: true,
            ids: true,
            images: true,
            ..Wanted::default()
        };
        let next = read_key(scene, index, cache, next_key, frame, 1, next_want)?;
        let next_path = cache.files.path(desc, next_key);
        let next_frame = Files::frame_of(next_key, frame);
        let next_ids = sorted_ids(&next.read.ids)
            .map_err(|m| Error::Scene(about(scene, index, next_frame, &next_path, &m)))?;
        let dt = next_time - placed.time;
        velocities = interpolate(&own.read, &next.read, &next_ids, dt, crossing(&own, &next))
            .map_err(own_error)?;
        if let Some(cell) = &own.cell {
            paths_within_box(&velocities, scene.shot.exposure(), cell).map_err(own_error)?;
        }
    }
    if velocities.iter().all(|v| *v == DVec3::ZERO) {
        velocities = Vec::new();
    }
    let Values { mut read, cell, .. } = own;
    let radii = radii(desc, &mut read).map_err(own_error)?;
    let materials = materials(desc, &read);
    let mut points = Columns {
        radii,
        colors: colors(desc, cache.range, &read.values, read.colors),
        materials,
        centers: read.centers,
        velocities,
    };
    if let Some(cell) = cell.filter(Cell::any_periodic) {
        let interval = scene.shot.interval(frame);
        points
            .wrap(&cell, placed.time, interval)
            .map_err(own_error)?;
    }
    Ok(points.into_sets(desc, placed.time))
}

/// What a frame reads of cache `desc`'s own snapshot: positions and looks, velocities unless
/// it is still, ids and image flags to interpolate, the `color_by` values.
fn own_wanted(desc: &PointCacheDesc) -> Wanted {
    let motion = desc.motion;
    let interpolated = motion == Some(PointMotion::Interpolate);
    Wanted {
        positions: true,
        velocities: motion != Some(PointMotion::Still),
        looks: true,
        ids: interpolated,
        images: interpolated,
        values: desc.color_by.is_some(),
    }
}

/// How the paths from `own`'s points to their places in `next` cross `own`'s periodic box:
/// as written where both snapshots' positions are unwrapped (or there is no such box), by
/// the image flags where both have them, else to the nearest image.
fn crossing<'a>(own: &'a Values, next: &Values) -> Crossing<'a> {
    let continuous = own.layout.placement.unwrapped() && next.layout.placement.unwrapped();
    let flags = !own.read.images.is_empty() && !next.read.images.is_empty();
    match own.cell.as_ref().filter(|c| c.any_periodic()) {
        _ if continuous => Crossing::Direct,
        Some(c) if flags => Crossing::Images(c),
        Some(c) => Crossing::Nearest(c),
        None => Crossing::Direct,
    }
}

/// Each point's colour: its `color_by` value (`values`) through the cache's colour map over
/// `range` where it has both, else the file's (`colors`).
fn colors(
    desc: &PointCacheDesc,
    range: Option<[f64; 2]>,
    values: &[f64],
    colors: Vec<[f32; 3]>,
) -> Vec<[f32; 3]> {
    match (&desc.color_by, range) {
        (Some(c), Some(range)) => values.iter().map(|&v| c.map.color_of(v, range)).collect(),
        _ => colors,
    }
}

/// A cache's points in one frame as columns, before they are split by material.
struct Columns {
    centers: Vec<DVec3>,
    velocities: Vec<DVec3>,
    radii: Vec<f64>,
    colors: Vec<[f32; 3]>,
    /// Per point, where types give materials; else empty.
    materials: Vec<u32>,
}

impl Columns {
    /// Appends a copy of point `i` shifted by `shift` for each `(i, shift)`.
    fn add_copies(&mut self, copies: &[(usize, DVec3)]) {
        for &(i, shift) in copies {
            self.centers.push(self.centers[i] + shift);
            if !self.velocities.is_empty() {
                self.velocities.push(self.velocities[i]);
            }
            if !self.radii.is_empty() {
                self.radii.push(self.radii[i]);
            }
            if !self.colors.is_empty() {
                self.colors.push(self.colors[i]);
            }
            if !self.materials.is_empty() {
                self.materials.push(self.materials[i]);
            }
        }
    }

    /// Draws the points in the periodic box `cell` during `interval` (the points at `time`):
    /// each path moved to start inside the box, and a copy added for each face it crosses.
    fn wrap(&mut self, cell: &Cell, time: f64, interval: Interval) -> Result<(), String> {
        let (moved, copies) = images(&self.centers, &self.velocities, time, interval, cell)?;
        self.add_copies(&copies);
        for (i, shift) in moved {
            self.centers[i] += shift;
        }
        Ok(())
    }

    /// The sets, one per material (the table's first, then the types' in their order), each
    /// point in the order of the columns; positions, velocities and radii rounded to the
    /// `f32` the sets keep (see [`raytrace_core::points`]).
    fn into_sets(self, desc: &PointCacheDesc, time: f64) -> Vec<PointSet> {
        let radius = desc.radius.unwrap_or(0.0) as f32;
        let narrow = |col: &[DVec3]| -> Vec<Vec3> { col.par_iter().map(|c| c.as_vec3()).collect() };
        if self.materials.is_empty() {
            return vec![PointSet {
                material: desc.material,
                time,
                centers: narrow(&self.centers),
                velocities: narrow(&self.velocities),
                radii: self.radii.par_iter().map(|&r| r as f32).collect(),
                radius,
                colors: self.colors,
            }];
        }
        let mut order: Vec<u32> = vec![desc.material];
        order.extend(desc.types.iter().filter_map(|t| t.material));
        order.dedup();
        let mut seen = std::collections::BTreeSet::new();
        order.retain(|m| seen.insert(*m));
        order
            .into_iter()
            .map(|m| {
                let pick = |i: &usize| self.materials[*i] == m;
                let all: Vec<usize> = (0..self.centers.len()).filter(pick).collect();
                let take = |col: &[DVec3]| -> Vec<Vec3> {
                    if col.is_empty() {
                        Vec::new()
                    } else {
                        all.iter().map(|&i| col[i].as_vec3()).collect()
                    }
                };
                PointSet {
                    material: m,
                    time,
                    centers: take(&self.centers),
                    velocities: take(&self.velocities),
                    radii: if self.radii.is_empty() {
                        Vec::new()
                    } else {
                        all.iter().map(|&i| self.radii[i] as f32).collect()
                    },
                    radius,
                    colors: if self.colors.is_empty() {
                        Vec::new()
                    } else {
                        all.iter().map(|&i| self.colors[i]).collect()
                    },
                }
            })
            .filter(|s| !s.is_empty())
            .collect()
    }
}

/// The `types` entry of each distinct type read (by the type's name).
fn looks<'a>(
    desc: &'a PointCacheDesc,
    read: &Read,
) -> Vec<Option<&'a raytrace_core::points::TypeLook>> {
    read.kind_names
        .iter()
        .map(|name| desc.types.iter().find(|t| &t.key == name))
        .collect()
}

/// Each point's radius where they differ: `radius_by`'s column, else its type's, else the
/// file's radius column, else the table's `radius` (then none is kept: every point has it).
fn radii(desc: &PointCacheDesc, read: &mut Read) -> Result<Vec<f64>, String> {
    let by_type = looks(desc, read);
    if desc.radius_by.is_some() || by_type.iter().all(|t| t.is_none_or(|t| t.radius.is_none())) {
        if read.radii.is_empty() && desc.radius.is_none() && !read.centers.is_empty() {
            return Err(
                "no radius column and no radius for the points' types or in the [[points]] table"
                    .into(),
            );
        }
        return Ok(std::mem::take(&mut read.radii));
    }
    read.kinds
        .iter()
        .enumerate()
        .map(|(i, &k)| {
            by_type[k as usize]
                .and_then(|t| t.radius)
                .or_else(|| read.radii.get(i).copied())
                .or(desc.radius)
                .ok_or_else(|| {
                    format!(
                        "point {i} (type {}) has no radius: the file has no radius column, its type none in types, the [[points]] table none",
                        read.kind_names[k as usize]
                    )
                })
        })
        .collect()
}

/// Each point's material where types give some; else none.
fn materials(desc: &PointCacheDesc, read: &Read) -> Vec<u32> {
    let by_type = looks(desc, read);
    if by_type
        .iter()
        .all(|t| t.is_none_or(|t| t.material.is_none()))
    {
        return Vec::new();
    }
    read.kinds
        .iter()
        .map(|&k| {
            by_type[k as usize]
                .and_then(|t| t.material)
                .unwrap_or(desc.material)
        })
        .collect()
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
        SurveyDepth::Files,
    )?;
    shot.read_frame(scene, frame)
}
