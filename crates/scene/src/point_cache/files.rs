//! A cache's files and snapshots, and which one each frame shows at what time:
//!
//! - a sequence (`#` in the name): frame `n`'s file, at frame `n`'s nominal time;
//! - one file, or a series (`*` in the name: every file whose name has a number there, in
//!   the numbers' order), holding snapshots one after another: with `snapshots = "frames"`
//!   the k-th snapshot is the shot's k-th frame, at its nominal time (a single snapshot is
//!   the same points at time 0 for every frame, as a single PLY file); with
//!   `snapshots = "timestep"` a snapshot is at `start_time + TIMESTEP * dt`, and a frame shows
//!   the last snapshot at or before its nominal time.
//!
//! With `interpolate`, a frame's points move towards their places in the next snapshot (the
//! next frame's file of a sequence, where there is one).

use std::path::{Path, PathBuf};

use crate::sim::Snapshot;
use raytrace_core::points::{PointCacheDesc, PointMotion, SnapshotTime};
use raytrace_core::shutter::Shot;

/// A snapshot: a sequence's frame (its file's only snapshot), or the k-th of a cache's
/// snapshots (from 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Key {
    Frame(u32),
    Snap(usize),
}

/// A snapshot of a file of several, or of a series: its file (an index into the cache's
/// paths), its place in that file (from 1) and its header.
#[derive(Clone, Debug)]
pub(super) struct Located {
    pub(super) file: usize,
    pub(super) ordinal: usize,
    pub(super) snap: Snapshot,
}

/// Where a cache's snapshots are.
#[derive(Debug)]
pub(super) enum Files {
    /// A file per frame (`#`).
    PerFrame,
    /// The snapshots of one file or of a series (`*`), in order.
    Snapshots {
        paths: Vec<PathBuf>,
        snaps: Vec<Located>,
    },
}

/// What a frame shows of a cache: the snapshot, the time its points are at, and with
/// `interpolate` the next snapshot and its time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Placed {
    pub(super) key: Key,
    pub(super) time: f64,
    pub(super) next: Option<(Key, f64)>,
}

/// The files of a series: every file in `pattern`'s folder whose name is the pattern's with
/// a number (digits) in place of its `*`, in the numbers' order.
pub(super) fn series(pattern: &str) -> Result<Vec<PathBuf>, String> {
    let path = Path::new(pattern);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (prefix, suffix) = name.split_once('*').unwrap_or((&name, ""));
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let entries = std::fs::read_dir(&dir).map_err(|e| {
        format!(
            "the series' folder {}: {e}",
            raytrace_core::error::elide_path(&dir)
        )
    })?;
    let mut found: Vec<(u128, PathBuf)> = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| e.to_string())?;
        let file = entry.file_name();
        let Some(file) = file.to_str() else { continue };
        let Some(middle) = file
            .strip_prefix(prefix)
            .and_then(|r| r.strip_suffix(suffix))
        else {
            continue;
        };
        if middle.is_empty() || middle.len() > 30 || !middle.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        let number: u128 = middle.parse().expect("digits");
        found.push((number, dir.join(file)));
    }
    if found.is_empty() {
        return Err("no file matches (the '*' stands for a number)".into());
    }
    found.sort();
    if let Some(w) = found.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(format!(
            "{} and {} have the same number",
            raytrace_core::error::elide_path(&w[0].1),
            raytrace_core::error::elide_path(&w[1].1)
        ));
    }
    Ok(found.into_iter().map(|f| f.1).collect())
}

/// The time of snapshot `snap` of a cache with `snapshots = "timestep"`.
pub(super) fn timestep_time(shot: &Shot, snap: &Snapshot, dt: f64) -> f64 {
    shot.start_time + snap.timestep.unwrap_or(0) as f64 * dt
}

impl Files {
    /// What frame `frame` shows of cache `desc`; an error says why there is nothing.
    pub(super) fn place(
        &self,
        desc: &PointCacheDesc,
        shot: &Shot,
        frame: u32,
    ) -> Result<Placed, String> {
        let interpolate = desc.motion == Some(PointMotion::Interpolate);
        let snaps = match self {
            Files::PerFrame => {
                let next = frame.checked_add(1).filter(|&n| {
                    interpolate
                        && (shot.contains_frame(n)
                            || raytrace_core::path_pattern::frame_path(&desc.file, n).exists())
                });
                return Ok(Placed {
                    key: Key::Frame(frame),
                    time: shot.frame_time(frame),
                    next: next.map(|n| (Key::Frame(n), shot.frame_time(n))),
                });
            }
            Files::Snapshots { snaps, .. } => snaps,
        };
        let n = snaps.len();
        let (k, time) = match desc.snapshots {
            SnapshotTime::Frames if n == 1 => {
                return Ok(Placed {
                    key: Key::Snap(0),
                    time: 0.0,
                    next: None,
                });
            }
            SnapshotTime::Frames => {
                let k = (frame - shot.first_frame) as usize;
                if k >= n {
                    return Err(format!(
                        "the cache holds {n} snapshots, the shot's frames {} to {}: frame {frame} has none",
                        shot.first_frame,
                        shot.first_frame as u64 + n as u64 - 1
                    ));
                }
                (k, shot.frame_time(frame))
            }
            SnapshotTime::Timestep { dt } => {
                let t = shot.frame_time(frame);
                // A snapshot and a frame at the same time in exact arithmetic may round
                // apart: a snapshot within 1e-9 of the frame's time counts as at it.
                let slack = 1e-9 * t.abs().max(1.0);
                let after =
                    snaps.partition_point(|s| timestep_time(shot, &s.snap, dt) <= t + slack);
                if after == 0 {
                    let first = &snaps[0].snap;
                    return Err(format!(
                        "frame {frame} is at {t} s, before the first snapshot (timestep {}, at {} s)",
                        first.timestep.unwrap_or(0),
                        timestep_time(shot, first, dt)
                    ));
                }
                let k = after - 1;
                (k, timestep_time(shot, &snaps[k].snap, dt))
            }
        };
        let next = (interpolate && k + 1 < n).then(|| {
            let time = match desc.snapshots {
                SnapshotTime::Frames => shot.frame_time(frame + 1),
                SnapshotTime::Timestep { dt } => timestep_time(shot, &snaps[k + 1].snap, dt),
            };
            (Key::Snap(k + 1), time)
        });
        Ok(Placed {
            key: Key::Snap(k),
            time,
            next,
        })
    }

    /// The file of snapshot `key` of cache `desc`.
    pub(super) fn path(&self, desc: &PointCacheDesc, key: Key) -> PathBuf {
        match (self, key) {
            (_, Key::Frame(f)) => raytrace_core::path_pattern::frame_path(&desc.file, f),
            (Files::Snapshots { paths, snaps }, Key::Snap(k)) => paths[snaps[k].file].clone(),
            (Files::PerFrame, Key::Snap(_)) => PathBuf::from(&desc.file),
        }
    }

    /// The frame messages name for snapshot `key` when frame `frame` reads it.
    pub(super) fn frame_of(key: Key, frame: u32) -> u32 {
        match key {
            Key::Frame(f) => f,
            Key::Snap(_) => frame,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_series_is_its_files_in_the_order_of_their_numbers() {
        let dir = tempfile::tempdir().unwrap();
        for name in [
            "d.100.txt",
            "d.20.txt",
            "d.3.txt",
            "d.x.txt",
            "e.5.txt",
            "d..txt",
        ] {
            std::fs::write(dir.path().join(name), "").unwrap();
        }
        let pattern = dir.path().join("d.*.txt");
        let files = series(&pattern.to_string_lossy()).unwrap();
        let names: Vec<String> = files
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["d.3.txt", "d.20.txt", "d.100.txt"]);
        std::fs::write(dir.path().join("d.020.txt"), "").unwrap();
        assert!(
            series(&pattern.to_string_lossy())
                .unwrap_err()
                .contains("the same number")
        );
        let none = dir.path().join("q*.txt");
        assert!(
            series(&none.to_string_lossy())
                .unwrap_err()
                .contains("no file matches")
        );
    }
}
