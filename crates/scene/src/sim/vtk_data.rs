//! VTK arrays' values wherever a file keeps them, decoded (the legacy and the XML readers
//! share this): the number types, where a piece's values are (text, raw bytes, base64,
//! appended), and the decoding of each: VTK's writers encode a header and its data apart,
//! padding each, so base64 is decoded four characters at a time; each binary XML array is a
//! byte count (or, zlib-compressed, a block table) before its data (VTK's file formats
//! document, "XML File Formats").

use std::io::Read;

use super::read_error::ReadError;

/// The name the points' positions go by among a VTK file's columns.
pub(crate) const POINTS: &str = "Points";

/// A number type of VTK arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Ty {
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

    pub(super) fn is_integer(self) -> bool {
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
    pub(super) pieces: Vec<Place>,
}

/// How a file's binary data is written.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Encoding {
    pub(super) big: bool,
    /// Byte counts and block tables in 64-bit words (`header_type="UInt64"`), else 32.
    pub(super) header64: bool,
    pub(super) zlib: bool,
    /// Where the appended data begins (after its `_`) and whether it is base64.
    pub(super) appended: Option<(usize, bool)>,
}

/// Where a piece's values of an array are.
#[derive(Clone, Debug)]
pub(super) enum Place {
    /// Numbers as text from `start`, within `end`.
    Text { start: usize, end: usize },
    /// A legacy file's binary values (big-endian, no byte count) from `start`.
    Raw { start: usize },
    /// Inline base64 text in `start..end`.
    Base64 { start: usize, end: usize },
    /// At `offset` in the appended data.
    Appended { offset: usize },
}

/// The line (from 1) of byte `pos`.
pub(super) fn line_of(bytes: &[u8], pos: usize) -> usize {
    bytes[..pos.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

pub(super) fn bad<T>(
    bytes: &[u8],
    pos: usize,
    what: impl std::fmt::Display,
) -> Result<T, ReadError> {
    Err(ReadError::Bad(format!(
        "line {}: {what}",
        line_of(bytes, pos)
    )))
}

/// A file's structure as a source finds it.
pub(super) struct Structure {
    pub(super) piece_counts: Vec<u64>,
    /// The points' array first.
    pub(super) arrays: Vec<Array>,
    pub(super) encoding: Encoding,
}

/// Bytes read one after another from raw bytes or from base64 text.
struct Stream<'a> {
    b: &'a [u8],
    pos: usize,
    end: usize,
    base64: bool,
    /// Decoded bytes not yet taken (base64).
    pending: Vec<u8>,
}

fn sextet(c: u8) -> Option<u32> {
    Some(match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => return None,
    } as u32)
}

impl Stream<'_> {
    /// The next `n` bytes; an error when the data ends first (checked before allocating).
    fn take(&mut self, n: usize, what: &str) -> Result<Vec<u8>, ReadError> {
        let short = || {
            ReadError::Bad(format!(
                "{what}: the data ends before the {n} bytes it needs (a wrong length)"
            ))
        };
        if !self.base64 {
            if n > self.end - self.pos {
                return Err(short());
            }
            self.pos += n;
            return Ok(self.b[self.pos - n..self.pos].to_vec());
        }
        if n > (self.end - self.pos) / 4 * 3 + self.pending.len() + 3 {
            return Err(short());
        }
        let mut out = std::mem::take(&mut self.pending);
        while out.len() < n {
            let mut group = [0u8; 4];
            let mut k = 0;
            while k < 4 {
                if self.pos >= self.end {
                    return Err(short());
                }
                let c = self.b[self.pos];
                self.pos += 1;
                if !c.is_ascii_whitespace() {
                    group[k] = c;
                    k += 1;
                }
            }
            let pad = group
                .iter()
                .rev()
                .take_while(|&&c| c == b'=')
                .count()
                .min(2);
            let mut word = 0u32;
            for &c in &group[..4 - pad] {
                let Some(s) = sextet(c) else {
                    return Err(ReadError::Bad(format!(
                        "{what}: {:?} is not base64",
                        c as char
                    )));
                };
                word = word << 6 | s;
            }
            word <<= 6 * pad as u32;
            let bytes = [(word >> 16) as u8, (word >> 8) as u8, word as u8];
            out.extend(&bytes[..3 - pad]);
        }
        self.pending = out.split_off(n);
        Ok(out)
    }

    fn word(&mut self, enc: Encoding, what: &str) -> Result<u64, ReadError> {
        let size = if enc.header64 { 8 } else { 4 };
        let b = self.take(size, what)?;
        Ok(if enc.header64 { Ty::U64 } else { Ty::U32 }.value(&b, enc.big) as u64)
    }
}

/// Whether `array`'s piece at `place` can hold `values` numbers, found without decoding them
/// (before anything is allocated for them): text of two bytes a value at least, base64 of
/// four characters to three bytes, raw bytes, a zlib block table whose blocks add up.
pub(super) fn room(
    b: &[u8],
    enc: Encoding,
    array: &Array,
    place: &Place,
    values: usize,
) -> Result<(), ReadError> {
    let what = format!("array {}", array.name);
    let need = values.saturating_mul(array.ty.size());
    let (start, end, base64) = match *place {
        Place::Text { start, end } => return text_room(b, start, end, values, &what),
        Place::Raw { .. } => return Ok(()),
        Place::Base64 { start, end } => (start, end, true),
        Place::Appended { offset } => {
            let (at, base64) = enc.appended.expect("checked");
            (at.saturating_add(offset).min(b.len()), b.len(), base64)
        }
    };
    let mut stream = Stream {
        b,
        pos: start,
        end,
        base64,
        pending: Vec::new(),
    };
    if enc.zlib {
        let total = BlockTable::read(&mut stream, enc, &what)?.total();
        if total != need {
            return bad(
                b,
                start,
                format_args!(
                    "{what}: its blocks hold {total} bytes, and {values} values of {} bytes need {need} (a wrong length)",
                    array.ty.size()
                ),
            );
        }
        return Ok(());
    }
    let declared = stream.word(enc, &what)? as usize;
    if declared != need {
        return bad(
            b,
            start,
            format_args!(
                "{what}: it declares {declared} bytes, and {values} values of {} bytes need {need} (a wrong length)",
                array.ty.size()
            ),
        );
    }
    let left = if base64 {
        (stream.end - stream.pos) / 4 * 3 + 3
    } else {
        stream.end - stream.pos
    };
    if need > left {
        return bad(
            b,
            start,
            format_args!("{what}: the data ends before the {need} bytes it needs (a wrong length)"),
        );
    }
    Ok(())
}

/// Checks that text in `start..end` can hold `values` numbers: a value takes at least two
/// bytes (a digit and a separator), but the last.
fn text_room(
    b: &[u8],
    start: usize,
    end: usize,
    values: usize,
    what: &str,
) -> Result<(), ReadError> {
    if values > (end - start) / 2 + 1 {
        return bad(
            b,
            start,
            format_args!(
                "{what}: {} bytes cannot hold its {values} values (a wrong length)",
                end - start
            ),
        );
    }
    Ok(())
}

/// The head of a zlib-compressed array's block table (VTK's file formats document, "XML
/// File Formats", compressed data): the number of blocks, the uncompressed size of a block,
/// and that of the last (0: a whole block).
struct BlockTable {
    blocks: usize,
    block: usize,
    last: usize,
}

impl BlockTable {
    /// Reads the table's first three words.
    fn read(stream: &mut Stream<'_>, enc: Encoding, what: &str) -> Result<BlockTable, ReadError> {
        Ok(BlockTable {
            blocks: stream.word(enc, what)? as usize,
            block: stream.word(enc, what)? as usize,
            last: stream.word(enc, what)? as usize,
        })
    }

    /// The uncompressed bytes of all the blocks.
    fn total(&self) -> usize {
        match self.blocks {
            0 => 0,
            n => (n - 1)
                .saturating_mul(self.block)
                .saturating_add(if self.last == 0 {
                    self.block
                } else {
                    self.last
                }),
        }
    }

    /// The uncompressed bytes of block `k`.
    fn size_of(&self, k: usize) -> usize {
        if k + 1 == self.blocks && self.last != 0 {
            self.last
        } else {
            self.block
        }
    }
}

/// Decodes `values` numbers of `array`'s piece at `place`.
pub(super) fn decode(
    b: &[u8],
    enc: Encoding,
    array: &Array,
    place: &Place,
    values: usize,
) -> Result<Vec<f64>, ReadError> {
    let what = format!("array {}", array.name);
    let size = array.ty.size();
    let need = values
        .checked_mul(size)
        .ok_or_else(|| ReadError::Bad(format!("{what}: too many values")))?;
    let mut stream = match *place {
        Place::Text { start, end } => {
            return decode_text(b, start, end, array, values, &what, end != b.len());
        }
        Place::Raw { start } => return decode_raw(b, start, array, values, need, &what),
        Place::Base64 { start, end } => Stream {
            b,
            pos: start,
            end,
            base64: true,
            pending: Vec::new(),
        },
        Place::Appended { offset } => appended_stream(b, enc, offset, &what)?,
    };
    let bytes = if enc.zlib {
        inflate(&mut stream, enc, values, size, need, &what)?
    } else {
        let declared = stream.word(enc, &what)? as usize;
        if declared != need {
            return Err(ReadError::Bad(format!(
                "{what}: it declares {declared} bytes, and {values} values of {size} bytes need {need} (a wrong length)"
            )));
        }
        stream.take(need, &what)?
    };
    Ok(bytes
        .chunks_exact(size)
        .map(|c| array.ty.value(c, enc.big))
        .collect())
}

/// The `values` numbers (`need` bytes) of a legacy file's binary block at `start`
/// (big-endian).
fn decode_raw(
    b: &[u8],
    start: usize,
    array: &Array,
    values: usize,
    need: usize,
    what: &str,
) -> Result<Vec<f64>, ReadError> {
    if need > b.len() - start {
        return bad(
            b,
            start,
            format_args!("{what}: the file ends before its {values} values"),
        );
    }
    Ok(b[start..start + need]
        .chunks_exact(array.ty.size())
        .map(|c| array.ty.value(c, true))
        .collect())
}

/// The appended data from `offset` as a stream; an error when `offset` is past it.
fn appended_stream<'a>(
    b: &'a [u8],
    enc: Encoding,
    offset: usize,
    what: &str,
) -> Result<Stream<'a>, ReadError> {
    let (at, base64) = enc.appended.expect("checked");
    let pos = at.checked_add(offset).filter(|&p| p <= b.len());
    let Some(pos) = pos else {
        return Err(ReadError::Bad(format!(
            "{what}: offset {offset} is past the appended data"
        )));
    };
    Ok(Stream {
        b,
        pos,
        end: b.len(),
        base64,
        pending: Vec::new(),
    })
}

/// The `need` bytes of a zlib-compressed array of `values` values of `size` bytes: its
/// block table, whose blocks must add up to them, then each block decompressed to its size.
fn inflate(
    stream: &mut Stream<'_>,
    enc: Encoding,
    values: usize,
    size: usize,
    need: usize,
    what: &str,
) -> Result<Vec<u8>, ReadError> {
    let table = BlockTable::read(stream, enc, what)?;
    let total = table.total();
    if total != need {
        return Err(ReadError::Bad(format!(
            "{what}: its blocks hold {total} bytes, and {values} values of {size} bytes need {need} (a wrong length)"
        )));
    }
    let mut sizes = Vec::new();
    for _ in 0..table.blocks.min(need / table.block.max(1) + 1) {
        sizes.push(stream.word(enc, what)? as usize);
    }
    let mut out = Vec::with_capacity(need.min(1 << 26));
    for (k, &compressed) in sizes.iter().enumerate() {
        let data = stream.take(compressed, what)?;
        let want = table.size_of(k);
        let mut part = Vec::new();
        flate2::read::ZlibDecoder::new(&data[..])
            .take(want as u64 + 1)
            .read_to_end(&mut part)
            .map_err(|e| ReadError::Bad(format!("{what}: block {k} does not decompress ({e})")))?;
        if part.len() != want {
            return Err(ReadError::Bad(format!(
                "{what}: block {k} holds {} bytes, not {want}",
                part.len()
            )));
        }
        out.extend(part);
    }
    Ok(out)
}

/// `values` numbers written as text from `start` (within `end`); `exact`: nothing but
/// whitespace may follow them before `end` (an XML array's content).
fn decode_text(
    b: &[u8],
    start: usize,
    end: usize,
    array: &Array,
    values: usize,
    what: &str,
    exact: bool,
) -> Result<Vec<f64>, ReadError> {
    text_room(b, start, end, values, what)?;
    let mut out = Vec::with_capacity(values);
    let mut pos = start;
    let text = &b[..end];
    while out.len() < values {
        while pos < end && text[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let from = pos;
        while pos < end && !text[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if from == pos {
            return bad(
                b,
                from,
                format_args!(
                    "{what}: {} values where its points need {values} (a wrong length)",
                    out.len()
                ),
            );
        }
        let token = std::str::from_utf8(&text[from..pos]).unwrap_or("?");
        match array.ty.parse(token) {
            Some(x) => out.push(x),
            None => {
                return bad(
                    b,
                    from,
                    format_args!(
                        "{what}: value {} is {:?}, not a number of type {:?}",
                        out.len(),
                        raytrace_core::error::elide(token),
                        array.ty
                    ),
                );
            }
        }
    }
    if exact && text[pos..end].iter().any(|c| !c.is_ascii_whitespace()) {
        return bad(
            b,
            pos,
            format_args!("{what}: more values than its points need ({values}) (a wrong length)"),
        );
    }
    Ok(out)
}
