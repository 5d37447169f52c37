//! Path patterns: frame file names (runs of `#` become the frame number) and `{scene}`.

use std::path::{Path, PathBuf};

/// The placeholder of a path pattern that stands for the scene file's name.
pub(crate) const SCENE_PLACEHOLDER: &str = "{scene}";

/// The name `{scene}` stands for: the scene file's name without its extension
/// (`shots/a.toml` → `a`); `frame` for a path without a file name.
pub fn scene_name(source: &Path) -> String {
    source
        .file_stem()
        .map_or("frame".into(), |s| s.to_string_lossy().into_owned())
}

/// `pattern` with every `{scene}` replaced by the scene file's name without its extension
/// ([`scene_name`]): `renders/{scene}_####.exr` for `shots/a.toml` is `renders/a_####.exr`.
pub fn with_scene(pattern: &str, source: &Path) -> String {
    pattern.replace(SCENE_PLACEHOLDER, &scene_name(source))
}

/// Whether the pattern contains `{scene}`, that is, whether scenes of different names get
/// different paths from [`with_scene`].
pub fn pattern_has_scene(pattern: &str) -> bool {
    pattern.contains(SCENE_PLACEHOLDER)
}

/// The widest run of `#` a pattern may hold: a run is part of one file name, and file names
/// are at most 255 bytes (Linux's `NAME_MAX`, as `io` checks an output's names), so a wider
/// run could name no file.
pub(crate) const MAX_RUN: usize = 255;

/// A path pattern whose runs of `#` can be formatted: checked once, where the scene's key or
/// the command line's option is read ([`FramePattern::new`]), so that making a frame's path
/// ([`frame_path`]) cannot fail.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePattern(String);

impl FramePattern {
    /// `text` as a pattern, or why it cannot be one: a run of more than [`MAX_RUN`] `#`.
    /// The message quotes neither the text nor the key: the caller names them.
    pub fn new(text: impl Into<String>) -> Result<FramePattern, String> {
        let text = text.into();
        let widest = text.split(|c| c != '#').map(str::len).max().unwrap_or(0);
        if widest > MAX_RUN {
            return Err(format!(
                "a run of {widest} '#' pads the frame number to {widest} digits, and a file \
                 name holds at most {MAX_RUN} bytes (runs of up to {MAX_RUN} '#' are taken)"
            ));
        }
        Ok(FramePattern(text))
    }

    /// The pattern's text.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::ops::Deref for FramePattern {
    type Target = str;
    fn deref(&self) -> &str {
        &self.0
    }
}

impl PartialEq<&str> for FramePattern {
    fn eq(&self, other: &&str) -> bool {
        self.0 == *other
    }
}

/// A pattern without `#` is the path of every frame.
impl AsRef<std::ffi::OsStr> for FramePattern {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_ref()
    }
}

impl std::fmt::Display for FramePattern {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// The path of `frame` for a file name pattern.
///
/// Every run of `#` in the pattern becomes the frame number, zero-padded to the length of the
/// run (`render.####.exr` → `render.0001.exr`). A number with more digits than the run is
/// written in full, never truncated (frame 12345 with `##` → `12345`).
///
/// A pattern without any `#` is returned unchanged, so every frame then writes the same
/// file; callers rendering more than one frame should check [`pattern_has_frame_number`].
pub fn frame_path(pattern: &FramePattern, frame: u32) -> PathBuf {
    let digits = frame.to_string();
    let mut out = String::with_capacity(pattern.len() + digits.len());
    let mut chars = pattern.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '#' {
            let mut width: usize = 1;
            while chars.next_if_eq(&'#').is_some() {
                width += 1;
            }
            // Padded by hand: `format!`'s width takes at most 65535.
            out.extend(std::iter::repeat_n('0', width.saturating_sub(digits.len())));
            out.push_str(&digits);
        } else {
            out.push(c);
        }
    }
    PathBuf::from(out)
}

/// Whether the pattern contains a `#` run, that is, whether different frames get different
/// paths from [`frame_path`].
pub fn pattern_has_frame_number(pattern: &str) -> bool {
    pattern.contains('#')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_up_to_a_file_name_are_taken_and_padded_in_full() {
        let widest = FramePattern::new(format!("f_{}.exr", "#".repeat(MAX_RUN))).unwrap();
        let path = frame_path(&widest, 42).to_string_lossy().into_owned();
        assert_eq!(path, format!("f_{}42.exr", "0".repeat(MAX_RUN - 2)));
        // Padding by hand agrees with `format!` wherever `format!` can pad.
        for width in [1, 2, 9, 10, 11, 200] {
            let pattern = FramePattern::new("#".repeat(width)).unwrap();
            for frame in [0, 7, 12345, u32::MAX] {
                assert_eq!(
                    frame_path(&pattern, frame),
                    PathBuf::from(format!("{frame:0width$}"))
                );
            }
        }
    }

    #[test]
    fn wider_runs_are_refused_whatever_their_place() {
        for text in [
            format!("{}.exr", "#".repeat(MAX_RUN + 1)),
            format!("a_#/b_{}_##.png", "#".repeat(65_536)),
            "#".repeat(1 << 20),
        ] {
            let e = FramePattern::new(text.as_str()).unwrap_err();
            let widest = text.split(|c| c != '#').map(str::len).max().unwrap();
            assert!(e.starts_with(&format!("a run of {widest} '#'")), "{e}");
            assert!(e.len() < 200, "{e}");
        }
        assert_eq!(FramePattern::new("still.exr").unwrap(), "still.exr");
    }
}
