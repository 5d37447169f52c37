//! Writing a PLY file of one vertex element.

use std::io::Write;

use super::header::{Encoding, Scalar};

/// One column of a vertex element to write: its name, its type and its values.
pub struct Column<'a> {
    pub name: &'a str,
    pub ty: Scalar,
    pub values: &'a [f64],
}

/// Writes a PLY file of one `vertex` element with `columns` (all of the same length), in
/// `encoding`. Values are converted to their column's type (`as`); ASCII floats are written
/// in the shortest form that reads back to the same value.
pub fn write_vertices(
    out: &mut impl Write,
    encoding: Encoding,
    columns: &[Column],
) -> std::io::Result<()> {
    let n = columns.first().map_or(0, |c| c.values.len());
    assert!(columns.iter().all(|c| c.values.len() == n));
    writeln!(out, "ply\nformat {} 1.0", encoding.name())?;
    writeln!(out, "element vertex {n}")?;
    for c in columns {
        writeln!(out, "property {} {}", c.ty.name(), c.name)?;
    }
    writeln!(out, "end_header")?;
    let big = encoding == Encoding::BinaryBigEndian;
    let mut line = String::new();
    for i in 0..n {
        if encoding == Encoding::Ascii {
            use std::fmt::Write as _;
            line.clear();
            for (k, c) in columns.iter().enumerate() {
                let v = c.values[i];
                let sep = if k == 0 { "" } else { " " };
                let _ = match c.ty {
                    // Debug: the shortest form that reads back, with an exponent where long.
                    Scalar::F32 => write!(line, "{sep}{:?}", v as f32),
                    Scalar::F64 => write!(line, "{sep}{v:?}"),
                    _ => write!(line, "{sep}{}", v as i64),
                };
            }
            line.push('\n');
            out.write_all(line.as_bytes())?;
            continue;
        }
        for c in columns {
            let v = c.values[i];
            macro_rules! put {
                ($x:expr) => {
                    if big {
                        out.write_all(&$x.to_be_bytes())?
                    } else {
                        out.write_all(&$x.to_le_bytes())?
                    }
                };
            }
            match c.ty {
                Scalar::I8 => put!(v as i8),
                Scalar::U8 => put!(v as u8),
                Scalar::I16 => put!(v as i16),
                Scalar::U16 => put!(v as u16),
                Scalar::I32 => put!(v as i32),
                Scalar::U32 => put!(v as u32),
                Scalar::F32 => put!(v as f32),
                Scalar::F64 => put!(v),
            }
        }
    }
    Ok(())
}
