//! LAMMPS text dumps (`dump atom` and `dump custom`, plain or gzip): a file holds snapshots,
//! each
//!
//! ```text
//! ITEM: TIMESTEP
//! 200
//! ITEM: NUMBER OF ATOMS
//! 108
//! ITEM: BOX BOUNDS xy xz yz pp pp ff      (orthogonal: "ITEM: BOX BOUNDS pp pp ff")
//! xlo_bound xhi_bound xy
//! ylo_bound yhi_bound xz
//! zlo_bound zhi_bound yz
//! ITEM: ATOMS id type x y z vx vy vz c_speed
//! 1 1 0.5 0.25 ...                       (one line an atom, one field a column)
//! ```
//!
//! (LAMMPS docs, the `dump` command.) Other items with one line of value (`UNITS`, `TIME`)
//! are read past; an item this reader does not know is skipped up to the next `ITEM:` line.
//! A snapshot's header is read ([`next_snapshot`]) and its atom lines either skipped (an
//! index of the file: where each snapshot's atoms begin) or read as numbers for the caller's
//! columns ([`read_rows`]). Every message names the line.

use std::sync::Arc;

use super::cell::Cell;
use super::read_error::ReadError;
use super::snapshot::{Column, Snapshot};
use super::text::{Lines, MAX_BLANK};

fn bad<T>(line: u64, what: impl std::fmt::Display) -> Result<T, ReadError> {
    Err(ReadError::Bad(format!("line {line}: {what}")))
}

/// The next line, or an error saying the file ends in the middle of `what`.
fn required<'a>(lines: &'a mut Lines, what: &str) -> Result<&'a str, ReadError> {
    let end = lines.last_line();
    match lines.next_line()? {
        Some(l) => Ok(l),
        None => bad(end, format_args!("the file ends inside {what} (truncated)")),
    }
}

/// A whole number on a line of its own (`TIMESTEP`, `NUMBER OF ATOMS`).
fn number_line<T: std::str::FromStr>(lines: &mut Lines, item: &str) -> Result<T, ReadError> {
    let line = lines.position().line;
    let text = required(lines, item)?.trim();
    text.parse().or_else(|_| {
        bad(
            line,
            format_args!(
                "{item} is \"{}\", not a whole number in range",
                raytrace_core::error::elide(text)
            ),
        )
    })
}

/// Reads the header of the next snapshot, up to and with its `ITEM: ATOMS` line, leaving
/// `lines` at its first atom; `None` at the end of the file. `last` is the previous
/// snapshot's columns, shared when they are the same.
pub(crate) fn next_snapshot(
    lines: &mut Lines,
    last: Option<&Arc<[Column]>>,
) -> Result<Option<Snapshot>, ReadError> {
    // Blank lines between snapshots are allowed.
    let Some((start, first)) = lines.next_filled_line()? else {
        return Ok(None);
    };
    if first != "ITEM: TIMESTEP" {
        return bad(
            start,
            format_args!(
                "expected \"ITEM: TIMESTEP\" (a LAMMPS dump's snapshot), found \"{}\"",
                raytrace_core::error::elide(&first)
            ),
        );
    }
    let timestep: i64 = number_line(lines, "TIMESTEP")?;
    let mut count: Option<u64> = None;
    let mut cell: Option<Cell> = None;
    loop {
        let line = lines.position().line;
        let item = required(lines, "a snapshot's header")?.trim().to_string();
        let Some(rest) = item.strip_prefix("ITEM:") else {
            return bad(
                line,
                format_args!(
                    "expected an \"ITEM:\" line, found \"{}\"",
                    raytrace_core::error::elide(&item)
                ),
            );
        };
        let rest = rest.trim();
        if rest == "NUMBER OF ATOMS" {
            count = Some(number_line(lines, "NUMBER OF ATOMS")?);
        } else if let Some(flags) = rest.strip_prefix("BOX BOUNDS") {
            cell = Some(box_bounds(lines, line, flags)?);
        } else if let Some(names) = rest.strip_prefix("ATOMS") {
            let Some(count) = count else {
                return bad(line, "ITEM: ATOMS before ITEM: NUMBER OF ATOMS");
            };
            let columns = atom_columns(names, line, last)?;
            return Ok(Some(Snapshot {
                line: start,
                rows: lines.position(),
                count,
                timestep: Some(timestep),
                cell: cell.map(Arc::new),
                columns,
            }));
        } else if rest == "UNITS" || rest == "TIME" {
            required(lines, rest)?;
        } else if rest == "TIMESTEP" {
            return bad(
                line,
                "ITEM: TIMESTEP again before this snapshot's ITEM: ATOMS",
            );
        } else {
            // An item of unknown length: skip to the next ITEM line.
            skip_item(lines)?;
        }
    }
}

/// The columns an `ITEM: ATOMS` line (line `line`, its text after the word `names`) names:
/// `last`, the previous snapshot's, when they are the same.
fn atom_columns(
    names: &str,
    line: u64,
    last: Option<&Arc<[Column]>>,
) -> Result<Arc<[Column]>, ReadError> {
    let names: Vec<&str> = names.split_whitespace().collect();
    if names.is_empty() {
        return bad(line, "ITEM: ATOMS names no columns");
    }
    let columns: Arc<[Column]> = match last {
        Some(c) if c.len() == names.len() && c.iter().zip(&names).all(|(c, n)| c.name == *n) => {
            c.clone()
        }
        _ => names.iter().map(|n| Column::scalar(n)).collect(),
    };
    if let Some(dup) = names
        .iter()
        .enumerate()
        .find(|(i, n)| names[..*i].contains(n))
    {
        return bad(
            line,
            format_args!("ITEM: ATOMS names column {} twice", dup.1),
        );
    }
    Ok(columns)
}

/// Skips the lines of an item this reader does not know, up to the next `ITEM:` line: at
/// most [`MAX_BLANK`] bytes of them, as blank lines, since no value is read from them.
fn skip_item(lines: &mut Lines) -> Result<(), ReadError> {
    let start = lines.position();
    loop {
        let at = lines.position();
        if at.offset - start.offset > MAX_BLANK {
            return bad(
                start.line - 1,
                format_args!(
                    "an item this reader does not know runs on for more than {MAX_BLANK} bytes (not a LAMMPS dump?)"
                ),
            );
        }
        let line = required(lines, "an item")?;
        if line.trim_start().starts_with("ITEM:") {
            return lines.seek(at);
        }
    }
}

/// The three lines after `ITEM: BOX BOUNDS` (whose text after the words is `flags`).
fn box_bounds(lines: &mut Lines, item_line: u64, flags: &str) -> Result<Cell, ReadError> {
    let words: Vec<&str> = flags.split_whitespace().collect();
    let triclinic = words.starts_with(&["xy", "xz", "yz"]);
    let flags = if triclinic { &words[3..] } else { &words[..] };
    // Old dumps write no flags; then nothing is known to be periodic.
    let periodic = match flags {
        [] => [false; 3],
        [a, b, c] => [*a == "pp", *b == "pp", *c == "pp"],
        _ => {
            return bad(
                item_line,
                "ITEM: BOX BOUNDS should have three boundary flags (pp, ff, ss, ...)",
            );
        }
    };
    let mut bounds = [[0.0; 3]; 3];
    let n = if triclinic { 3 } else { 2 };
    for b in &mut bounds {
        let line = lines.position().line;
        let text = required(lines, "the box bounds")?;
        let fields: Vec<&str> = text.split_whitespace().collect();
        if fields.len() != n {
            return bad(
                line,
                format_args!("a box bound line holds {n} numbers, found {}", fields.len()),
            );
        }
        for (x, f) in b.iter_mut().zip(&fields) {
            *x = f.parse().or_else(|_| {
                bad(
                    line,
                    format_args!(
                        "box bound \"{}\" is not a number",
                        raytrace_core::error::elide(f)
                    ),
                )
            })?;
        }
    }
    // The bound lines follow the item's line.
    Cell::from_lammps(bounds, triclinic, periodic)
        .or_else(|(k, m)| bad(item_line + 1 + k as u64, m))
}

/// Skips the atom lines of `snap` (`lines` at its first); an error when the file ends first.
/// The last line is read: its fields must be as many as the columns, and it must end with a
/// line end (a file cut inside its last line is truncated).
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
                "the file ends after {skipped} of the {} atoms its snapshot (timestep {}) declares (truncated, or a wrong count)",
                snap.count,
                snap.timestep.unwrap_or(0)
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
        return bad(
            line,
            format_args!(
                "atom {before}: {n} fields for the {} columns of ITEM: ATOMS",
                snap.columns.len()
            ),
        );
    }
    Ok(())
}

/// Reads the atom lines of `snap` (`lines` at its first), calling `row(i, values)` with the
/// numbers in the columns `wanted`, in that order. Each line must hold one field a column;
/// a wanted field must be a number. An error `row` returns is returned with the line.
pub(crate) fn read_rows(
    lines: &mut Lines,
    snap: &Snapshot,
    wanted: &[usize],
    mut row: impl FnMut(u64, &[f64]) -> Result<(), String>,
) -> Result<(), ReadError> {
    let columns = snap.columns.len();
    let mut values = vec![0.0; wanted.len()];
    // Where each column's value goes (usize::MAX: not wanted).
    let mut slot = vec![usize::MAX; columns];
    for (k, &w) in wanted.iter().enumerate() {
        slot[w] = k;
    }
    for i in 0..snap.count {
        let line = lines.position().line;
        let Some(text) = lines.next_line()? else {
            return bad(
                lines.last_line(),
                format_args!(
                    "the file ends after {i} of the {} atoms its snapshot (timestep {}) declares (truncated, or a wrong count)",
                    snap.count,
                    snap.timestep.unwrap_or(0)
                ),
            );
        };
        if text.trim_start().starts_with("ITEM:") {
            return bad(
                line,
                format_args!(
                    "an ITEM: line where atom {i} of the {} atoms its snapshot (timestep {}) declares should be (a wrong count)",
                    snap.count,
                    snap.timestep.unwrap_or(0)
                ),
            );
        }
        let mut n = 0;
        for field in text.split_ascii_whitespace() {
            if n < columns && slot[n] != usize::MAX {
                values[slot[n]] = match field.parse::<f64>() {
                    Ok(x) => x,
                    Err(_) => {
                        return bad(
                            line,
                            format_args!(
                                "atom {i}: {} is \"{}\", not a number",
                                snap.columns[n].name,
                                raytrace_core::error::elide(field)
                            ),
                        );
                    }
                };
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
            return bad(
                line,
                format_args!("atom {i}: {n} fields for the {columns} columns of ITEM: ATOMS"),
            );
        }
        row(i, &values).or_else(|m| bad(line, m))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines_of(text: &str) -> (tempfile::TempDir, Lines) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.lammpstrj");
        std::fs::write(&path, text).unwrap();
        let l = Lines::open(&path, "dump").unwrap();
        (dir, l)
    }

    const DUMP: &str = "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS pp pp ff\n0 4\n0 4\n-1 1\nITEM: ATOMS id type x y z\n1 1 0.5 0.5 0\n2 2 1.5 1.5 0.25\nITEM: TIMESTEP\n10\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS xy xz yz pp pp pp\n-1 5 1\n0 4 -1\n0 2 0\nITEM: ATOMS id type x y z\n1 1 0.75 0.5 0\n";

    #[test]
    fn snapshots_are_indexed_and_read_back() {
        let (_d, mut l) = lines_of(DUMP);
        let a = next_snapshot(&mut l, None).unwrap().unwrap();
        assert_eq!((a.line, a.count, a.timestep), (1, 2, Some(0)));
        assert_eq!(a.rows.line, 10);
        let cell = *a.cell.clone().unwrap();
        assert_eq!(cell.periodic, [true, true, false]);
        assert_eq!(cell.edges.z_axis.z, 2.0);
        skip_rows(&mut l, &a).unwrap();
        let b = next_snapshot(&mut l, Some(&a.columns)).unwrap().unwrap();
        assert!(Arc::ptr_eq(&a.columns, &b.columns));
        assert_eq!((b.line, b.count, b.timestep), (12, 1, Some(10)));
        // xlo = -1 - min(0, 1, -1, 0) = 0, xhi = 5 - max(0, 1, -1, 0) = 4.
        let cell = *b.cell.clone().unwrap();
        assert_eq!(cell.edges.x_axis.x, 4.0);
        assert_eq!(cell.edges.z_axis.x, -1.0);
        skip_rows(&mut l, &b).unwrap();
        assert!(next_snapshot(&mut l, Some(&b.columns)).unwrap().is_none());
        // Back to the first snapshot's rows: its z and x columns.
        l.seek(a.rows).unwrap();
        let mut got = Vec::new();
        read_rows(&mut l, &a, &[4, 2], |i, v| {
            got.push((i, v.to_vec()));
            Ok(())
        })
        .unwrap();
        assert_eq!(got, vec![(0, vec![0.0, 0.5]), (1, vec![0.25, 1.5])]);
    }

    fn error_of(text: &str) -> String {
        let (_d, mut l) = lines_of(text);
        let mut columns = None;
        loop {
            match next_snapshot(&mut l, columns.as_ref()) {
                Ok(Some(s)) => {
                    let r = read_rows(&mut l, &s, &[2], |_, _| Ok(()));
                    if let Err(ReadError::Bad(m)) = r {
                        return m;
                    }
                    columns = Some(s.columns.clone());
                }
                Ok(None) => panic!("no error in {text}"),
                Err(ReadError::Bad(m)) => return m,
                Err(ReadError::Io(e)) => panic!("{e}"),
            }
        }
    }

    #[test]
    fn bad_dumps_are_errors_naming_the_line() {
        let cut = &DUMP[..DUMP.len() - 16];
        assert!(
            error_of(cut).starts_with("line 20: the file ends after 0 of the 1 atoms"),
            "{}",
            error_of(cut)
        );
        let nan = DUMP.replace("1 1 0.5 0.5 0", "1 1 abc 0.5 0");
        assert_eq!(
            error_of(&nan),
            "line 10: atom 0: x is \"abc\", not a number"
        );
        let short = DUMP.replace("2 2 1.5 1.5 0.25", "2 2 1.5 1.5");
        assert_eq!(
            error_of(&short),
            "line 11: atom 1: 4 fields for the 5 columns of ITEM: ATOMS"
        );
        // The bad bound line is named: y's is the item's second line after it (line 7; in
        // the second snapshot, line 18), z's the third.
        let inverted = DUMP.replace("0 4\n0 4\n-1 1", "0 4\n4 0\n-1 1");
        assert_eq!(
            error_of(&inverted),
            "line 7: the box's y bounds are 4 to 0: the upper must not be less than the lower"
        );
        let later = DUMP.replace("0 4 -1\n", "4 0 -1\n");
        assert!(
            error_of(&later).starts_with("line 18: the box's y bounds are 4 to 0"),
            "{}",
            error_of(&later)
        );
        let infinite = DUMP.replace("0 4\n0 4\n-1 1", "0 4\n0 4\n-1 inf");
        assert_eq!(
            error_of(&infinite),
            "line 8: box bound inf is not a finite number"
        );
        let count = DUMP.replace("ITEM: NUMBER OF ATOMS\n2", "ITEM: NUMBER OF ATOMS\n-2");
        assert!(error_of(&count).contains("NUMBER OF ATOMS is \"-2\", not a whole number"));
        let unknown = DUMP.replacen(
            "ITEM: ATOMS",
            &format!(
                "ITEM: FOO\n{}ITEM: ATOMS",
                "x\n".repeat(MAX_BLANK as usize / 2 + 1)
            ),
            1,
        );
        assert_eq!(
            error_of(&unknown),
            "line 9: an item this reader does not know runs on for more than 1048576 bytes (not a LAMMPS dump?)"
        );
        let small = DUMP.replacen("ITEM: ATOMS", "ITEM: FOO\nx\nITEM: ATOMS", 1);
        let (_d, mut l) = lines_of(&small);
        assert_eq!(next_snapshot(&mut l, None).unwrap().unwrap().count, 2);
        let text = DUMP.replace("ITEM: TIMESTEP\n0", "hello\n0");
        assert!(error_of(&text).starts_with("line 1: expected \"ITEM: TIMESTEP\""));
    }
}
