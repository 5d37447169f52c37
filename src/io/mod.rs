//! Files in and out: frame paths from patterns, atomic writes (every file the renderer writes
//! goes through [`atomic`]), EXR and PNG frames, and the one place that tells a file's format
//! from its extension.

mod atomic;
mod exr;
mod frame_path;
mod png;

#[cfg(test)]
mod tests;

use std::ffi::OsStr;
use std::path::Path;

use crate::error::Error;
use crate::passes::Channel;

pub(crate) use atomic::{
    check_target, files_written, remove_stale_temp_files, stop_writing, write_file, write_with,
    write_with_temp_file,
};
pub(crate) use exr::fps_rational;
pub use exr::{FrameInfo, read_exr_rgb};
pub(crate) use frame_path::{
    frame_path, pattern_has_frame_number, pattern_has_scene, scene_name, with_scene,
};
pub use png::linear_to_srgb8;

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
        Format::from_extension(path, allowed)
            .ok_or_else(|| format!("{}: {}", path.display(), Format::unsupported(allowed, what)))
    }

    /// Why a file's extension is refused: `unsupported output format (the file name must
    /// end in .exr or .png)`.
    pub(crate) fn unsupported(allowed: &[Format], what: &str) -> String {
        format!(
            "unsupported {what} format (the file name must end in {})",
            Format::names(allowed)
        )
    }

    /// The extensions of `formats` as a message lists them: `.exr or .png`, `.mp4, .gif,
    /// .apng or .png`.
    pub(crate) fn names(formats: &[Format]) -> String {
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

/// A frame's colour as the encoders take it: pixel `i` (row-major, top row first) to its
/// linear RGB, computed as the encoder asks, so no copy of the image is made.
pub type RgbSource<'a> = &'a (dyn Fn(usize) -> [f32; 3] + Sync);

/// A frame's pixels as the encoders take them: linear RGB and the passes' channels.
struct Image<'a> {
    width: u32,
    height: u32,
    rgb: RgbSource<'a>,
    /// The passes' channels, one value per pixel each (EXR: all; PNG: only `A`).
    channels: &'a [Channel],
    /// Whether `rgb` is premultiplied by the `A` channel (a transparent background).
    premultiplied: bool,
}

/// Writes one frame to `path`, in the format its extension names (`.exr` or `.png`).
///
/// `rgb` holds linear RGB, row-major, top row first, three floats per pixel. Parent folders
/// are created as needed. The file appears atomically (see [`atomic`]); on any failure
/// nothing is left behind and an existing file at `path` is untouched. Errors name `path`.
pub fn write_frame(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[f32],
    info: &FrameInfo,
) -> Result<(), Error> {
    write_frame_with_passes(path, width, height, rgb, &[], false, info)
}

/// [`write_frame`] with the passes' `channels` beside the colour: in an EXR file, each
/// channel under its name, as `half` or `float` as it says; a PNG file takes only an `A`
/// channel, as 8-bit straight alpha (RGBA), dividing the colour by it first when
/// `premultiplied`. Any other channel with a PNG path, or a channel of the wrong length, is
/// an error and nothing is written.
pub fn write_frame_with_passes(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[f32],
    channels: &[Channel],
    premultiplied: bool,
    info: &FrameInfo,
) -> Result<(), Error> {
    let expected = (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(3));
    if width > 0 && height > 0 && expected != Some(rgb.len()) {
        return Err(Error::Output {
            path: path.to_path_buf(),
            message: format!(
                "{} floats given for a {width}x{height} RGB image (expected {})",
                rgb.len(),
                expected.map_or("more than fit in memory".to_string(), |n| n.to_string())
            ),
        });
    }
    let source = |i: usize| [rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]];
    write_frame_from(path, width, height, &source, channels, premultiplied, info)
}

/// [`write_frame_with_passes`] with the colour given by a function of the pixel's index
/// (row-major) instead of an array: the renderer writes its film this way, without a copy.
pub fn write_frame_from(
    path: &Path,
    width: u32,
    height: u32,
    rgb: RgbSource,
    channels: &[Channel],
    premultiplied: bool,
    info: &FrameInfo,
) -> Result<(), Error> {
    let output_error = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    if width == 0 || height == 0 {
        return Err(output_error(format!(
            "cannot write an empty {width}x{height} image"
        )));
    }
    let pixels = width as usize * height as usize;
    let format = Format::from_extension(path, FRAME_FORMATS)
        .ok_or_else(|| output_error(Format::unsupported(FRAME_FORMATS, "output")))?;
    for c in channels {
        if c.values.len() != pixels {
            return Err(output_error(format!(
                "channel {} has {} values for {} pixels",
                c.name,
                c.values.len(),
                pixels
            )));
        }
        if format == Format::Png && c.name != "A" {
            return Err(output_error(format!(
                "a PNG file takes only the alpha pass, not channel {}",
                c.name
            )));
        }
    }
    // Validate the metadata before touching the disk.
    let exr_attributes = match format {
        Format::Exr => Some(exr::attributes(info).map_err(output_error)?),
        _ => None,
    };
    let image = Image {
        width,
        height,
        rgb,
        channels,
        premultiplied,
    };
    atomic::write_with(path, |writer| match exr_attributes {
        Some(attributes) => exr::write(writer, path, &image, attributes),
        None => png::write(writer, path, &image),
    })
}

/// Whether the frame file at `path` is complete, cheaply (no pixel is decoded): an EXR file
/// whose header reads and whose chunks all lie inside the file, or a PNG file that starts
/// with its signature and header and ends with its end chunk. Used to tell a finished frame
/// from a truncated or empty file under another name's writer. The error says what is
/// wrong: `0 bytes`, `truncated (...)`, `not a readable EXR file (...)`.
pub(crate) fn check_frame_file(path: &Path) -> Result<(), String> {
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("not a file".to_string());
    }
    if meta.len() == 0 {
        return Err("0 bytes".to_string());
    }
    match Format::from_extension(path, FRAME_FORMATS) {
        Some(Format::Exr) => exr::check_complete(path),
        Some(Format::Png) => png::check_complete(path),
        _ => Err(Format::unsupported(FRAME_FORMATS, "output")),
    }
}
