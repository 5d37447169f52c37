//! An open PLY file: the rows of one element, their chosen properties handed to the caller
//! as numbers, in chunks of rows of fixed size where it can.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use super::header::{Element, Encoding, Header, Kind, PlyError, Scalar, bad, read_header};

/// Rows decoded per read of a binary element without lists.
const CHUNK_ROWS: usize = 1 << 14;

/// An open PLY file, positioned after its header.
pub struct PlyFile {
    header: Header,
    reader: BufReader<File>,
}

impl PlyFile {
    /// Opens `path` and reads its header. Only a regular file is opened; every element must
    /// fit in the bytes the file holds after its header (at the fewest bytes a row can take).
    pub fn open(path: &Path) -> Result<PlyFile, PlyError> {
        let meta = std::fs::metadata(path).map_err(|e| PlyError::Bad(e.to_string()))?;
        if !meta.is_file() {
            return bad(format!(
                "is {}, not a PLY file (point caches are read from regular files only)",
                crate::scene_file::file_kind(&meta.file_type())
            ));
        }
        let file = File::open(path).map_err(|e| PlyError::Bad(e.to_string()))?;
        let meta = file.metadata()?;
        if !meta.is_file() {
            return bad(format!(
                "is {}, not a PLY file (point caches are read from regular files only)",
                crate::scene_file::file_kind(&meta.file_type())
            ));
        }
        let mut reader = BufReader::with_capacity(1 << 20, file);
        let (header, header_bytes) = read_header(&mut reader)?;
        let data_bytes = meta.len().saturating_sub(header_bytes as u64);
        let mut needed = 0u64;
        for e in &header.elements {
            if e.properties.is_empty() && e.count > 0 {
                return bad(format!(
                    "element {} has {} rows but no properties",
                    e.name, e.count
                ));
            }
            let row = e.min_row_bytes(header.encoding);
            let bytes = e.count.checked_mul(row).and_then(|b| b.checked_add(needed));
            // In ASCII the last value needs no separator.
            let slack = u64::from(header.encoding == Encoding::Ascii);
            match bytes {
                Some(b) if b <= data_bytes + slack => needed = b,
                _ => {
                    return bad(format!(
                        "the header declares {} {} rows, at least {} bytes each, but the file holds only {} bytes after its header (truncated, or a wrong count)",
                        e.count, e.name, row, data_bytes
                    ));
                }
            }
        }
        Ok(PlyFile { header, reader })
    }

    /// The header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Reads the rows of element `element` (an index into the header's elements), calling
    /// `row(i, values)` for row `i` with the values of its properties `wanted` (indices into
    /// the element's properties, each a scalar), in that order. An error `row` returns stops
    /// the reading and is returned. Elements before it are skipped; those after it are not
    /// read.
    pub fn read_rows(
        mut self,
        element: usize,
        wanted: &[usize],
        mut row: impl FnMut(u64, &[f64]) -> Result<(), String>,
    ) -> Result<(), PlyError> {
        let e = &self.header.elements[element];
        let mut types = Vec::with_capacity(wanted.len());
        for &w in wanted {
            match e.properties[w].kind {
                Kind::Scalar(s) => types.push(s),
                Kind::List { .. } => {
                    return bad(format!(
                        "property {} of element {} is a list; a single number was expected",
                        e.properties[w].name, e.name
                    ));
                }
            }
        }
        let encoding = self.header.encoding;
        if encoding == Encoding::Ascii {
            let mut tokens = Tokens {
                reader: &mut self.reader,
                token: Vec::new(),
            };
            for skipped in &self.header.elements[..element] {
                for i in 0..skipped.count {
                    ascii_row(&mut tokens, skipped, i, &[], &mut [], &mut |_, _| Ok(()))?;
                }
            }
            let mut values = vec![0.0; wanted.len()];
            for i in 0..e.count {
                ascii_row(&mut tokens, e, i, wanted, &mut values, &mut row)?;
            }
            return Ok(());
        }
        let big = encoding == Encoding::BinaryBigEndian;
        for skipped in &self.header.elements[..element] {
            match skipped.fixed_row_bytes() {
                Some(n) => {
                    // The size check at opening guarantees the bytes are there.
                    let bytes = skipped.count * n as u64;
                    self.reader.seek(SeekFrom::Current(bytes as i64))?;
                }
                None => {
                    for i in 0..skipped.count {
                        binary_row(&mut self.reader, skipped, i, big, &[], &mut [])?;
                    }
                }
            }
        }
        let mut values = vec![0.0; wanted.len()];
        let Some(stride) = e.fixed_row_bytes() else {
            for i in 0..e.count {
                binary_row(&mut self.reader, e, i, big, wanted, &mut values)?;
                row(i, &values).map_err(PlyError::Bad)?;
            }
            return Ok(());
        };
        // Rows of fixed size: read in chunks, each value at its offset in the row.
        let mut offsets = Vec::with_capacity(wanted.len());
        for &w in wanted {
            offsets.push(
                e.properties[..w]
                    .iter()
                    .map(|p| match p.kind {
                        Kind::Scalar(s) => s.size(),
                        Kind::List { .. } => 0,
                    })
                    .sum::<usize>(),
            );
        }
        let fields: Vec<(usize, Scalar)> = offsets.into_iter().zip(types).collect();
        let mut buf = vec![0u8; stride.max(1) * CHUNK_ROWS];
        let mut i = 0u64;
        while i < e.count {
            let rows = (e.count - i).min(CHUNK_ROWS as u64) as usize;
            let chunk = &mut buf[..rows * stride];
            let got = read_full(&mut self.reader, chunk)?;
            if got < chunk.len() {
                return bad(truncated(e, i + (got / stride.max(1)) as u64));
            }
            for r in chunk.chunks_exact(stride) {
                for (v, &(off, ty)) in values.iter_mut().zip(&fields) {
                    *v = ty.decode(&r[off..], big);
                }
                row(i, &values).map_err(PlyError::Bad)?;
                i += 1;
            }
        }
        Ok(())
    }
}

/// `truncated: the file ends in vertex 12 of 1000`.
fn truncated(e: &Element, row: u64) -> String {
    format!(
        "truncated: the file ends in {} {row} of {} (rows counted from 0)",
        e.name, e.count
    )
}

/// Reads until `buf` is full or the file ends; returns the bytes read.
fn read_full(r: &mut (impl Read + ?Sized), buf: &mut [u8]) -> Result<usize, std::io::Error> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// Reads one binary row of `e` (row `i`), storing the values of properties `wanted` in
/// `values`.
fn binary_row(
    r: &mut impl Read,
    e: &Element,
    i: u64,
    big: bool,
    wanted: &[usize],
    values: &mut [f64],
) -> Result<(), PlyError> {
    let mut b = [0u8; 8];
    let mut read = |r: &mut dyn Read, s: Scalar| -> Result<f64, PlyError> {
        if read_full(r, &mut b[..s.size()])? < s.size() {
            return bad(truncated(e, i));
        }
        Ok(s.decode(&b, big))
    };
    for (k, p) in e.properties.iter().enumerate() {
        match p.kind {
            Kind::Scalar(s) => {
                let v = read(r, s)?;
                if let Some(j) = wanted.iter().position(|&w| w == k) {
                    values[j] = v;
                }
            }
            Kind::List { count, item } => {
                let n = read(r, count)?;
                if n < 0.0 {
                    return bad(format!(
                        "{} {i}: list {} has a negative count ({n})",
                        e.name, p.name
                    ));
                }
                // A list's items are skipped, whatever their number: none is kept.
                for _ in 0..n as u64 {
                    read(r, item)?;
                }
            }
        }
    }
    Ok(())
}

/// Whitespace-separated tokens of an ASCII body.
struct Tokens<'a, R> {
    reader: &'a mut R,
    token: Vec<u8>,
}

impl<R: BufRead> Tokens<'_, R> {
    /// The next token, or `None` at the end of the file.
    fn next(&mut self) -> Result<Option<&str>, PlyError> {
        self.token.clear();
        loop {
            let buf = self.reader.fill_buf()?;
            if buf.is_empty() {
                break;
            }
            let mut used = 0;
            let mut done = false;
            for &c in buf {
                if c.is_ascii_whitespace() {
                    if !self.token.is_empty() {
                        done = true;
                        break;
                    }
                } else {
                    if self.token.len() >= 64 {
                        return bad("a value of more than 64 characters in the data");
                    }
                    self.token.push(c);
                }
                used += 1;
            }
            self.reader.consume(used);
            if done {
                break;
            }
        }
        if self.token.is_empty() {
            return Ok(None);
        }
        match std::str::from_utf8(&self.token) {
            Ok(t) => Ok(Some(t)),
            Err(_) => bad("a value that is not ASCII text in the data"),
        }
    }
}

/// Reads one ASCII row of `e` (row `i`), storing the values of properties `wanted` in
/// `values`, then calls `row` with them (when some are wanted).
fn ascii_row<R: BufRead>(
    tokens: &mut Tokens<R>,
    e: &Element,
    i: u64,
    wanted: &[usize],
    values: &mut [f64],
    row: &mut impl FnMut(u64, &[f64]) -> Result<(), String>,
) -> Result<(), PlyError> {
    let value = |tokens: &mut Tokens<R>, s: Scalar, name: &str| -> Result<f64, PlyError> {
        let Some(t) = tokens.next()? else {
            return bad(truncated(e, i));
        };
        match s.parse_value(t) {
            Some(v) => Ok(v),
            None => bad(format!(
                "{} {i}: {name} is \"{t}\", not a value of type {}",
                e.name,
                s.name()
            )),
        }
    };
    for (k, p) in e.properties.iter().enumerate() {
        match p.kind {
            Kind::Scalar(s) => {
                let v = value(tokens, s, &p.name)?;
                if let Some(j) = wanted.iter().position(|&w| w == k) {
                    values[j] = v;
                }
            }
            Kind::List { count, item } => {
                let n = value(tokens, count, &p.name)?;
                if n < 0.0 {
                    return bad(format!(
                        "{} {i}: list {} has a negative count ({n})",
                        e.name, p.name
                    ));
                }
                for _ in 0..n as u64 {
                    value(tokens, item, &p.name)?;
                }
            }
        }
    }
    if !wanted.is_empty() {
        row(i, values).map_err(PlyError::Bad)?;
    }
    Ok(())
}
