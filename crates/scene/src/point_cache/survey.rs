//! The survey of a shot's point caches, before anything renders: every file of the frames a
//! command renders opened and indexed once (a file of many snapshots: where each begins), its
//! columns checked against what the cache needs, the snapshots matched to frames, the colour
//! range found where `color_range` is not given, and what a frame will hold counted for the
//! memory estimate. `check` reads every value once here ([`SurveyDepth::Values`]); `render` reads a
//! frame's values when it renders it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use glam::DVec3;

use super::columns::map_columns;
use super::files::{Files, Key, Located, series, timestep_time};
use super::load::PointLoad;
use super::message::{MAX_FRAME_SPHERES, MAX_SNAPSHOTS, about, error};
use super::motion::file_velocities_within_box;
use super::read::{Wanted, read_values};
use super::table::{self, OpenText};
use crate::sim::ReadError;
use raytrace_core::error::Error;
use raytrace_core::points::{PointCacheDesc, PointMotion, SnapshotTime};
use raytrace_core::scene::Scene;

/// The frames `first..=last`, each.
pub(crate) fn frame_range<'a>(first: u32, last: u32) -> Frames<'a> {
    Frames {
        first,
        last,
        each: Box::new(first..=last),
    }
}

/// The frames of `list` (in increasing order); `None` when it is empty.
pub fn frame_list(list: &[u32]) -> Option<Frames<'_>> {
    list.first().zip(list.last()).map(|(&first, &last)| Frames {
        first,
        last,
        each: Box::new(list.iter().copied()),
    })
}

/// How much of each file a survey reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurveyDepth {
    /// Headers and the layout of the text (every line of a text format, not parsed).
    Files,
    /// Every value the caches use, checked (`check`).
    Values,
}

/// Frames a command covers, in increasing order: the first, the last, and each (taken only
/// where each frame has a file of its own, a sequence's).
pub struct Frames<'a> {
    pub first: u32,
    pub last: u32,
    pub each: Box<dyn Iterator<Item = u32> + 'a>,
}

/// What a survey found of one snapshot.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Figures {
    pub(super) count: u64,
    /// Points with a non-zero velocity (read at [`SurveyDepth::Values`]).
    pub(super) moving: Option<u64>,
    /// The least and greatest `color_by` values.
    pub(super) range: Option<[f64; 2]>,
}

/// One cache of a shot, surveyed.
pub(super) struct CacheShot {
    pub(super) files: Files,
    pub(super) figures: BTreeMap<Key, Figures>,
    /// The colour map's range: given, or found over the frames selected.
    pub(super) range: Option<[f64; 2]>,
    /// Text files kept open between frames: for the frame's own snapshot, and for the next.
    pub(super) open: Mutex<[Option<OpenText>; 2]>,
    /// Files the survey read.
    pub(super) reads: usize,
}

/// A shot's point caches, surveyed: what frames read of them, in the order of the scene's
/// `[[points]]` tables.
pub struct ShotPoints {
    pub(super) caches: Vec<CacheShot>,
    /// The most a rendered frame holds.
    pub(super) most: PointLoad,
}

/// The figures `check` reports of one frame's points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameSurvey {
    /// Points in the frame's files, over every cache.
    pub points: u64,
    /// Of them, those that move during the frame's interval; `None` where points move to
    /// their next snapshot (known when the frame is read).
    pub moving: Option<u64>,
    /// What the frame holds, for the memory estimate.
    pub load: PointLoad,
}

/// The figures of a snapshot from its values.
fn figures_of(read: &super::read::Read, count: u64) -> Figures {
    let moving = read
        .velocities
        .iter()
        .filter(|v| **v != DVec3::ZERO)
        .count() as u64;
    let range = read.values.iter().fold(None, |r: Option<[f64; 2]>, &x| {
        Some(r.map_or([x, x], |[lo, hi]| [lo.min(x), hi.max(x)]))
    });
    Figures {
        count,
        moving: Some(moving),
        range,
    }
}

impl ShotPoints {
    /// No caches.
    pub fn none() -> ShotPoints {
        ShotPoints {
            caches: Vec::new(),
            most: PointLoad::default(),
        }
    }

    /// Surveys the caches of `scene` for the frames `render` (none: nothing renders), with
    /// the colour range found over the frames `colour` (a chunk's whole selection, so that
    /// every chunk colours alike). Errors name the cache, the frame, the file and what is
    /// wrong.
    pub fn survey(
        scene: &Scene,
        render: Option<Frames>,
        colour: Option<Frames>,
        depth: SurveyDepth,
    ) -> Result<ShotPoints, Error> {
        let Some(mut render) = render else {
            return Ok(ShotPoints::none());
        };
        let mut colour = colour;
        let mut caches = Vec::with_capacity(scene.points.len());
        // The frames are taken once; each cache of a sequence needs them.
        let frames: Vec<u32> = match scene.points.iter().any(PointCacheDesc::is_sequence) {
            true => render.each.by_ref().collect(),
            false => Vec::new(),
        };
        let colour_frames: Vec<u32> = match &mut colour {
            Some(c)
                if scene.points.iter().any(|p| {
                    p.is_sequence() && p.color_by.as_ref().is_some_and(|c| c.range.is_none())
                }) =>
            {
                c.each.by_ref().collect()
            }
            _ => Vec::new(),
        };
        let span = (render.first, render.last);
        let colour_span = colour.as_ref().map_or(span, |c| (c.first, c.last));
        for (index, desc) in scene.points.iter().enumerate() {
            let cache = if desc.is_sequence() {
                survey_sequence(scene, index, &frames, &colour_frames, depth)?
            } else {
                survey_snapshots(scene, index, span, colour_span, depth)?
            };
            caches.push(cache);
        }
        let mut shot = ShotPoints {
            caches,
            most: PointLoad::default(),
        };
        // The most a frame holds: over a sequence's frames, or the span of snapshots.
        let mut most = PointLoad::default();
        let frames_to_count: Box<dyn Iterator<Item = u32>> = if frames.is_empty() {
            Box::new([span.0, span.1].into_iter())
        } else {
            Box::new(frames.iter().copied())
        };
        for frame in frames_to_count {
            let load = shot.frame_survey(scene, frame)?.load;
            most.points = most.points.max(load.points);
            most.next = most.next.max(load.next);
        }
        for (index, c) in shot.caches.iter().enumerate() {
            if let Files::Snapshots { .. } = c.files {
                let desc = &scene.points[index];
                let (a, b) = (
                    place_key(c, scene, index, span.0)?,
                    place_key(c, scene, index, span.1)?,
                );
                for (key, f) in c.figures.range(a..=b) {
                    let next = next_count(c, desc, *key);
                    most.points = most.points.max(f.count);
                    most.next = most.next.max(next);
                }
            }
        }
        most.snapshots = shot.snapshots();
        shot.most = most;
        Ok(shot)
    }

    /// The most points a rendered frame holds (and the most its next snapshots hold).
    pub fn most(&self) -> PointLoad {
        self.most
    }

    /// The snapshots the caches' files of several index, together.
    fn snapshots(&self) -> u64 {
        let count = |c: &CacheShot| match &c.files {
            Files::Snapshots { snaps, .. } => snaps.len() as u64,
            Files::PerFrame => 0,
        };
        self.caches.iter().map(count).sum()
    }

    /// The files the survey read (each once, when it works as it should).
    pub fn files_read(&self) -> usize {
        self.caches.iter().map(|c| c.reads).sum()
    }

    /// The fewest and the most points a frame from `first` to `last` holds (each cache's,
    /// summed over the caches).
    pub fn count_range(&self, scene: &Scene, first: u32, last: u32) -> Result<(u64, u64), Error> {
        let (mut least, mut most) = (0, 0);
        for (index, c) in self.caches.iter().enumerate() {
            let (a, b) = (
                place_key(c, scene, index, first)?,
                place_key(c, scene, index, last)?,
            );
            let counts = c.figures.range(a..=b).map(|(_, f)| f.count);
            least += counts.clone().min().unwrap_or(0);
            most += counts.max().unwrap_or(0);
        }
        Ok((least, most))
    }

    /// The files frame `frame` (one the survey covered) reads: each cache's snapshot, and
    /// the next one where its points move towards it.
    pub fn frame_files(&self, scene: &Scene, frame: u32) -> Result<Vec<PathBuf>, Error> {
        let mut files = Vec::new();
        for (index, c) in self.caches.iter().enumerate() {
            let desc = &scene.points[index];
            let placed = c
                .files
                .place(desc, &scene.shot, frame)
                .map_err(|m| Error::Scene(about(scene, index, frame, Path::new(&desc.file), &m)))?;
            files.push(c.files.path(desc, placed.key));
            if let Some((next, _)) = placed.next {
                files.push(c.files.path(desc, next));
            }
        }
        Ok(files)
    }

    /// The figures of frame `frame` (one the survey covered).
    pub fn frame_survey(&self, scene: &Scene, frame: u32) -> Result<FrameSurvey, Error> {
        let interval = scene.shot.interval(frame);
        let mut out = FrameSurvey {
            moving: Some(0),
            ..FrameSurvey::default()
        };
        out.load.snapshots = self.snapshots();
        for (index, c) in self.caches.iter().enumerate() {
            let desc = &scene.points[index];
            let placed = c
                .files
                .place(desc, &scene.shot, frame)
                .map_err(|m| Error::Scene(about(scene, index, frame, Path::new(&desc.file), &m)))?;
            let f = c.figures.get(&placed.key).copied().unwrap_or_default();
            out.points += f.count;
            out.load.points += f.count;
            if let Some((next, _)) = placed.next {
                out.load.next += c.figures.get(&next).map_or(0, |f| f.count);
            }
            let motion = desc.motion.unwrap_or(PointMotion::Velocity);
            out.moving = match (out.moving, motion, f.moving) {
                (_, PointMotion::Still, _) => out.moving,
                (_, _, _) if interval.is_instant() => out.moving,
                (Some(m), PointMotion::Velocity, Some(k)) => Some(m + k),
                _ => None,
            };
        }
        Ok(out)
    }
}

/// The key of the snapshot frame `frame` shows of cache `index`.
fn place_key(c: &CacheShot, scene: &Scene, index: usize, frame: u32) -> Result<Key, Error> {
    let desc = &scene.points[index];
    c.files
        .place(desc, &scene.shot, frame)
        .map(|p| p.key)
        .map_err(|m| Error::Scene(about(scene, index, frame, Path::new(&desc.file), &m)))
}

/// The count of the snapshot after `key`, where the cache interpolates.
fn next_count(c: &CacheShot, desc: &PointCacheDesc, key: Key) -> u64 {
    if desc.motion != Some(PointMotion::Interpolate) {
        return 0;
    }
    let next = match key {
        Key::Frame(f) => Key::Frame(f.saturating_add(1)),
        Key::Snap(k) => Key::Snap(k + 1),
    };
    c.figures.get(&next).map_or(0, |f| f.count)
}

/// What to read of a snapshot surveyed at `depth`, with its colour values when `colour`.
fn wanted(depth: SurveyDepth, colour: bool) -> Option<Wanted> {
    match depth {
        SurveyDepth::Values => Some(Wanted {
            positions: true,
            velocities: true,
            looks: true,
            ids: true,
            images: true,
            values: true,
        }),
        SurveyDepth::Files if colour => Some(Wanted {
            values: true,
            ..Wanted::default()
        }),
        SurveyDepth::Files => None,
    }
}

/// Indexes `path` for cache `index`, checking each snapshot's layout and reading the values
/// `read` asks of the snapshots it picks (by their number in the cache), handing each
/// snapshot with its figures to `keep`; how many there were.
fn index_file(
    scene: &Scene,
    index: usize,
    path: &Path,
    first: usize,
    read: &dyn Fn(usize, &crate::sim::Snapshot) -> Option<Wanted>,
    keep: &mut dyn FnMut(crate::sim::Snapshot, Figures) -> Result<(), ReadError>,
) -> Result<usize, ReadError> {
    let desc = &scene.points[index];
    let mut last_timestep: Option<i64> = None;
    let visit = |ordinal, snap: &crate::sim::Snapshot, rows: &mut table::Rows| {
        if snap.count > MAX_FRAME_SPHERES {
            return Err(ReadError::Bad(format!(
                "{} points, more than the {MAX_FRAME_SPHERES} a frame can hold",
                snap.count
            )));
        }
        if let (SnapshotTime::Timestep { .. }, Some(t), Some(last)) =
            (desc.snapshots, snap.timestep, last_timestep)
            && t <= last
        {
            return Err(ReadError::Bad(format!(
                "its timestep {t} is not after the one before ({last}): snapshots must be in the order of their timesteps"
            )));
        }
        last_timestep = snap.timestep.or(last_timestep);
        let layout = map_columns(&snap.columns, desc).map_err(ReadError::Bad)?;
        let names: Vec<String> = snap.columns.iter().map(|c| c.label()).collect();
        Ok(match read(first + ordinal - 1, snap) {
            Some(want) => {
                let cell = super::read::cell_of(snap, desc)?;
                let values =
                    read_values(rows, snap.count, &names, &layout, cell.as_ref(), desc, want)?;
                let exposure = scene.shot.exposure();
                file_velocities_within_box(&values, cell.as_ref(), desc, exposure)
                    .map_err(ReadError::Bad)?;
                if desc.motion == Some(PointMotion::Interpolate) && want.ids {
                    super::motion::sorted_ids(&values.ids).map_err(ReadError::Bad)?;
                }
                figures_of(&values, snap.count)
            }
            None => Figures {
                count: snap.count,
                ..Figures::default()
            },
        })
    };
    table::index(path, desc.format, visit, keep)
}

/// Surveys a sequence: each frame's file of `frames` (and with `interpolate` the next
/// frame's), then the colour values of `colour_frames` where the range is not given.
fn survey_sequence(
    scene: &Scene,
    index: usize,
    frames: &[u32],
    colour_frames: &[u32],
    depth: SurveyDepth,
) -> Result<CacheShot, Error> {
    let desc = &scene.points[index];
    let needs_range = desc.color_by.as_ref().is_some_and(|c| c.range.is_none());
    let mut cache = CacheShot {
        files: Files::PerFrame,
        figures: BTreeMap::new(),
        range: desc.color_by.as_ref().and_then(|c| c.range),
        open: Mutex::new([None, None]),
        reads: 0,
    };
    let survey = |frame: u32, want: Option<Wanted>, cache: &mut CacheShot| -> Result<(), Error> {
        let done = match (cache.figures.get(&Key::Frame(frame)), want) {
            (None, _) => false,
            (Some(_), None) => true,
            (Some(f), Some(w)) => f.moving.is_some() || (!w.positions && f.range.is_some()),
        };
        if done {
            return Ok(());
        }
        let path = raytrace_core::path_pattern::frame_path(&desc.file, frame);
        cache.reads += 1;
        // The first snapshot's figures; the others are only counted.
        let mut first = None;
        let found = index_file(scene, index, &path, 0, &|_, _| want, &mut |_, f| {
            first.get_or_insert(f);
            Ok(())
        })
        .map_err(|e| error(scene, index, frame, &path, e))?;
        if found > 1 {
            let m = format!(
                "holds {found} snapshots, and a sequence ('#') is a file per frame: name the file without '#' (or with '*') to take its snapshots as frames"
            );
            return Err(Error::Scene(about(scene, index, frame, &path, &m)));
        }
        let f = first.expect("a file holds a snapshot");
        cache.figures.insert(Key::Frame(frame), f);
        Ok(())
    };
    for &frame in frames {
        survey(frame, wanted(depth, needs_range), &mut cache)?;
        if let Some((Key::Frame(next), _)) = cache
            .files
            .place(desc, &scene.shot, frame)
            .ok()
            .and_then(|p| p.next)
        {
            survey(next, wanted(depth, false), &mut cache)?;
        }
    }
    if needs_range {
        for &frame in colour_frames {
            survey(frame, wanted(SurveyDepth::Files, true), &mut cache)?;
        }
        cache.range = range_over(
            colour_frames
                .iter()
                .map(|&f| (f, cache.figures.get(&Key::Frame(f)))),
            scene,
            index,
        )?;
    }
    Ok(cache)
}

/// The colour range over the snapshots given (each with the frame that reads it).
fn range_over<'a>(
    figures: impl Iterator<Item = (u32, Option<&'a Figures>)>,
    scene: &Scene,
    index: usize,
) -> Result<Option<[f64; 2]>, Error> {
    let mut range: Option<[f64; 2]> = None;
    let mut last_frame = 0;
    for (frame, f) in figures {
        last_frame = frame;
        if let Some([lo, hi]) = f.and_then(|f| f.range) {
            range = Some(range.map_or([lo, hi], |[a, b]| [a.min(lo), b.max(hi)]));
        }
    }
    match range {
        Some(r) => Ok(Some(r)),
        None => {
            let desc = &scene.points[index];
            let m = "no point to take the colour range from: give color_range";
            Err(Error::Scene(about(
                scene,
                index,
                last_frame,
                Path::new(&desc.file),
                m,
            )))
        }
    }
}

/// Surveys one file of snapshots, or a series: each indexed once, values read for the
/// snapshots of frames `span` at `depth`, and for those of `colour_span` where the colour
/// range is not given; the frames of `span` must each have a snapshot.
fn survey_snapshots(
    scene: &Scene,
    index: usize,
    span: (u32, u32),
    colour_span: (u32, u32),
    depth: SurveyDepth,
) -> Result<CacheShot, Error> {
    let desc = &scene.points[index];
    let shot = &scene.shot;
    let needs_range = desc.color_by.as_ref().is_some_and(|c| c.range.is_none());
    let named = |m: String| Error::Scene(about(scene, index, span.0, Path::new(&desc.file), &m));
    let paths = match desc.is_series() {
        true => series(&desc.file).map_err(named)?,
        false => vec![Path::new(&desc.file).to_path_buf()],
    };
    // Which snapshots frames of a span may show, by their number or their time: from the
    // first frame's back to any earlier (a timestep's snapshot may sit before its frame).
    let within = |k: usize, snap: &crate::sim::Snapshot, (a, b): (u32, u32)| match desc.snapshots {
        SnapshotTime::Frames => {
            let frame = shot.first_frame as u64 + k as u64;
            (frame >= a as u64 && frame <= b as u64) || k == 0
        }
        SnapshotTime::Timestep { dt } => {
            timestep_time(shot, snap, dt)
                <= shot.frame_time(b) + 1e-9 * shot.frame_time(b).abs().max(1.0)
        }
    };
    let read = |k: usize, snap: &crate::sim::Snapshot| -> Option<Wanted> {
        let for_values = depth == SurveyDepth::Values && within(k, snap, span);
        let for_colour = needs_range && within(k, snap, colour_span);
        match (for_values, for_colour) {
            (true, _) => wanted(SurveyDepth::Values, true),
            (false, true) => wanted(SurveyDepth::Files, true),
            (false, false) => None,
        }
    };
    let mut snaps: Vec<Located> = Vec::new();
    let mut figures: Vec<(Key, Figures)> = Vec::new();
    for (file, path) in paths.iter().enumerate() {
        let mut ordinal = 0;
        let first = snaps.len();
        let mut keep = |snap, f| {
            if snaps.len() >= MAX_SNAPSHOTS {
                return Err(ReadError::Bad(format!(
                    "the cache holds more than {MAX_SNAPSHOTS} snapshots, the most it may (its index: {} bytes a snapshot)",
                    PointLoad::INDEX_BYTES_PER_SNAPSHOT
                )));
            }
            ordinal += 1;
            figures.push((Key::Snap(snaps.len()), f));
            snaps.push(Located {
                file,
                ordinal,
                snap,
            });
            Ok(())
        };
        index_file(scene, index, path, first, &read, &mut keep)
            .map_err(|e| error(scene, index, span.0, path, e))?;
    }
    // Built from keys in order, the map's nodes are full.
    let figures: BTreeMap<Key, Figures> = figures.into_iter().collect();
    if let (SnapshotTime::Timestep { .. }, true) = (desc.snapshots, desc.is_series()) {
        // Timesteps in order across the series' files too.
        timesteps_in_order(scene, index, span.0, &paths, &snaps)?;
    }
    let mut cache = CacheShot {
        reads: paths.len(),
        files: Files::Snapshots { paths, snaps },
        figures,
        range: desc.color_by.as_ref().and_then(|c| c.range),
        open: Mutex::new([None, None]),
    };
    // Every frame of the span has a snapshot: its ends do.
    place_key(&cache, scene, index, span.0)?;
    place_key(&cache, scene, index, span.1)?;
    if needs_range {
        let a = place_key(&cache, scene, index, colour_span.0)?;
        let b = place_key(&cache, scene, index, colour_span.1)?;
        let snaps = cache
            .figures
            .range(a..=b)
            .map(|(_, f)| (colour_span.1, Some(f)));
        cache.range = range_over(snaps, scene, index)?;
    }
    Ok(cache)
}

/// Checks that the snapshots `snaps` of cache `index`'s series (its files `paths`) are in
/// the order of their timesteps; an error names the file of the first out of order, and
/// `frame`.
fn timesteps_in_order(
    scene: &Scene,
    index: usize,
    frame: u32,
    paths: &[PathBuf],
    snaps: &[Located],
) -> Result<(), Error> {
    if let Some(w) = snaps
        .windows(2)
        .find(|w| w[1].snap.timestep <= w[0].snap.timestep)
    {
        let m = format!(
            "timestep {} follows timestep {}: the series' snapshots must be in the order of their timesteps",
            w[1].snap.timestep.unwrap_or(0),
            w[0].snap.timestep.unwrap_or(0)
        );
        return Err(Error::Scene(about(
            scene,
            index,
            frame,
            &paths[w[1].file],
            &m,
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_count_moving_points_and_the_colour_range() {
        let read = super::super::read::Read {
            velocities: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            values: vec![2.0, -1.0, 5.0],
            ..Default::default()
        };
        let f = figures_of(&read, 3);
        assert_eq!(f.moving, Some(2));
        assert_eq!(f.range, Some([-1.0, 5.0]));
        assert_eq!(figures_of(&Default::default(), 0).range, None);
    }
}
