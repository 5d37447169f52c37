//! VTK XML files (`.vtp`, `.vtu`): a scanner of the tags VTK writes, and the structure of the
//! points and point data arrays of every piece (where each piece's values are; `vtk_data`
//! decodes them).

use super::read_error::ReadError;
use super::vtk_data::{Array, Encoding, POINTS, Place, Structure, Ty, bad};

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
                encoding = file_encoding(b, &tag)?;
            }
            "Piece" => {
                counts.push(piece_count(b, &tag)?);
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
                encoding.appended = Some(appended(b, &tag)?);
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
    // Nothing but white space after the file's last tag (NULs that pad a file are not XML).
    let end = b.len()
        - b.iter()
            .rev()
            .take_while(|c| c.is_ascii_whitespace())
            .count();
    if !b[..end].ends_with(b"</VTKFile>") {
        return bad(
            b,
            end.saturating_sub(1),
            "the file does not end with </VTKFile> (padded, or cut short)",
        );
    }
    let arrays = every_piece_arrays(b, pieces)?;
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

/// How a `<VTKFile>` tag says its binary data is written (nothing appended yet); an error
/// for a type whose points are not read or a compressor that is not.
fn file_encoding(b: &[u8], tag: &Tag) -> Result<Encoding, ReadError> {
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
    let zlib = match tag.get("compressor") {
        None | Some("") => false,
        Some("vtkZLibDataCompressor") => true,
        Some(other) => {
            return bad(
                b,
                tag.start,
                format_args!("compressor {other}: only vtkZLibDataCompressor (or none) is read"),
            );
        }
    };
    Ok(Encoding {
        big: tag.get("byte_order") == Some("BigEndian"),
        header64: tag.get("header_type") == Some("UInt64"),
        zlib,
        appended: None,
    })
}

/// A `<Piece>` tag's number of points.
fn piece_count(b: &[u8], tag: &Tag) -> Result<u64, ReadError> {
    let n = tag
        .get("NumberOfPoints")
        .and_then(|n| n.parse::<u64>().ok());
    match n {
        Some(n) => Ok(n),
        None => bad(b, tag.start, "a Piece without a whole NumberOfPoints"),
    }
}

/// Where an `<AppendedData>` tag's data begins (after its `_`) and whether it is base64.
fn appended(b: &[u8], tag: &Tag) -> Result<(usize, bool), ReadError> {
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
    Ok((tag.end + underscore + 1, base64))
}

/// The arrays that every piece holds alike, the points' first, each with its places in
/// every piece; an error for a piece without points or with other arrays than piece 1's.
fn every_piece_arrays(b: &[u8], pieces: Vec<Vec<Found>>) -> Result<Vec<Array>, ReadError> {
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
    Ok(arrays)
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
    let place = data_place(b, tag, &name)?;
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

/// Where the values of a `<DataArray>` tag (of array `name`) are, as its format says: its
/// content (text or base64, up to the next tag) or an offset in the appended data.
fn data_place(b: &[u8], tag: &Tag, name: &str) -> Result<Place, ReadError> {
    let content_end = match tag.empty {
        true => tag.end,
        false => b[tag.end..]
            .iter()
            .position(|&c| c == b'<')
            .map_or(b.len(), |k| tag.end + k),
    };
    Ok(match tag.get("format").unwrap_or("ascii") {
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
    })
}
