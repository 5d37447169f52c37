//! Large scene files parsed in pieces: the file is cut at its `[[sphere]]` headers (found
//! with the TOML lexer) into runs of spheres parsed and validated in parallel, and the rest
//! (settings, materials) parsed as one document. Messages are those of a whole parse.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;
use toml_parser::lexer::Lexer;

use super::overrides::Overrides;
use super::report::{self, Located};
use super::scan;
use super::schema::{RawScene, RawSphere};
use super::validate::{Validated, Validator, add_spheres};
use raytrace_core::error::Error;
use raytrace_core::scene::Scene;

/// Files at least this large are parsed in pieces, in parallel (when their layout allows).
pub(super) const PIECES_FROM_BYTES: usize = 1 << 20;
/// Spheres per piece.
pub(super) const PIECE_SPHERES: usize = 4096;

/// What a top-level table header opens.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Section {
    /// Anything but the spheres (and the text before the first header).
    Other,
    /// `[[sphere]]`: the next sphere.
    Sphere,
    /// A header under `sphere` (`[sphere.orbit]`, `[[sphere.keyframes]]`): part of the last
    /// sphere.
    SphereSub,
}

/// Where each top-level section starts (the offset of its header's `[`) and what it is, found
/// with the TOML lexer, so brackets inside strings (even multi-line ones), comments and
/// multi-line arrays are never taken for headers. `None` when the layout is unusual (quoted
/// header keys, unbalanced brackets): the caller then parses the document whole.
fn sections(text: &str) -> Option<Vec<(usize, Section)>> {
    use toml_parser::lexer::TokenKind as K;
    let mut out = vec![(0, Section::Other)];
    let mut lexer = toml_parser::Source::new(text).lex();
    // Nesting of arrays and inline tables in a value; headers only occur outside values, at
    // the start of a line.
    let mut depth = 0usize;
    let mut line_start = true;
    let mut in_value = false;
    // Before the first header, where a `sphere` key would clash with `[[sphere]]`.
    let mut root = true;
    while let Some(tok) = lexer.next() {
        if root && depth == 0 && line_start && !in_value {
            let key = &text[tok.span().start()..tok.span().end()];
            let quoted = matches!(tok.kind(), K::BasicString | K::LiteralString);
            if quoted || (tok.kind() == K::Atom && key == "sphere") {
                return None;
            }
        }
        match tok.kind() {
            K::Whitespace | K::Comment => {}
            K::Newline => {
                if depth == 0 {
                    line_start = true;
                    in_value = false;
                }
            }
            K::LeftSquareBracket if depth == 0 && line_start && !in_value => {
                let start = tok.span().start();
                out.push((start, header(&mut lexer, text, start)?));
                line_start = false;
                root = false;
            }
            K::LeftSquareBracket | K::LeftCurlyBracket => {
                depth += 1;
                line_start = false;
            }
            K::RightSquareBracket | K::RightCurlyBracket => {
                depth = depth.checked_sub(1)?;
                line_start = false;
            }
            K::Equals => {
                if depth == 0 {
                    in_value = true;
                }
                line_start = false;
            }
            K::Eof => break,
            _ => line_start = false,
        }
    }
    (depth == 0).then_some(out)
}

/// What the table header whose first `[` is at `start` opens, read from `lexer` up to the
/// header's last `]`; `None` for a header left to a whole parse (a quoted key, or what is
/// not a plain header).
fn header(lexer: &mut Lexer<'_>, text: &str, start: usize) -> Option<Section> {
    use toml_parser::lexer::TokenKind as K;
    let mut next = || lexer.next();
    let mut t = next()?;
    let array = t.kind() == K::LeftSquareBracket && t.span().start() == start + 1;
    if array {
        t = next()?;
    }
    while t.kind() == K::Whitespace {
        t = next()?;
    }
    if t.kind() != K::Atom {
        return None;
    }
    let first = &text[t.span().start()..t.span().end()];
    let mut single_key = true;
    loop {
        t = next()?;
        match t.kind() {
            K::RightSquareBracket => break,
            K::Whitespace => {}
            K::Dot | K::Atom => single_key = false,
            _ => return None,
        }
    }
    if array && next()?.kind() != K::RightSquareBracket {
        return None;
    }
    Some(match (first, array && single_key) {
        ("sphere", true) => Section::Sphere,
        ("sphere", false) => Section::SphereSub,
        _ => Section::Other,
    })
}

/// The spheres of one piece.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpheres {
    #[serde(default)]
    sphere: Vec<RawSphere>,
}

/// What went wrong in a piece.
enum PieceError {
    /// A limit of the scan before the parse ([`scan`]), at this span of the whole text.
    Limit(Located),
    /// Syntax or type, at this span of the whole text.
    Syntax(Located),
    /// A value, with its message.
    Value(String),
}

/// Parses `text` cut into pieces of about `per_piece` spheres: every run of `[[sphere]]`
/// sections (with their sub-tables) becomes pieces parsed and validated in parallel, and the
/// rest (settings, materials) is parsed as one document. Byte offsets in pieces are mapped
/// back to the whole text, so errors carry the same line:column as a whole parse, and sphere
/// indices count from the file's first sphere. The first syntax error in the file wins, then
/// settings errors, then the first sphere's error, as for a whole parse. `None` when the
/// layout is unusual (see [`sections`]) or the rest also defines `sphere`.
pub(super) fn parse_in_pieces(
    text: &str,
    source: &Path,
    overrides: &Overrides,
    per_piece: usize,
) -> Option<Result<Scene, Error>> {
    use rayon::prelude::*;
    let sections = sections(text)?;
    let cut = Cut::of(&sections, text.len(), per_piece)?;
    let file = raytrace_core::error::elide_path(source);
    let check = Validator::new(&file, overrides);
    let rest = Rest::of(text, &cut.rest);
    let head = rest.parse(&check);
    if let Ok(raw) = &head
        && !raw.sphere.is_empty()
        && !cut.pieces.is_empty()
    {
        return None;
    }
    let checked_head = head.as_ref().ok().map(|raw| check.scene_head(raw, source));
    let names = match &checked_head {
        Some(Ok((_, names))) => Some(names),
        _ => None,
    };
    let results: Vec<Result<Validated, PieceError>> = cut
        .pieces
        .par_iter()
        .map(|&piece| parse_piece(text, piece, &check, names))
        .collect();
    let fail = |msg: String| Some(Err(Error::Scene(msg)));
    let errors = results
        .iter()
        .filter_map(|r| r.as_ref().err())
        .chain(head.as_ref().err());
    if let Some(e) = first_error(errors) {
        return fail(report::render(&file, text, e.span.clone(), &e.message));
    }
    let mut scene = match checked_head? {
        Ok((scene, _)) => scene,
        Err(msg) => return fail(msg),
    };
    scene.spheres.reserve_exact(cut.spheres);
    for r in results {
        match r {
            Ok((s, inline)) => add_spheres(&mut scene, s, inline),
            Err(PieceError::Value(msg)) => return fail(msg),
            // Reported above.
            Err(PieceError::Limit(e) | PieceError::Syntax(e)) => {
                return fail(report::render(&file, text, e.span, &e.message));
            }
        }
    }
    Some(Ok(scene))
}

/// A file cut at its sections' headers.
struct Cut {
    /// Runs of spheres: (start, end, index of the first sphere).
    pieces: Vec<(usize, usize, usize)>,
    /// The rest: (start, end) ranges.
    rest: Vec<(usize, usize)>,
    /// The number of spheres.
    spheres: usize,
}

impl Cut {
    /// The cut of a text of `len` bytes with `sections`, into pieces of at most `per_piece`
    /// spheres; `None` where a sphere's sub-table does not follow its sphere.
    fn of(sections: &[(usize, Section)], len: usize, per_piece: usize) -> Option<Cut> {
        let mut pieces: Vec<(usize, usize, usize)> = Vec::new();
        let mut rest: Vec<(usize, usize)> = Vec::new();
        let mut spheres = 0usize;
        let mut in_piece = 0usize; // spheres in the last piece, if it is open
        let mut open = false;
        for (i, &(start, kind)) in sections.iter().enumerate() {
            let end = sections.get(i + 1).map_or(len, |s| s.0);
            match kind {
                Section::Other => {
                    open = false;
                    rest.push((start, end));
                }
                Section::Sphere => {
                    if open && in_piece < per_piece {
                        pieces.last_mut()?.1 = end;
                        in_piece += 1;
                    } else {
                        pieces.push((start, end, spheres));
                        in_piece = 1;
                        open = true;
                    }
                    spheres += 1;
                }
                // A sub-table right after its sphere; anywhere else the whole parse decides.
                Section::SphereSub if open => pieces.last_mut()?.1 = end,
                Section::SphereSub => return None,
            }
        }
        Some(Cut {
            pieces,
            rest,
            spheres,
        })
    }
}

/// The rest of a file (settings, materials) as one document, with a map from its offsets
/// back to the file's.
struct Rest {
    text: String,
    /// Where each range starts in `text`, and in the file's text.
    map: Vec<(usize, usize)>,
}

impl Rest {
    /// The ranges `ranges` of `text`, one after another.
    fn of(text: &str, ranges: &[(usize, usize)]) -> Rest {
        let mut rest = Rest {
            text: String::new(),
            map: Vec::new(),
        };
        for &(a, b) in ranges {
            rest.map.push((rest.text.len(), a));
            rest.text.push_str(&text[a..b]);
        }
        rest
    }

    /// An error at offsets of the rest, placed at the file's.
    fn locate(&self, e: Located) -> Located {
        let to_text = |off: usize| {
            let i = self.map.partition_point(|m| m.0 <= off).max(1) - 1;
            self.map.get(i).map_or(off, |&(r, t)| t + (off - r))
        };
        let start = to_text(e.span.start);
        Located {
            span: start..start + e.span.len(),
            message: e.message,
        }
    }

    /// The rest scanned and parsed, with `check`'s overrides applied.
    fn parse(&self, check: &Validator) -> Result<RawScene, PieceError> {
        match scan::scan(&self.text, 0) {
            Err(e) => Err(PieceError::Limit(self.locate(e))),
            Ok(()) => toml::from_str(&self.text)
                .map(|mut raw| {
                    check.apply(&mut raw);
                    raw
                })
                .map_err(|e| {
                    PieceError::Syntax(self.locate(report::toml_error(&self.text, &e, 0)))
                }),
        }
    }
}

/// The spheres of piece `(a, b, first)` of `text` scanned, parsed and, where the rest gave
/// the material `names`, validated.
fn parse_piece(
    text: &str,
    (a, b, first): (usize, usize, usize),
    check: &Validator,
    names: Option<&BTreeMap<&str, u32>>,
) -> Result<Validated, PieceError> {
    let doc = &text[a..b];
    let to_text = |e: Located| Located {
        span: a + e.span.start..a + e.span.end,
        message: e.message,
    };
    scan::scan(doc, first).map_err(|e| PieceError::Limit(to_text(e)))?;
    let raw: RawSpheres = toml::from_str(doc)
        .map_err(|e| PieceError::Syntax(to_text(report::toml_error(doc, &e, first))))?;
    match names {
        Some(names) => check
            .spheres(&raw.sphere, first, names)
            .map_err(PieceError::Value),
        None => Ok((Vec::new(), Vec::new())),
    }
}

/// The error a whole parse would report first of `errors`: the first limit passed in the
/// text (a whole parse scans the text before parsing it), else the first syntax error.
fn first_error<'e>(errors: impl Iterator<Item = &'e PieceError> + Clone) -> Option<&'e Located> {
    let limits = errors.clone().filter_map(|e| match e {
        PieceError::Limit(l) => Some(l),
        _ => None,
    });
    let syntax = errors.filter_map(|e| match e {
        PieceError::Syntax(l) => Some(l),
        _ => None,
    });
    let first = |located: &&Located| located.span.start;
    limits
        .min_by_key(first)
        .or_else(|| syntax.min_by_key(first))
}
