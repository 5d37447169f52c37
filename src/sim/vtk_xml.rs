//! VTK XML files (`.vtp`, `.vtu`): a scanner of the tags VTK writes, the structure of the
//! points and point data arrays of every piece, and the decoding of an array's values
//! wherever they are (which the legacy reader shares): text, raw bytes, base64 (VTK's
//! writers encode a header and its data apart, padding each, so base64 is decoded four
//! characters at a time), each binary array a byte count (or, zlib-compressed, a block
//! table) before its data (VTK's file formats document, "XML File Formats").

use std::io::Read;

use super::ReadError;
use super::vtk::{Array, POINTS, Structure, Ty};

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

fn bad<T>(bytes: &[u8], pos: usize, what: impl std::fmt::Display) -> Result<T, ReadError> {
    Err(ReadError::Bad(format!(
        "line {}: {what}",
        line_of(bytes, pos)
    )))
}

/// A tag: its name, attributes, whether it closes (`</x>`) or is empty (`<x/>`), and where
/// it starts and ends.
struct Tag {
    name: String,
    attributes: Vec<(String, String)>,
    closing: bool,
    empty: bool,
    start: usize,
    end: usize,
}

impl Tag {
    fn get(&self, key: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// The next tag from `pos` (comments, declarations and processing instructions read past).
fn next_tag(b: &[u8], mut pos: usize) -> Result<Option<Tag>, ReadError> {
    loop {
        let Some(open) = b[pos..].iter().position(|&c| c == b'<').map(|k| pos + k) else {
            return Ok(None);
        };
        let rest = &b[open..];
        let skip_to = |end: &[u8]| -> Result<usize, ReadError> {
            match rest.windows(end.len()).position(|w| w == end) {
                Some(k) => Ok(open + k + end.len()),
                None => bad(b, open, "a comment or declaration that does not end"),
            }
        };
        if rest.starts_with(b"<!--") {
            pos = skip_to(b"-->")?;
            continue;
        }
        if rest.starts_with(b"<?") || rest.starts_with(b"<!") {
            pos = skip_to(b">")?;
            continue;
        }
        let Some(close) = rest.iter().position(|&c| c == b'>') else {
            return bad(b, open, "a tag that does not end");
        };
        let inner = std::str::from_utf8(&rest[1..close])
            .or_else(|_| bad(b, open, "a tag that is not text"))?;
        let closing = inner.starts_with('/');
        let empty = inner.ends_with('/');
        let inner = inner.trim_start_matches('/').trim_end_matches('/');
        let name_end = inner.find(char::is_whitespace).unwrap_or(inner.len());
        let name = inner[..name_end].to_string();
        let mut attributes = Vec::new();
        let mut s = inner[name_end..].trim_start();
        while !s.is_empty() {
            let Some(eq) = s.find('=') else {
                return bad(
                    b,
                    open,
                    format_args!("tag {name}: an attribute without a value"),
                );
            };
            let key = s[..eq].trim().to_string();
            let after = s[eq + 1..].trim_start();
            let quote = after.chars().next().filter(|c| *c == '"' || *c == '\'');
            let Some(q) = quote else {
                return bad(
                    b,
                    open,
                    format_args!("tag {name}: attribute {key} is not quoted"),
                );
            };
            let Some(end) = after[1..].find(q) else {
                return bad(
                    b,
                    open,
                    format_args!("tag {name}: attribute {key} has no closing quote"),
                );
            };
            let value = after[1..1 + end]
                .replace("&quot;", "\"")
                .replace("&apos;", "'")
                .replace("&lt;", "<")
                .replace("&gt;", ">")
                .replace("&amp;", "&");
            attributes.push((key, value));
            s = after[1 + end + 1..].trim_start();
        }
        return Ok(Some(Tag {
            name,
            attributes,
            closing,
            empty,
            start: open,
            end: open + close + 1,
        }));
    }
}

/// One `<DataArray>` found in a piece.
struct Found {
    array: Array,
    at: usize,
}

/// The structure of an XML file: its pieces' point counts, the points' array and the point
/// data arrays (the same in every piece), where their values are.
pub(super) fn structure(b: &[u8]) -> Result<Structure, ReadError> {
    let mut encoding = Encoding::default();
    let mut stack: Vec<String> = Vec::new();
    let mut counts: Vec<u64> = Vec::new();
    let mut pieces: Vec<Vec<Found>> = Vec::new();
    let mut pos = 0;
    let mut seen_file = false;
    while let Some(tag) = next_tag(b, pos)? {
        pos = tag.end;
        if tag.closing {
            if stack.pop().as_deref() != Some(tag.name.as_str()) {
                return bad(
                    b,
                    tag.start,
                    format_args!("</{}> closes a tag it did not open", tag.name),
                );
            }
            continue;
        }
        match tag.name.as_str() {
            "VTKFile" => {
                seen_file = true;
                match tag.get("type") {
                    Some("PolyData" | "UnstructuredGrid") => {}
                    other => {
                        return bad(
                            b,
                            tag.start,
                            format_args!(
                                "VTKFile type {:?}: the points are read from PolyData (.vtp) and UnstructuredGrid (.vtu) files",
                                other.unwrap_or("")
                            ),
                        );
                    }
                }
                encoding.big = tag.get("byte_order") == Some("BigEndian");
                encoding.header64 = tag.get("header_type") == Some("UInt64");
                encoding.zlib = match tag.get("compressor") {
                    None | Some("") => false,
                    Some("vtkZLibDataCompressor") => true,
                    Some(other) => {
                        return bad(
                            b,
                            tag.start,
                            format_args!(
                                "compressor {other}: only vtkZLibDataCompressor (or none) is read"
                            ),
                        );
                    }
                };
            }
            "Piece" => {
                let n = tag
                    .get("NumberOfPoints")
                    .and_then(|n| n.parse::<u64>().ok());
                let Some(n) = n else {
                    return bad(b, tag.start, "a Piece without a whole NumberOfPoints");
                };
                counts.push(n);
                pieces.push(Vec::new());
            }
            "DataArray" => {
                let parent = stack.last().map(String::as_str);
                if matches!(parent, Some("Points" | "PointData")) && !pieces.is_empty() {
                    let found = data_array(b, &tag, parent == Some("Points"))?;
                    pieces.last_mut().expect("a piece").push(found);
                }
            }
            "AppendedData" => {
                let Some(underscore) = b[tag.end..].iter().position(|&c| c == b'_') else {
                    return bad(b, tag.start, "AppendedData without its '_' before the data");
                };
                let base64 = match tag.get("encoding") {
                    Some("base64") => true,
                    Some("raw") | None => false,
                    Some(other) => {
                        return bad(
                            b,
                            tag.start,
                            format_args!("AppendedData encoding {other:?}: raw or base64"),
                        );
                    }
                };
                encoding.appended = Some((tag.end + underscore + 1, base64));
                break;
            }
            _ => {}
        }
        if !tag.empty {
            stack.push(tag.name);
        }
    }
    if !seen_file {
        return Err(ReadError::Bad(
            "not a VTK file (no <VTKFile>, nor the legacy \"# vtk DataFile\" line)".into(),
        ));
    }
    if pieces.is_empty() {
        return Err(ReadError::Bad("no Piece: no points".into()));
    }
    // Every piece with the same arrays; the points first.
    let mut arrays: Vec<Array> = Vec::new();
    for (p, found) in pieces.into_iter().enumerate() {
        let mut found: Vec<Found> = found;
        let Some(k) = found.iter().position(|f| f.array.name == POINTS) else {
            return Err(ReadError::Bad(format!("piece {} has no Points", p + 1)));
        };
        let points = found.remove(k);
        found.insert(0, points);
        if p == 0 {
            arrays = found.into_iter().map(|f| f.array).collect();
            continue;
        }
        let same = found.len() == arrays.len()
            && found.iter().zip(&arrays).all(|(f, a)| {
                f.array.name == a.name && f.array.components == a.components && f.array.ty == a.ty
            });
        if !same {
            let at = found.first().map_or(0, |f| f.at);
            return bad(
                b,
                at,
                format_args!("piece {}'s point arrays differ from piece 1's", p + 1),
            );
        }
        for (a, f) in arrays.iter_mut().zip(found) {
            a.pieces.extend(f.array.pieces);
        }
    }
    for a in &arrays {
        if let Some(Place::Appended { .. }) = a.pieces.first()
            && encoding.appended.is_none()
        {
            return Err(ReadError::Bad(format!(
                "array {} is appended, and the file has no AppendedData",
                a.name
            )));
        }
    }
    Ok(Structure {
        piece_counts: counts,
        arrays,
        encoding,
    })
}

/// A `<DataArray>` tag: its name, type, components and where its values are.
fn data_array(b: &[u8], tag: &Tag, points: bool) -> Result<Found, ReadError> {
    let name = if points {
        POINTS.to_string()
    } else {
        tag.get("Name").unwrap_or("").to_string()
    };
    if name.is_empty() {
        return bad(b, tag.start, "a point DataArray without a Name");
    }
    let ty_name = tag.get("type").unwrap_or("");
    let Some(ty) = Ty::xml(ty_name) else {
        return bad(
            b,
            tag.start,
            format_args!(
                "DataArray {name} has type {ty_name:?}, not one of Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64"
            ),
        );
    };
    let components: u8 = match tag.get("NumberOfComponents").map(str::parse::<u8>) {
        None => 1,
        Some(Ok(n)) if (1..=64).contains(&n) => n,
        Some(_) => {
            return bad(
                b,
                tag.start,
                format_args!("DataArray {name}: NumberOfComponents is not 1 to 64"),
            );
        }
    };
    if points && components != 3 {
        return bad(
            b,
            tag.start,
            format_args!("the Points array has {components} components, not 3"),
        );
    }
    let content_end = match tag.empty {
        true => tag.end,
        false => b[tag.end..]
            .iter()
            .position(|&c| c == b'<')
            .map_or(b.len(), |k| tag.end + k),
    };
    let place = match tag.get("format").unwrap_or("ascii") {
        "ascii" => Place::Text {
            start: tag.end,
            end: content_end,
        },
        "binary" => Place::Base64 {
            start: tag.end,
            end: content_end,
        },
        "appended" => match tag.get("offset").and_then(|o| o.parse::<usize>().ok()) {
            Some(offset) => Place::Appended { offset },
            None => {
                return bad(
                    b,
                    tag.start,
                    format_args!("DataArray {name} is appended without a whole offset"),
                );
            }
        },
        other => {
            return bad(
                b,
                tag.start,
                format_args!("DataArray {name} has format {other:?}: ascii, binary or appended"),
            );
        }
    };
    Ok(Found {
        array: Array {
            name,
            components,
            ty,
            pieces: vec![place],
        },
        at: tag.start,
    })
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
        Place::Text { start, end } => {
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
            return Ok(());
        }
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
        let blocks = stream.word(enc, &what)? as usize;
        let block = stream.word(enc, &what)? as usize;
        let last = stream.word(enc, &what)? as usize;
        let total = match blocks {
            0 => 0,
            n => (n - 1)
                .saturating_mul(block)
                .saturating_add(if last == 0 { block } else { last }),
        };
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
        Place::Raw { start } => {
            if need > b.len() - start {
                return bad(
                    b,
                    start,
                    format_args!("{what}: the file ends before its {values} values"),
                );
            }
            return Ok(b[start..start + need]
                .chunks_exact(size)
                .map(|c| array.ty.value(c, true))
                .collect());
        }
        Place::Base64 { start, end } => Stream {
            b,
            pos: start,
            end,
            base64: true,
            pending: Vec::new(),
        },
        Place::Appended { offset } => {
            let (at, base64) = enc.appended.expect("checked");
            let pos = at.checked_add(offset).filter(|&p| p <= b.len());
            let Some(pos) = pos else {
                return Err(ReadError::Bad(format!(
                    "{what}: offset {offset} is past the appended data"
                )));
            };
            Stream {
                b,
                pos,
                end: b.len(),
                base64,
                pending: Vec::new(),
            }
        }
    };
    let bytes = if enc.zlib {
        let blocks = stream.word(enc, &what)? as usize;
        let block = stream.word(enc, &what)? as usize;
        let last = stream.word(enc, &what)? as usize;
        let total = match blocks {
            0 => 0,
            n => (n - 1)
                .saturating_mul(block)
                .saturating_add(if last == 0 { block } else { last }),
        };
        if total != need {
            return Err(ReadError::Bad(format!(
                "{what}: its blocks hold {total} bytes, and {values} values of {size} bytes need {need} (a wrong length)"
            )));
        }
        let mut sizes = Vec::new();
        for _ in 0..blocks.min(need / block.max(1) + 1) {
            sizes.push(stream.word(enc, &what)? as usize);
        }
        let mut out = Vec::with_capacity(need.min(1 << 26));
        for (k, &compressed) in sizes.iter().enumerate() {
            let data = stream.take(compressed, &what)?;
            let want = if k + 1 == blocks && last != 0 {
                last
            } else {
                block
            };
            let mut part = Vec::new();
            flate2::read::ZlibDecoder::new(&data[..])
                .take(want as u64 + 1)
                .read_to_end(&mut part)
                .map_err(|e| {
                    ReadError::Bad(format!("{what}: block {k} does not decompress ({e})"))
                })?;
            if part.len() != want {
                return Err(ReadError::Bad(format!(
                    "{what}: block {k} holds {} bytes, not {want}",
                    part.len()
                )));
            }
            out.extend(part);
        }
        out
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
    // A value takes at least two bytes (a digit and a separator), but the last.
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
                        crate::error::elide(token),
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
