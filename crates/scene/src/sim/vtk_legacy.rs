//! Legacy VTK files (`.vtk`, VTK's file formats document, "Simple Legacy Formats"): a
//! version line, a title, `ASCII` or `BINARY` (big-endian), then `DATASET POLYDATA`,
//! `UNSTRUCTURED_GRID` or `STRUCTURED_GRID` with its `POINTS`; cells (`VERTICES`, `CELLS`,
//! ... in the count-and-size form or VTK 5's `OFFSETS`/`CONNECTIVITY`) and `CELL_DATA` read
//! past; `POINT_DATA` attributes (`SCALARS`, `VECTORS`, `NORMALS`, `TENSORS`,
//! `TEXTURE_COORDINATES`, `COLOR_SCALARS`, `FIELD` arrays) kept as the file's arrays.

use super::read_error::ReadError;
use super::vtk_data::{Array, Encoding, POINTS, Place, Structure, Ty, line_of};

/// The rows the attributes being read describe, and their number: the points'
/// (`POINT_DATA`) or the cells' (`CELL_DATA`).
#[derive(Clone, Copy)]
enum Rows {
    Points(u64),
    Cells(u64),
}

/// A cursor over a legacy file's words and its binary blocks.
struct Words<'a> {
    b: &'a [u8],
    pos: usize,
    binary: bool,
}

impl<'a> Words<'a> {
    fn bad<T>(&self, at: usize, what: impl std::fmt::Display) -> Result<T, ReadError> {
        Err(ReadError::Bad(format!(
            "line {}: {what}",
            line_of(self.b, at)
        )))
    }

    /// The next word and where it starts; `None` at the end.
    fn next(&mut self) -> Option<(&'a str, usize)> {
        while self.pos < self.b.len() && self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.b.len() && !self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        (start < self.pos).then(|| {
            (
                std::str::from_utf8(&self.b[start..self.pos]).unwrap_or("?"),
                start,
            )
        })
    }

    fn word(&mut self, what: &str) -> Result<(&'a str, usize), ReadError> {
        match self.next() {
            Some(w) => Ok(w),
            None => self.bad(
                self.b.len(),
                format_args!("the file ends where {what} should be (truncated)"),
            ),
        }
    }

    fn number(&mut self, what: &str) -> Result<u64, ReadError> {
        let (w, at) = self.word(what)?;
        w.parse().or_else(|_| {
            self.bad(
                at,
                format_args!(
                    "{what} is {:?}, not a whole number",
                    raytrace_core::error::elide(w)
                ),
            )
        })
    }

    fn ty(&mut self) -> Result<Ty, ReadError> {
        let (w, at) = self.word("a type")?;
        match Ty::legacy(w) {
            Some(t) => Ok(t),
            None => self.bad(at, format_args!(
                "unknown type {:?} (bit is not read; the types are char, unsigned_char, short, unsigned_short, int, unsigned_int, long, unsigned_long, float, double, vtktypeint64, vtktypeuint64)",
                raytrace_core::error::elide(w)
            )),
        }
    }

    /// Moves past the rest of the current line (a binary block starts after it).
    fn end_line(&mut self) {
        while self.pos < self.b.len() && self.b[self.pos] != b'\n' {
            self.pos += 1;
        }
        self.pos = (self.pos + 1).min(self.b.len());
    }

    /// Moves past `values` values of type `ty` (for `what`), returning where they are.
    fn skip(&mut self, values: u64, ty: Ty, what: &str) -> Result<Place, ReadError> {
        if self.binary {
            self.end_line();
            let start = self.pos;
            let bytes = values.checked_mul(ty.size() as u64);
            match bytes {
                Some(n) if n <= (self.b.len() - start) as u64 => {
                    self.pos += n as usize;
                    Ok(Place::Raw { start })
                }
                _ => self.bad(start, format_args!(
                    "{what}: {values} values of {} bytes, and the file holds only {} bytes after them (a wrong length, or truncated)",
                    ty.size(),
                    self.b.len() - start
                )),
            }
        } else {
            let start = self.pos;
            let room = (self.b.len() - start) as u64 / 2 + 1;
            if values > room {
                return self.bad(start, format_args!(
                    "{what}: {values} values, more than the {} bytes left can hold (a wrong length, or truncated)",
                    self.b.len() - start
                ));
            }
            for k in 0..values {
                let Some((w, at)) = self.next() else {
                    return self.bad(
                        self.b.len(),
                        format_args!(
                            "{what}: the file ends after {k} of its {values} values (truncated)"
                        ),
                    );
                };
                if ty.parse(w).is_none() {
                    return self.bad(
                        at,
                        format_args!(
                            "{what}: value {k} is {:?}, not a number of its type (a wrong length?)",
                            raytrace_core::error::elide(w)
                        ),
                    );
                }
            }
            Ok(Place::Text {
                start,
                end: self.b.len(),
            })
        }
    }

    /// The next word when `wanted` accepts it; otherwise `None`, the cursor where it was.
    fn next_if(&mut self, wanted: impl Fn(&str) -> bool) -> Option<&'a str> {
        let save = self.pos;
        match self.next() {
            Some((w, _)) if wanted(w) => Some(w),
            _ => {
                self.pos = save;
                None
            }
        }
    }

    /// Moves past a METADATA block: up to a blank line.
    fn skip_metadata(&mut self) {
        let rest = &self.b[self.pos..];
        let end = rest
            .windows(2)
            .position(|p| p == b"\n\n")
            .map_or(rest.len(), |k| k + 2);
        self.pos += end.min(rest.len());
    }

    /// The type of colour and lookup-table values: bytes in a binary file, floats in ASCII.
    fn byte_type(&self) -> Ty {
        if self.binary { Ty::U8 } else { Ty::F32 }
    }

    /// Checks DATASET's type: one whose points are read.
    fn dataset(&mut self) -> Result<(), ReadError> {
        let (kind, k) = self.word("the dataset's type")?;
        if !matches!(
            kind.to_ascii_uppercase().as_str(),
            "POLYDATA" | "UNSTRUCTURED_GRID" | "STRUCTURED_GRID"
        ) {
            return self.bad(k, format_args!("DATASET {kind}: the points are read from POLYDATA, UNSTRUCTURED_GRID and STRUCTURED_GRID"));
        }
        Ok(())
    }

    /// POINTS: their number and their array.
    fn points(&mut self) -> Result<(u64, Array), ReadError> {
        let n = self.number("the number of points")?;
        let ty = self.ty()?;
        let place = self.skip(n.saturating_mul(3), ty, "POINTS")?;
        let array = Array {
            name: POINTS.into(),
            components: 3,
            ty,
            pieces: vec![place],
        };
        Ok((n, array))
    }

    /// Moves past a cell list (`key`: `VERTICES`... `CELLS`), in the count-and-size form or
    /// VTK 5's `OFFSETS` and `CONNECTIVITY`.
    fn cells(&mut self, key: &str) -> Result<(), ReadError> {
        let a = self.number("a cell count")?;
        let size = self.number("a cell list's size")?;
        if self
            .next_if(|o| o.eq_ignore_ascii_case("OFFSETS"))
            .is_none()
        {
            self.skip(size, Ty::I32, key)?;
            return Ok(());
        }
        let ty = self.ty()?;
        self.skip(a, ty, "OFFSETS")?;
        let (c, k) = self.word("CONNECTIVITY")?;
        if !c.eq_ignore_ascii_case("CONNECTIVITY") {
            return self.bad(
                k,
                format_args!("expected CONNECTIVITY after OFFSETS, found {c:?}"),
            );
        }
        let ty = self.ty()?;
        self.skip(size, ty, "CONNECTIVITY")?;
        Ok(())
    }

    /// The rows of the attributes after POINT_DATA or CELL_DATA (`key`, at `at`); the
    /// points' number must be the file's `count`.
    fn data_rows(&mut self, key: &str, at: usize, count: Option<u64>) -> Result<Rows, ReadError> {
        let n = self.number(key)?;
        let points = key == "POINT_DATA";
        if points && count.is_some_and(|c| c != n) {
            return self.bad(
                at,
                format_args!(
                    "POINT_DATA {n}, and the file has {} points",
                    count.unwrap_or(0)
                ),
            );
        }
        Ok(if points {
            Rows::Points(n)
        } else {
            Rows::Cells(n)
        })
    }

    /// An attribute (`key`: `SCALARS`... `COLOR_SCALARS`, at `at`) of `rows`: its array when
    /// the rows are the points', `None` when they are the cells'.
    fn attribute(&mut self, key: &str, at: usize, rows: Rows) -> Result<Option<Array>, ReadError> {
        let (Rows::Points(n) | Rows::Cells(n)) = rows;
        let (name, _) = self.word("the attribute's name")?;
        let name = name.to_string();
        let (components, ty) = self.attribute_shape(key)?;
        if components == 0 || components > 64 {
            return self.bad(at, format_args!("{key} {name}: {components} components"));
        }
        let place = self.skip(
            n.saturating_mul(components as u64),
            ty,
            &format!("{key} {name}"),
        )?;
        Ok(matches!(rows, Rows::Points(_)).then(|| Array {
            name,
            components,
            ty,
            pieces: vec![place],
        }))
    }

    /// An attribute's components and type, as its keyword (`key`) writes them.
    fn attribute_shape(&mut self, key: &str) -> Result<(u8, Ty), ReadError> {
        Ok(match key {
            "SCALARS" => self.scalars_shape()?,
            "VECTORS" | "NORMALS" => (3, self.ty()?),
            "TENSORS" => (9, self.ty()?),
            "TENSORS6" => (6, self.ty()?),
            "TEXTURE_COORDINATES" => {
                let d = self.number("the texture's dimension")?;
                (d.clamp(1, 3) as u8, self.ty()?)
            }
            _ => {
                let k = self.number("the colour's values")?;
                (k.clamp(1, 4) as u8, self.byte_type())
            }
        })
    }

    /// SCALARS' components and type: the type, then an optional component count (1 without)
    /// and an optional LOOKUP_TABLE line.
    fn scalars_shape(&mut self) -> Result<(u8, Ty), ReadError> {
        let ty = self.ty()?;
        let components = self
            .next_if(|c| c.parse::<u8>().is_ok())
            .map_or(1, |c| c.parse::<u8>().unwrap_or(1));
        if self
            .next_if(|l| l.eq_ignore_ascii_case("LOOKUP_TABLE"))
            .is_some()
        {
            self.word("the lookup table's name")?;
        }
        Ok((components, ty))
    }

    /// Moves past a LOOKUP_TABLE: its name, its size and its RGBA values.
    fn lookup_table(&mut self) -> Result<(), ReadError> {
        self.word("the lookup table's name")?;
        let size = self.number("the lookup table's size")?;
        self.skip(size.saturating_mul(4), self.byte_type(), "LOOKUP_TABLE")?;
        Ok(())
    }

    /// Reads a FIELD (at `at`) past, adding its arrays to `arrays` where `rows` are the
    /// points'.
    fn field(
        &mut self,
        at: usize,
        rows: Option<Rows>,
        arrays: &mut Vec<Array>,
    ) -> Result<(), ReadError> {
        self.word("the field's name")?;
        let k = self.number("the field's number of arrays")?;
        for _ in 0..k {
            arrays.extend(self.field_array(at, rows)?);
            // A METADATA block may follow an array.
            if self
                .next_if(|m| m.eq_ignore_ascii_case("METADATA"))
                .is_some()
            {
                self.skip_metadata();
            }
        }
        Ok(())
    }

    /// One array of a FIELD (at `at`): its array when `rows` are the points' (whose number
    /// its tuples must be), `None` otherwise.
    fn field_array(&mut self, at: usize, rows: Option<Rows>) -> Result<Option<Array>, ReadError> {
        let (name, _) = self.word("a field array's name")?;
        let name = name.to_string();
        let comps = self.number("a field array's components")?;
        let tuples = self.number("a field array's tuples")?;
        let ty = self.ty()?;
        if !(1..=64).contains(&comps) {
            return self.bad(at, format_args!("field array {name}: {comps} components"));
        }
        let place = self.skip(
            tuples.saturating_mul(comps),
            ty,
            &format!("field array {name}"),
        )?;
        match rows {
            Some(Rows::Points(n)) if tuples == n => Ok(Some(Array {
                name,
                components: comps as u8,
                ty,
                pieces: vec![place],
            })),
            Some(Rows::Points(n)) => self.bad(
                at,
                format_args!("field array {name} has {tuples} tuples, and POINT_DATA {n}"),
            ),
            _ => Ok(None),
        }
    }
}

/// Whether the third line, the encoding, says BINARY (not ASCII); an error when it says
/// neither.
fn is_binary(b: &[u8]) -> Result<bool, ReadError> {
    // Three lines: the version, a title, the encoding.
    let mut lines = b.splitn(4, |&c| c == b'\n');
    let _version = lines.next();
    let _title = lines.next();
    let encoding = lines
        .next()
        .map(|l| String::from_utf8_lossy(l).trim().to_ascii_uppercase());
    match encoding.as_deref() {
        Some("ASCII") => Ok(false),
        Some("BINARY") => Ok(true),
        other => Err(ReadError::Bad(format!(
            "line 3 is {:?}, not ASCII or BINARY",
            other.unwrap_or("")
        ))),
    }
}

/// Where the three header lines end (the file's length when it has fewer).
fn header_end(b: &[u8]) -> usize {
    b.iter()
        .enumerate()
        .filter(|(_, c)| **c == b'\n')
        .nth(2)
        .map_or(b.len(), |(k, _)| k + 1)
}

/// The structure of a legacy file.
pub(super) fn structure(b: &[u8]) -> Result<Structure, ReadError> {
    let binary = is_binary(b)?;
    let mut w = Words {
        b,
        pos: header_end(b),
        binary,
    };
    let mut count: Option<u64> = None;
    let mut arrays: Vec<Array> = Vec::new();
    // The rows of the attributes read, once POINT_DATA or CELL_DATA has said.
    let mut rows: Option<Rows> = None;
    while let Some((key, at)) = w.next() {
        let key = key.to_ascii_uppercase();
        match key.as_str() {
            "DATASET" => w.dataset()?,
            "DIMENSIONS" => {
                for _ in 0..3 {
                    w.number("a dimension")?;
                }
            }
            "POINTS" => {
                let (n, points) = w.points()?;
                count = Some(n);
                arrays.insert(0, points);
            }
            "VERTICES" | "LINES" | "POLYGONS" | "TRIANGLE_STRIPS" | "CELLS" => w.cells(&key)?,
            "CELL_TYPES" => {
                let n = w.number("the number of cell types")?;
                w.skip(n, Ty::I32, "CELL_TYPES")?;
            }
            "METADATA" => w.skip_metadata(),
            "POINT_DATA" | "CELL_DATA" => rows = Some(w.data_rows(&key, at, count)?),
            "SCALARS"
            | "VECTORS"
            | "NORMALS"
            | "TENSORS"
            | "TENSORS6"
            | "TEXTURE_COORDINATES"
            | "COLOR_SCALARS" => {
                let Some(rows) = rows else {
                    return w.bad(at, format_args!("{key} before POINT_DATA or CELL_DATA"));
                };
                arrays.extend(w.attribute(&key, at, rows)?);
            }
            "LOOKUP_TABLE" => w.lookup_table()?,
            "FIELD" => w.field(at, rows, &mut arrays)?,
            other => {
                return w.bad(
                    at,
                    format_args!(
                        "unknown keyword {:?} (a wrong length before it?)",
                        raytrace_core::error::elide(other)
                    ),
                );
            }
        }
    }
    let Some(n) = count else {
        return Err(ReadError::Bad("no POINTS: no points".into()));
    };
    Ok(Structure {
        piece_counts: vec![n],
        arrays,
        encoding: Encoding {
            big: true,
            ..Encoding::default()
        },
    })
}
