//! Animated PNG clips, encoded in process (the `png` crate): 8-bit sRGB frames, each
//! shown for exactly the shot's frame period (see [`Rate::apng_delay`]), looping forever.

use std::io::Write;
use std::path::Path;

use super::source::FrameImage;
use super::timing::Rate;
use raytrace_core::error::Error;

/// Writes `count` frames of `width` x `height` as an animated PNG into `writer`.
pub(super) fn write(
    writer: impl Write,
    path: &Path,
    (width, height, count): (u32, u32, u32),
    rate: Rate,
    frames: impl Iterator<Item = Result<FrameImage, Error>>,
) -> Result<(), Error> {
    let fail = |e: png::EncodingError| match e {
        png::EncodingError::IoError(e) => Error::io(path, e),
        other => Error::Output {
            path: path.to_path_buf(),
            message: format!("APNG encoder: {other}"),
        },
    };
    let mut encoder = png::Encoder::new(writer, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    // 0 plays: loop forever.
    encoder.set_animated(count, 0).map_err(fail)?;
    let mut writer = encoder.write_header().map_err(fail)?;
    for (i, frame) in frames.enumerate() {
        let frame = frame?;
        let (num, den) = rate.apng_delay(i as u64);
        writer.set_frame_delay(num, den).map_err(fail)?;
        writer.write_image_data(&frame.rgb).map_err(fail)?;
    }
    writer.finish().map_err(fail)
}
