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

use super::text::open_regular;
use super::{Column, ColumnKind, ReadError};

/// The name the points' positions go by among a VTK file's columns.
pub const POINTS: &str = "Points";

/// Largest VTK file read (bytes): it is held whole while it is read.
pub const MAX_FILE: u64 = 16 << 30;

/// A number type of VTK arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Ty {
    /// The type of a legacy name (`float`, `unsigned_char`, `vtktypeint64`...).
    pub(super) fn legacy(name: &str) -> Option<Ty> {
        Some(match name.to_ascii_lowercase().as_str() {
            "char" => Ty::I8,
            "unsigned_char" => Ty::U8,
            "short" => Ty::I16,
            "unsigned_short" => Ty::U16,
            "int" => Ty::I32,
            "unsigned_int" => Ty::U32,
            "long" | "vtktypeint64" | "vtkidtype" => Ty::I64,
            "unsigned_long" | "vtktypeuint64" => Ty::U64,
            "float" => Ty::F32,
            "double" => Ty::F64,
            _ => return None,
        })
    }

    /// The type of an XML name (`Float32`, `Int64`...).
    pub(super) fn xml(name: &str) -> Option<Ty> {
        Some(match name {
            "Int8" | "Char" => Ty::I8,
            "UInt8" | "UChar" => Ty::U8,
            "Int16" => Ty::I16,
            "UInt16" => Ty::U16,
            "Int32" => Ty::I32,
            "UInt32" => Ty::U32,
            "Int64" => Ty::I64,
            "UInt64" => Ty::U64,
            "Float32" => Ty::F32,
            "Float64" => Ty::F64,
            _ => return None,
        })
    }

    pub(super) fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::I64 | Ty::U64 | Ty::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Ty::F32 | Ty::F64)
    }

    /// A value from its bytes (`b.len() == size`).
    pub(super) fn value(self, b: &[u8], big: bool) -> f64 {
        macro_rules! get {
            ($t:ty) => {{
                let a = b.try_into().expect("the type's size");
                (if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }) as f64
            }};
        }
        match self {
            Ty::I8 => b[0] as i8 as f64,
            Ty::U8 => b[0] as f64,
            Ty::I16 => get!(i16),
            Ty::U16 => get!(u16),
            Ty::I32 => get!(i32),
            Ty::U32 => get!(u32),
            Ty::I64 => get!(i64),
            Ty::U64 => get!(u64),
            Ty::F32 => get!(f32),
            Ty::F64 => get!(f64),
        }
    }

    /// A value of this type written as text: floats `f32` rounded as a binary file holds
    /// them (as PLY's reader does), integers whole.
    pub(super) fn parse(self, text: &str) -> Option<f64> {
        match self {
            Ty::F32 => text.parse::<f32>().ok().map(f64::from),
            Ty::F64 => text.parse::<f64>().ok(),
            _ => text
                .parse::<i64>()
                .ok()
                .map(|x| x as f64)
                .or_else(|| text.parse::<u64>().ok().map(|x| x as f64)),
        }
    }
}

/// Where an array's values are, and how to decode them: the source's business
/// (`vtk_legacy`, `vtk_xml`).
#[derive(Clone, Debug)]
pub(super) struct Array {
    pub(super) name: String,
    pub(super) components: u8,
    pub(super) ty: Ty,
    /// Per piece, where its values are.
    pub(super) pieces: Vec<super::vtk_xml::Place>,
}

/// A VTK file's points and point data.
pub struct VtkFile {
    bytes: Vec<u8>,
    count: u64,
    /// Per piece, its number of points.
    piece_counts: Vec<u64>,
    columns: Arc<[Column]>,
    /// The arrays, the points' first; column `k` is a component of one of them.
    arrays: Vec<Array>,
    /// The array and component of each column.
    of_column: Vec<(usize, u8)>,
    format: super::vtk_xml::Encoding,
}

impl VtkFile {
    /// Opens and reads `path`: its structure (the points, the point data arrays, their
    /// types and where their values are), each length checked against the file.
    pub fn open(path: &Path) -> Result<VtkFile, ReadError> {
        use std::io::Read;
        let mut file = open_regular(path, "VTK file")?;
        let size = file.metadata()?.len();
        if size > MAX_FILE {
            return Err(ReadError::Bad(format!(
                "holds {size} bytes, more than the {MAX_FILE} a VTK file may (it is read whole)"
            )));
        }
        let mut bytes = Vec::with_capacity(size as usize);
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
                super::vtk_xml::room(&bytes, structure.encoding, array, place, values)?;
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
    pub fn columns(&self) -> Arc<[Column]> {
        self.columns.clone()
    }

    /// The number of points.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Reads every point's values of columns `wanted`, in that order, calling `row(i,
    /// values)`; an error `row` returns is returned.
    pub fn read_rows(
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
                    pieces.push(super::vtk_xml::decode(
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

/// A file's structure as a source finds it.
pub(super) struct Structure {
    pub(super) piece_counts: Vec<u64>,
    /// The points' array first.
    pub(super) arrays: Vec<Array>,
    pub(super) encoding: super::vtk_xml::Encoding,
}
