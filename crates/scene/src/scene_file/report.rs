//! Messages for errors found in the text of a scene file, in the form
//! `file:line:col: field.path: what was expected, what was found`, followed by the source line
//! with a caret under the place:
//!
//! ```text
//! shot.toml:3:7: shot.fps: expected a number, found the string "big"
//!   |
//! 3 | fps = "big"
//!   |       ^^^^^
//! ```
//!
//! The TOML layer reports a byte span and a message in serde's words; the span is mapped to
//! the path of the key or value it covers (from a parse of the document that keeps spans), and
//! serde's phrases are put in the format's words, so no Rust or serde type name reaches a user.

use std::ops::Range;

use toml::de::{DeTable, DeValue};

/// An error at a place in a document: a byte span in that document and the message (with
/// the field path, when there is one).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Located {
    pub(super) span: Range<usize>,
    pub(super) message: String,
}

/// Longest quoted value shown in a message, in characters; longer ones are cut.
const QUOTE_CHARS: usize = 40;
/// Longest source line shown whole, in characters; a longer one is shown around the place.
const LINE_CHARS: usize = 120;

/// Describes a TOML error on `doc`. `first_sphere` is the file's index of the document's first
/// `[[sphere]]` (documents parsed in pieces hold a run of spheres), added to the path's
/// sphere index.
pub(super) fn toml_error(doc: &str, e: &toml::de::Error, first_sphere: usize) -> Located {
    let span = e.span().unwrap_or(0..0);
    let raw = e.message().trim_end();
    // A document that parses as TOML failed in the schema: name the field. A syntax error has
    // no field (the document has no tree to take it from).
    let node = match DeTable::parse(doc) {
        Ok(root) => node_at(root.get_ref(), &span),
        Err(_) => None,
    };
    // A control character TOML does not allow (NUL, escape, ...) is the likeliest cause of a
    // syntax error whose span holds one: say so, at that character.
    if node.is_none()
        && let Some((i, c)) = doc.get(span.clone()).and_then(|s| {
            s.char_indices()
                .find(|&(_, c)| c.is_control() && !matches!(c, '\t' | '\n' | '\r'))
        })
    {
        let at = span.start + i;
        return Located {
            span: at..at + c.len_utf8(),
            message: format!(
                "control character U+{:04X} in the text: TOML allows it only escaped in a string (\\u{:04X})",
                c as u32, c as u32
            ),
        };
    }
    let mut message = humanize(raw, node.as_ref().and_then(|n| n.found.clone()), doc, &span);
    if let Some(node) = node {
        let path = path_string(&node.path, first_sphere);
        if !path.is_empty() {
            message = format!("{path}: {message}");
        }
    }
    Located {
        span,
        message: clean(&message),
    }
}

/// The path of the key or value at `span` in the document `doc`, if it parses.
pub(super) fn path_at(doc: &str, span: &Range<usize>, first_sphere: usize) -> Option<String> {
    let (root, _) = DeTable::parse_recoverable(doc);
    let node = node_at(root.get_ref(), span)?;
    Some(path_string(&node.path, first_sphere)).filter(|p| !p.is_empty())
}

/// One step of a path: a key or an array index.
#[derive(Clone, Debug)]
enum Step {
    Key(String),
    Index(usize),
}

/// The node found at a span: its path, and what it holds, described for "found ...".
struct Node {
    path: Vec<Step>,
    found: Option<String>,
}

/// The innermost key or value whose span contains `span.start`, preferring one whose span is
/// exactly `span` (a value the schema refused, or a key), then the shortest, then the deepest.
fn node_at(root: &DeTable<'_>, span: &Range<usize>) -> Option<Node> {
    let mut search = Search {
        span,
        path: Vec::new(),
        best: None,
    };
    search.table(root);
    search.best.map(|b| Node {
        path: b.path,
        found: b.found,
    })
}

/// The best node a [`Search`] has found so far, and what made it the best.
struct Best {
    exact: bool,
    len: usize,
    depth: usize,
    path: Vec<Step>,
    found: Option<String>,
}

/// A walk through a document for the node at `span`: the path walked to, and the best node.
struct Search<'s> {
    span: &'s Range<usize>,
    path: Vec<Step>,
    best: Option<Best>,
}

impl Search<'_> {
    /// Considers each key of table `t` (at the end of the path), then its value.
    fn table(&mut self, t: &DeTable<'_>) {
        for (k, v) in t.iter() {
            self.path.push(Step::Key(k.get_ref().to_string()));
            // A key's errors (unknown, duplicate) are reported at the table that holds it.
            self.consider(k.span(), self.path.len() - 1, None);
            self.value(v);
            self.path.pop();
        }
    }

    /// Considers a value at the end of the path, then everything inside it.
    fn value(&mut self, v: &toml::Spanned<DeValue<'_>>) {
        self.consider(v.span(), self.path.len(), Some(describe(v.get_ref())));
        match v.get_ref() {
            DeValue::Table(t) => self.table(t),
            DeValue::Array(a) => {
                for (i, v) in a.iter().enumerate() {
                    self.path.push(Step::Index(i));
                    self.value(v);
                    self.path.pop();
                }
            }
            _ => {}
        }
    }

    /// Takes a node at `s`, whose path is the first `steps` of the path walked and which
    /// holds `found`, where it contains the span and is better than the best so far.
    fn consider(&mut self, s: Range<usize>, steps: usize, found: Option<String>) {
        let span = self.span;
        let contains = s.start <= span.start && span.start < s.end.max(s.start + 1);
        if !contains {
            return;
        }
        let exact = s == *span;
        let len = s.end - s.start;
        let depth = self.path.len();
        let better = match &self.best {
            None => true,
            Some(b) => {
                (exact, std::cmp::Reverse(len), depth)
                    > (b.exact, std::cmp::Reverse(b.len), b.depth)
            }
        };
        if better {
            self.best = Some(Best {
                exact,
                len,
                depth,
                path: self.path[..steps].to_vec(),
                found,
            });
        }
    }
}

/// What a value is, for "found ...": its kind and, for a scalar, how it is written.
fn describe(v: &DeValue<'_>) -> String {
    match v {
        DeValue::String(s) => format!("the string {:?}", s.as_ref()),
        DeValue::Integer(i) => format!("the integer {}", i.as_str()),
        DeValue::Float(f) => format!("the number {}", f.as_str()),
        DeValue::Boolean(b) => format!("the boolean {b}"),
        DeValue::Datetime(d) => format!("the date-time {d}"),
        DeValue::Array(a) => match a.len() {
            1 => "an array of 1 value".to_string(),
            n => format!("an array of {n} values"),
        },
        DeValue::Table(_) => "a table".to_string(),
    }
}

/// `sphere[3].material.albedo[1]`; the leading sphere index is offset by `first_sphere`.
fn path_string(path: &[Step], first_sphere: usize) -> String {
    let mut out = String::new();
    let mut sphere = false;
    for (i, step) in path.iter().enumerate() {
        match step {
            Step::Key(k) => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(k);
                sphere = i == 0 && k == "sphere";
            }
            Step::Index(n) => {
                let n = if sphere && i == 1 {
                    n + first_sphere
                } else {
                    *n
                };
                out.push_str(&format!("[{n}]"));
            }
        }
    }
    out
}

/// Puts serde's and the TOML parser's phrases in the format's words: "expected ..., found ...",
/// "key" rather than "field", no Rust type names. `found` describes the value at the span,
/// when known.
fn humanize(raw: &str, found: Option<String>, doc: &str, span: &Range<usize>) -> String {
    let split = |rest: &str| -> Option<(String, String)> {
        let i = rest.rfind(", expected ")?;
        Some((
            rest[..i].to_string(),
            rest[i + ", expected ".len()..].to_string(),
        ))
    };
    for prefix in ["invalid type: ", "invalid value: "] {
        if let Some((unexp, exp)) = raw.strip_prefix(prefix).and_then(split) {
            let found = found.unwrap_or_else(|| unexpected_words(&unexp));
            return format!("expected {}, found {found}", expected_words(&exp));
        }
    }
    if let Some(rest) = raw.strip_prefix("invalid length ")
        && let Some((n, exp)) = split(rest)
    {
        return format!("expected {}, found {n} values", expected_words(&exp));
    }
    if let Some(rest) = raw.strip_prefix("unknown field ") {
        let (key, exp) = match rest.split_once(", ") {
            Some((key, exp)) => (key, Some(exp)),
            None => (rest, None),
        };
        return match exp {
            Some(exp) if exp.starts_with("expected ") => {
                format!("unknown key {key}, {}", exp.replace('`', ""))
            }
            _ => format!("unknown key {key}"),
        };
    }
    if let Some(rest) = raw.strip_prefix("missing field ") {
        return format!("missing key {rest}");
    }
    if let Some(rest) = raw.strip_prefix("unknown variant ") {
        let (value, exp) = rest
            .split_once(", expected ")
            .unwrap_or((rest, "another value"));
        return format!(
            "expected {}, found \"{}\"",
            exp.replace('`', "\""),
            value.trim_matches('`')
        );
    }
    if raw == "duplicate key" {
        let key = doc.get(span.clone()).unwrap_or("");
        let header = span.start > 0 && doc.as_bytes().get(span.start - 1) == Some(&b'[');
        return if header {
            format!("duplicate table [{key}]")
        } else {
            format!("duplicate key `{key}`")
        };
    }
    raw.to_string()
}

/// serde's name for what a type expects, in the format's words.
fn expected_words(exp: &str) -> String {
    match exp {
        "f64" | "f32" => "a number".into(),
        "i8" | "i16" | "i32" | "i64" | "i128" | "u8" | "u16" | "u32" | "u64" | "u128" => {
            "an integer".into()
        }
        "a sequence" => "an array".into(),
        "a map" => "a table".into(),
        "a boolean" | "a string" => exp.into(),
        _ if exp.starts_with("struct ")
            || exp.starts_with("internally tagged enum ")
            || exp.starts_with("enum ") =>
        {
            "a table".into()
        }
        _ => exp.replace('`', "\""),
    }
}

/// serde's description of an unexpected value, in the format's words.
fn unexpected_words(unexp: &str) -> String {
    let ticked = |prefix: &str| {
        unexp.strip_prefix(prefix).map(|r| {
            r.trim_start_matches('`')
                .split('`')
                .next()
                .unwrap_or("")
                .to_string()
        })
    };
    if let Some(s) = unexp.strip_prefix("string ") {
        return format!("the string {s}");
    }
    if let Some(n) = ticked("integer ") {
        return format!("the integer {n}");
    }
    if let Some(n) = ticked("floating point ") {
        return format!("the number {n}");
    }
    if let Some(b) = ticked("boolean ") {
        return format!("the boolean {b}");
    }
    match unexp {
        "sequence" => "an array".into(),
        "map" => "a table".into(),
        _ => unexp.replace('`', "\""),
    }
}

/// Cuts quoted values longer than [`QUOTE_CHARS`] and escapes control characters, so a
/// message stays one readable line whatever the file holds.
pub(super) fn clean(message: &str) -> String {
    let chars: Vec<char> = message.chars().collect();
    let mut out = String::with_capacity(message.len().min(1024));
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == '"' || c == '`' {
            // The closing delimiter (a `"` may be escaped inside a string).
            let mut j = i + 1;
            while j < chars.len() && chars[j] != c {
                if c == '"' && chars[j] == '\\' {
                    j += 1;
                }
                j += 1;
            }
            if j < chars.len() && j - i - 1 > QUOTE_CHARS {
                out.push(c);
                push_escaped(
                    &mut out,
                    chars[i + 1..i + 1 + QUOTE_CHARS - 3].iter().copied(),
                );
                out.push_str("...");
                out.push(c);
                i = j + 1;
                continue;
            }
        }
        push_escaped(&mut out, std::iter::once(c));
        i += 1;
    }
    out
}

fn push_escaped(out: &mut String, chars: impl Iterator<Item = char>) {
    for c in chars {
        if c.is_control() {
            out.push_str(&c.escape_unicode().to_string());
        } else {
            out.push(c);
        }
    }
}

/// The 1-based line and column (in characters) of byte `offset` in `text`.
pub(super) fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = floor_boundary(text, offset);
    let before = &text[..offset];
    let line = before.bytes().filter(|&b| b == b'\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

fn floor_boundary(text: &str, offset: usize) -> usize {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    offset
}

/// `file:line:col: message`, then the line of `text` holding `span.start` with carets under
/// the span (its part on that line, at least one character).
pub(super) fn render(file: &str, text: &str, span: Range<usize>, message: &str) -> String {
    let start = floor_boundary(text, span.start);
    let end = floor_boundary(text, span.end.max(start));
    let (line, col) = line_col(text, start);
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    let source = text[line_start..line_end].trim_end_matches('\r');
    let width = text[start..end.min(line_end)].chars().count();
    format_place(file, line, col, source, width, message)
}

/// The message for bytes that are not UTF-8: the place of the first bad byte, and its value.
pub(super) fn not_utf8(file: &str, bytes: &[u8], e: &std::str::Utf8Error) -> String {
    let at = e.valid_up_to();
    // Everything before the bad byte is valid.
    let before = std::str::from_utf8(&bytes[..at]).unwrap_or("");
    let line = before.bytes().filter(|&b| b == b'\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let col = before[line_start..].chars().count() + 1;
    let line_end = bytes[at..]
        .iter()
        .position(|&b| b == b'\n')
        .map_or(bytes.len(), |i| at + i);
    let source = String::from_utf8_lossy(&bytes[line_start..line_end]);
    let bad = &bytes[at..at + e.error_len().unwrap_or(bytes.len() - at)];
    let shown: Vec<String> = bad.iter().take(4).map(|b| format!("0x{b:02X}")).collect();
    let hint = if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        " (the file looks like UTF-16; scenes are UTF-8)"
    } else {
        ""
    };
    let message = match e.error_len() {
        Some(_) => format!("the file is not UTF-8 text: byte {}{hint}", shown.join(" ")),
        None => format!(
            "the file ends inside a UTF-8 character: {}{hint}",
            shown.join(" ")
        ),
    };
    format_place(file, line, col, source.trim_end_matches('\r'), 1, &message)
}

/// [`render`] for a place given as line, column (1-based, in characters), the line's text and
/// the width of the span on it.
pub(super) fn format_place(
    file: &str,
    line: usize,
    col: usize,
    source: &str,
    width: usize,
    message: &str,
) -> String {
    let len = source.chars().count();
    let at = (col - 1).min(len);
    // A window around the place when the line is long.
    let (from, to) = if len <= LINE_CHARS {
        (0, len)
    } else {
        let from = at.saturating_sub(LINE_CHARS / 3);
        (from, (from + LINE_CHARS).min(len))
    };
    let mut shown = String::new();
    let mut under = String::new();
    if from > 0 {
        shown.push_str("...");
        under.push_str("   ");
    }
    for (i, c) in source.chars().skip(from).take(to - from).enumerate() {
        // Tabs are kept so the caret lines up; other control characters (and NUL) are shown
        // as a replacement character.
        let shown_c = if c == '\t' {
            '\t'
        } else if c.is_control() {
            '\u{fffd}'
        } else {
            c
        };
        shown.push(shown_c);
        if from + i < at {
            under.push(if c == '\t' { '\t' } else { ' ' });
        }
    }
    if to < len {
        shown.push_str("...");
    }
    let carets = width.clamp(1, (to.max(at + 1) - at).max(1));
    under.push_str(&"^".repeat(carets));
    let number = line.to_string();
    let pad = " ".repeat(number.len());
    format!("{file}:{line}:{col}: {message}\n{pad} |\n{number} | {shown}\n{pad} | {under}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serde_phrases_become_the_formats_words() {
        let span = 0..0;
        for (raw, want) in [
            (
                "invalid type: string \"big\", expected f64",
                "expected a number, found the string \"big\"",
            ),
            (
                "invalid type: integer `5`, expected struct RawCamera",
                "expected a table, found the integer 5",
            ),
            (
                "invalid type: integer `5`, expected internally tagged enum RawMaterial",
                "expected a table, found the integer 5",
            ),
            (
                "invalid type: sequence, expected a map",
                "expected a table, found an array",
            ),
            (
                "invalid length 2, expected an array of length 3",
                "expected an array of length 3, found 2 values",
            ),
            (
                "unknown field `fpz`, expected one of `fps`, `frames`",
                "unknown key `fpz`, expected one of fps, frames",
            ),
            ("unknown field `x`, there are no fields", "unknown key `x`"),
            ("missing field `radius`", "missing key `radius`"),
            (
                "unknown variant `middle`, expected one of `start`, `end`",
                "expected one of \"start\", \"end\", found \"middle\"",
            ),
        ] {
            assert_eq!(humanize(raw, None, "", &span), want);
        }
        let doc = "[shot]\nfps = 1\nfps = 2\n[shot]\n";
        assert_eq!(
            humanize("duplicate key", None, doc, &(15..18)),
            "duplicate key `fps`"
        );
        assert_eq!(
            humanize("duplicate key", None, doc, &(24..28)),
            "duplicate table [shot]"
        );
    }

    #[test]
    fn long_quotes_are_cut_and_control_characters_escaped() {
        let long = "x".repeat(1000);
        let m = clean(&format!("found the string \"{long}\" and `{long}`"));
        assert!(m.len() < 120, "{m}");
        assert!(m.contains("\"xxx") && m.contains("...\""));
        assert_eq!(clean("a\u{0}b\u{1b}c"), "a\\u{0}b\\u{1b}c");
    }

    #[test]
    fn render_puts_a_caret_under_the_place() {
        let text = "[shot]\nfps = \"big\"\n";
        let m = render("s.toml", text, 13..18, "shot.fps: expected a number");
        assert_eq!(
            m,
            "s.toml:2:7: shot.fps: expected a number\n  |\n2 | fps = \"big\"\n  |       ^^^^^"
        );
        // A tab before the place is kept under it; control characters are replaced.
        let m = render("s.toml", "a =\t\u{0}1\n", 4..5, "m");
        assert!(m.ends_with("1 | a =\t\u{fffd}1\n  |    \t^"), "{m:?}");
        // A very long line is shown around the place.
        let text = format!("a = [{}9]\n", "0, ".repeat(100_000));
        let at = text.find('9').unwrap();
        let m = render("s.toml", &text, at..at + 1, "m");
        assert!(m.len() < 400, "{}", m.len());
        let lines: Vec<&str> = m.lines().collect();
        let caret = lines[3].find('^').unwrap();
        assert_eq!(lines[2].as_bytes()[caret], b'9', "{m}");
        // Offsets inside a character or past the end do not panic.
        let _ = render("s.toml", "é", 1..9, "m");
        assert_eq!(line_col("a\nbé\nc", 4), (2, 2));
    }

    #[test]
    fn paths_come_from_spans() {
        let doc = "[shot]\nfps = 1\n[[sphere]]\nradius = 1\n[[sphere]]\nmaterial = { albedo = [1, \"x\", 1] }\n";
        let at = doc.find("\"x\"").unwrap();
        assert_eq!(
            path_at(doc, &(at..at + 3), 0).as_deref(),
            Some("sphere[1].material.albedo[1]")
        );
        assert_eq!(
            path_at(doc, &(at..at + 3), 10).as_deref(),
            Some("sphere[11].material.albedo[1]")
        );
        let at = doc.find("1\n").unwrap();
        assert_eq!(path_at(doc, &(at..at + 1), 0).as_deref(), Some("shot.fps"));
        // A key names the table that holds it.
        let at = doc.find("fps").unwrap();
        assert_eq!(path_at(doc, &(at..at + 3), 0).as_deref(), Some("shot"));
    }
}
