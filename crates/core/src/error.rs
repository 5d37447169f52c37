//! The error type of the library, the exit status each kind maps to, and how long texts
//! (paths, arguments) are shortened in messages.

use std::borrow::Cow;
use std::fmt;
use std::path::{Path, PathBuf};

/// Everything that can go wrong, split by who has to act on it.
#[derive(Debug)]
pub enum Error {
    /// A scene file that cannot be read as TOML or fails validation. The message already names
    /// the file and the line:column or the field path.
    Scene(String),
    /// A bad command-line argument (frame spec, chunk, override value).
    Usage(String),
    /// An input/output failure on a path (reading the scene, writing a frame).
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Any other failure while producing output (an encoder error, for example).
    Output { path: PathBuf, message: String },
    /// The machine could not give what a run needs: worker threads, a GPU, the denoiser,
    /// a program a clip is encoded with. The source says what and why.
    Resource(Box<dyn std::error::Error + Send + Sync>),
    /// A frame could not be rendered (its device was lost or ran out of memory, its
    /// denoiser failed): nothing of it was kept.
    Frame { frame: u32, source: Box<Error> },
}

impl Error {
    /// The process exit status for this error: 2 for bad input (nothing was written),
    /// 1 for everything else.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Scene(_) | Error::Usage(_) => 2,
            Error::Io { .. } | Error::Output { .. } | Error::Resource(_) => 1,
            Error::Frame { source, .. } => source.exit_code(),
        }
    }

    /// A resource the run could not get, as `message` says.
    pub fn resource(message: impl Into<String>) -> Error {
        Error::Resource(message.into().into())
    }

    /// This error, of the rendering of frame `frame`.
    pub fn in_frame(self, frame: u32) -> Error {
        Error::Frame {
            frame,
            source: Box::new(self),
        }
    }

    /// Convenience constructor for an I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Error {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Scene(m) | Error::Usage(m) => write!(f, "{}", elide_message(m)),
            Error::Resource(e) => write!(f, "{}", elide_message(&e.to_string())),
            Error::Frame { frame, source } => write!(f, "frame {frame}: {source}"),
            Error::Io { path, source } => write!(f, "{}: {source}", elide_path(path)),
            Error::Output { path, message } => {
                write!(f, "{}: {}", elide_path(path), elide_message(message))
            }
        }
    }
}

/// The longest text (path, argument) a message quotes whole, in bytes.
pub(crate) const MAX_QUOTED: usize = 400;

/// The longest message printed whole, in bytes.
const MAX_MESSAGE: usize = 4000;

/// `text` as a message quotes it: control characters escaped as Rust writes them (`\n`,
/// `\u{1b}`), so that a name cannot move the cursor, recolour or retitle the terminal; then,
/// when longer than [`MAX_QUOTED`] bytes, its start, an ellipsis, its last few characters
/// and its length: `renders/aaaaaaaa…aaa/f_####.exr (20971531 bytes)`. A message never
/// repeats a huge argument. A text longer than that is cut before it is escaped, and its
/// length is its own: a huge token (a 3 GiB run of NULs) is never copied whole.
pub fn elide(text: &str) -> Cow<'_, str> {
    if text.len() > MAX_QUOTED {
        return Cow::Owned(format!(
            "{}…{} ({} bytes)",
            escaped_head(text, MAX_QUOTED / 2),
            escaped_tail(text, 32),
            text.len()
        ));
    }
    match escape_controls(text) {
        Cow::Borrowed(text) => shorten(text),
        Cow::Owned(escaped) => Cow::Owned(shorten(&escaped).into_owned()),
    }
}

/// The escaped form of a character: itself, or as Rust writes a control character.
fn escaped_char(c: char) -> String {
    match c.is_control() {
        true => c.escape_debug().collect(),
        false => c.to_string(),
    }
}

/// The start of `text`, escaped, in at most `bytes` bytes (whole characters and escapes).
fn escaped_head(text: &str, bytes: usize) -> String {
    let mut out = String::new();
    for piece in text.chars().map(escaped_char) {
        if out.len() + piece.len() > bytes {
            break;
        }
        out.push_str(&piece);
    }
    out
}

/// The end of `text`, escaped, in at most `bytes` bytes (whole characters and escapes).
fn escaped_tail(text: &str, bytes: usize) -> String {
    let mut pieces = Vec::new();
    let mut len = 0;
    for piece in text.chars().rev().map(escaped_char) {
        if len + piece.len() > bytes {
            break;
        }
        len += piece.len();
        pieces.push(piece);
    }
    pieces.into_iter().rev().collect()
}

/// `text` with its control characters (C0, DEL and C1) escaped.
fn escape_controls(text: &str) -> Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if c.is_control() {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

/// `text` itself when it is at most [`MAX_QUOTED`] bytes, else its start, end and length.
fn shorten(text: &str) -> Cow<'_, str> {
    if text.len() <= MAX_QUOTED {
        return Cow::Borrowed(text);
    }
    let mut head = MAX_QUOTED / 2;
    while !text.is_char_boundary(head) {
        head -= 1;
    }
    let mut tail = text.len() - 32;
    while !text.is_char_boundary(tail) {
        tail += 1;
    }
    Cow::Owned(format!(
        "{}…{} ({} bytes)",
        &text[..head],
        &text[tail..],
        text.len()
    ))
}

/// A path for a message, escaped and shortened as [`elide`] does.
pub fn elide_path(path: &Path) -> String {
    elide(&path.to_string_lossy()).into_owned()
}

/// A message with every run of more than [`MAX_QUOTED`] non-blank characters shortened as
/// [`elide`] does, and cut after [`MAX_MESSAGE`] bytes: messages that quote a value of the
/// input (a scene's output path, say) stay readable however long the value is.
fn elide_message(message: &str) -> Cow<'_, str> {
    let long_run = message
        .split(char::is_whitespace)
        .any(|w| w.len() > MAX_QUOTED);
    if !long_run && message.len() <= MAX_MESSAGE {
        return Cow::Borrowed(message);
    }
    let mut out = String::new();
    let mut word = String::new();
    let flush = |out: &mut String, word: &mut String| {
        out.push_str(&elide(word));
        word.clear();
    };
    for c in message.chars() {
        if c.is_whitespace() {
            flush(&mut out, &mut word);
            out.push(c);
        } else {
            word.push(c);
        }
    }
    flush(&mut out, &mut word);
    if out.len() > MAX_MESSAGE {
        let mut end = MAX_MESSAGE;
        while !out.is_char_boundary(end) {
            end -= 1;
        }
        out = format!("{}… (message of {} bytes cut)", &out[..end], out.len());
    }
    Cow::Owned(out)
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            Error::Resource(e) => Some(e.as_ref()),
            Error::Frame { source, .. } => Some(source.as_ref()),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_texts_are_quoted_by_their_start_and_length() {
        assert_eq!(elide("out/f_####.exr"), "out/f_####.exr");
        let long = format!("renders/{}/f_####.exr", "a".repeat(20 << 20));
        let short = elide(&long);
        assert!(short.len() < MAX_QUOTED, "{short}");
        assert!(short.starts_with("renders/aaa"), "{short}");
        assert!(
            short.ends_with(&format!("aaa/f_####.exr ({} bytes)", long.len())),
            "{short}"
        );
        // Never cut inside a character.
        let accents = elide(&"é".repeat(1000)).into_owned();
        assert!(accents.ends_with("é (2000 bytes)"), "{accents}");

        let e = Error::io(&long, std::io::Error::other("File name too long"));
        let text = e.to_string();
        assert!(
            text.len() < 1000 && text.ends_with("File name too long"),
            "{text}"
        );
        let e = Error::Scene(format!(
            "shot.toml: output.path \"{long}\" must end in .exr"
        ));
        let text = e.to_string();
        assert!(text.len() < 1000, "{}", text.len());
        assert!(
            text.starts_with("shot.toml: output.path \"renders/"),
            "{text}"
        );
        assert!(text.ends_with(" must end in .exr"), "{text}");
        // Many short words: cut as a whole.
        let e = Error::Usage("word ".repeat(100_000));
        let text = e.to_string();
        assert!(
            text.len() < MAX_MESSAGE + 100 && text.ends_with("bytes cut)"),
            "{text}"
        );
        assert_eq!(Error::Usage("short".into()).to_string(), "short");
    }

    #[test]
    fn control_characters_are_escaped_in_quoted_texts_and_paths() {
        assert_eq!(
            elide("a\u{1b}[31mb\u{7}\n\t\u{9b}"),
            "a\\u{1b}[31mb\\u{7}\\n\\t\\u{9b}"
        );
        // Printable text, quotes and backslashes included, is left alone.
        assert!(matches!(elide("é \"q\" \\ ~"), Cow::Borrowed(_)));
        let e = Error::io("d/p\u{1b}]0;title\u{7}.ply", std::io::Error::other("gone"));
        assert_eq!(e.to_string(), "d/p\\u{1b}]0;title\\u{7}.ply: gone");
        // A long text is cut before it is escaped: the length given is its own.
        let long = "\u{1b}".repeat(1000);
        let short = elide(&long);
        assert!(
            short.starts_with("\\u{1b}\\u{1b}") && short.ends_with("\\u{1b} (1000 bytes)"),
            "{short}"
        );
        assert!(short.len() < MAX_QUOTED, "{short}");
        // A short text is escaped, then shortened where its escapes make it long.
        let escapes = "\u{1b}".repeat(100);
        let short = elide(&escapes);
        assert!(short.ends_with("(600 bytes)"), "{short}");
        // A huge one is cut from its two ends, never copied: 256 MiB of NULs.
        let huge = "\0".repeat(256 << 20);
        let short = elide(&huge);
        assert!(
            short.starts_with("\\0\\0") && short.ends_with(&format!("({} bytes)", 256 << 20)),
            "{short}"
        );
    }
}
