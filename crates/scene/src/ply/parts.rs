//! Reading an element in parts, on every thread: where a binary element's rows have a fixed
//! size, the rows of each part are at a known place in the file, read there
//! (`FileExt::read_at`, which moves no shared position) and decoded apart from the others'.
//! Each row is handed over with its number, as in order, so what the caller stores does not
//! depend on the parts or the threads; the error returned is the first row's that has one,
//! as in order. With the columns' memory written on every thread first
//! (`raytrace_core::pages`), a frame of 1e7 points of 35-byte rows is read in 0.6 of the
//! time it took in order on two threads (docs/performance.md).

use std::fs::File;
use std::io::Seek;

use super::header::{Encoding, PlyError, bad};
use super::read::{Fields, PlyFile, scalar_types, skip_binary, truncated};

/// Bytes of rows in a part of a read in parts ([`PlyFile::part_rows`]), whole rows: each
/// thread holds one part's at a time. Rows wider than this are read in order.
pub(crate) const PART_BYTES: u64 = 1 << 18;

impl PlyFile {
    /// Rows a part of element `element` holds when its properties `wanted` are read in
    /// parts ([`PlyFile::read_rows_in_parts`]); `None` where they are read in order: text,
    /// rows of lists, rows wider than [`PART_BYTES`], or rows whose wanted values are few
    /// among many unused bytes (read alone with a seek each).
    pub(crate) fn part_rows(&self, element: usize, wanted: &[usize]) -> Option<u64> {
        let e = self.header.elements.get(element)?;
        if self.header.encoding == Encoding::Ascii {
            return None;
        }
        let stride = e.fixed_row_bytes()?;
        let types = scalar_types(e, wanted).ok()?;
        let wide = Fields::of(e, wanted, types, false).wide(stride);
        let stride = stride as u64;
        (stride > 0 && stride <= PART_BYTES && !wide).then(|| PART_BYTES / stride)
    }

    /// [`PlyFile::read_rows`] in parts of [`PlyFile::part_rows`] rows (which must be
    /// `Some`), on every thread: part `k` holds rows `k * part_rows..` and calls
    /// `row(&mut parts[k], i, values)` for each of its rows `i`. Returns the first row's
    /// error, as [`PlyFile::read_rows`] does (later parts' rows may have been handed over).
    pub(crate) fn read_rows_in_parts<S: Send>(
        self,
        element: usize,
        wanted: &[usize],
        parts: Vec<S>,
        row: impl Fn(&mut S, u64, &[f64]) -> Result<(), String> + Sync,
    ) -> Result<(), PlyError> {
        use rayon::prelude::*;

        let part_rows = self
            .part_rows(element, wanted)
            .expect("rows that can be read in parts");
        let PlyFile {
            header, mut reader, ..
        } = self;
        let e = &header.elements[element];
        let big = header.encoding == Encoding::BinaryBigEndian;
        skip_binary(&mut reader, &header.elements[..element], big)?;
        let start = reader.stream_position()?;
        let file = reader.into_inner();
        let stride = e.fixed_row_bytes().expect("rows of fixed size");
        let fields = Fields::of(e, wanted, scalar_types(e, wanted)?, big);
        let parts_needed = e.count.div_ceil(part_rows) as usize;
        assert_eq!(parts.len(), parts_needed, "a state for every part");
        let done: Vec<Result<(), PlyError>> = parts
            .into_par_iter()
            .enumerate()
            .map_init(Vec::new, |buf, (k, mut part)| {
                let first = k as u64 * part_rows;
                let rows = (e.count - first).min(part_rows) as usize;
                buf.resize(rows * stride, 0u8);
                let at = start + first * stride as u64;
                let got = read_full_at(&file, buf, at)?;
                if got < buf.len() {
                    return bad(truncated(e, first + (got / stride) as u64));
                }
                let mut values = vec![0.0; fields.at.len()];
                for (j, r) in buf.chunks_exact(stride).enumerate() {
                    fields.decode(&mut values, r, 0);
                    row(&mut part, first + j as u64, &values).map_err(PlyError::Bad)?;
                }
                Ok(())
            })
            .collect();
        done.into_iter().collect()
    }
}

/// Reads from `file` at byte `at` until `buf` is full or the file ends; returns the bytes
/// read.
fn read_full_at(file: &File, buf: &mut [u8], at: u64) -> Result<usize, std::io::Error> {
    #[cfg(unix)]
    use std::os::unix::fs::FileExt;
    #[cfg(windows)]
    let read_at = |buf: &mut [u8], at| std::os::windows::fs::FileExt::seek_read(file, buf, at);
    #[cfg(unix)]
    let read_at = |buf: &mut [u8], at| file.read_at(buf, at);
    let mut n = 0;
    while n < buf.len() {
        match read_at(&mut buf[n..], at + n as u64) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}
