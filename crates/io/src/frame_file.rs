//! Writing a frame file (EXR or PNG) atomically, and telling a finished frame file from an
//! incomplete one.

use std::path::Path;

use super::atomic;
use super::exr::{self, FrameInfo};
use super::png;
use raytrace_core::error::Error;
use raytrace_core::format::{FRAME_FORMATS, Format};
use raytrace_core::image::{COLOUR, Channel, Image, Precision};
use raytrace_core::pass::{Pass, PassSet};

/// Writes `image` to `path` as a frame in `format` (the validated output's: `.exr` or
/// `.png`), with the attributes `info` (EXR only). An EXR file holds every channel of the
/// image, each stored as it says; a PNG file holds the colour and, where the image has one,
/// the `A` channel as 8-bit straight alpha (dividing the colour by it first when the image is
/// premultiplied): any other channel with a PNG path is an error. The image must hold the
/// colour ([`COLOUR`]). Parent folders are created as needed. The file appears atomically
/// (see [`atomic`]); on any failure nothing is left behind and an existing file at `path` is
/// untouched. Errors name `path`.
pub fn write_image(
    path: &Path,
    format: Format,
    image: &Image,
    info: &FrameInfo,
) -> Result<(), Error> {
    let (width, height) = (image.width(), image.height());
    let output_error = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    if width == 0 || height == 0 {
        return Err(output_error(format!(
            "cannot write an empty {width}x{height} image"
        )));
    }
    if !FRAME_FORMATS.contains(&format) {
        return Err(output_error(Format::unsupported(FRAME_FORMATS, "output")));
    }
    if image.rgb(COLOUR).is_none() {
        return Err(output_error("the image has no colour".to_string()));
    }
    for c in passes(image) {
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

/// The bytes writing a frame of `pixels` pixels with the channels of `passes` beside its
/// colour takes in `format`, beyond the image: an EXR file with passes copies every channel
/// for its encoder (the colour as `f32`, each pass as it is stored), one without none (its
/// colour is encoded straight from the image); a PNG file encodes 8-bit RGB, or RGBA with an
/// alpha pass.
pub fn bytes_for(format: Format, pixels: u64, passes: PassSet) -> u64 {
    let per_pixel: usize = match format {
        Format::Exr if passes.is_empty() => 0,
        Format::Exr => {
            let size = |p: Pass| match p.precision() {
                Precision::Half => 2,
                Precision::Float => 4,
            };
            3 * 4
                + passes
                    .iter()
                    .map(|p| p.channels().len() * size(p))
                    .sum::<usize>()
        }
        _ if passes.contains(Pass::Alpha) => 4,
        _ => 3,
    };
    pixels * per_pixel as u64
}

/// The channels of `image` beside its colour: the passes'.
pub(crate) fn passes(image: &Image) -> impl Iterator<Item = &Channel> {
    image
        .channels()
        .iter()
        .filter(|c| !COLOUR.0.contains(&c.name))
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
