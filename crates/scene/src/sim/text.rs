//! Text files read line by line, plain or gzip-compressed (found by the gzip magic bytes, not
//! by the name), with the line number and the byte offset in the uncompressed text of every
//! line, so a snapshot found once can be read again from where it starts.
//!
//! A plain file seeks to an offset. A gzip stream cannot seek: it is read on from where it is
//! when the offset is ahead (frames render in order, so a shot reads each stream about once)
//! and opened again from its start when the offset is behind.
//!
//! Hostile files cost little: only a regular file is opened, a line is at most [`MAX_LINE`]
//! bytes (a file with no line ends is refused there, not held whole), and a cut or corrupt
//! gzip stream is an error naming the line it stopped in.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use flate2::read::MultiGzDecoder;

use super::read_error::ReadError;

/// Longest line read, in bytes (a LAMMPS line of a few hundred columns is a few kB).
pub(crate) const MAX_LINE: usize = 1 << 20;

/// Most bytes of blank lines in a row, where snapshots may be apart: as a line's
/// [`MAX_LINE`], a margin no writer comes near (LAMMPS and XYZ writers put none).
pub(crate) const MAX_BLANK: u64 = MAX_LINE as u64;

/// The buffer of a file's reader.
const BUFFER: usize = 1 << 20;

/// Where a line is: its number (from 1) and its byte offset in the uncompressed text.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Position {
    pub line: u64,
    pub offset: u64,
}

enum Stream {
    Plain(BufReader<File>),
    Gzip(Box<BufReader<MultiGzDecoder<BufReader<File>>>>),
}

/// A text file's lines.
pub(crate) struct Lines {
    path: PathBuf,
    stream: Stream,
    /// The position of the next line.
    next: Position,
    buffer: Vec<u8>,
    /// Whether the last line read ended with a line end (only a file's last line may not).
    ended: bool,
}

/// Opens `path`, a regular file, refusing anything else (a named pipe would block).
pub(crate) fn open_regular(path: &Path, what: &str) -> Result<File, ReadError> {
    let meta = std::fs::metadata(path).map_err(|e| ReadError::Bad(e.to_string()))?;
    if !meta.is_file() {
        return Err(ReadError::Bad(format!(
            "is {}, not a {what} (point caches are read from regular files only)",
            raytrace_io::file_kind(&meta.file_type())
        )));
    }
    let file = File::open(path).map_err(|e| ReadError::Bad(e.to_string()))?;
    if !file.metadata()?.is_file() {
        return Err(ReadError::Bad(format!(
            "is not a regular file, not a {what}"
        )));
    }
    Ok(file)
}

impl Lines {
    /// Opens `path` (a `what`, for messages) at its first line.
    pub(crate) fn open(path: &Path, what: &str) -> Result<Lines, ReadError> {
        let mut file = open_regular(path, what)?;
        let mut magic = [0u8; 2];
        let n = read_up_to(&mut file, &mut magic)?;
        file.seek(SeekFrom::Start(0))?;
        let stream = if n == 2 && magic == [0x1f, 0x8b] {
            Stream::Gzip(Box::new(BufReader::with_capacity(
                BUFFER,
                MultiGzDecoder::new(BufReader::with_capacity(BUFFER, file)),
            )))
        } else {
            Stream::Plain(BufReader::with_capacity(BUFFER, file))
        };
        Ok(Lines {
            path: path.to_path_buf(),
            stream,
            next: Position { line: 1, offset: 0 },
            buffer: Vec::new(),
            ended: true,
        })
    }

    /// Whether the last line [`Lines::next_line`] gave ended with a line end: a file whose last
    /// line has none was cut inside it (the tools that write these files end every line).
    pub(crate) fn line_ended(&self) -> bool {
        self.ended
    }

    /// Whether the file is gzip-compressed.
    pub(crate) fn is_gzip(&self) -> bool {
        matches!(self.stream, Stream::Gzip(_))
    }

    /// The position of the next line.
    pub(crate) fn position(&self) -> Position {
        self.next
    }

    /// The number of the last line read (0 before the first): where a file that ends too
    /// soon ends.
    pub(crate) fn last_line(&self) -> u64 {
        self.next.line - 1
    }

    fn reader(&mut self) -> &mut dyn BufRead {
        match &mut self.stream {
            Stream::Plain(r) => r,
            Stream::Gzip(r) => r.as_mut(),
        }
    }

    /// An error reading the stream, worded: a gzip stream's bad data is bad input.
    fn stream_error(&self, e: io::Error) -> ReadError {
        let bad = matches!(
            e.kind(),
            io::ErrorKind::InvalidInput | io::ErrorKind::InvalidData | io::ErrorKind::UnexpectedEof
        );
        if self.is_gzip() && bad {
            ReadError::Bad(format!(
                "line {}: the gzip stream is cut short or corrupt ({e})",
                self.next.line
            ))
        } else {
            ReadError::Io(e)
        }
    }

    /// The next line, without its line end (`\n` or `\r\n`); `None` at the end of the file.
    pub(crate) fn next_line(&mut self) -> Result<Option<&str>, ReadError> {
        self.buffer.clear();
        let mut buffer = std::mem::take(&mut self.buffer);
        let read = self
            .reader()
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut buffer);
        self.buffer = buffer;
        let n = read.map_err(|e| self.stream_error(e))?;
        if n == 0 {
            return Ok(None);
        }
        if n > MAX_LINE {
            return Err(ReadError::Bad(format!(
                "line {}: longer than {} bytes (not a text file of lines?)",
                self.next.line, MAX_LINE
            )));
        }
        let line = self.next.line;
        self.next.line += 1;
        self.next.offset += n as u64;
        let mut end = self.buffer.len();
        self.ended = self.buffer.last() == Some(&b'\n');
        if self.ended {
            end -= 1;
            if end > 0 && self.buffer[end - 1] == b'\r' {
                end -= 1;
            }
        }
        match std::str::from_utf8(&self.buffer[..end]) {
            Ok(s) => Ok(Some(s)),
            Err(_) => Err(ReadError::Bad(format!(
                "line {line}: not text (a byte that is not UTF-8)"
            ))),
        }
    }

    /// The next line that is not blank, trimmed, and its number; `None` at the end of the
    /// file. Blank lines in a row are at most [`MAX_BLANK`] bytes: text no value is read from
    /// is not decompressed on and on (a gzip bomb of line ends).
    pub(crate) fn next_filled_line(&mut self) -> Result<Option<(u64, String)>, ReadError> {
        let start = self.next;
        loop {
            let at = self.next.line;
            match self.next_line()? {
                None => return Ok(None),
                Some(l) if l.trim().is_empty() => {
                    if self.next.offset - start.offset > MAX_BLANK {
                        return Err(ReadError::Bad(format!(
                            "line {}: more than {MAX_BLANK} bytes of blank lines from line {} (not a file of snapshots?)",
                            self.last_line(),
                            start.line
                        )));
                    }
                }
                Some(l) => return Ok(Some((at, l.trim().to_string()))),
            }
        }
    }

    /// Skips `n` lines without keeping them; returns how many there were (fewer at the end of
    /// the file).
    pub(crate) fn skip_lines(&mut self, n: u64) -> Result<u64, ReadError> {
        let mut left = n;
        let mut pending = 0u64; // bytes of a line begun and not ended
        while left > 0 {
            let chunk = match self.reader().fill_buf() {
                Ok(c) => c,
                Err(e) => return Err(self.stream_error(e)),
            };
            if chunk.is_empty() {
                // A last line without a line end counts.
                if pending > 0 {
                    left -= 1;
                    self.next.line += 1;
                }
                break;
            }
            let mut used = chunk.len();
            let mut ends = 0u64;
            for (i, _) in chunk.iter().enumerate().filter(|(_, b)| **b == b'\n') {
                ends += 1;
                if ends == left {
                    used = i + 1;
                    break;
                }
            }
            let tail = if ends == left {
                0
            } else {
                // Bytes after the chunk's last line end.
                chunk.len() - chunk.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1)
            };
            self.reader().consume(used);
            self.next.offset += used as u64;
            self.next.line += ends;
            left -= ends;
            pending = if ends > 0 {
                tail as u64
            } else {
                pending + tail as u64
            };
            if pending > MAX_LINE as u64 {
                return Err(ReadError::Bad(format!(
                    "line {}: longer than {} bytes (not a text file of lines?)",
                    self.next.line, MAX_LINE
                )));
            }
        }
        Ok(n - left)
    }

    /// Moves to `at` (a position this file's lines gave): a seek in a plain file; in a gzip
    /// stream, reading on to it, or from the start when it is behind.
    pub(crate) fn seek(&mut self, at: Position) -> Result<(), ReadError> {
        if at == self.next {
            return Ok(());
        }
        match &mut self.stream {
            Stream::Plain(r) => {
                r.seek(SeekFrom::Start(at.offset))?;
            }
            Stream::Gzip(_) => {
                if at.offset < self.next.offset {
                    *self = Lines::open(&self.path.clone(), "file")?;
                }
                let skip = at.offset - self.next.offset;
                let copied = io::copy(&mut self.reader().take(skip), &mut io::sink())
                    .map_err(|e| self.stream_error(e))?;
                if copied < skip {
                    return Err(ReadError::Bad(format!(
                        "line {}: the file ends before where it ended when it was indexed (changed since?)",
                        self.next.line
                    )));
                }
            }
        }
        self.next = at;
        Ok(())
    }
}

/// Reads up to `buf.len()` bytes (fewer only at the end of the file).
fn read_up_to(file: &mut File, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match file.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn gz(text: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(text).unwrap();
        e.finish().unwrap()
    }

    /// Lines, positions, skipping and seeking agree between a plain and a gzip file, and with
    /// the text split by hand.
    #[test]
    fn plain_and_gzip_give_the_same_lines_and_positions() {
        let text: String = (0..5000)
            .map(|i| format!("line {i} {}\r\n", "x".repeat(i % 97)))
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("a.txt");
        let zipped = dir.path().join("a.txt.gz");
        std::fs::write(&plain, &text).unwrap();
        std::fs::write(&zipped, gz(text.as_bytes())).unwrap();
        let expected: Vec<&str> = text.lines().collect();
        for path in [&plain, &zipped] {
            let mut l = Lines::open(path, "file").unwrap();
            assert_eq!(l.is_gzip(), path == &zipped);
            assert_eq!(l.next_line().unwrap(), Some(expected[0]));
            assert_eq!(l.skip_lines(2999).unwrap(), 2999);
            let at = l.position();
            assert_eq!(at.line, 3001);
            assert_eq!(l.next_line().unwrap(), Some(expected[3000]));
            assert_eq!(l.skip_lines(10_000).unwrap(), 1999);
            assert_eq!(l.next_line().unwrap(), None);
            l.seek(at).unwrap();
            assert_eq!(l.next_line().unwrap(), Some(expected[3000]));
            let first = Position { line: 1, offset: 0 };
            l.seek(first).unwrap();
            assert_eq!(l.next_line().unwrap(), Some(expected[0]));
        }
    }

    /// Blank lines in a row are read up to [`MAX_BLANK`] bytes, and refused past it.
    #[test]
    fn blank_lines_in_a_row_are_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.gz");
        let blank = MAX_BLANK as usize;
        std::fs::write(&path, gz(format!("{}x\n", "\n".repeat(blank)).as_bytes())).unwrap();
        let mut l = Lines::open(&path, "file").unwrap();
        assert_eq!(
            l.next_filled_line().unwrap(),
            Some((blank as u64 + 1, "x".into()))
        );
        std::fs::write(
            &path,
            gz(format!("{}x\n", "\n".repeat(blank + 1)).as_bytes()),
        )
        .unwrap();
        let mut l = Lines::open(&path, "file").unwrap();
        assert!(matches!(
            l.next_filled_line(),
            Err(ReadError::Bad(m)) if m == format!("line {}: more than {blank} bytes of blank lines from line 1 (not a file of snapshots?)", blank + 1)
        ));
    }

    #[test]
    fn a_cut_gzip_stream_and_a_line_without_end_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let text: String = (0..20000).map(|i| format!("{i} 1.5 2.5\n")).collect();
        let mut bytes = gz(text.as_bytes());
        bytes.truncate(bytes.len() / 2);
        let path = dir.path().join("cut.gz");
        std::fs::write(&path, bytes).unwrap();
        let mut l = Lines::open(&path, "file").unwrap();
        let e = loop {
            match l.next_line() {
                Ok(Some(_)) => {}
                Ok(None) => panic!("read to the end"),
                Err(e) => break e,
            }
        };
        match e {
            ReadError::Bad(m) => assert!(m.contains("gzip stream is cut short"), "{m}"),
            ReadError::Io(e) => panic!("{e}"),
        }
        let long = dir.path().join("long");
        std::fs::write(&long, vec![b'1'; MAX_LINE + 10]).unwrap();
        let mut l = Lines::open(&long, "file").unwrap();
        assert!(matches!(l.next_line(), Err(ReadError::Bad(m)) if m.contains("longer than")));
    }
}
