//! PLY files (the Polygon File Format of Turk's 1994 description, which simulation tools write
//! point caches in): the header, and one element's chosen properties read row by row as
//! numbers for the caller to store in columns; and writing a vertex element.
//!
//! Read: ASCII, binary little- and big-endian; the eight numeric types under their two names
//! each (`char`/`int8` ... `double`/`float64`); properties in any order; other elements and
//! properties, lists among them, skipped. Every value is handed over as an `f64`, which holds
//! every value of every PLY type exactly (a `float` written in ASCII is rounded to `f32`
//! first, as a binary file would hold it, so the three encodings of the same points give the
//! same numbers).
//!
//! Hostile files cost little: only a regular file is opened (a named pipe would block, a
//! directory has no data), the header is at most [`MAX_HEADER`] bytes, and an element's count
//! is compared with the bytes the file holds before anything is allocated for it, so a header
//! that declares 2^31 rows of a small file is refused at once.
//!
//! Why not a crate: `ply-rs-bw` reads an element as a `Vec` of a struct per row (1.1 GB peak
//! and 2.7 s for 1e7 points of 28 bytes, against 0.8 GB and 1.35 s here, measured with the
//! same release build), and `serde-ply` takes 2.7 s for the same file through a row type
//! that accepts every attribute name a cache may use (1.5 s only when the row type matches
//! the file's properties exactly, which a reader of caches from several tools cannot know).
//! Either would miss the 2 s asked for 1e7 points, and neither reports the row of a bad value.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::path::Path;

/// Largest header read, in bytes.
pub const MAX_HEADER: usize = 1 << 20;

/// Rows decoded per read of a binary element without lists.
const CHUNK_ROWS: usize = 1 << 14;

/// How the data after the header is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

impl Encoding {
    /// The name in a header's `format` line.
    pub fn name(self) -> &'static str {
        match self {
            Encoding::Ascii => "ascii",
            Encoding::BinaryLittleEndian => "binary_little_endian",
            Encoding::BinaryBigEndian => "binary_big_endian",
        }
    }
}

/// A PLY numeric type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    /// Both names of each type, as headers write them.
    const NAMES: [(&'static str, &'static str, Scalar); 8] = [
        ("char", "int8", Scalar::I8),
        ("uchar", "uint8", Scalar::U8),
        ("short", "int16", Scalar::I16),
        ("ushort", "uint16", Scalar::U16),
        ("int", "int32", Scalar::I32),
        ("uint", "uint32", Scalar::U32),
        ("float", "float32", Scalar::F32),
        ("double", "float64", Scalar::F64),
    ];

    fn parse(word: &str) -> Option<Scalar> {
        Scalar::NAMES
            .iter()
            .find(|(a, b, _)| *a == word || *b == word)
            .map(|t| t.2)
    }

    /// The type's first name (`uchar`, `float`).
    pub fn name(self) -> &'static str {
        Scalar::NAMES
            .iter()
            .find(|t| t.2 == self)
            .map_or("", |t| t.0)
    }

    /// Bytes of a binary value.
    pub fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// Whether the type holds integers.
    pub fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The value of binary bytes `b` (at least [`Scalar::size`] of them).
    #[inline(always)]
    fn decode(self, b: &[u8], big: bool) -> f64 {
        macro_rules! num {
            ($t:ty, $n:expr) => {{
                let a: [u8; $n] = b[..$n].try_into().expect("enough bytes");
                if big {
                    <$t>::from_be_bytes(a) as f64
                } else {
                    <$t>::from_le_bytes(a) as f64
                }
            }};
        }
        match self {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => num!(i16, 2),
            Scalar::U16 => num!(u16, 2),
            Scalar::I32 => num!(i32, 4),
            Scalar::U32 => num!(u32, 4),
            Scalar::F32 => num!(f32, 4),
            Scalar::F64 => num!(f64, 8),
        }
    }

    /// The value of an ASCII token, which must be a number of this type.
    fn parse_value(self, token: &str) -> Option<f64> {
        let int = |lo: i64, hi: i64| {
            token
                .parse::<i64>()
                .ok()
                .filter(|v| (lo..=hi).contains(v))
                .map(|v| v as f64)
        };
        match self {
            Scalar::I8 => int(i8::MIN.into(), i8::MAX.into()),
            Scalar::U8 => int(0, u8::MAX.into()),
            Scalar::I16 => int(i16::MIN.into(), i16::MAX.into()),
            Scalar::U16 => int(0, u16::MAX.into()),
            Scalar::I32 => int(i32::MIN.into(), i32::MAX.into()),
            Scalar::U32 => int(0, u32::MAX.into()),
            // Rounded to f32 as a binary file would hold it.
            Scalar::F32 => token.parse::<f32>().ok().map(f64::from),
            Scalar::F64 => token.parse::<f64>().ok(),
        }
    }
}

/// A property's type: one number, or a list of numbers preceded by their count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

/// A property of an element.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Property {
    pub name: String,
    pub kind: Kind,
}

/// An element: its name, its number of rows and the properties of each row.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Element {
    pub name: String,
    pub count: u64,
    pub properties: Vec<Property>,
}

impl Element {
    /// The index of the property named `name`.
    pub fn property(&self, name: &str) -> Option<usize> {
        self.properties.iter().position(|p| p.name == name)
    }

    /// The fewest bytes a row takes: every scalar and every list's count (a list may be
    /// empty); in ASCII, a character and a separator a value.
    fn min_row_bytes(&self, encoding: Encoding) -> u64 {
        self.properties
            .iter()
            .map(|p| match (encoding, p.kind) {
                (Encoding::Ascii, _) => 2,
                (_, Kind::Scalar(s) | Kind::List { count: s, .. }) => s.size() as u64,
            })
            .sum()
    }

    /// Bytes of every row in binary, when the element has no lists.
    fn fixed_row_bytes(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => Some(s.size()),
                Kind::List { .. } => None,
            })
            .sum()
    }
}

/// A PLY file's header.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Header {
    pub encoding: Encoding,
    pub elements: Vec<Element>,
}

impl Header {
    /// The element named `name` and its index.
    pub fn element(&self, name: &str) -> Option<(usize, &Element)> {
        self.elements
            .iter()
            .enumerate()
            .find(|(_, e)| e.name == name)
    }
}

/// What went wrong reading a PLY file: a file that is not a good PLY file (bad input), or a
/// failure to read one (the system's).
#[derive(Debug)]
pub enum PlyError {
    Bad(String),
    Io(std::io::Error),
}

impl From<std::io::Error> for PlyError {
    fn from(e: std::io::Error) -> PlyError {
        PlyError::Io(e)
    }
}

fn bad<T>(msg: impl Into<String>) -> Result<T, PlyError> {
    Err(PlyError::Bad(msg.into()))
}

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
                file_kind(&meta)
            ));
        }
        let file = File::open(path).map_err(|e| PlyError::Bad(e.to_string()))?;
        let meta = file.metadata()?;
        if !meta.is_file() {
            return bad(format!(
                "is {}, not a PLY file (point caches are read from regular files only)",
                file_kind(&meta)
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
                if !(n >= 0.0) {
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
                if !(n >= 0.0) {
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

/// Reads the header: its lines up to `end_header`, at most [`MAX_HEADER`] bytes. Returns it
/// and its length in bytes.
fn read_header(r: &mut impl BufRead) -> Result<(Header, usize), PlyError> {
    let mut used = 0usize;
    let mut line = Vec::new();
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut number = 0usize;
    loop {
        line.clear();
        let n = r
            .take((MAX_HEADER - used) as u64 + 1)
            .read_until(b'\n', &mut line)?;
        used += n;
        number += 1;
        if used > MAX_HEADER {
            return bad(format!(
                "no end_header in the first {MAX_HEADER} bytes: not a PLY header"
            ));
        }
        if n == 0 || line.last() != Some(&b'\n') {
            return bad(if number == 1 {
                "empty: not a PLY file".to_string()
            } else {
                "truncated: the file ends inside its header (no end_header line)".to_string()
            });
        }
        let Ok(text) = std::str::from_utf8(&line) else {
            return bad(format!("header line {number} is not ASCII text"));
        };
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        if number == 1 {
            if words != ["ply"] {
                return bad("does not start with the line \"ply\": not a PLY file");
            }
            continue;
        }
        let at = |msg: String| PlyError::Bad(format!("header line {number}: {msg}"));
        match words.as_slice() {
            [] | ["comment" | "obj_info", ..] => {}
            ["format", enc, version] => {
                if encoding.is_some() {
                    return Err(at("a second format line".into()));
                }
                encoding = Some(match *enc {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::BinaryLittleEndian,
                    "binary_big_endian" => Encoding::BinaryBigEndian,
                    other => {
                        return Err(at(format!(
                            "format \"{other}\": expected ascii, binary_little_endian or binary_big_endian"
                        )));
                    }
                });
                if *version != "1.0" {
                    return Err(at(format!("format version {version}: expected 1.0")));
                }
            }
            ["element", name, count] => {
                let Ok(count) = count.parse::<u64>() else {
                    return Err(at(format!(
                        "element {name}: count \"{count}\" is not a whole number"
                    )));
                };
                if elements.iter().any(|e| e.name == *name) {
                    return Err(at(format!("element {name} is declared twice")));
                }
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            ["property", rest @ ..] => {
                let Some(e) = elements.last_mut() else {
                    return Err(at("a property before any element".into()));
                };
                let ty = |w: &str| {
                    Scalar::parse(w).ok_or_else(|| at(format!("unknown property type \"{w}\"")))
                };
                let (kind, name) = match rest {
                    ["list", count, item, name] => {
                        let count = ty(count)?;
                        if !count.is_integer() {
                            return Err(at(format!(
                                "list {name}: its count must be of an integer type, not {}",
                                count.name()
                            )));
                        }
                        (
                            Kind::List {
                                count,
                                item: ty(item)?,
                            },
                            name,
                        )
                    }
                    [t, name] => (Kind::Scalar(ty(t)?), name),
                    _ => return Err(at(format!("cannot read \"{}\"", text.trim_end()))),
                };
                if e.property(name).is_some() {
                    return Err(at(format!(
                        "property {name} of element {} is declared twice",
                        e.name
                    )));
                }
                e.properties.push(Property {
                    name: name.to_string(),
                    kind,
                });
            }
            ["end_header"] => break,
            _ => {
                return Err(at(format!(
                    "cannot read \"{}\"",
                    text.trim_end().chars().take(80).collect::<String>()
                )));
            }
        }
    }
    let Some(encoding) = encoding else {
        return bad("the header has no format line");
    };
    Ok((Header { encoding, elements }, used))
}

/// What kind of file system object `meta` describes, for messages.
fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a named pipe";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    fn write_file(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    /// Reads properties `names` of the vertex element as rows.
    fn rows(path: &Path, names: &[&str]) -> Result<Vec<Vec<f64>>, String> {
        let f = PlyFile::open(path).map_err(message)?;
        let (k, e) = f.header().element("vertex").ok_or("no vertex")?;
        let wanted: Vec<usize> = names.iter().map(|n| e.property(n).unwrap()).collect();
        let mut out = Vec::new();
        f.read_rows(k, &wanted, |_, v| {
            out.push(v.to_vec());
            Ok(())
        })
        .map_err(message)?;
        Ok(out)
    }

    fn message(e: PlyError) -> String {
        match e {
            PlyError::Bad(m) => m,
            PlyError::Io(e) => e.to_string(),
        }
    }

    /// The same columns written in the three encodings read back as the same numbers, with
    /// every type, properties in another order, and other elements and lists skipped.
    #[test]
    fn three_encodings_read_the_same_values() {
        let dir = tempfile::tempdir().unwrap();
        let values: [&[f64]; 8] = [
            &[-128.0, 0.0, 127.0],
            &[0.0, 200.0, 255.0],
            &[-32768.0, 5.0, 32767.0],
            &[0.0, 1.0, 65535.0],
            &[-2147483648.0, 7.0, 2147483647.0],
            &[0.0, 3.0, 4294967295.0],
            &[0.1f32 as f64, -1e30f32 as f64, f32::MIN_POSITIVE as f64],
            &[0.1, -1e300, 5e-324],
        ];
        let types = [
            Scalar::I8,
            Scalar::U8,
            Scalar::I16,
            Scalar::U16,
            Scalar::I32,
            Scalar::U32,
            Scalar::F32,
            Scalar::F64,
        ];
        let names = ["a", "b", "c", "d", "e", "f", "g", "h"];
        let columns: Vec<Column> = (0..8)
            .map(|k| Column {
                name: names[k],
                ty: types[k],
                values: values[k],
            })
            .collect();
        let mut got = Vec::new();
        for enc in [
            Encoding::Ascii,
            Encoding::BinaryLittleEndian,
            Encoding::BinaryBigEndian,
        ] {
            let mut bytes = Vec::new();
            write_vertices(&mut bytes, enc, &columns).unwrap();
            let p = write_file(&dir, "v.ply", &bytes);
            let r = rows(&p, &["h", "a", "g", "b", "c", "d", "e", "f"]).unwrap();
            got.push(r);
        }
        assert_eq!(got[0], got[1]);
        assert_eq!(got[1], got[2]);
        assert_eq!(got[0][2][0], 5e-324);
        assert_eq!(got[0][0][1], -128.0);
        // An element before the vertices, with a list, and a list inside them: skipped.
        let text = "ply\nformat ascii 1.0\ncomment made by hand\nelement camera 2\nproperty list uchar int ids\nproperty float f\nelement vertex 2\nproperty list uchar float junk\nproperty double y\nproperty int x\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n2 7 8 0.5\n0 1.5\n3 1 2 3 0.25 -4\n1 9.5 6\n3 0 1 2\n";
        let p = write_file(&dir, "t.ply", text.as_bytes());
        assert_eq!(
            rows(&p, &["x", "y"]).unwrap(),
            [vec![-4.0, 0.25], vec![6.0, 9.5]]
        );
        let mut bin = b"ply\nformat binary_big_endian 1.0\nelement camera 1\nproperty list uchar int ids\nelement vertex 1\nproperty list uchar float junk\nproperty short x\nend_header\n".to_vec();
        bin.extend([2, 0, 0, 0, 1, 0, 0, 0, 2]);
        bin.extend([1, 0, 0, 0, 0]);
        bin.extend((-3i16).to_be_bytes());
        let p = write_file(&dir, "b.ply", &bin);
        assert_eq!(rows(&p, &["x"]).unwrap(), [vec![-3.0]]);
    }

    #[test]
    fn bad_files_are_refused_with_what_is_wrong() {
        let dir = tempfile::tempdir().unwrap();
        let head = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nend_header\n";
        let check = |bytes: &[u8], want: &str| {
            let p = write_file(&dir, "bad.ply", bytes);
            let got = rows(&p, &["x"]).unwrap_err();
            assert!(got.contains(want), "{got:?} lacks {want:?}");
        };
        // Two of three rows: refused at opening, from the size.
        let mut short = head.as_bytes().to_vec();
        short.extend([0; 8]);
        check(
            &short,
            "declares 3 vertex rows, at least 4 bytes each, but the file holds only 8",
        );
        check(
            b"ply\nformat binary_little_endian 1.0\nelement vertex 2147483648\nproperty float x\nend_header\n",
            "declares 2147483648 vertex rows",
        );
        check(
            b"ply\nformat ascii 1.0\nelement vertex 18446744073709551615\nproperty float x\nend_header\n1\n",
            "declares 18446744073709551615 vertex rows",
        );
        check(b"", "empty");
        check(b"plyx\n", "not a PLY file");
        check(
            b"ply\nformat ascii 1.0\nelement vertex 1\n",
            "ends inside its header",
        );
        check(b"ply\nformat ascii 2.0\nend_header\n", "version 2.0");
        check(
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty real x\nend_header\n",
            "unknown property type \"real\"",
        );
        check(
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\nabc\n",
            "vertex 0: x is \"abc\", not a value of type float",
        );
        check(
            b"ply\nformat ascii 1.0\nelement vertex 2\nproperty uchar x\nend_header\n3 256\n",
            "vertex 1: x is \"256\"",
        );
        check(
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1 2\n",
            "truncated: the file ends in vertex 2 of 3",
        );
        // A list where a number is wanted.
        let p = write_file(
            &dir,
            "l.ply",
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nend_header\n1 2\n",
        );
        let f = PlyFile::open(&p).unwrap();
        let got = message(f.read_rows(0, &[0], |_, _| Ok(())).unwrap_err());
        assert!(
            got.contains("property x of element vertex is a list"),
            "{got}"
        );
        // A directory.
        let got = message(PlyFile::open(dir.path()).err().unwrap());
        assert!(got.contains("is a directory"), "{got}");
        // A header without end.
        let big = vec![b'a'; MAX_HEADER + 10];
        let mut text = b"ply\ncomment ".to_vec();
        text.extend(big);
        check(&text, "no end_header");
        // Data shorter than its lists say: truncated, with the row.
        let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty list uchar int l\nproperty uchar x\nend_header\n".to_vec();
        bin.extend([0, 1, 9, 0, 0]);
        check(&bin, "truncated: the file ends in vertex 1 of 2");
    }

    #[test]
    fn an_error_of_the_caller_stops_the_reading() {
        let dir = tempfile::tempdir().unwrap();
        let mut bytes = Vec::new();
        let v: Vec<f64> = (0..100_000).map(f64::from).collect();
        write_vertices(
            &mut bytes,
            Encoding::BinaryLittleEndian,
            &[Column {
                name: "x",
                ty: Scalar::F32,
                values: &v,
            }],
        )
        .unwrap();
        let p = write_file(&dir, "v.ply", &bytes);
        let f = PlyFile::open(&p).unwrap();
        let mut seen = 0;
        let e = f
            .read_rows(0, &[0], |i, v| {
                seen += 1;
                if v[0] == 54321.0 {
                    Err(format!("point {i} is bad"))
                } else {
                    Ok(())
                }
            })
            .unwrap_err();
        assert_eq!(message(e), "point 54321 is bad");
        assert_eq!(seen, 54322);
    }
}
