//! Extended XYZ files (as ASE and OVITO write them): frames one after another, each
//!
//! ```text
//! 3
//! Lattice="4 0 0 0 4 0 0 0 4" Properties=species:S:1:pos:R:3:velo:R:3 pbc="T T T"
//! Ar 0.5 0.5 0.5 0.1 0 0
//! ...
//! ```
//!
//! a count line, a comment line of `key=value` pairs (values in double quotes or braces may
//! hold spaces) and one line an atom whose fields are the `Properties=` columns in order:
//! `name:type:count`, type `S` (text), `R` (real), `I` (integer) or `L` (logical, `T`/`F`).
//! Without `Properties=` a line is `species x y z` (plain XYZ). `Lattice=` gives the box's
//! three edge vectors (`Origin=` its corner, default 0), `pbc=` which are periodic (default:
//! all, when there is a lattice).

use std::collections::HashMap;
use std::sync::Arc;

use glam::{DMat3, DVec3};

use super::cell::Cell;
use super::read_error::ReadError;
use super::snapshot::{Column, ColumnKind, Snapshot};
use super::text::Lines;

fn bad<T>(line: u64, what: impl std::fmt::Display) -> Result<T, ReadError> {
    Err(ReadError::Bad(format!("line {line}: {what}")))
}

/// The `key=value` pairs of a comment line (keys lower-cased). A bare word is a flag in
/// extended XYZ, and none of the keys read here is one: it is left out, so that a plain XYZ
/// comment (`fcc lattice of argon`) does not give `lattice` a value.
fn pairs(comment: &str) -> Result<HashMap<String, String>, String> {
    let mut out = HashMap::new();
    let mut chars = comment.chars().peekable();
    loop {
        while chars.next_if(|c| c.is_whitespace()).is_some() {}
        if chars.peek().is_none() {
            return Ok(out);
        }
        let mut key = String::new();
        while let Some(c) = chars.next_if(|c| !c.is_whitespace() && *c != '=') {
            key.push(c);
        }
        let mut value = String::new();
        let pair = chars.next_if_eq(&'=').is_some();
        if pair {
            match chars.peek() {
                Some('"') => {
                    chars.next();
                    loop {
                        match chars.next() {
                            Some('"') => break,
                            Some('\\') => value.extend(chars.next()),
                            Some(c) => value.push(c),
                            None => return Err(format!("the value of {key} has no closing quote")),
                        }
                    }
                }
                Some('{') => {
                    chars.next();
                    loop {
                        match chars.next() {
                            Some('}') => break,
                            Some(c) => value.push(c),
                            None => return Err(format!("the value of {key} has no closing brace")),
                        }
                    }
                }
                _ => {
                    while let Some(c) = chars.next_if(|c| !c.is_whitespace()) {
                        value.push(c);
                    }
                }
            }
        }
        if pair {
            out.insert(key.to_ascii_lowercase(), value);
        }
    }
}

/// Whether a comment line gives one of the keys this reader reads (`Properties=`,
/// `Lattice=`, `Origin=`, `pbc=`, in any case): then it is extended XYZ, and must parse.
fn gives_a_key(comment: &str) -> bool {
    let lower = comment.to_ascii_lowercase();
    ["properties=", "lattice=", "origin=", "pbc="]
        .iter()
        .any(|k| lower.contains(k))
}

/// The columns a `Properties=` value declares.
fn properties(spec: &str) -> Result<Vec<Column>, String> {
    let parts: Vec<&str> = spec.split(':').collect();
    if !parts.len().is_multiple_of(3) || parts.is_empty() {
        return Err(format!(
            "Properties=\"{}\" is not name:type:count triples",
            raytrace_core::error::elide(spec)
        ));
    }
    let mut out = Vec::new();
    for t in parts.chunks(3) {
        let kind = match t[1] {
            "S" => ColumnKind::Text,
            "R" => ColumnKind::Real,
            "I" => ColumnKind::Integer,
            "L" => ColumnKind::Logical,
            other => {
                return Err(format!(
                    "property {} has type \"{}\"; the types are S, R, I and L",
                    t[0],
                    raytrace_core::error::elide(other)
                ));
            }
        };
        let count: u8 = match t[2].parse() {
            Ok(n) if (1..=64).contains(&n) => n,
            _ => {
                return Err(format!(
                    "property {} has count \"{}\", not 1 to 64",
                    t[0],
                    raytrace_core::error::elide(t[2])
                ));
            }
        };
        if out.iter().any(|c: &Column| c.name == t[0]) {
            return Err(format!("property {} is declared twice", t[0]));
        }
        for k in 0..count {
            out.push(Column {
                name: t[0].to_string(),
                component: k,
                components: count,
                kind,
            });
        }
    }
    Ok(out)
}

/// Reads the count and comment lines of the next frame, leaving `lines` at its first atom;
/// `None` at the end of the file.
pub(crate) fn next_snapshot(
    lines: &mut Lines,
    last: Option<&Arc<[Column]>>,
) -> Result<Option<Snapshot>, ReadError> {
    let Some((start, count_text)) = lines.next_filled_line()? else {
        return Ok(None);
    };
    let count = atom_count(start, &count_text)?;
    let comment_line = lines.position().line;
    let Some(comment) = lines.next_line()? else {
        return bad(
            lines.last_line(),
            "the file ends before the frame's comment line (truncated)",
        );
    };
    let keys = match pairs(comment) {
        Ok(keys) => keys,
        // A comment that gives none of the keys read is free text (plain XYZ): its quotes and
        // braces are not extended XYZ's.
        Err(_) if !gives_a_key(comment) => HashMap::new(),
        Err(m) => return bad(comment_line, m),
    };
    let columns: Vec<Column> = match keys.get("properties") {
        Some(spec) => properties(spec).or_else(|m| bad(comment_line, m))?,
        None => properties("species:S:1:pos:R:3").expect("the default"),
    };
    let columns: Arc<[Column]> = match last {
        Some(c) if **c == *columns => c.clone(),
        _ => columns.into(),
    };
    let cell = match keys.get("lattice") {
        None => None,
        Some(lattice) => Some(lattice_cell(lattice, &keys, comment_line)?),
    };
    Ok(Some(Snapshot {
        line: start,
        rows: lines.position(),
        count,
        timestep: None,
        cell: cell.map(Arc::new),
        columns,
    }))
}

/// The atom count of a frame's count line (`text`, line `line`): one whole number alone.
fn atom_count(line: u64, text: &str) -> Result<u64, ReadError> {
    match text.split_whitespace().next().map(str::parse) {
        Some(Ok(n)) if text.split_whitespace().count() == 1 => Ok(n),
        _ => bad(
            line,
            format_args!(
                "expected a frame's atom count, found \"{}\" (the count line before it lies?)",
                raytrace_core::error::elide(text)
            ),
        ),
    }
}

/// The cell a comment line (line `line`, its pairs `keys`) declares: `Lattice=`'s three edge
/// vectors (`lattice`), at `Origin=` (default 0), periodic as `pbc=` says (default: all).
fn lattice_cell(
    lattice: &str,
    keys: &HashMap<String, String>,
    line: u64,
) -> Result<Cell, ReadError> {
    let l = numbers(lattice, 9, "Lattice", line)?;
    let origin = match keys.get("origin") {
        Some(o) => DVec3::from_slice(&numbers(o, 3, "Origin", line)?),
        None => DVec3::ZERO,
    };
    let periodic = match keys.get("pbc") {
        None => [true; 3],
        Some(p) => pbc_flags(p, line)?,
    };
    let edges = DMat3::from_cols(
        DVec3::from_slice(&l[0..3]),
        DVec3::from_slice(&l[3..6]),
        DVec3::from_slice(&l[6..9]),
    );
    Cell::new(origin, edges, periodic).or_else(|m| bad(line, format_args!("Lattice=: {m}")))
}

/// The `n` numbers of a comment line's (line `line`) `key=` value `text`.
fn numbers(text: &str, n: usize, key: &str, line: u64) -> Result<Vec<f64>, ReadError> {
    let v: Vec<f64> = text
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .or_else(|_| {
            bad(
                line,
                format_args!("{key}= holds a field that is not a number"),
            )
        })?;
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return bad(line, format_args!("{key}= holds {x}, not a finite number"));
    }
    if v.len() != n {
        return bad(
            line,
            format_args!("{key}= holds {} numbers, not {n}", v.len()),
        );
    }
    Ok(v)
}

/// Which of the cell's axes are periodic, as a comment line's (line `line`) `pbc=` value
/// `text` says: three flags, T or F.
fn pbc_flags(text: &str, line: u64) -> Result<[bool; 3], ReadError> {
    let f: Vec<&str> = text.split_whitespace().collect();
    let flag = |s: &str| match s {
        "T" | "t" | "True" | "true" | "1" => Some(true),
        "F" | "f" | "False" | "false" | "0" => Some(false),
        _ => None,
    };
    match f[..] {
        [a, b, c] => match (flag(a), flag(b), flag(c)) {
            (Some(a), Some(b), Some(c)) => Ok([a, b, c]),
            _ => bad(line, "pbc= holds a flag that is not T or F"),
        },
        _ => bad(line, "pbc= holds three flags (T or F)"),
    }
}

/// Skips the atom lines of `snap`; an error when the file ends first. The last line is read:
/// its fields must be as many as the columns, and it must end with a line end.
pub(crate) fn skip_rows(lines: &mut Lines, snap: &Snapshot) -> Result<(), ReadError> {
    let before = snap.count.saturating_sub(1);
    let skipped = lines.skip_lines(before)?;
    let line = lines.position().line;
    let last = match snap.count {
        0 => None,
        _ if skipped < before => None,
        _ => lines
            .next_line()?
            .map(|l| l.split_ascii_whitespace().count()),
    };
    if snap.count > 0 && last.is_none() {
        return bad(
            lines.last_line(),
            format_args!(
                "the file ends after {skipped} of the {} atoms its count line (line {}) declares (the count line lies, or the file is truncated)",
                snap.count, snap.line
            ),
        );
    }
    if snap.count > 0 && !lines.line_ended() {
        return bad(
            line,
            format_args!("the file ends inside atom {before}'s line (truncated)"),
        );
    }
    if let Some(n) = last.filter(|&n| n != snap.columns.len()) {
        return bad(line, mismatch(before, n, snap.columns.len()));
    }
    Ok(())
}

/// A line of `n` fields for `columns` columns: a count line read as an atom (one field)
/// says the count before it lies.
fn mismatch(i: u64, n: usize, columns: usize) -> String {
    let hint = if n == 1 {
        " (the count line of its frame lies?)"
    } else {
        ""
    };
    format!("atom {i}: {n} fields for the {columns} columns Properties= declares{hint}")
}

/// Reads the atom lines of `snap`, calling `row(i, values)` with the values of the columns
/// `wanted` in that order: numbers as they are, logicals as 1 or 0, text as the index of its
/// first appearance in the labels returned.
pub(crate) fn read_rows(
    lines: &mut Lines,
    snap: &Snapshot,
    wanted: &[usize],
    mut row: impl FnMut(u64, &[f64]) -> Result<(), String>,
) -> Result<Vec<String>, ReadError> {
    let columns = snap.columns.len();
    let mut values = vec![0.0; wanted.len()];
    let mut slot = vec![usize::MAX; columns];
    for (k, &w) in wanted.iter().enumerate() {
        slot[w] = k;
    }
    let mut labels: Vec<String> = Vec::new();
    for i in 0..snap.count {
        let line = lines.position().line;
        let Some(text) = lines.next_line()? else {
            return bad(
                lines.last_line(),
                format_args!(
                    "the file ends after {i} of the {} atoms its count line (line {}) declares (the count line lies, or the file is truncated)",
                    snap.count, snap.line
                ),
            );
        };
        let mut n = 0;
        for field in text.split_ascii_whitespace() {
            if n < columns && slot[n] != usize::MAX {
                let value = field_value(field, &snap.columns[n], &mut labels);
                values[slot[n]] = value.or_else(|m| bad(line, format_args!("atom {i}: {m}")))?;
            }
            n += 1;
        }
        if !lines.line_ended() {
            return bad(
                line,
                format_args!("the file ends inside atom {i}'s line (truncated)"),
            );
        }
        if n != columns {
            return bad(line, mismatch(i, n, columns));
        }
        row(i, &values).or_else(|m| bad(line, m))?;
    }
    Ok(labels)
}

/// The value of `field` in column `c`: a number as it is, a logical as 1 or 0, text as the
/// index of its first appearance in `labels` (added there when new).
fn field_value(field: &str, c: &Column, labels: &mut Vec<String>) -> Result<f64, String> {
    let value = match c.kind {
        ColumnKind::Text => match labels.iter().position(|l| l == field) {
            Some(k) => Some(k as f64),
            // At most 65,536 distinct labels (species) in a frame.
            None if labels.len() < 1 << 16 => {
                labels.push(field.to_string());
                Some((labels.len() - 1) as f64)
            }
            None => return Err(format!("more than 65536 different {} values", c.name)),
        },
        ColumnKind::Logical => match field {
            "T" | "True" | "true" => Some(1.0),
            "F" | "False" | "false" => Some(0.0),
            _ => None,
        },
        ColumnKind::Integer => field.parse::<i64>().ok().map(|x| x as f64),
        ColumnKind::Real | ColumnKind::List => field.parse::<f64>().ok(),
    };
    value.ok_or_else(|| {
        format!(
            "{} is \"{}\", not {}",
            c.label(),
            raytrace_core::error::elide(field),
            c.kind.expected()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comment_lines_and_properties_are_parsed() {
        let p = pairs(r#"Lattice="4 0 0 0 4 0 0 0 4" Properties=species:S:1:pos:R:3 pbc="T F T" flag energy=-1.5 note={a b}"#).unwrap();
        assert_eq!(p["lattice"], "4 0 0 0 4 0 0 0 4");
        assert_eq!(p["pbc"], "T F T");
        assert!(
            !p.contains_key("flag"),
            "a bare word is a flag, not a key with a value"
        );
        assert_eq!(p["energy"], "-1.5");
        assert_eq!(p["note"], "a b");
        let c = properties("species:S:1:pos:R:3:id:I:1").unwrap();
        assert_eq!(c.len(), 5);
        assert_eq!(
            (c[2].name.as_str(), c[2].component, c[2].components),
            ("pos", 1, 3)
        );
        assert!(properties("pos:R").is_err());
        assert!(properties("pos:Q:3").unwrap_err().contains("type \"Q\""));
        assert!(pairs("a=\"b").is_err());
    }

    #[test]
    fn frames_are_read_with_species_as_labels() {
        let text = "2\nLattice=\"4 0 0 0 4 0 0 0 4\" Properties=species:S:1:pos:R:3:fixed:L:1 pbc=\"T T F\"\nAr 0.5 1 1.5 T\nNe 1 2 3 F\n1\nProperties=species:S:1:pos:R:3:fixed:L:1\nNe 1 1 1 F\n";
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.xyz");
        std::fs::write(&path, text).unwrap();
        let mut l = Lines::open(&path, "xyz").unwrap();
        let a = next_snapshot(&mut l, None).unwrap().unwrap();
        assert_eq!(a.cell.clone().unwrap().periodic, [true, true, false]);
        let mut rows = Vec::new();
        let labels = read_rows(&mut l, &a, &[0, 3, 4], |_, v| {
            rows.push(v.to_vec());
            Ok(())
        })
        .unwrap();
        assert_eq!(labels, ["Ar", "Ne"]);
        assert_eq!(rows, vec![vec![0.0, 1.5, 1.0], vec![1.0, 3.0, 0.0]]);
        let b = next_snapshot(&mut l, Some(&a.columns)).unwrap().unwrap();
        assert!(Arc::ptr_eq(&a.columns, &b.columns));
        assert!(b.cell.is_none());
        skip_rows(&mut l, &b).unwrap();
        assert!(next_snapshot(&mut l, None).unwrap().is_none());
    }

    #[test]
    fn a_plain_comment_is_free_text_and_an_origin_not_finite_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.xyz");
        // Words that name keys, and a quote and a brace left open: a plain XYZ's comment.
        for comment in [
            "fcc lattice of argon, 300 K",
            "properties: argon's {first frame",
            "PBC lattice \"origin",
        ] {
            std::fs::write(&path, format!("1\n{comment}\nAr 1 2 3\n")).unwrap();
            let mut l = Lines::open(&path, "xyz").unwrap();
            let a = next_snapshot(&mut l, None).unwrap().unwrap();
            assert!(a.cell.is_none(), "{comment}");
            let mut rows = Vec::new();
            read_rows(&mut l, &a, &[1, 2, 3], |_, v| {
                rows.push(v.to_vec());
                Ok(())
            })
            .unwrap();
            assert_eq!(rows, vec![vec![1.0, 2.0, 3.0]], "{comment}");
        }
        // A key given and malformed is still an error, and a number that is not finite is
        // named with its own key.
        for (comment, message) in [
            (
                "Lattice=\"4 0 0",
                "line 2: the value of Lattice has no closing quote",
            ),
            (
                "Lattice=\"4 0 0 0 4 0 0 0 4\" Origin=\"nan 0 0\"",
                "line 2: Origin= holds NaN, not a finite number",
            ),
            (
                "Lattice=\"4 0 0 0 inf 0 0 0 4\"",
                "line 2: Lattice= holds inf, not a finite number",
            ),
        ] {
            std::fs::write(&path, format!("1\n{comment}\nAr 1 2 3\n")).unwrap();
            let mut l = Lines::open(&path, "xyz").unwrap();
            let e = next_snapshot(&mut l, None).unwrap_err();
            assert!(
                matches!(&e, ReadError::Bad(m) if m == message),
                "{comment}: {e:?}"
            );
        }
    }

    #[test]
    fn a_lying_count_and_mismatched_properties_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.xyz");
        // Three atoms claimed, two there, then the next frame's count line read as an atom.
        std::fs::write(&path, "3\n\nAr 0 0 0\nAr 1 1 1\n1\n\nAr 2 2 2\n").unwrap();
        let mut l = Lines::open(&path, "xyz").unwrap();
        let a = next_snapshot(&mut l, None).unwrap().unwrap();
        let e = read_rows(&mut l, &a, &[1], |_, _| Ok(())).unwrap_err();
        assert!(
            matches!(e, ReadError::Bad(m) if m == "line 5: atom 2: 1 fields for the 4 columns Properties= declares (the count line of its frame lies?)")
        );
        std::fs::write(
            &path,
            "1\nProperties=species:S:1:pos:R:3:id:I:1\nAr 0 0 0\n",
        )
        .unwrap();
        let mut l = Lines::open(&path, "xyz").unwrap();
        let a = next_snapshot(&mut l, None).unwrap().unwrap();
        let e = read_rows(&mut l, &a, &[1], |_, _| Ok(())).unwrap_err();
        assert!(matches!(e, ReadError::Bad(m) if m.contains("4 fields for the 5 columns")));
        std::fs::write(&path, "1\nProperties=species:S:1:pos:R:3\nAr 0 x 0\n").unwrap();
        let mut l = Lines::open(&path, "xyz").unwrap();
        let a = next_snapshot(&mut l, None).unwrap().unwrap();
        let e = read_rows(&mut l, &a, &[2], |_, _| Ok(())).unwrap_err();
        assert!(
            matches!(e, ReadError::Bad(m) if m == "line 3: atom 0: pos[1] is \"x\", not a number"),
        );
    }

    /// A file that ends too soon is named at its last line (a 9-line file at line 9), whether
    /// its rows are read or skipped, and where it ends before a comment line.
    #[test]
    fn a_file_that_ends_early_is_named_at_its_last_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.xyz");
        let nine = "3\n\nAr 0 0 0\nAr 1 1 1\nAr 2 2 2\n3\n\nAr 0 0 0\nAr 1 1 1\n";
        assert_eq!(nine.lines().count(), 9);
        std::fs::write(&path, nine).unwrap();
        let expected = "line 9: the file ends after 2 of the 3 atoms its count line (line 6) declares (the count line lies, or the file is truncated)";
        let mut l = Lines::open(&path, "xyz").unwrap();
        let a = next_snapshot(&mut l, None).unwrap().unwrap();
        skip_rows(&mut l, &a).unwrap();
        let b = next_snapshot(&mut l, Some(&a.columns)).unwrap().unwrap();
        let mut read = Lines::open(&path, "xyz").unwrap();
        read.seek(b.rows).unwrap();
        let e = read_rows(&mut read, &b, &[1], |_, _| Ok(())).unwrap_err();
        assert!(matches!(&e, ReadError::Bad(m) if m == expected), "{e:?}");
        let e = skip_rows(&mut l, &b).unwrap_err();
        assert!(matches!(&e, ReadError::Bad(m) if m == expected), "{e:?}");
        std::fs::write(&path, "1\n").unwrap();
        let mut l = Lines::open(&path, "xyz").unwrap();
        let e = next_snapshot(&mut l, None).unwrap_err();
        assert!(
            matches!(&e, ReadError::Bad(m) if m == "line 1: the file ends before the frame's comment line (truncated)"),
            "{e:?}"
        );
    }
}
