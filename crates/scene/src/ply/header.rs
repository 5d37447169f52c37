//! A PLY header: its encoding, elements and properties with their types; reading it; and
//! what goes wrong reading a PLY file.

use std::collections::HashSet;
use std::hash::{BuildHasher, RandomState};
use std::io::{BufRead, Read};

/// Largest header read, in bytes.
pub(crate) const MAX_HEADER: usize = 1 << 20;

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
    pub(crate) fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The value of binary bytes `b` (at least [`Scalar::size`] of them).
    #[inline(always)]
    pub(super) fn decode(self, b: &[u8], big: bool) -> f64 {
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
    pub(super) fn parse_value(self, token: &str) -> Option<f64> {
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
pub(crate) enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

/// A property of an element.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Property {
    pub name: String,
    pub kind: Kind,
}

/// An element: its name, its number of rows and the properties of each row.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Element {
    pub name: String,
    pub count: u64,
    pub properties: Vec<Property>,
}

impl Element {
    /// The index of the property named `name`.
    pub(crate) fn property(&self, name: &str) -> Option<usize> {
        self.properties.iter().position(|p| p.name == name)
    }

    /// The fewest bytes a row takes: every scalar and every list's count (a list may be
    /// empty); in ASCII, a character and a separator a value.
    pub(super) fn min_row_bytes(&self, encoding: Encoding) -> u64 {
        self.properties
            .iter()
            .map(|p| match (encoding, p.kind) {
                (Encoding::Ascii, _) => 2,
                (_, Kind::Scalar(s) | Kind::List { count: s, .. }) => s.size() as u64,
            })
            .sum()
    }

    /// Bytes of every row in binary, when the element has no lists.
    pub(super) fn fixed_row_bytes(&self) -> Option<usize> {
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
pub(crate) struct Header {
    pub encoding: Encoding,
    pub elements: Vec<Element>,
}

impl Header {
    /// The element named `name` and its index.
    pub(crate) fn element(&self, name: &str) -> Option<(usize, &Element)> {
        self.elements
            .iter()
            .enumerate()
            .find(|(_, e)| e.name == name)
    }
}

/// What went wrong reading a PLY file: a file that is not a good PLY file (bad input), or a
/// failure to read one (the system's).
#[derive(Debug)]
pub(crate) enum PlyError {
    Bad(String),
    Io(std::io::Error),
}

impl From<std::io::Error> for PlyError {
    fn from(e: std::io::Error) -> PlyError {
        PlyError::Io(e)
    }
}

pub(super) fn bad<T>(msg: impl Into<String>) -> Result<T, PlyError> {
    Err(PlyError::Bad(msg.into()))
}

/// Names declared so far, each found in time independent of their number: a set of their
/// hashes (8 bytes a name, no copy of it), a hash found again confirmed against the names
/// themselves (a collision of SipHash's 64 bits with random keys is left to chance, and even
/// then costs one search of the names).
#[derive(Default)]
struct Seen {
    hashes: HashSet<u64>,
    state: RandomState,
}

impl Seen {
    /// Records `name`; false if it was declared before (`declared` searches the names).
    fn insert(&mut self, name: &str, declared: impl FnOnce(&str) -> bool) -> bool {
        self.hashes.insert(self.state.hash_one(name)) || !declared(name)
    }
}

/// Where a header ends: its length in bytes and in lines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct HeaderEnd {
    pub(super) bytes: usize,
    pub(super) lines: u64,
}

/// Reads the header: its lines up to `end_header`, at most [`MAX_HEADER`] bytes, in time
/// linear in its size (names are looked up in hash sets, not compared with every one before
/// them). Returns it and where it ends.
pub(super) fn read_header(r: &mut impl BufRead) -> Result<(Header, HeaderEnd), PlyError> {
    let mut used = 0usize;
    let mut line = Vec::new();
    let mut declared = Declared::default();
    let mut number = 0usize;
    loop {
        number += 1;
        let text = header_line(r, &mut line, &mut used, number)?;
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        if number == 1 {
            if words != ["ply"] {
                return bad("does not start with the line \"ply\": not a PLY file");
            }
            continue;
        }
        let at = |msg: String| PlyError::Bad(format!("header line {number}: {msg}"));
        match words.as_slice() {
            ["end_header"] => break,
            words => declared.line(words, text).map_err(at)?,
        }
    }
    let Some(encoding) = declared.encoding else {
        return bad("the header has no format line");
    };
    let end = HeaderEnd {
        bytes: used,
        lines: number as u64,
    };
    let elements = declared.elements;
    Ok((Header { encoding, elements }, end))
}

/// Reads header line `number` into `line`, adding its bytes to `used` (the header's so far):
/// its text; an error where it cannot be a line of a header.
fn header_line<'a>(
    r: &mut impl BufRead,
    line: &'a mut Vec<u8>,
    used: &mut usize,
    number: usize,
) -> Result<&'a str, PlyError> {
    line.clear();
    let n = (&mut *r)
        .take((MAX_HEADER - *used) as u64 + 1)
        .read_until(b'\n', line)?;
    *used += n;
    let line: &'a Vec<u8> = line;
    // A carriage return before a line's end: lines that end in CR alone (old Mac
    // files), which would otherwise read as one long line.
    let body = line.strip_suffix(b"\n").unwrap_or(line);
    let body = body.strip_suffix(b"\r").unwrap_or(body);
    if body.contains(&b'\r') {
        return bad(format!(
            "header line {number} holds a carriage return (CR) inside it: PLY header lines \
             end in LF or CR LF, and these seem to end in CR alone"
        ));
    }
    if *used > MAX_HEADER {
        return bad(format!(
            "no end_header in the first {MAX_HEADER} bytes: not a PLY header"
        ));
    }
    if n == 0 && number == 1 {
        return bad("empty: not a PLY file");
    }
    if line.last() != Some(&b'\n') {
        return bad(if number == 1 {
            "the file ends inside its first line: not a PLY file".to_string()
        } else {
            "truncated: the file ends inside its header (no end_header line)".to_string()
        });
    }
    match std::str::from_utf8(line) {
        Ok(text) => Ok(text),
        Err(_) => bad(format!("header line {number} is not ASCII text")),
    }
}

/// What a header's lines have declared so far.
#[derive(Default)]
struct Declared {
    encoding: Option<Encoding>,
    elements: Vec<Element>,
    /// The names declared so far: every element's, and the last element's properties'.
    element_names: Seen,
    property_names: Seen,
}

impl Declared {
    /// Takes a header line after the first, other than `end_header` (its `words`, and its
    /// `text`); an error says what is wrong with it.
    fn line(&mut self, words: &[&str], text: &str) -> Result<(), String> {
        match words {
            [] | ["comment" | "obj_info", ..] => Ok(()),
            ["format", enc, version] => self.format(enc, version),
            ["element", name, count] => self.element(name, count),
            ["property", rest @ ..] => self.property(rest, text),
            _ => Err(format!(
                "cannot read \"{}\"",
                text.trim_end().chars().take(80).collect::<String>()
            )),
        }
    }

    /// Takes a `format` line: the encoding, and version 1.0.
    fn format(&mut self, enc: &str, version: &str) -> Result<(), String> {
        if self.encoding.is_some() {
            return Err("a second format line".into());
        }
        self.encoding = Some(match enc {
            "ascii" => Encoding::Ascii,
            "binary_little_endian" => Encoding::BinaryLittleEndian,
            "binary_big_endian" => Encoding::BinaryBigEndian,
            other => {
                return Err(format!(
                    "format \"{other}\": expected ascii, binary_little_endian or binary_big_endian"
                ));
            }
        });
        if version != "1.0" {
            return Err(format!("format version {version}: expected 1.0"));
        }
        Ok(())
    }

    /// Takes an `element` line: an element of a new name and a whole count of rows.
    fn element(&mut self, name: &str, count: &str) -> Result<(), String> {
        let Ok(count) = count.parse::<u64>() else {
            return Err(format!(
                "element {name}: count \"{count}\" is not a whole number"
            ));
        };
        if !self
            .element_names
            .insert(name, |n| self.elements.iter().any(|e| e.name == n))
        {
            return Err(format!("element {name} is declared twice"));
        }
        self.property_names = Seen::default();
        self.elements.push(Element {
            name: name.to_string(),
            count,
            properties: Vec::new(),
        });
        Ok(())
    }

    /// Takes a `property` line (`rest`: its words after `property`; `text`: the line): a
    /// property of a new name in the last element.
    fn property(&mut self, rest: &[&str], text: &str) -> Result<(), String> {
        let Some(e) = self.elements.last_mut() else {
            return Err("a property before any element".into());
        };
        let (kind, name) = property_kind(rest, text)?;
        if !self
            .property_names
            .insert(name, |n| e.property(n).is_some())
        {
            return Err(format!(
                "property {name} of element {} is declared twice",
                e.name
            ));
        }
        e.properties.push(Property {
            name: name.to_string(),
            kind,
        });
        Ok(())
    }
}

/// A property line's type and name (`rest`: its words after `property`; `text`: the line).
fn property_kind<'w>(rest: &[&'w str], text: &str) -> Result<(Kind, &'w str), String> {
    let ty = |w: &str| Scalar::parse(w).ok_or_else(|| format!("unknown property type \"{w}\""));
    match rest {
        ["list", count, item, name] => {
            let count = ty(count)?;
            if !count.is_integer() {
                return Err(format!(
                    "list {name}: its count must be of an integer type, not {}",
                    count.name()
                ));
            }
            let item = ty(item)?;
            Ok((Kind::List { count, item }, name))
        }
        [t, name] => Ok((Kind::Scalar(ty(t)?), name)),
        _ => Err(format!("cannot read \"{}\"", text.trim_end())),
    }
}
