//! Limits checked on a document's text before it is parsed, with the TOML lexer alone (no
//! allocation per token), so that no file can make the parse hold more memory than a large
//! legitimate scene does.
//!
//! The TOML parser builds the whole document as a tree before the schema sees any of it, at
//! about 200 bytes per value: a 15 MB line `look_from = [0, 0, 0, ...]` of 5 million numbers
//! took 1 GB and 3 s before the schema refused its length. The scan refuses
//! - an array of more than [`MAX_ARRAY`] elements, unless its elements are tables (keyframes):
//!   only `shot.shutter_curve` takes more than 3 values, and 4096 points are plenty;
//! - a document of more than [`MAX_VALUES`] values (about 800 MB of tree): a scene larger
//!   than that gives its spheres as `[[sphere]]` tables, which are parsed in pieces of 4096
//!   (see [`super::pieces`]), each its own document;
//! - a key of more than [`MAX_KEY_PARTS`] dotted parts (the parser's own limit, 80, reports
//!   no position).
//!
//! Anything else, well-formed or not, is left to the parser.

use std::ops::Range;

use toml_parser::lexer::{Lexer, TokenKind as K};

use super::report::{self, Located};

/// Most elements in an array that does not hold tables.
pub(super) const MAX_ARRAY: usize = 4096;
/// Most values (scalars, arrays, inline tables and table headers) in one parsed document.
pub(super) const MAX_VALUES: usize = 1 << 22;
/// Most parts in a dotted key or table header.
pub(super) const MAX_KEY_PARTS: usize = 64;

/// An open array or inline table.
struct Frame {
    array: bool,
    /// Elements so far (arrays).
    count: usize,
    /// Whether every element so far is an inline table.
    tables_only: bool,
    /// Where the array starts.
    start: usize,
}

/// Checks `doc` against the limits. `first_sphere` is the file's index of the document's first
/// `[[sphere]]`, for the path in messages.
pub(super) fn scan(doc: &str, first_sphere: usize) -> Result<(), Located> {
    let mut lexer = toml_parser::Source::new(doc).lex();
    let mut scanner = Scanner {
        doc,
        first_sphere,
        stack: Vec::new(),
        expect_value: false,
        line_start: true,
        in_key: true,
        key_parts: 1,
        values: 0,
    };
    while let Some(tok) = lexer.next() {
        let kind = tok.kind();
        let at = tok.span().start()..tok.span().end();
        match kind {
            K::Whitespace | K::Comment => {}
            K::Newline => scanner.line_end(),
            K::Eof => break,
            _ if scanner.expect_value => scanner.value(kind, at, &mut lexer)?,
            _ => scanner.token(kind, at)?,
        }
    }
    Ok(())
}

/// Where a scan is in a document: the arrays and inline tables open, and what is counted.
struct Scanner<'d> {
    doc: &'d str,
    /// The file's index of the document's first `[[sphere]]`.
    first_sphere: usize,
    stack: Vec<Frame>,
    /// Whether the next token starts a value.
    expect_value: bool,
    /// Whether the next token is the first of its line (outside arrays and inline tables).
    line_start: bool,
    /// Whether the tokens are a key's (whose dotted parts are counted).
    in_key: bool,
    key_parts: usize,
    values: usize,
}

impl Scanner<'_> {
    /// Takes a line end: outside arrays and inline tables, a key may follow.
    fn line_end(&mut self) {
        if self.stack.is_empty() {
            self.line_start = true;
            self.in_key = true;
            self.key_parts = 1;
            self.expect_value = false;
        }
    }

    /// Takes the token where a value is expected (`kind`, at `at`; `lexer` after it): the
    /// value is counted, and an array or inline table it opens is pushed.
    fn value(&mut self, kind: K, at: Range<usize>, lexer: &mut Lexer<'_>) -> Result<(), Located> {
        self.expect_value = false;
        if kind == K::RightSquareBracket && self.stack.last().is_some_and(|f| f.array) {
            // An empty array, or a trailing comma.
            self.stack.pop();
            return Ok(());
        }
        let start = at.start;
        self.count_value(kind, at, lexer)?;
        match kind {
            K::LeftSquareBracket => {
                self.stack.push(Frame {
                    array: true,
                    count: 0,
                    tables_only: true,
                    start,
                });
                self.expect_value = true;
            }
            K::LeftCurlyBracket => {
                self.stack.push(Frame {
                    array: false,
                    count: 0,
                    tables_only: false,
                    start,
                });
                self.in_key = true;
                self.key_parts = 1;
            }
            _ => {}
        }
        self.line_start = false;
        Ok(())
    }

    /// Counts a value (`kind`, at `at`) in the document and in the array it is in: an error
    /// past [`MAX_VALUES`], or past [`MAX_ARRAY`] in an array not of tables alone.
    fn count_value(
        &mut self,
        kind: K,
        at: Range<usize>,
        lexer: &mut Lexer<'_>,
    ) -> Result<(), Located> {
        self.values += 1;
        if self.values > MAX_VALUES {
            return Err(Located {
                span: at,
                message: format!(
                    "more than {MAX_VALUES} values in one document, the most read at once (about 800 MB); a larger scene gives its spheres as [[sphere]] tables, which are read in pieces"
                ),
            });
        }
        let depth = self.stack.len();
        if let Some(f) = self.stack.last_mut().filter(|f| f.array) {
            f.count += 1;
            f.tables_only &= kind == K::LeftCurlyBracket;
            if f.count > MAX_ARRAY && !f.tables_only {
                let opened = matches!(kind, K::LeftSquareBracket | K::LeftCurlyBracket);
                let nesting = depth + usize::from(opened);
                return Err(long_array(
                    self.doc,
                    f.start,
                    lexer,
                    depth,
                    nesting,
                    self.first_sphere,
                ));
            }
        }
        Ok(())
    }

    /// Takes a token outside a value's start (`kind`, at `at`): a table header, a key's
    /// parts, `=`, a comma or a closing bracket.
    fn token(&mut self, kind: K, at: Range<usize>) -> Result<(), Located> {
        match kind {
            K::LeftSquareBracket if self.stack.is_empty() && self.line_start => {
                // A table header: a value of its own; its key's parts are counted below.
                self.values += 1;
                self.in_key = true;
                self.key_parts = 1;
            }
            K::Equals => {
                self.expect_value = true;
                self.in_key = false;
            }
            K::Dot if self.in_key => {
                self.key_parts += 1;
                if self.key_parts > MAX_KEY_PARTS {
                    return Err(Located {
                        span: at,
                        message: format!("a key of more than {MAX_KEY_PARTS} dotted parts"),
                    });
                }
            }
            K::Comma => match self.stack.last() {
                Some(f) if f.array => self.expect_value = true,
                Some(_) => {
                    self.in_key = true;
                    self.key_parts = 1;
                }
                None => {}
            },
            K::RightSquareBracket if self.stack.last().is_some_and(|f| f.array) => {
                self.stack.pop();
            }
            K::RightCurlyBracket if self.stack.last().is_some_and(|f| !f.array) => {
                self.stack.pop();
            }
            _ => {}
        }
        self.line_start = false;
        Ok(())
    }
}

/// The error for an array starting at `start` that has just passed [`MAX_ARRAY`] elements:
/// its length (counted to its end with the lexer) and the path of its key.
fn long_array(
    doc: &str,
    start: usize,
    lexer: &mut Lexer<'_>,
    depth: usize,
    mut nesting: usize,
    first_sphere: usize,
) -> Located {
    let mut count = MAX_ARRAY + 1;
    let mut element_start = false;
    for tok in lexer.by_ref() {
        match tok.kind() {
            K::Whitespace | K::Comment | K::Newline => {}
            K::Eof => break,
            K::Comma if nesting == depth => element_start = true,
            K::LeftSquareBracket | K::LeftCurlyBracket => {
                if element_start && nesting == depth {
                    count += 1;
                }
                element_start = false;
                nesting += 1;
            }
            K::RightSquareBracket | K::RightCurlyBracket => {
                nesting -= 1;
                element_start = false;
                if nesting < depth {
                    break;
                }
            }
            _ => {
                if element_start && nesting == depth {
                    count += 1;
                }
                element_start = false;
            }
        }
    }
    // The path of the array's key: from the text before it, with a short value in its place.
    let prefix = format!("{}0", &doc[..start]);
    let path = report::path_at(&prefix, &(start..start + 1), first_sphere);
    let message = format!(
        "expected an array of at most {MAX_ARRAY} values (only shot.shutter_curve takes more than 3 values), found {count} values"
    );
    Located {
        span: start..start + 1,
        message: match path {
            Some(p) => format!("{p}: {message}"),
            None => message,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_arrays_are_refused_cheaply_with_their_length_and_path() {
        let doc = format!(
            "[camera]\nup = [0, 1, 0]\nlook_from = [{}1]\n",
            "0, ".repeat(4_999_999)
        );
        let e = scan(&doc, 0).unwrap_err();
        assert_eq!(
            e.message,
            "camera.look_from: expected an array of at most 4096 values (only shot.shutter_curve takes more than 3 values), found 5000000 values"
        );
        assert_eq!(e.span.start, doc.find("look_from = [").unwrap() + 12);
        // Nested, in a sphere of a piece starting at sphere 7.
        let doc = format!(
            "[[sphere]]\nradius = 1\n[[sphere]]\nmaterial = {{ type = \"metal\", albedo = [{}] }}\n",
            "[1], ".repeat(5000)
        );
        let e = scan(&doc, 7).unwrap_err();
        assert!(
            e.message
                .starts_with("sphere[8].material.albedo: expected an array of at most 4096 values"),
            "{}",
            e.message
        );
        assert!(e.message.ends_with("found 5000 values"), "{}", e.message);
    }

    #[test]
    fn arrays_of_tables_and_short_arrays_pass() {
        let keys = (0..10_000)
            .map(|i| format!("{{ time = {i}, center = [0, 0, {i}] }}"))
            .collect::<Vec<_>>()
            .join(", ");
        let doc = format!(
            "[[sphere]]\nkeyframes = [{keys}]\n[camera]\nlook_from = [1.5, -2e3, 3]\nx = [[], [1,], {{}}]\n"
        );
        assert_eq!(scan(&doc, 0), Ok(()));
        let doc = format!("a = [{}1]\n", "0, ".repeat(MAX_ARRAY - 1));
        assert_eq!(scan(&doc, 0), Ok(()));
        let doc = format!("a = [{}1]\n", "0, ".repeat(MAX_ARRAY));
        assert!(scan(&doc, 0).is_err());
    }

    #[test]
    fn documents_of_too_many_values_are_refused() {
        let doc = "a = [0, 0, 0]\n".repeat(MAX_VALUES / 4 + 1);
        let e = scan(&doc, 0).unwrap_err();
        assert!(
            e.message.starts_with("more than 4194304 values"),
            "{}",
            e.message
        );
        let doc = "a = [0, 0]\n".repeat(MAX_VALUES / 3);
        assert_eq!(scan(&doc, 0), Ok(()));
    }

    #[test]
    fn deep_keys_are_refused_with_a_place() {
        let doc = format!("x = 1\na{} = 1\n", ".a".repeat(100));
        let e = scan(&doc, 0).unwrap_err();
        assert_eq!(e.message, "a key of more than 64 dotted parts");
        assert_eq!(e.span.start, 7 + 2 * 63);
        // Floats have dots too, and are not keys.
        assert_eq!(scan(&"a = [1.5, 2.5]\n".repeat(100), 0), Ok(()));
        let doc = format!("[a{}]\n", ".a".repeat(70));
        assert!(scan(&doc, 0).is_err());
    }

    #[test]
    fn malformed_text_does_not_panic() {
        for doc in [
            "]]]]",
            "}}}",
            "a = ",
            "= = =",
            "[[[[",
            "a = [1, 2",
            "a = {",
            "a = [}",
            ",,,",
            "[a.]",
            "a = [,]",
        ] {
            let _ = scan(doc, 0);
        }
    }
}
