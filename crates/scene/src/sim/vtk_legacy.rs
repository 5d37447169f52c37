//! Legacy VTK files (`.vtk`, VTK's file formats document, "Simple Legacy Formats"): a
//! version line, a title, `ASCII` or `BINARY` (big-endian), then `DATASET POLYDATA`,
//! `UNSTRUCTURED_GRID` or `STRUCTURED_GRID` with its `POINTS`; cells (`VERTICES`, `CELLS`,
//! ... in the count-and-size form or VTK 5's `OFFSETS`/`CONNECTIVITY`) and `CELL_DATA` read
//! past; `POINT_DATA` attributes (`SCALARS`, `VECTORS`, `NORMALS`, `TENSORS`,
//! `TEXTURE_COORDINATES`, `COLOR_SCALARS`, `FIELD` arrays) kept as the file's arrays.

use super::read_error::ReadError;
use super::vtk_data::{Array, Encoding, POINTS, Place, Structure, Ty, line_of};

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
}

/// The structure of a legacy file.
pub(super) fn structure(b: &[u8]) -> Result<Structure, ReadError> {
    // Three lines: the version, a title, the encoding.
    let mut lines = b.splitn(4, |&c| c == b'\n');
    let _version = lines.next();
    let _title = lines.next();
    let encoding = lines
        .next()
        .map(|l| String::from_utf8_lossy(l).trim().to_ascii_uppercase());
    let binary = match encoding.as_deref() {
        Some("ASCII") => false,
        Some("BINARY") => true,
        other => {
            return Err(ReadError::Bad(format!(
                "line 3 is {:?}, not ASCII or BINARY",
                other.unwrap_or("")
            )));
        }
    };
    let header: usize = b
        .iter()
        .enumerate()
        .filter(|(_, c)| **c == b'\n')
        .nth(2)
        .map_or(b.len(), |(k, _)| k + 1);
    let mut w = Words {
        b,
        pos: header,
        binary,
    };
    let mut count: Option<u64> = None;
    let mut arrays: Vec<Array> = Vec::new();
    // Rows of the attributes read: the points' (POINT_DATA) or the cells' (CELL_DATA).
    let mut rows: Option<(u64, bool)> = None;
    while let Some((key, at)) = w.next() {
        let key = key.to_ascii_uppercase();
        let attribute_rows = |what: &str| -> Result<(u64, bool), ReadError> {
            rows.ok_or_else(|| {
                ReadError::Bad(format!(
                    "line {}: {what} before POINT_DATA or CELL_DATA",
                    line_of(b, at)
                ))
            })
        };
        match key.as_str() {
            "DATASET" => {
                let (kind, k) = w.word("the dataset's type")?;
                if !matches!(
                    kind.to_ascii_uppercase().as_str(),
                    "POLYDATA" | "UNSTRUCTURED_GRID" | "STRUCTURED_GRID"
                ) {
                    return w.bad(k, format_args!("DATASET {kind}: the points are read from POLYDATA, UNSTRUCTURED_GRID and STRUCTURED_GRID"));
                }
            }
            "DIMENSIONS" => {
                for _ in 0..3 {
                    w.number("a dimension")?;
                }
            }
            "POINTS" => {
                let n = w.number("the number of points")?;
                let ty = w.ty()?;
                let place = w.skip(n.saturating_mul(3), ty, "POINTS")?;
                count = Some(n);
                arrays.insert(
                    0,
                    Array {
                        name: POINTS.into(),
                        components: 3,
                        ty,
                        pieces: vec![place],
                    },
                );
            }
            "VERTICES" | "LINES" | "POLYGONS" | "TRIANGLE_STRIPS" | "CELLS" => {
                let a = w.number("a cell count")?;
                let size = w.number("a cell list's size")?;
                let before = w.pos;
                match w.next() {
                    Some((o, _)) if o.eq_ignore_ascii_case("OFFSETS") => {
                        let ty = w.ty()?;
                        w.skip(a, ty, "OFFSETS")?;
                        let (c, k) = w.word("CONNECTIVITY")?;
                        if !c.eq_ignore_ascii_case("CONNECTIVITY") {
                            return w.bad(
                                k,
                                format_args!("expected CONNECTIVITY after OFFSETS, found {c:?}"),
                            );
                        }
                        let ty = w.ty()?;
                        w.skip(size, ty, "CONNECTIVITY")?;
                    }
                    _ => {
                        w.pos = before;
                        w.skip(size, Ty::I32, &key)?;
                    }
                }
            }
            "CELL_TYPES" => {
                let n = w.number("the number of cell types")?;
                w.skip(n, Ty::I32, "CELL_TYPES")?;
            }
            "METADATA" => {
                // Up to a blank line.
                let rest = &b[w.pos..];
                let end = rest
                    .windows(2)
                    .position(|p| p == b"\n\n")
                    .map_or(rest.len(), |k| k + 2);
                w.pos += end.min(rest.len());
            }
            "POINT_DATA" | "CELL_DATA" => {
                let n = w.number(&key)?;
                let points = key == "POINT_DATA";
                if points && count.is_some_and(|c| c != n) {
                    return w.bad(
                        at,
                        format_args!(
                            "POINT_DATA {n}, and the file has {} points",
                            count.unwrap_or(0)
                        ),
                    );
                }
                rows = Some((n, points));
            }
            "SCALARS"
            | "VECTORS"
            | "NORMALS"
            | "TENSORS"
            | "TENSORS6"
            | "TEXTURE_COORDINATES"
            | "COLOR_SCALARS" => {
                let (n, points) = attribute_rows(&key)?;
                let (name, _) = w.word("the attribute's name")?;
                let name = name.to_string();
                let (components, ty) = match key.as_str() {
                    "SCALARS" => {
                        let ty = w.ty()?;
                        // An optional component count, then an optional LOOKUP_TABLE line.
                        let save = w.pos;
                        let comps = match w.next() {
                            Some((c, _)) if c.parse::<u8>().is_ok() => c.parse::<u8>().unwrap_or(1),
                            _ => {
                                w.pos = save;
                                1
                            }
                        };
                        let save = w.pos;
                        match w.next() {
                            Some((l, _)) if l.eq_ignore_ascii_case("LOOKUP_TABLE") => {
                                w.word("the lookup table's name")?;
                            }
                            _ => w.pos = save,
                        }
                        (comps, ty)
                    }
                    "VECTORS" | "NORMALS" => (3, w.ty()?),
                    "TENSORS" => (9, w.ty()?),
                    "TENSORS6" => (6, w.ty()?),
                    "TEXTURE_COORDINATES" => {
                        let d = w.number("the texture's dimension")?;
                        (d.clamp(1, 3) as u8, w.ty()?)
                    }
                    _ => {
                        let k = w.number("the colour's values")?;
                        (k.clamp(1, 4) as u8, if binary { Ty::U8 } else { Ty::F32 })
                    }
                };
                if components == 0 || components > 64 {
                    return w.bad(at, format_args!("{key} {name}: {components} components"));
                }
                let place = w.skip(
                    n.saturating_mul(components as u64),
                    ty,
                    &format!("{key} {name}"),
                )?;
                if points {
                    arrays.push(Array {
                        name,
                        components,
                        ty,
                        pieces: vec![place],
                    });
                }
            }
            "LOOKUP_TABLE" => {
                w.word("the lookup table's name")?;
                let size = w.number("the lookup table's size")?;
                w.skip(
                    size.saturating_mul(4),
                    if binary { Ty::U8 } else { Ty::F32 },
                    "LOOKUP_TABLE",
                )?;
            }
            "FIELD" => {
                w.word("the field's name")?;
                let k = w.number("the field's number of arrays")?;
                for _ in 0..k {
                    let (name, _) = w.word("a field array's name")?;
                    let name = name.to_string();
                    let comps = w.number("a field array's components")?;
                    let tuples = w.number("a field array's tuples")?;
                    let ty = w.ty()?;
                    if !(1..=64).contains(&comps) {
                        return w.bad(at, format_args!("field array {name}: {comps} components"));
                    }
                    let place = w.skip(
                        tuples.saturating_mul(comps),
                        ty,
                        &format!("field array {name}"),
                    )?;
                    match rows {
                        Some((n, true)) if tuples == n => arrays.push(Array {
                            name,
                            components: comps as u8,
                            ty,
                            pieces: vec![place],
                        }),
                        Some((n, true)) => {
                            return w.bad(
                                at,
                                format_args!(
                                    "field array {name} has {tuples} tuples, and POINT_DATA {n}"
                                ),
                            );
                        }
                        _ => {}
                    }
                    // A METADATA block may follow an array.
                    let save = w.pos;
                    match w.next() {
                        Some((m, _)) if m.eq_ignore_ascii_case("METADATA") => {
                            let rest = &b[w.pos..];
                            let end = rest
                                .windows(2)
                                .position(|p| p == b"\n\n")
                                .map_or(rest.len(), |e| e + 2);
                            w.pos += end.min(rest.len());
                        }
                        _ => w.pos = save,
                    }
                }
            }
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
