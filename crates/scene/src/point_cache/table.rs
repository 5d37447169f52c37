//! A cache's files as tables of snapshots, whatever their format: indexing a file (its
//! snapshots: where each begins, its count, columns, timestep and box), and reading one
//! snapshot's rows as numbers for the chosen columns. PLY and VTK files hold one snapshot;
//! LAMMPS dumps and XYZ files hold any number, read through `sim::text` (gzip or not).

use std::path::Path;
use std::sync::Arc;

use crate::ply::{Kind, PlyError, PlyFile};
use crate::sim::cell::Cell;
use crate::sim::text::{Lines, Position};
use crate::sim::vtk::VtkFile;
use crate::sim::{Column, ColumnKind, ReadError, Snapshot, lammps, xyz};
use raytrace_core::points::CacheFormat;

impl From<PlyError> for ReadError {
    fn from(e: PlyError) -> Self {
        match e {
            PlyError::Bad(m) => ReadError::Bad(m),
            PlyError::Io(e) => ReadError::Io(e),
        }
    }
}

/// The columns of a PLY file's `vertex` element (a file without one is an error).
fn ply_snapshot(file: &PlyFile) -> Result<(usize, Snapshot), ReadError> {
    let Some((element, e)) = file.header().element("vertex") else {
        return Err(ReadError::Bad(
            "no vertex element: a point cache's points are its vertices".into(),
        ));
    };
    let columns: Arc<[Column]> = e
        .properties
        .iter()
        .map(|p| Column {
            kind: match p.kind {
                Kind::Scalar(s) if s.is_integer() => ColumnKind::Integer,
                Kind::Scalar(_) => ColumnKind::Real,
                Kind::List { .. } => ColumnKind::List,
            },
            ..Column::scalar(&p.name)
        })
        .collect();
    Ok((element, one_snapshot(e.count, columns)))
}

fn one_snapshot(count: u64, columns: Arc<[Column]>) -> Snapshot {
    Snapshot {
        line: 1,
        rows: Position::default(),
        count,
        timestep: None,
        cell: None,
        columns,
    }
}

/// A snapshot's rows, ready to be read (once) or skipped.
pub(super) enum Rows<'a> {
    Ply(Option<(PlyFile, usize)>),
    Vtk(&'a VtkFile),
    Text {
        lines: &'a mut Lines,
        snap: &'a Snapshot,
        format: CacheFormat,
        read: bool,
    },
}

impl Rows<'_> {
    /// How many rows of the `count` a header declares may be allocated for before reading:
    /// all of them where the count was held against the file's size (PLY, VTK); a text
    /// format's count is believed only as its lines are read (the columns then grow).
    pub(super) fn believed(&self, count: u64) -> usize {
        match self {
            Rows::Ply(_) | Rows::Vtk(_) => count as usize,
            Rows::Text { .. } => count.min(1 << 16) as usize,
        }
    }

    /// Reads the rows, calling `row(i, values)` with the values of columns `wanted` in that
    /// order; returns the labels of text columns (an XYZ species), by their index.
    pub(super) fn read(
        &mut self,
        wanted: &[usize],
        row: impl FnMut(u64, &[f64]) -> Result<(), String>,
    ) -> Result<Vec<String>, ReadError> {
        match self {
            Rows::Ply(file) => {
                let (file, element) = file.take().expect("rows are read once");
                file.read_rows(element, wanted, row)?;
                Ok(Vec::new())
            }
            Rows::Vtk(file) => {
                file.read_rows(wanted, row)?;
                Ok(Vec::new())
            }
            Rows::Text {
                lines,
                snap,
                format,
                read,
            } => {
                assert!(!*read, "rows are read once");
                *read = true;
                match format {
                    CacheFormat::Xyz => xyz::read_rows(lines, snap, wanted, row),
                    _ => lammps::read_rows(lines, snap, wanted, row).map(|()| Vec::new()),
                }
            }
        }
    }

    /// Rows a part holds where these rows are read in parts ([`Rows::read_in_parts`]): a
    /// PLY file's binary rows of fixed size (`PlyFile::part_rows`); `None` where they are read
    /// in order.
    pub(super) fn part_rows(&self, wanted: &[usize]) -> Option<u64> {
        match self {
            Rows::Ply(Some((file, element))) => file.part_rows(*element, wanted),
            _ => None,
        }
    }

    /// [`Rows::read`] in parts of [`Rows::part_rows`] rows (which must be `Some`), on every
    /// thread: part `k` calls `row(&mut parts[k], i, values)` for each of its rows `i`.
    pub(super) fn read_in_parts<S: Send>(
        &mut self,
        wanted: &[usize],
        parts: Vec<S>,
        row: impl Fn(&mut S, u64, &[f64]) -> Result<(), String> + Sync,
    ) -> Result<(), ReadError> {
        let Rows::Ply(file) = self else {
            unreachable!("only a PLY file's rows are read in parts")
        };
        let (file, element) = file.take().expect("rows are read once");
        file.read_rows_in_parts(element, wanted, parts, row)?;
        Ok(())
    }

    /// Skips the rows if they were not read (a text file's reader moves past them).
    fn finish(self) -> Result<(), ReadError> {
        match self {
            Rows::Text {
                lines,
                snap,
                format,
                read: false,
            } => match format {
                CacheFormat::Xyz => xyz::skip_rows(lines, snap),
                _ => lammps::skip_rows(lines, snap),
            },
            _ => Ok(()),
        }
    }
}

/// Goes through the snapshots of `path` in order, calling `visit(ordinal, snapshot, rows)`
/// for each (ordinal from 1; the visitor may read the rows, else they are skipped), then
/// `keep(snapshot, what visit gave)`: the snapshots are handed over, not gathered here, so
/// a file of a million is held once. Consecutive snapshots with the same columns or box
/// share them. Returns how many there were. A file of a one-snapshot format (PLY, VTK)
/// gives one.
pub(super) fn index<T>(
    path: &Path,
    format: CacheFormat,
    mut visit: impl FnMut(usize, &Snapshot, &mut Rows) -> Result<T, ReadError>,
    mut keep: impl FnMut(Snapshot, T) -> Result<(), ReadError>,
) -> Result<usize, ReadError> {
    match format {
        CacheFormat::Ply => {
            let file = PlyFile::open(path)?;
            let (element, snap) = ply_snapshot(&file)?;
            let t = visit(1, &snap, &mut Rows::Ply(Some((file, element))))?;
            keep(snap, t)?;
            Ok(1)
        }
        CacheFormat::Vtk => {
            let file = VtkFile::open(path)?;
            let snap = one_snapshot(file.count(), file.columns());
            let t = visit(1, &snap, &mut Rows::Vtk(&file))?;
            keep(snap, t)?;
            Ok(1)
        }
        CacheFormat::Lammps | CacheFormat::Xyz => {
            let what = match format {
                CacheFormat::Xyz => "XYZ file",
                _ => "LAMMPS dump",
            };
            let mut lines = Lines::open(path, what)?;
            // The last snapshot's columns and box, shared with the next where the same.
            let mut columns: Option<Arc<[Column]>> = None;
            let mut cell: Option<Arc<Cell>> = None;
            let mut count = 0;
            loop {
                let next = match format {
                    CacheFormat::Xyz => xyz::next_snapshot(&mut lines, columns.as_ref())?,
                    _ => lammps::next_snapshot(&mut lines, columns.as_ref())?,
                };
                let Some(mut snap) = next else { break };
                if snap.cell.is_some() && snap.cell == cell {
                    snap.cell = cell.clone();
                }
                count += 1;
                let mut rows = Rows::Text {
                    lines: &mut lines,
                    snap: &snap,
                    format,
                    read: false,
                };
                let timestep = snap.timestep;
                let with = |e: ReadError| about_snapshot(e, count, timestep);
                let t = visit(count, &snap, &mut rows).map_err(with)?;
                rows.finish().map_err(with)?;
                (columns, cell) = (Some(snap.columns.clone()), snap.cell.clone());
                keep(snap, t).map_err(with)?;
            }
            if count == 0 {
                return Err(ReadError::Bad(format!(
                    "holds no snapshot (an empty {what})"
                )));
            }
            Ok(count)
        }
    }
}

/// An error inside snapshot `ordinal` (at `timestep`, where the file gives one) of a file of
/// several, with the snapshot named.
pub(super) fn about_snapshot(e: ReadError, ordinal: usize, timestep: Option<i64>) -> ReadError {
    match e {
        ReadError::Bad(m) => ReadError::Bad(format!("{}: {m}", snapshot_name(ordinal, timestep))),
        io => io,
    }
}

/// `snapshot 3 (timestep 200)`, or `snapshot 3` where the file gives no timestep.
pub(super) fn snapshot_name(ordinal: usize, timestep: Option<i64>) -> String {
    match timestep {
        Some(t) => format!("snapshot {ordinal} (timestep {t})"),
        None => format!("snapshot {ordinal}"),
    }
}

/// An open text file kept between reads of its snapshots (a gzip stream reads on from where
/// it is).
pub(super) struct OpenText {
    pub(super) file: usize,
    pub(super) lines: Lines,
}

/// Reads snapshot `snap` (the `ordinal`-th of file `file`, `path`) with `read`; `open` is a
/// text file kept open for this purpose, used when it is the same file and replaced when not.
pub(super) fn read_snapshot<T>(
    path: &Path,
    format: CacheFormat,
    (file, ordinal, snap): (usize, usize, &Snapshot),
    open: &mut Option<OpenText>,
    read: impl FnOnce(&mut Rows) -> Result<T, ReadError>,
) -> Result<T, ReadError> {
    match format {
        CacheFormat::Ply => {
            let ply = PlyFile::open(path)?;
            let (element, now) = ply_snapshot(&ply)?;
            check_unchanged(&now, snap)?;
            read(&mut Rows::Ply(Some((ply, element))))
        }
        CacheFormat::Vtk => {
            let vtk = VtkFile::open(path)?;
            check_unchanged(&one_snapshot(vtk.count(), vtk.columns()), snap)?;
            read(&mut Rows::Vtk(&vtk))
        }
        CacheFormat::Lammps | CacheFormat::Xyz => {
            if open.as_ref().is_none_or(|o| o.file != file) {
                *open = Some(OpenText {
                    file,
                    lines: Lines::open(path, "file")?,
                });
            }
            let lines = &mut open.as_mut().expect("opened").lines;
            let result = lines.seek(snap.rows).and_then(|()| {
                read(&mut Rows::Text {
                    lines,
                    snap,
                    format,
                    read: false,
                })
            });
            if result.is_err() {
                // A reader left inside a snapshot is not reused.
                *open = None;
            }
            let several = format.has_snapshots();
            result.map_err(|e| {
                if several {
                    about_snapshot(e, ordinal, snap.timestep)
                } else {
                    e
                }
            })
        }
    }
}

/// A file read again must have the count and columns it had when it was surveyed.
fn check_unchanged(now: &Snapshot, then: &Snapshot) -> Result<(), ReadError> {
    if now.count != then.count || now.columns != then.columns {
        return Err(ReadError::Bad(format!(
            "has changed since it was checked before rendering ({} points then, {} now)",
            then.count, now.count
        )));
    }
    Ok(())
}
