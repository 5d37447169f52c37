//! File formats, named by their extensions: the one place that tells a file's format from its
//! name. The output's format is decided once, when the scene is validated, and stored in its
//! [`OutputSettings`](crate::scene::OutputSettings); which passes a format can hold is decided
//! here ([`Format::takes_channel`]) for the validator and the writers alike.

use std::ffi::OsStr;
use std::path::Path;

/// A file format the renderer writes, named by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// OpenEXR: linear 32-bit float RGB, ZIP compressed, with the frame's metadata.
    Exr,
    /// PNG: 8-bit sRGB, clamped to [0, 1]. No metadata.
    Png,
    /// SVG (plots).
    Svg,
    /// Comma-separated values (measurements).
    Csv,
    /// TOML (generated scenes).
    Toml,
    /// An H.264 clip in an MP4 file (made by the `ffmpeg` program).
    Mp4,
    /// An animated GIF clip.
    Gif,
    /// An animated PNG clip.
    Apng,
    /// PLY (point caches that `generate` writes).
    Ply,
}

/// The formats a frame can be written in.
pub const FRAME_FORMATS: &[Format] = &[Format::Exr, Format::Png];

/// The formats a clip can be written in (a `.png` clip is a contact sheet).
pub const CLIP_FORMATS: &[Format] = &[Format::Mp4, Format::Gif, Format::Apng, Format::Png];

impl Format {
    /// The extension that names the format, lower case, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Exr => "exr",
            Format::Png => "png",
            Format::Svg => "svg",
            Format::Csv => "csv",
            Format::Toml => "toml",
            Format::Mp4 => "mp4",
            Format::Gif => "gif",
            Format::Apng => "apng",
            Format::Ply => "ply",
        }
    }

    /// The format of `path` from its extension (in any letter case), if it is one of
    /// `allowed`.
    pub fn from_extension(path: &Path, allowed: &[Format]) -> Option<Format> {
        let ext = path
            .extension()
            .and_then(OsStr::to_str)
            .map(str::to_ascii_lowercase);
        allowed
            .iter()
            .copied()
            .find(|f| ext.as_deref() == Some(f.extension()))
    }

    /// The format of `path` as [`Format::from_extension`] tells it, or a message naming
    /// `what` the file is, the path and the extensions allowed.
    pub fn of(path: &Path, allowed: &[Format], what: &str) -> Result<Format, String> {
        Format::from_extension(path, allowed).ok_or_else(|| {
            format!(
                "{}: {}",
                crate::error::elide_path(path),
                Format::unsupported(allowed, what)
            )
        })
    }

    /// Why a file's extension is refused: `unsupported output format (the file name must
    /// end in .exr or .png)`.
    pub fn unsupported(allowed: &[Format], what: &str) -> String {
        format!(
            "unsupported {what} format (the file name must end in {})",
            Format::names(allowed)
        )
    }

    /// The extensions of `formats` as a message lists them: `.exr or .png`, `.mp4, .gif,
    /// .apng or .png`.
    pub fn names(formats: &[Format]) -> String {
        let names: Vec<String> = formats
            .iter()
            .map(|f| format!(".{}", f.extension()))
            .collect();
        match names.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
            _ => names.concat(),
        }
    }
}

impl Format {
    /// Whether a frame file of this format can hold the pass channel `name` beside its
    /// colour: EXR every channel, PNG only alpha (`A`, as 8-bit straight alpha).
    pub fn takes_channel(self, name: &str) -> bool {
        match self {
            Format::Png => name == "A",
            _ => true,
        }
    }
}
