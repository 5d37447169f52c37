//! Frame selections: the `--frames` specification and splitting a selection into chunks.
//!
//! A specification is a comma-separated list of parts, each one of
//!
//! - `N`: the single frame `N`,
//! - `A-B`: every frame from `A` to `B` inclusive,
//! - `A-B:S`: every `S`-th frame from `A` up to at most `B` (`1-48:4` is 1, 5, 9, …, 45).
//!
//! Whitespace around parts and around the numbers inside a part is ignored. The result is
//! sorted and free of duplicates, so overlapping parts are harmless.

/// Parses a frame specification (see the module documentation) for a shot whose frames are
/// `first..=last`, and returns the selected frame numbers, sorted and de-duplicated.
///
/// Every number written in the specification (including the end of a stepped range, even
/// when the step skips it) must lie in the shot. Errors are one-line messages that quote the
/// offending part.
pub(crate) fn parse_frames(spec: &str, first: u32, last: u32) -> Result<Vec<u32>, String> {
    if spec.trim().is_empty() {
        return Err("empty frame specification".to_string());
    }
    let mut frames = Vec::new();
    for (index, raw) in spec.split(',').enumerate() {
        let part = raw.trim();
        if part.is_empty() {
            return Err(format!(
                "empty part {} in frame specification \"{}\" (parts are separated by commas)",
                index + 1,
                spec.trim()
            ));
        }
        let fail = |reason: String| format!("frame specification \"{part}\": {reason}");
        let (start, end, step) = parse_part(part).map_err(fail)?;
        for frame in [start, end] {
            if frame < first || frame > last {
                return Err(fail(format!(
                    "frame {frame} is outside the shot (frames {first}-{last})"
                )));
            }
        }
        let step = usize::try_from(step).map_err(|_| fail("the step is too large".to_string()))?;
        frames.extend((start..=end).step_by(step));
    }
    frames.sort_unstable();
    frames.dedup();
    Ok(frames)
}

/// Splits one part into `(start, end, step)`; a single frame is `(n, n, 1)`.
fn parse_part(part: &str) -> Result<(u32, u32, u32), String> {
    let (range, step) = match part.split_once(':') {
        Some((range, step)) => (range.trim(), Some(step.trim())),
        None => (part, None),
    };
    if range.starts_with('-') {
        return Err("negative frame numbers are not allowed".to_string());
    }
    match range.split_once('-') {
        None => {
            if step.is_some() {
                return Err("a step needs a range, as in 1-48:4".to_string());
            }
            let n = parse_number(range, "frame number")?;
            Ok((n, n, 1))
        }
        Some((a, b)) => {
            let (a, b) = (a.trim(), b.trim());
            if b.starts_with('-') {
                return Err("negative frame numbers are not allowed".to_string());
            }
            let start = parse_number(a, "frame number")?;
            let end = parse_number(b, "frame number")?;
            if start > end {
                return Err(format!(
                    "reversed range {start}-{end} (the first frame must not be after the last)"
                ));
            }
            let step = match step {
                None => 1,
                Some(s) => {
                    if s.starts_with('-') {
                        return Err("the step must be a positive whole number".to_string());
                    }
                    let s = parse_number(s, "step")?;
                    if s == 0 {
                        return Err("the step must be at least 1".to_string());
                    }
                    s
                }
            };
            Ok((start, end, step))
        }
    }
}

/// Parses a non-negative decimal number made of ASCII digits only.
fn parse_number(text: &str, what: &str) -> Result<u32, String> {
    if text.is_empty() {
        return Err(format!("missing {what}"));
    }
    if !text.bytes().all(|b| b.is_ascii_digit()) {
        return Err(format!("\"{text}\" is not a valid {what}"));
    }
    text.parse::<u32>()
        .map_err(|_| format!("{what} {text} is too large (the largest is {})", u32::MAX))
}

/// The number of chunks of `chunk_size` consecutive frames that `n_frames` frames make, the
/// last one possibly shorter. Zero when there are no frames or when `chunk_size` is 0.
pub(crate) fn chunk_count(n_frames: u64, chunk_size: u64) -> u64 {
    if chunk_size == 0 {
        0
    } else {
        n_frames.div_ceil(chunk_size)
    }
}

/// The `index`-th (from 0) chunk of `chunk_size` consecutive frames of the selection
/// `frames`; the last chunk may be shorter. Errors on a chunk size of 0 and on an index past
/// the last chunk (the message says how many chunks there are).
pub(crate) fn chunk(frames: &[u32], chunk_size: u64, index: u64) -> Result<&[u32], String> {
    if chunk_size == 0 {
        return Err("the chunk size must be at least 1".to_string());
    }
    let count = chunk_count(frames.len() as u64, chunk_size);
    if index >= count {
        let n = frames.len();
        let frames_word = if n == 1 { "frame" } else { "frames" };
        let make = if n == 1 { "makes" } else { "make" };
        let chunks = match count {
            0 => "no chunks".to_string(),
            1 => "1 chunk (0)".to_string(),
            c => format!("{c} chunks (0-{})", c - 1),
        };
        return Err(format!(
            "chunk {index} is past the end: {n} {frames_word} in chunks of {chunk_size} \
             {make} {chunks}"
        ));
    }
    // index < count, so start < frames.len() and both fit a usize.
    let start = (index * chunk_size) as usize;
    let end = frames.len().min(start.saturating_add(chunk_size as usize));
    Ok(&frames[start..end])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(spec: &str) -> Result<Vec<u32>, String> {
        parse_frames(spec, 1, 48)
    }

    fn err(spec: &str) -> String {
        p(spec).expect_err(spec)
    }

    #[test]
    fn single_frames_ranges_and_steps() {
        assert_eq!(p("12").unwrap(), vec![12]);
        assert_eq!(p("1-48").unwrap(), (1..=48).collect::<Vec<_>>());
        assert_eq!(
            p("1-48:4").unwrap(),
            vec![1, 5, 9, 13, 17, 21, 25, 29, 33, 37, 41, 45]
        );
        assert_eq!(p("3-3").unwrap(), vec![3]);
        assert_eq!(p("3-3:5").unwrap(), vec![3]);
        assert_eq!(p("1-9:4").unwrap(), vec![1, 5, 9]);
        assert_eq!(p("1-48:100").unwrap(), vec![1]);
    }

    #[test]
    fn lists_are_sorted_and_deduplicated() {
        assert_eq!(
            p("1,5,10-20").unwrap(),
            vec![1, 5, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20]
        );
        assert_eq!(p("20,3,3,1-4").unwrap(), vec![1, 2, 3, 4, 20]);
        assert_eq!(p("1-10:3,1-10:2").unwrap(), vec![1, 3, 4, 5, 7, 9, 10]);
    }

    #[test]
    fn whitespace_is_tolerated() {
        assert_eq!(p("  12 ").unwrap(), vec![12]);
        assert_eq!(p(" 1 , 5 ,\t10 - 12 : 2 ").unwrap(), vec![1, 5, 10, 12]);
    }

    #[test]
    fn shot_bounds_are_enforced() {
        assert_eq!(
            err("60"),
            "frame specification \"60\": frame 60 is outside the shot (frames 1-48)"
        );
        assert!(err("40-60").contains("frame 60 is outside the shot (frames 1-48)"));
        assert!(err("0").contains("frame 0 is outside the shot (frames 1-48)"));
        // The written end counts even when the step would skip it.
        assert!(err("1-50:4").contains("frame 50 is outside"));
        assert_eq!(
            parse_frames("101-103", 101, 148).unwrap(),
            vec![101, 102, 103]
        );
        assert!(
            parse_frames("100", 101, 148)
                .unwrap_err()
                .contains("(frames 101-148)")
        );
        assert_eq!(parse_frames("0", 0, 0).unwrap(), vec![0]);
    }

    #[test]
    fn large_frame_numbers_do_not_overflow() {
        let max = u32::MAX;
        let spec = format!("{}-{max}:3", max - 7);
        assert_eq!(
            parse_frames(&spec, 0, max).unwrap(),
            vec![max - 7, max - 4, max - 1]
        );
        assert_eq!(parse_frames(&format!("{max}"), 0, max).unwrap(), vec![max]);
        let e = parse_frames("4294967296", 0, max).unwrap_err();
        assert!(e.contains("too large") && e.contains("4294967296"), "{e}");
        assert!(err("1-99999999999").contains("too large"));
        assert!(err("1-48:99999999999").contains("step 99999999999 is too large"));
    }

    #[test]
    fn malformed_specs_are_rejected_with_the_part_named() {
        assert_eq!(err(""), "empty frame specification");
        assert_eq!(err("   "), "empty frame specification");
        let e = err("1,,3");
        assert!(e.contains("empty part 2") && e.contains("\"1,,3\""), "{e}");
        assert!(err("1,").contains("empty part 2"));
        assert!(err(",1").contains("empty part 1"));
        let e = err("1,abc");
        assert!(
            e.contains("\"abc\"") && e.contains("not a valid frame number"),
            "{e}"
        );
        assert!(err("1.5").contains("not a valid frame number"));
        assert!(err("+3").contains("not a valid frame number"));
        assert!(err("1 2").contains("not a valid frame number"));
        assert!(err("1-2-3").contains("not a valid frame number"));
        assert!(err("-5").contains("negative"));
        assert!(err("3--5").contains("negative"));
        assert!(err("-").contains("negative"));
        assert!(err("3-").contains("missing frame number"));
        let e = err("9-3");
        assert!(
            e.contains("\"9-3\"") && e.contains("reversed range 9-3"),
            "{e}"
        );
        let e = err("1-48:0");
        assert!(
            e.contains("\"1-48:0\"") && e.contains("step must be at least 1"),
            "{e}"
        );
        assert!(err("1-48:-2").contains("step must be a positive"));
        assert!(err("1-48:").contains("missing step"));
        assert!(err("1-48:x").contains("not a valid step"));
        assert!(err("12:4").contains("a step needs a range"));
        assert!(err("1-4:2:3").contains("not a valid step"));
        for spec in ["1,,3", "x", "9-3", "1-48:0", "60"] {
            assert!(!err(spec).contains('\n'));
        }
    }

    #[test]
    fn chunks_split_the_selection() {
        let frames: Vec<u32> = (1..=12).collect();
        assert_eq!(chunk_count(12, 5), 3);
        assert_eq!(chunk_count(10, 5), 2);
        assert_eq!(chunk_count(0, 5), 0);
        assert_eq!(chunk_count(3, 0), 0);
        assert_eq!(chunk(&frames, 5, 0).unwrap(), &[1, 2, 3, 4, 5]);
        assert_eq!(chunk(&frames, 5, 1).unwrap(), &[6, 7, 8, 9, 10]);
        assert_eq!(chunk(&frames, 5, 2).unwrap(), &[11, 12]);
        assert_eq!(chunk(&frames, 12, 0).unwrap(), &frames[..]);
        assert_eq!(chunk(&frames, 100, 0).unwrap(), &frames[..]);
        let sparse = [1, 5, 9, 13];
        assert_eq!(chunk(&sparse, 3, 1).unwrap(), &[13]);
        // Every frame is in exactly one chunk.
        let all: Vec<u32> = (0..chunk_count(12, 5))
            .flat_map(|i| chunk(&frames, 5, i).unwrap().to_vec())
            .collect();
        assert_eq!(all, frames);
    }

    #[test]
    fn chunk_errors() {
        let frames: Vec<u32> = (1..=12).collect();
        assert_eq!(
            chunk(&frames, 5, 5).unwrap_err(),
            "chunk 5 is past the end: 12 frames in chunks of 5 make 3 chunks (0-2)"
        );
        assert_eq!(
            chunk(&frames, 5, 3).unwrap_err(),
            "chunk 3 is past the end: 12 frames in chunks of 5 make 3 chunks (0-2)"
        );
        assert_eq!(
            chunk(&[7], 5, 1).unwrap_err(),
            "chunk 1 is past the end: 1 frame in chunks of 5 makes 1 chunk (0)"
        );
        assert_eq!(
            chunk(&[], 5, 0).unwrap_err(),
            "chunk 0 is past the end: 0 frames in chunks of 5 make no chunks"
        );
        assert!(
            chunk(&frames, 0, 0)
                .unwrap_err()
                .contains("chunk size must be at least 1")
        );
    }
}
