//! Output compared by its shape: the words, field names, units and their order, with the
//! figures free. A quoted line matches an output line that holds it with every number
//! (`12`, `2.535`, `1,088,237`, `1e-3`) replaced by `#` and runs of white space by one space;
//! `...` in a quoted line stands for any text.

/// `line` with its numbers replaced by `#` and its white space runs by one space.
pub(crate) fn shape(line: &str) -> String {
    let mut out = String::new();
    let chars: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_ascii_digit() {
            i = number_end(&chars, i);
            out.push('#');
        } else if c.is_whitespace() {
            while i < chars.len() && chars[i].is_whitespace() {
                i += 1;
            }
            out.push(' ');
        } else {
            out.push(c);
            i += 1;
        }
    }
    out.trim().to_string()
}

/// The index after the number that starts at `start`: digits, with `.` or `,` between digits,
/// and an exponent.
fn number_end(chars: &[char], start: usize) -> usize {
    let digit = |k: usize| chars.get(k).is_some_and(|c| c.is_ascii_digit());
    let mut i = start;
    while digit(i) || (matches!(chars.get(i), Some('.' | ',')) && digit(i + 1) && digit(i - 1)) {
        i += 1;
    }
    let sign = usize::from(matches!(chars.get(i + 1), Some('+' | '-')));
    if matches!(chars.get(i), Some('e')) && digit(i + 1 + sign) {
        i += 1 + sign;
        while digit(i) {
            i += 1;
        }
    }
    i
}

/// Whether `output_line` holds `quoted`'s shape (`...` in it standing for any text).
pub(crate) fn line_matches(quoted: &str, output_line: &str) -> bool {
    let have = shape(output_line);
    let mut at = 0;
    for piece in shape(quoted).split("...").map(str::trim) {
        match have[at..].find(piece) {
            Some(k) => at += k + piece.len(),
            None => return false,
        }
    }
    true
}

/// The first quoted line (of `quoted`, in order) that no later line of `output` matches;
/// `None` when every one does.
pub(crate) fn first_unmatched<'a>(quoted: &'a [String], output: &str) -> Option<&'a str> {
    let mut lines = output.lines();
    quoted
        .iter()
        .filter(|q| !q.trim().is_empty())
        .find(|q| !lines.any(|l| line_matches(q, l)))
        .map(String::as_str)
}

#[test]
fn figures_are_free_and_words_are_not() {
    assert_eq!(
        shape("frame 48  0.5 s 2.535% (1,088,237 rays)"),
        "frame # # s #% (# rays)"
    );
    assert_eq!(shape("1e-3 and 1-48:4"), "# and #-#:#");
    assert!(line_matches(
        "est. error 2.399% denoised",
        "frame 1: est. error 2.535% denoised x"
    ));
    assert!(!line_matches(
        "est. error 2.399% denoised",
        "est. error 2.535% raw"
    ));
    assert!(!line_matches(
        "chunks: 3 of up to 5 frames",
        "chunks: 3 of 5 frames"
    ));
    assert!(line_matches(
        "corrupt (...)",
        "error: corrupt (deflate: bad block)"
    ));
}

#[test]
fn quoted_lines_must_come_in_order() {
    let quoted = vec!["a 1".to_string(), "b 2".to_string()];
    assert_eq!(first_unmatched(&quoted, "x\na 7\nb 9\n"), None);
    assert_eq!(first_unmatched(&quoted, "b 9\na 7\n"), Some("b 2"));
}
