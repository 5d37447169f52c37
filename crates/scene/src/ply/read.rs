//! An open PLY file: the rows of one element, their chosen properties handed to the caller
//! as numbers, in chunks of rows of fixed size where it can; ASCII rows line by line, each
//! holding exactly its properties' values.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use super::header::{
    Element, Encoding, Header, Kind, MAX_HEADER, PlyError, Scalar, bad, read_header,
};

/// The reader's buffer, in bytes.
const READER_BYTES: usize = 1 << 20;

/// Bytes of rows decoded per read of a binary element without lists (whole rows, at least
/// one). A row is less than this: its properties' header lines take at least 16 bytes each
/// (`property char a`), 18 for the largest type (`property double a`, 8 bytes), so a row
/// holds at most [`MAX_HEADER`] / 18 * 8 bytes, under half of it.
const CHUNK_BYTES: usize = 1 << 20;
const _: () = assert!(MAX_HEADER / 18 * 8 <= CHUNK_BYTES);

/// Unused bytes in a row from which each row's used bytes are read alone, with a seek over
/// the rest: two system calls a row cost less than copying 64 KiB, and a file of wide rows
/// is read in time proportional to its rows, not its bytes.
const SKIP_BYTES: usize = 1 << 16;

/// The buffers reading one PLY file holds, in bytes: the reader's and a chunk of rows, 2 MiB
/// whatever the rows' size. The point caches' memory estimate counts one such file at a
/// time (`raytrace_render::memory`, through `PointLoad`). The parsed header comes on top: a few hundred bytes for a
/// cache's usual dozen properties, at most about 6 MiB for the largest header, 1 MiB of
/// one-byte properties (measured: docs/robustness.md). A file read in parts holds a part's
/// rows on each thread as well (`parts::PART_BYTES`).
pub(crate) const READ_BUFFER_BYTES: u64 = (READER_BYTES + CHUNK_BYTES) as u64;

/// An open PLY file, positioned after its header.
pub(crate) struct PlyFile {
    pub(super) header: Header,
    /// The header's lines: an ASCII body's first line is the next.
    header_lines: u64,
    pub(super) reader: BufReader<File>,
}

impl PlyFile {
    /// Opens `path` and reads its header. Only a regular file is opened; every element must
    /// fit in the bytes the file holds after its header (at the fewest bytes a row can take).
    pub(crate) fn open(path: &Path) -> Result<PlyFile, PlyError> {
        let meta = std::fs::metadata(path).map_err(|e| PlyError::Bad(e.to_string()))?;
        if !meta.is_file() {
            return bad(format!(
                "is {}, not a PLY file (point caches are read from regular files only)",
                raytrace_io::file_kind(&meta.file_type())
            ));
        }
        let file = File::open(path).map_err(|e| PlyError::Bad(e.to_string()))?;
        let meta = file.metadata()?;
        if !meta.is_file() {
            return bad(format!(
                "is {}, not a PLY file (point caches are read from regular files only)",
                raytrace_io::file_kind(&meta.file_type())
            ));
        }
        let mut reader = BufReader::with_capacity(READER_BYTES, file);
        let (header, end) = read_header(&mut reader)?;
        let data_bytes = meta.len().saturating_sub(end.bytes as u64);
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
        Ok(PlyFile {
            header,
            header_lines: end.lines,
            reader,
        })
    }

    /// The header.
    pub(crate) fn header(&self) -> &Header {
        &self.header
    }

    /// Reads the rows of element `element` (an index into the header's elements), calling
    /// `row(i, values)` for row `i` with the values of its properties `wanted` (indices into
    /// the element's properties, each a scalar), in that order. An error `row` returns stops
    /// the reading and is returned. Elements before it are skipped. In binary, those after it
    /// are not read; in ASCII they are read to the end of the file, which must hold nothing
    /// after the last row: every row is one line of exactly its properties' values (blank
    /// lines between rows and blanks at the ends of lines are taken), so that values that
    /// shift rows, a file cut inside a value and text after the rows are found, with their
    /// line.
    pub(crate) fn read_rows(
        self,
        element: usize,
        wanted: &[usize],
        mut row: impl FnMut(u64, &[f64]) -> Result<(), String>,
    ) -> Result<(), PlyError> {
        let PlyFile {
            header,
            header_lines,
            mut reader,
        } = self;
        let e = &header.elements[element];
        let types = scalar_types(e, wanted)?;
        if header.encoding == Encoding::Ascii {
            let lines = Lines {
                reader: &mut reader,
                token: Vec::new(),
                line: header_lines + 1,
            };
            return read_ascii(lines, &header.elements, element, wanted, row);
        }
        let big = header.encoding == Encoding::BinaryBigEndian;
        skip_binary(&mut reader, &header.elements[..element], big)?;
        let Some(stride) = e.fixed_row_bytes() else {
            let mut values = vec![0.0; wanted.len()];
            for i in 0..e.count {
                binary_row(&mut reader, e, i, big, wanted, &mut values)?;
                row(i, &values).map_err(PlyError::Bad)?;
            }
            return Ok(());
        };
        // Rows of fixed size: each value at its offset in the row.
        let fields = Fields::of(e, wanted, types, big);
        if fields.wide(stride) {
            return read_wide(reader, e, stride, &fields, row);
        }
        read_chunks(&mut reader, e, stride, &fields, row)
    }
}

/// The types of `e`'s properties `wanted`; an error for a list.
pub(super) fn scalar_types(e: &Element, wanted: &[usize]) -> Result<Vec<Scalar>, PlyError> {
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
    Ok(types)
}

/// Reads an ASCII body from `lines`: the rows of every element of `elements`, those of
/// `element` handed to `row` with their properties `wanted`, then only blanks to the end.
fn read_ascii<R: BufRead>(
    mut lines: Lines<R>,
    elements: &[Element],
    element: usize,
    wanted: &[usize],
    mut row: impl FnMut(u64, &[f64]) -> Result<(), String>,
) -> Result<(), PlyError> {
    let mut values = vec![0.0; wanted.len()];
    for (k, each) in elements.iter().enumerate() {
        let (wanted, values) = match k == element {
            true => (wanted, &mut values[..]),
            false => (&[][..], &mut [][..]),
        };
        for i in 0..each.count {
            ascii_row(&mut lines, each, i, wanted, values, &mut row)?;
        }
    }
    lines.end(elements.last())
}

/// Moves a binary body past the rows of `elements`: a seek where rows have a fixed size,
/// else each row read.
pub(super) fn skip_binary(
    reader: &mut BufReader<File>,
    elements: &[Element],
    big: bool,
) -> Result<(), PlyError> {
    for skipped in elements {
        match skipped.fixed_row_bytes() {
            Some(n) => {
                // The size check at opening guarantees the bytes are there.
                let bytes = skipped.count * n as u64;
                reader.seek(SeekFrom::Current(bytes as i64))?;
            }
            None => {
                for i in 0..skipped.count {
                    binary_row(reader, skipped, i, big, &[], &mut [])?;
                }
            }
        }
    }
    Ok(())
}

/// Where the wanted values of a binary row of fixed size are, and how to decode them.
pub(super) struct Fields {
    /// Each value's offset in the row, and its type.
    pub(super) at: Vec<(usize, Scalar)>,
    big: bool,
}

impl Fields {
    /// The fields of `e`'s properties `wanted` (of types `types`), big-endian or not.
    pub(super) fn of(e: &Element, wanted: &[usize], types: Vec<Scalar>, big: bool) -> Fields {
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
        let at = offsets.into_iter().zip(types).collect();
        Fields { at, big }
    }

    /// The bytes of a row that hold wanted values: from the first's start to the last's end.
    fn span(&self) -> (usize, usize) {
        let lo = self.at.iter().map(|f| f.0).min().unwrap_or(0);
        let hi = self.at.iter().map(|f| f.0 + f.1.size()).max().unwrap_or(0);
        (lo, hi)
    }

    /// Whether rows of `stride` bytes hold so many unused bytes ([`SKIP_BYTES`]) that each
    /// row's used bytes are read alone, with a seek over the rest.
    pub(super) fn wide(&self, stride: usize) -> bool {
        let (lo, hi) = self.span();
        stride - (hi - lo) >= SKIP_BYTES
    }

    /// The values of a row from its bytes `r`, which start at byte `start` of the row.
    #[inline(always)]
    pub(super) fn decode(&self, values: &mut [f64], r: &[u8], start: usize) {
        for (v, &(off, ty)) in values.iter_mut().zip(&self.at) {
            *v = ty.decode(&r[off - start..], self.big);
        }
    }
}

/// Reads the rows of `e` (`stride` bytes each) where they are wide: each row's bytes that
/// hold `fields` alone, the rest seeked over.
fn read_wide(
    mut reader: BufReader<File>,
    e: &Element,
    stride: usize,
    fields: &Fields,
    mut row: impl FnMut(u64, &[f64]) -> Result<(), String>,
) -> Result<(), PlyError> {
    let (lo, hi) = fields.span();
    let mut values = vec![0.0; fields.at.len()];
    let mut at = reader.stream_position()?;
    let mut file = reader.into_inner();
    let mut used = vec![0u8; hi - lo];
    for i in 0..e.count {
        file.seek(SeekFrom::Start(at + lo as u64))?;
        if read_full(&mut file, &mut used)? < used.len() {
            return bad(truncated(e, i));
        }
        fields.decode(&mut values, &used, lo);
        row(i, &values).map_err(PlyError::Bad)?;
        at += stride as u64;
    }
    Ok(())
}

/// Reads the rows of `e` (`stride` bytes each) in chunks of whole rows, bounded in bytes,
/// not rows: a row of many unused properties is large.
fn read_chunks(
    reader: &mut BufReader<File>,
    e: &Element,
    stride: usize,
    fields: &Fields,
    mut row: impl FnMut(u64, &[f64]) -> Result<(), String>,
) -> Result<(), PlyError> {
    let mut values = vec![0.0; fields.at.len()];
    let chunk_rows = (CHUNK_BYTES / stride.max(1)).max(1);
    let mut buf = vec![0u8; stride.max(1) * chunk_rows.min(e.count as usize)];
    let mut i = 0u64;
    while i < e.count {
        let rows = (e.count - i).min(chunk_rows as u64) as usize;
        let chunk = &mut buf[..rows * stride];
        let got = read_full(reader, chunk)?;
        if got < chunk.len() {
            return bad(truncated(e, i + (got / stride.max(1)) as u64));
        }
        for r in chunk.chunks_exact(stride) {
            fields.decode(&mut values, r, 0);
            row(i, &values).map_err(PlyError::Bad)?;
            i += 1;
        }
    }
    Ok(())
}

/// `truncated: the file ends in vertex 12 of 1000`.
pub(super) fn truncated(e: &Element, row: u64) -> String {
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

/// What comes next in an ASCII body.
enum Item {
    /// A value (in [`Lines::token`]).
    Value,
    /// The end of a line, consumed.
    LineEnd,
    /// The end of the file.
    End,
}

/// The whitespace-separated values of an ASCII body, and its line ends.
struct Lines<'a, R> {
    reader: &'a mut R,
    token: Vec<u8>,
    /// The line the reading is in, counted from the file's first.
    line: u64,
}

impl<R: BufRead> Lines<'_, R> {
    /// The next value of the current line, the line's end, or the file's.
    fn next(&mut self) -> Result<Item, PlyError> {
        self.token.clear();
        loop {
            let buf = self.reader.fill_buf()?;
            if buf.is_empty() {
                // A value the file ends in is a value (found cut short by the row's end).
                return Ok(match self.token.is_empty() {
                    true => Item::End,
                    false => Item::Value,
                });
            }
            let mut used = 0;
            let mut found = None;
            for &c in buf {
                if c == b'\n' {
                    // A value ends before its line's end, which the next call consumes.
                    if self.token.is_empty() {
                        used += 1;
                        self.line += 1;
                        found = Some(Item::LineEnd);
                    } else {
                        found = Some(Item::Value);
                    }
                    break;
                }
                used += 1;
                if c.is_ascii_whitespace() {
                    if !self.token.is_empty() {
                        found = Some(Item::Value);
                        break;
                    }
                } else {
                    if self.token.len() >= 64 {
                        return bad(format!(
                            "line {}: a value of more than 64 characters in the data",
                            self.line
                        ));
                    }
                    self.token.push(c);
                }
            }
            self.reader.consume(used);
            if let Some(item) = found {
                return Ok(item);
            }
        }
    }

    /// The value [`Lines::next`] found.
    fn value(&self) -> Result<&str, PlyError> {
        std::str::from_utf8(&self.token).or_else(|_| {
            bad(format!(
                "line {}: a value that is not ASCII text in the data",
                self.line
            ))
        })
    }

    /// Whether the file ends here.
    fn at_end(&mut self) -> Result<bool, PlyError> {
        Ok(self.reader.fill_buf()?.is_empty())
    }

    /// Reads to the end of the file after the rows of every element (`last` is the last
    /// element): only blanks and line ends may follow them.
    fn end(mut self, last: Option<&Element>) -> Result<(), PlyError> {
        loop {
            match self.next()? {
                Item::LineEnd => {}
                Item::End => return Ok(()),
                Item::Value => {
                    let rows = last.map_or("the header's".to_string(), |e| {
                        format!("the {} {} rows the header declares", e.count, e.name)
                    });
                    return bad(format!(
                        "line {}: text after {rows}: \"{}\"",
                        self.line,
                        self.value()?
                    ));
                }
            }
        }
    }
}

/// Reads one ASCII row of `e` (row `i`), one line holding exactly its properties' values
/// (blank lines before it are skipped), storing the values of properties `wanted` in
/// `values`, then calls `row` with them (when some are wanted).
fn ascii_row<R: BufRead>(
    lines: &mut Lines<R>,
    e: &Element,
    i: u64,
    wanted: &[usize],
    values: &mut [f64],
    row: &mut impl FnMut(u64, &[f64]) -> Result<(), String>,
) -> Result<(), PlyError> {
    let mut this = AsciiRow { e, i, read: 0 };
    for (k, p) in e.properties.iter().enumerate() {
        match p.kind {
            Kind::Scalar(s) => {
                let v = this.value(lines, s, &p.name)?;
                if let Some(j) = wanted.iter().position(|&w| w == k) {
                    values[j] = v;
                }
            }
            Kind::List { count, item } => {
                let n = this.value(lines, count, &p.name)?;
                if n < 0.0 {
                    return bad(format!(
                        "line {}: {} {i}: list {} has a negative count ({n})",
                        lines.line, e.name, p.name
                    ));
                }
                for _ in 0..n as u64 {
                    this.value(lines, item, &p.name)?;
                }
            }
        }
    }
    this.line_end(lines)?;
    if !wanted.is_empty() {
        row(i, values).map_err(PlyError::Bad)?;
    }
    Ok(())
}

/// An ASCII row being read: row `i` of element `e`, and how many values of it are read.
struct AsciiRow<'e> {
    e: &'e Element,
    i: u64,
    read: usize,
}

impl AsciiRow<'_> {
    /// The row's next value, of type `s` (of property `name`), on the row's line (blank
    /// lines before its first value skipped).
    fn value<R: BufRead>(
        &mut self,
        lines: &mut Lines<R>,
        s: Scalar,
        name: &str,
    ) -> Result<f64, PlyError> {
        let (e, i) = (self.e, self.i);
        loop {
            match lines.next()? {
                Item::Value => break,
                Item::LineEnd if self.read == 0 => {}
                Item::End => return bad(format!("line {}: {}", lines.line, truncated(e, i))),
                Item::LineEnd if lines.at_end()? => {
                    return bad(format!("line {}: {}", lines.line - 1, truncated(e, i)));
                }
                Item::LineEnd => {
                    return bad(format!(
                        "line {}: {} {i} ends after {} values, short of its {} properties \
                         (each row is one line)",
                        lines.line - 1,
                        e.name,
                        self.read,
                        e.properties.len()
                    ));
                }
            }
        }
        self.read += 1;
        let t = lines.value()?;
        match s.parse_value(t) {
            Some(v) => Ok(v),
            None => bad(format!(
                "line {}: {} {i}: {name} is \"{t}\", not a value of type {}",
                lines.line,
                e.name,
                s.name()
            )),
        }
    }

    /// Reads the end of the row's line, which must follow its last value.
    fn line_end<R: BufRead>(&self, lines: &mut Lines<R>) -> Result<(), PlyError> {
        let (e, i) = (self.e, self.i);
        match lines.next()? {
            Item::LineEnd => Ok(()),
            Item::Value => {
                let last = e.properties.last().map_or("", |p| p.name.as_str());
                bad(format!(
                    "line {}: {} {i} has more values than its {} properties: \"{}\" after {last} \
                     (each row is one line)",
                    lines.line,
                    e.name,
                    e.properties.len(),
                    lines.value()?
                ))
            }
            Item::End => bad(format!(
                "line {}: the file ends inside {} {i}, with no line end after its last value: \
                 truncated (that value may be cut short)",
                lines.line, e.name
            )),
        }
    }
}
