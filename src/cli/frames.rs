//! Frame selections: the `--frames` specification and splitting a selection into chunks.
//!
//! A specification is a comma-separated list of parts, each one of
//!
//! - `N`: the single frame `N`,
//! - `A-B`: every frame from `A` to `B` inclusive,
//! - `A-B:S`: every `S`-th frame from `A` up to at most `B` (`1-48:4` is 1, 5, 9, …, 45).
//!
//! Whitespace around parts and around the numbers inside a part is ignored. The selection is
//! sorted and free of duplicates, so overlapping parts are harmless.
//!
//! A [`Selection`] holds its frames as sorted, disjoint arithmetic runs, never as a list of
//! frames: a shot of four billion frames, or a chunk near its end, costs a few bytes and a few
//! operations. Counting and chunking are arithmetic, and iteration is lazy.

/// Frames `first, first + step, …`, `count` of them (at least one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Run {
    first: u32,
    /// The distance between consecutive frames; 1 for a run of one frame.
    step: u32,
    count: u64,
}

impl Run {
    fn nth(&self, i: u64) -> u32 {
        // i < count, and the run's last frame is a u32.
        (self.first as u64 + i * self.step as u64) as u32
    }

    fn last(&self) -> u32 {
        self.nth(self.count - 1)
    }

    /// The frames `skip..skip + take` of this run (both within it).
    fn slice(&self, skip: u64, take: u64) -> Run {
        Run {
            first: self.nth(skip),
            step: if take == 1 { 1 } else { self.step },
            count: take,
        }
    }
}

/// A set of frame numbers, as sorted disjoint runs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Selection {
    runs: Vec<Run>,
    len: u64,
}

/// How many frames of overlapping stepped parts (`1-99:2,1-99:3`) a specification may have
/// where their steps differ; those frames are merged one by one. Parts that do not overlap,
/// and overlaps where one part holds every frame of the others (`1-48,12`, `1-48:2,5-9:4`),
/// are merged arithmetically, whatever their length.
pub(crate) const MAX_MERGED_ONE_BY_ONE: u64 = 1_000_000;

/// Bound on the steps of merging a specification's parts: the parts times the places where
/// the set of overlapping parts changes (a spec of a few thousand parts is far below it).
const MAX_MERGE_WORK: u64 = 50_000_000;

impl Selection {
    /// Every frame from `first` to `last` (nothing when `first > last`).
    pub(crate) fn range(first: u32, last: u32) -> Selection {
        let mut b = Builder::default();
        if first <= last {
            b.push(Run {
                first,
                step: 1,
                count: (last - first) as u64 + 1,
            });
        }
        b.finish()
    }

    /// Parses a frame specification (see the module documentation) for a shot whose frames
    /// are `first..=last`.
    ///
    /// Every number written in the specification (including the end of a stepped range, even
    /// when the step skips it) must lie in the shot. Errors are one-line messages that quote
    /// the offending part.
    pub(crate) fn parse(spec: &str, first: u32, last: u32) -> Result<Selection, String> {
        if spec.trim().is_empty() {
            return Err("empty frame specification".to_string());
        }
        let mut parts = Vec::new();
        for (index, raw) in spec.split(',').enumerate() {
            let part = raw.trim();
            if part.is_empty() {
                return Err(format!(
                    "empty part {} in frame specification \"{}\" (parts are separated by commas)",
                    index + 1,
                    raytrace_core::error::elide(spec.trim())
                ));
            }
            let fail = |reason: String| {
                format!(
                    "frame specification \"{}\": {reason}",
                    raytrace_core::error::elide(part)
                )
            };
            let (start, end, step) = parse_part(part).map_err(fail)?;
            for frame in [start, end] {
                if frame < first || frame > last {
                    return Err(fail(format!(
                        "frame {frame} is outside the shot (frames {first}-{last})"
                    )));
                }
            }
            let (start, end, step) = (start as u64, end as u64, step as u64);
            parts.push(Part {
                next: start,
                last: start + (end - start) / step * step,
                step,
            });
        }
        merge(parts).map_err(|e| format!("frame specification: {e}"))
    }

    /// The number of frames.
    pub(crate) fn len(&self) -> u64 {
        self.len
    }

    /// The smallest frame.
    pub(crate) fn first(&self) -> Option<u32> {
        self.runs.first().map(|r| r.first)
    }

    /// The largest frame.
    pub(crate) fn last(&self) -> Option<u32> {
        self.runs.last().map(Run::last)
    }

    /// The frames in increasing order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = u32> + Clone + '_ {
        self.runs
            .iter()
            .flat_map(|r| (0..r.count).map(|i| r.nth(i)))
    }

    /// The frames `skip..skip + take` of the selection (as many of them as there are).
    fn slice(&self, mut skip: u64, mut take: u64) -> Selection {
        let mut b = Builder::default();
        for run in &self.runs {
            if take == 0 {
                break;
            }
            if skip >= run.count {
                skip -= run.count;
                continue;
            }
            let n = take.min(run.count - skip);
            b.push(run.slice(skip, n));
            take -= n;
            skip = 0;
        }
        b.finish()
    }
}

/// The `index`-th (from 0) chunk of `chunk_size` consecutive frames of a batch of shots,
/// counted over the frames of every selection in the order given: for each selection, the
/// part of it inside the chunk (empty for the shots the chunk does not reach); the last chunk
/// may be shorter. Errors on a chunk size of 0 and on an index past the last chunk (the
/// message says how many chunks there are, counting every frame of the batch).
pub(crate) fn batch_chunk(
    selections: &[Selection],
    chunk_size: u64,
    index: u64,
) -> Result<Vec<Selection>, String> {
    if chunk_size == 0 {
        return Err("the chunk size must be at least 1".to_string());
    }
    let total = batch_len(selections);
    if index >= chunk_count(total, chunk_size) {
        return Err(past_end(total, chunk_size, index));
    }
    // index < ceil(total / size), so start < total; the end is capped at the total.
    let start = index * chunk_size;
    let end = start.saturating_add(chunk_size).min(total);
    let mut offset = 0;
    let mut parts = Vec::with_capacity(selections.len());
    for s in selections {
        let (from, to) = (start.max(offset), end.min(offset + s.len));
        parts.push(if from < to {
            s.slice(from - offset, to - from)
        } else {
            Selection::default()
        });
        offset += s.len;
    }
    Ok(parts)
}

/// The frames of a batch: every selection's, added up. Each selection holds at most 2^32
/// frames, so a batch of fewer than 2^32 shots cannot overflow.
pub(crate) fn batch_len(selections: &[Selection]) -> u64 {
    selections.iter().map(Selection::len).sum()
}

/// Why chunk `index` is refused: `n` frames in chunks of `chunk_size` make fewer chunks.
fn past_end(n: u64, chunk_size: u64, index: u64) -> String {
    let count = chunk_count(n, chunk_size);
    let frames_word = if n == 1 { "frame" } else { "frames" };
    let make = if n == 1 { "makes" } else { "make" };
    let chunks = match count {
        0 => "no chunks".to_string(),
        1 => "1 chunk (0)".to_string(),
        c => format!("{c} chunks (0-{})", c - 1),
    };
    format!(
        "chunk {index} is past the end: {n} {frames_word} in chunks of {chunk_size} \
         {make} {chunks}"
    )
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

/// Collects runs in increasing order, joining a run to the one before when the steps agree.
#[derive(Default)]
struct Builder {
    runs: Vec<Run>,
    len: u64,
}

impl Builder {
    /// Appends `run`, whose first frame is above every frame pushed so far.
    fn push(&mut self, run: Run) {
        self.len += run.count;
        if let Some(last) = self.runs.last_mut() {
            let gap = run.first as u64 - last.last() as u64;
            let fits = gap <= u32::MAX as u64;
            if last.count == 1 && fits && (run.count == 1 || gap == run.step as u64) {
                last.step = gap as u32;
                last.count += run.count;
                return;
            }
            if last.count > 1
                && gap == last.step as u64
                && (run.count == 1 || run.step == last.step)
            {
                last.count += run.count;
                return;
            }
        }
        self.runs.push(run);
    }

    fn finish(self) -> Selection {
        Selection {
            runs: self.runs,
            len: self.len,
        }
    }
}

/// One part of a specification while the parts are merged: its frames from `next` to `last`
/// (a frame of the part) by `step`.
#[derive(Clone, Copy, Debug)]
struct Part {
    next: u64,
    last: u64,
    step: u64,
}

impl Part {
    /// Whether every frame of `other` from its `next` on is a frame of this part's lattice
    /// (the numbers `self.next + k * self.step` for any k).
    fn holds_lattice_of(&self, other: &Part) -> bool {
        other.step.is_multiple_of(self.step)
            && other.next >= self.next
            && (other.next - self.next).is_multiple_of(self.step)
    }

    /// Moves `next` to this part's first frame above `frame`.
    fn skip_through(&mut self, frame: u64) {
        if self.next <= frame {
            self.next += ((frame - self.next) / self.step + 1) * self.step;
        }
    }
}

/// Merges the parts into a selection: a sweep over the frames in increasing order. Where one
/// part holds every frame of the parts that overlap it, its frames up to the next change go in
/// as one run; elsewhere (parts of different steps overlapping) frames go in one at a time,
/// at most [`MAX_MERGED_ONE_BY_ONE`] of them.
fn merge(mut parts: Vec<Part>) -> Result<Selection, String> {
    parts.sort_unstable_by_key(|p| (p.next, p.step));
    let mut pending = parts.into_iter().peekable();
    let mut active: Vec<Part> = Vec::new();
    let mut out = Builder::default();
    let mut one_by_one = 0u64;
    let mut work = 0u64;
    loop {
        active.retain(|p| p.next <= p.last);
        let lo = match (active.iter().map(|p| p.next).min(), pending.peek()) {
            (None, None) => break,
            (Some(a), Some(p)) => a.min(p.next),
            (Some(a), None) => a,
            (None, Some(p)) => p.next,
        };
        while let Some(p) = pending.next_if(|p| p.next <= lo) {
            active.push(p);
        }
        work += active.len() as u64;
        if work > MAX_MERGE_WORK {
            return Err("too many overlapping parts to merge; list them without overlaps".into());
        }
        // The part that starts at `lo` with the smallest step is the only one that can hold
        // all the others.
        let lead = *active
            .iter()
            .filter(|p| p.next == lo)
            .min_by_key(|p| p.step)
            .expect("a part starts at lo");
        if active.iter().all(|p| lead.holds_lattice_of(p)) {
            // Its frames go in up to its end, or up to the first part still to come that it
            // does not hold; those it holds are taken along.
            let mut end = lead.last;
            while let Some(p) = pending.peek() {
                if p.next > end {
                    break;
                }
                if lead.holds_lattice_of(p) {
                    active.extend(pending.next());
                    work += 1;
                } else {
                    end = p.next - 1;
                    break;
                }
            }
            let count = (end - lo) / lead.step + 1;
            let through = lo + (count - 1) * lead.step;
            out.push(Run {
                first: lo as u32,
                step: if count == 1 { 1 } else { lead.step as u32 },
                count,
            });
            for p in &mut active {
                p.skip_through(through);
            }
        } else {
            one_by_one += 1;
            if one_by_one > MAX_MERGED_ONE_BY_ONE {
                return Err(format!(
                    "parts with different steps overlap on more than {MAX_MERGED_ONE_BY_ONE} \
                     frames; list them without overlaps"
                ));
            }
            out.push(Run {
                first: lo as u32,
                step: 1,
                count: 1,
            });
            for p in &mut active {
                p.skip_through(lo);
            }
        }
    }
    Ok(out.finish())
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
        return Err(format!(
            "\"{}\" is not a valid {what}",
            raytrace_core::error::elide(text)
        ));
    }
    text.parse::<u32>().map_err(|_| {
        format!(
            "{what} {} is too large (the largest is {})",
            raytrace_core::error::elide(text),
            u32::MAX
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chunk of one selection: a batch of one shot.
    fn chunk_of(s: &Selection, size: u64, index: u64) -> Result<Selection, String> {
        batch_chunk(std::slice::from_ref(s), size, index).map(|mut parts| parts.remove(0))
    }

    fn p(spec: &str) -> Result<Vec<u32>, String> {
        Selection::parse(spec, 1, 48).map(|s| s.iter().collect())
    }

    fn err(spec: &str) -> String {
        p(spec).expect_err(spec)
    }

    /// The frames of `spec` the slow way: every part listed, sorted, de-duplicated.
    fn listed(spec: &str) -> Vec<u32> {
        let mut v = Vec::new();
        for part in spec.split(',') {
            let (a, b, s) = parse_part(part.trim()).unwrap();
            v.extend((a..=b).step_by(s as usize));
        }
        v.sort_unstable();
        v.dedup();
        v
    }

    #[test]
    fn batch_chunks_cover_every_frame_of_every_shot_once_in_order() {
        let shots = [
            Selection::parse("1-12", 1, 12).unwrap(),
            Selection::default(),
            Selection::parse("1-48:4,7", 1, 48).unwrap(),
            Selection::parse("5", 1, 9).unwrap(),
        ];
        // (shot, frame) listed one by one, the slow way.
        let all: Vec<(usize, u32)> = shots
            .iter()
            .enumerate()
            .flat_map(|(i, s)| s.iter().map(move |f| (i, f)))
            .collect();
        assert_eq!(batch_len(&shots), all.len() as u64);
        for size in 1..=all.len() as u64 + 1 {
            let mut seen = Vec::new();
            for index in 0..chunk_count(all.len() as u64, size) {
                let parts = batch_chunk(&shots, size, index).unwrap();
                let chunk: Vec<(usize, u32)> = parts
                    .iter()
                    .enumerate()
                    .flat_map(|(i, s)| s.iter().map(move |f| (i, f)))
                    .collect();
                let start = (index * size) as usize;
                let end = (start + size as usize).min(all.len());
                assert_eq!(chunk, all[start..end], "size {size} chunk {index}");
                seen.extend(chunk);
            }
            assert_eq!(seen, all);
            let past = chunk_count(all.len() as u64, size);
            let e = batch_chunk(&shots, size, past).unwrap_err();
            assert!(
                e.starts_with(&format!("chunk {past} is past the end: 26 frames")),
                "{e}"
            );
        }
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
    fn merging_agrees_with_listing_every_frame() {
        for spec in [
            "1-48,12",
            "12,1-48",
            "1-48:2,5-9:4",
            "1-48:2,2-48:2",
            "1-48:2,1-48:3,1-48:5",
            "1-20:3,10-40:6,30-48",
            "5,5,5,1-5:2,2-4",
            "1-48:7,2-48:7,3-48:14,40-41",
            "1-10,12-20,11",
            "3-30:9,1-48:3",
            "2-44:6,2-44:2,8",
            "1,3,5,7,9,10,12,14",
        ] {
            let sel = Selection::parse(spec, 1, 48).unwrap();
            let want = listed(spec);
            assert_eq!(sel.iter().collect::<Vec<_>>(), want, "{spec}");
            assert_eq!(sel.len(), want.len() as u64, "{spec}");
            assert_eq!(sel.first(), want.first().copied(), "{spec}");
            assert_eq!(sel.last(), want.last().copied(), "{spec}");
            for size in 1..=7 {
                let chunks: Vec<u32> = (0..chunk_count(sel.len(), size))
                    .flat_map(|i| chunk_of(&sel, size, i).unwrap().iter().collect::<Vec<_>>())
                    .collect();
                assert_eq!(chunks, want, "{spec} in chunks of {size}");
            }
        }
    }

    #[test]
    fn long_selections_are_counted_and_chunked_without_listing() {
        // A billion frames and the last of their chunks: arithmetic, instant.
        let sel = Selection::parse("1-1000000000", 1, 1_000_000_000).unwrap();
        assert_eq!(sel.len(), 1_000_000_000);
        assert_eq!(sel.runs.len(), 1);
        let last = chunk_of(&sel, 1, 999_999_999).unwrap();
        assert_eq!(last.iter().collect::<Vec<_>>(), vec![1_000_000_000]);
        let all = Selection::range(0, u32::MAX);
        assert_eq!(all.len(), 1 << 32);
        assert_eq!(
            chunk_of(&all, 1000, (1 << 32) / 1000).unwrap().len(),
            (1u64 << 32) % 1000
        );
        assert_eq!(
            chunk_of(&all, 3, 5).unwrap().iter().collect::<Vec<_>>(),
            vec![15, 16, 17]
        );
        // Overlaps held by one part merge arithmetically however long they are.
        let big = Selection::parse(
            "0-4294967295:2,10-4294967294:4,7,0-4294967295:2,4294967295",
            0,
            u32::MAX,
        )
        .unwrap();
        assert_eq!(big.len(), (1 << 31) + 2);
        assert!(big.runs.len() <= 4, "{:?}", big.runs);
        assert_eq!(
            chunk_of(&big, 4, 0).unwrap().iter().collect::<Vec<_>>(),
            vec![0, 2, 4, 6]
        );
        assert_eq!(
            big.iter().take(6).collect::<Vec<_>>(),
            vec![0, 2, 4, 6, 7, 8]
        );
        assert_eq!(big.last(), Some(u32::MAX));
    }

    #[test]
    fn overlaps_of_different_steps_are_bounded() {
        // Listed one by one where they overlap: a million frames at most.
        let ok = Selection::parse("1-1000000:2,1-1000000:3", 1, 1_000_000).unwrap();
        assert_eq!(ok.len(), 500_000 + 333_334 - 166_667);
        let e = Selection::parse("1-1000000000:2,1-1000000000:3", 1, 1_000_000_000).unwrap_err();
        assert!(
            e.contains("different steps overlap on more than 1000000 frames"),
            "{e}"
        );
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
        let sel = Selection::parse("101-103", 101, 148).unwrap();
        assert_eq!(sel.iter().collect::<Vec<_>>(), vec![101, 102, 103]);
        assert!(
            Selection::parse("100", 101, 148)
                .unwrap_err()
                .contains("(frames 101-148)")
        );
        let zero = Selection::parse("0", 0, 0).unwrap();
        assert_eq!(zero.iter().collect::<Vec<_>>(), vec![0]);
    }

    #[test]
    fn large_frame_numbers_do_not_overflow() {
        let max = u32::MAX;
        let spec = format!("{}-{max}:3", max - 7);
        let sel = Selection::parse(&spec, 0, max).unwrap();
        assert_eq!(
            sel.iter().collect::<Vec<_>>(),
            vec![max - 7, max - 4, max - 1]
        );
        let one = Selection::parse(&format!("{max}"), 0, max).unwrap();
        assert_eq!(one.iter().collect::<Vec<_>>(), vec![max]);
        let e = Selection::parse("4294967296", 0, max).unwrap_err();
        assert!(e.contains("too large") && e.contains("4294967296"), "{e}");
        assert!(err("1-99999999999").contains("too large"));
        assert!(err("1-48:99999999999").contains("step 99999999999 is too large"));
        let wide = Selection::parse(&format!("0-{max}:{max}"), 0, max).unwrap();
        assert_eq!(wide.iter().collect::<Vec<_>>(), vec![0, max]);
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
        // A very long bad part is quoted by its start and length.
        let long = "7".repeat(100_000);
        let e = err(&long);
        assert!(e.len() < 1000 && e.contains("100000 bytes"), "{e}");
    }

    #[test]
    fn chunks_split_the_selection() {
        let frames = Selection::range(1, 12);
        let chunk = |size, i| -> Vec<u32> { chunk_of(&frames, size, i).unwrap().iter().collect() };
        assert_eq!(chunk_count(12, 5), 3);
        assert_eq!(chunk_count(10, 5), 2);
        assert_eq!(chunk_count(0, 5), 0);
        assert_eq!(chunk_count(3, 0), 0);
        assert_eq!(chunk(5, 0), [1, 2, 3, 4, 5]);
        assert_eq!(chunk(5, 1), [6, 7, 8, 9, 10]);
        assert_eq!(chunk(5, 2), [11, 12]);
        assert_eq!(chunk(12, 0), (1..=12).collect::<Vec<_>>());
        assert_eq!(chunk(100, 0), (1..=12).collect::<Vec<_>>());
        let sparse = Selection::parse("1,5,9,13", 1, 48).unwrap();
        assert_eq!(
            chunk_of(&sparse, 3, 1).unwrap().iter().collect::<Vec<_>>(),
            [13]
        );
        // Every frame is in exactly one chunk.
        let all: Vec<u32> = (0..chunk_count(12, 5)).flat_map(|i| chunk(5, i)).collect();
        assert_eq!(all, (1..=12).collect::<Vec<_>>());
    }

    #[test]
    fn chunk_errors() {
        let frames = Selection::range(1, 12);
        assert_eq!(
            chunk_of(&frames, 5, 5).unwrap_err(),
            "chunk 5 is past the end: 12 frames in chunks of 5 make 3 chunks (0-2)"
        );
        assert_eq!(
            chunk_of(&frames, 5, 3).unwrap_err(),
            "chunk 3 is past the end: 12 frames in chunks of 5 make 3 chunks (0-2)"
        );
        assert_eq!(
            chunk_of(&Selection::range(7, 7), 5, 1).unwrap_err(),
            "chunk 1 is past the end: 1 frame in chunks of 5 makes 1 chunk (0)"
        );
        assert_eq!(
            chunk_of(&Selection::range(1, 0), 5, 0).unwrap_err(),
            "chunk 0 is past the end: 0 frames in chunks of 5 make no chunks"
        );
        assert!(
            chunk_of(&frames, 0, 0)
                .unwrap_err()
                .contains("chunk size must be at least 1")
        );
        let e = chunk_of(&Selection::range(0, u32::MAX), 1, u64::MAX).unwrap_err();
        assert!(
            e.contains("4294967296 frames") && e.contains("(0-4294967295)"),
            "{e}"
        );
    }
}
