//! Writing a frame file (EXR or PNG) atomically, and telling a finished frame file from an
//! incomplete one.

use std::path::Path;

use super::atomic;
use super::exr::{self, FrameInfo};
use super::image::Image;
use super::png;
use raytrace_core::error::Error;
use raytrace_core::format::{FRAME_FORMATS, Format};
use raytrace_core::pass::Channel;

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
pub(crate) fn write_frame_with_passes(
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
    let format = Format::from_extension(path, FRAME_FORMATS).ok_or_else(|| Error::Output {
        path: path.to_path_buf(),
        message: Format::unsupported(FRAME_FORMATS, "output"),
    })?;
    let source = |i: usize| [rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]];
    let image = Image {
        width,
        height,
        rgb: &source,
        channels,
        premultiplied,
    };
    write_frame_from(path, format, &image, info)
}

/// [`write_frame_with_passes`] in a `format` already decided (the validated output's), with
/// the colour given by a function of the pixel's index (row-major) instead of an array: the
/// renderer writes its film this way, without a copy.
pub fn write_frame_from(
    path: &Path,
    format: Format,
    image: &Image,
    info: &FrameInfo,
) -> Result<(), Error> {
    let (width, height, channels) = (image.width, image.height, image.channels);
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
    if !FRAME_FORMATS.contains(&format) {
        return Err(output_error(Format::unsupported(FRAME_FORMATS, "output")));
    }
    for c in channels {
        if c.values.len() != pixels {
            return Err(output_error(format!(
                "channel {} has {} values for {} pixels",
                c.name,
                c.values.len(),
                pixels
            )));
        }
        if !format.takes_channel(c.name) {
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
    atomic::write_with(path, |writer| match exr_attributes {
        Some(attributes) => exr::write(writer, path, image, attributes),
        None => png::write(writer, path, image),
    })
}

/// Whether the frame file at `path` is complete, cheaply (no pixel is decoded): an EXR file
/// whose header reads and whose chunks all lie inside the file, or a PNG file that starts
/// with its signature and header and ends with its end chunk. Used to tell a finished frame
/// from a truncated or empty file under another name's writer. The error says what is
/// wrong: `0 bytes`, `truncated (...)`, `not a readable EXR file (...)`.
pub fn check_frame_file(path: &Path) -> Result<(), String> {
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
