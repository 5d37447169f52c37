//! VTK point data: the points and their point data arrays of a legacy `.vtk` file
//! (`vtk_legacy`: POLYDATA or UNSTRUCTURED_GRID, ASCII or BINARY) or of an XML `.vtp`/`.vtu`
//! file (`vtk_xml`: PolyData or UnstructuredGrid, its pieces one after another; arrays
//! `ascii`, `binary` or `appended`, raw or base64, plain or zlib-compressed). Cells and cell
//! data are read past.
//!
//! Why not the `vtkio` crate: its stable release (0.6.3, 2021) is built on nom 3, and its 0.7
//! has been a release candidate since 2023 (its release was closed unmerged); tried on
//! malformed files, 0.7.0-rc2 dropped an XML point array one value short without a word,
//! read an array of an unknown type as 64-bit floats, and named no line in its errors
//! ("Parse error: Digit"). What particles need is the points and their arrays, read and
//! checked here with every length held against the file before anything is allocated for it.
//! The XML is read by a scanner of the tags VTK writes (an appended section is raw bytes,
//! which no XML parser reads).
//!
//! A file is read whole into memory when opened (its size is what a reader of it holds);
//! each array's values are decoded when a caller reads it.

use std::path::Path;
use std::sync::Arc;

use super::read_error::ReadError;
use super::snapshot::{Column, ColumnKind};
use super::text::open_regular;
use super::vtk_data::Array;

pub(crate) use super::vtk_data::POINTS;

/// Largest VTK file read (bytes): it is held whole while it is read.
pub(crate) const MAX_FILE: u64 = 16 << 30;

/// Bytes a VTK file may hold besides its points' values: its header, cells, field data and
/// layout, read whole with it. The head of the file read first, where its points are declared.
const MARGIN: u64 = 16 << 20;

/// Bytes a point may take in a file: its position and a few dozen values in ASCII (25
/// characters each, as `%.17g` writes them), its cell and its cell data; a file larger than
/// its points may need is refused unread (a file padded with gigabytes of NULs).
const BYTES_PER_POINT: u64 = 4096;

/// The points a VTK file's head declares: a legacy file's `POINTS n`, or the sum of an XML
/// file's `NumberOfPoints="n"` (0 where the head names none).
fn declared_points(head: &[u8]) -> u64 {
    let number = |b: &[u8]| -> u64 {
        let digits = b.iter().take_while(|c| c.is_ascii_digit()).count();
        std::str::from_utf8(&b[..digits])
            .ok()
            .and_then(|d| d.parse().ok())
            .unwrap_or(0)
    };
    if head.starts_with(b"# vtk DataFile") {
        let mut words = head
            .split(|c| c.is_ascii_whitespace())
            .filter(|w| !w.is_empty());
        return match words.position(|w| w.eq_ignore_ascii_case(b"POINTS")) {
            Some(_) => words.next().map_or(0, number),
            None => 0,
        };
    }
    const KEY: &[u8] = b"NumberOfPoints=";
    let mut total: u64 = 0;
    let mut rest = head;
    while let Some(k) = rest.windows(KEY.len()).position(|w| w == KEY) {
        rest = &rest[k + KEY.len()..];
        total = total.saturating_add(number(rest.get(1..).unwrap_or_default()));
    }
    total
}

/// A VTK file's points and point data.
pub(crate) struct VtkFile {
    bytes: Vec<u8>,
    count: u64,
    /// Per piece, its number of points.
    piece_counts: Vec<u64>,
    columns: Arc<[Column]>,
    /// The arrays, the points' first; column `k` is a component of one of them.
    arrays: Vec<Array>,
    /// The array and component of each column.
    of_column: Vec<(usize, u8)>,
    format: super::vtk_data::Encoding,
}

impl VtkFile {
    /// Opens and reads `path`: its structure (the points, the point data arrays, their
    /// types and where their values are), each length checked against the file.
    pub(crate) fn open(path: &Path) -> Result<VtkFile, ReadError> {
        use std::io::Read;
        let mut file = open_regular(path, "VTK file")?;
        let size = file.metadata()?.len();
        if size > MAX_FILE {
            return Err(ReadError::Bad(format!(
                "holds {size} bytes, more than the {MAX_FILE} a VTK file may (it is read whole)"
            )));
        }
        // The head, where the points are declared; the rest only where they may need it.
        let mut bytes = Vec::with_capacity(size.min(MARGIN) as usize);
        (&mut file).take(MARGIN).read_to_end(&mut bytes)?;
        let points = declared_points(&bytes);
        let most = MARGIN.saturating_add(points.saturating_mul(BYTES_PER_POINT));
        if size > most {
            return Err(ReadError::Bad(format!(
                "holds {size} bytes, more than the {most} its {points} points may need ({MARGIN} bytes and {BYTES_PER_POINT} a point): padded, or not a VTK file"
            )));
        }
        bytes.reserve_exact((size - bytes.len() as u64) as usize);
        file.read_to_end(&mut bytes)?;
        let structure = if bytes.starts_with(b"# vtk DataFile") {
            super::vtk_legacy::structure(&bytes)?
        } else {
            super::vtk_xml::structure(&bytes)?
        };
        for array in &structure.arrays {
            for (place, &n) in array.pieces.iter().zip(&structure.piece_counts) {
                let values = usize::try_from(n.saturating_mul(array.components as u64))
                    .unwrap_or(usize::MAX);
                super::vtk_data::room(&bytes, structure.encoding, array, place, values)?;
            }
        }
        let mut columns = Vec::new();
        let mut of_column = Vec::new();
        for (a, array) in structure.arrays.iter().enumerate() {
            if columns.iter().any(|c: &Column| c.name == array.name) {
                return Err(ReadError::Bad(format!(
                    "two point arrays are named {}",
                    array.name
                )));
            }
            for k in 0..array.components {
                columns.push(Column {
                    name: array.name.clone(),
                    component: k,
                    components: array.components,
                    kind: if array.ty.is_integer() {
                        ColumnKind::Integer
                    } else {
                        ColumnKind::Real
                    },
                });
                of_column.push((a, k));
            }
        }
        Ok(VtkFile {
            bytes,
            count: structure.piece_counts.iter().sum(),
            piece_counts: structure.piece_counts,
            columns: columns.into(),
            arrays: structure.arrays,
            of_column,
            format: structure.encoding,
        })
    }

    /// The columns: the points' three (named [`POINTS`]), then each point data array's.
    pub(crate) fn columns(&self) -> Arc<[Column]> {
        self.columns.clone()
    }

    /// The number of points.
    pub(crate) fn count(&self) -> u64 {
        self.count
    }

    /// Reads every point's values of columns `wanted`, in that order, calling `row(i,
    /// values)`; an error `row` returns is returned.
    pub(crate) fn read_rows(
        &self,
        wanted: &[usize],
        mut row: impl FnMut(u64, &[f64]) -> Result<(), String>,
    ) -> Result<(), ReadError> {
        // Each array wanted, decoded once: per piece, its values.
        let mut decoded: Vec<Option<Vec<Vec<f64>>>> = vec![None; self.arrays.len()];
        for &w in wanted {
            let (a, _) = self.of_column[w];
            if decoded[a].is_none() {
                let array = &self.arrays[a];
                let mut pieces = Vec::with_capacity(array.pieces.len());
                for (place, &n) in array.pieces.iter().zip(&self.piece_counts) {
                    let values = n as usize * array.components as usize;
                    pieces.push(super::vtk_data::decode(
                        &self.bytes,
                        self.format,
                        array,
                        place,
                        values,
                    )?);
                }
                decoded[a] = Some(pieces);
            }
        }
        let mut values = vec![0.0; wanted.len()];
        let mut i = 0u64;
        for (p, &n) in self.piece_counts.iter().enumerate() {
            for j in 0..n as usize {
                for (v, &w) in values.iter_mut().zip(wanted) {
                    let (a, k) = self.of_column[w];
                    let comps = self.arrays[a].components as usize;
                    *v = decoded[a].as_ref().expect("decoded")[p][j * comps + k as usize];
                }
                row(i, &values).map_err(ReadError::Bad)?;
                i += 1;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_points_a_head_declares_are_found() {
        let legacy = b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 12 float\n";
        assert_eq!(declared_points(legacy), 12);
        assert_eq!(
            declared_points(b"# vtk DataFile Version 3.0\nt\nASCII\n"),
            0
        );
        let xml =
            b"<VTKFile><PolyData><Piece NumberOfPoints=\"3\"></Piece><Piece NumberOfPoints=\"40\">";
        assert_eq!(declared_points(xml), 43);
        assert_eq!(declared_points(b"<VTKFile NumberOfPoints=\"x\">"), 0);
    }
}
