//! Animated GIF clips, encoded in process (the `image` crate's GIF encoder).
//!
//! GIF counts delays in hundredths of a second, so a frame period is rounded with the error
//! carried to the next frame ([`Rate::delay`]): the clip's length is exact to a hundredth. Each
//! frame gets a palette of its own (256 colours, NeuQuant), and the clip loops forever.
//! Browsers show delays under 2 hundredths as 10, so above 50 fps a GIF plays slowly: use
//! `.apng` or `.mp4` for such rates.

use std::io::Write;
use std::path::Path;

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbaImage};

use super::source::FrameImage;
use super::timing::Rate;
use raytrace_core::error::Error;

/// NeuQuant's sampling factor, 1 (best) to 30 (fastest); 10 is the usual balance.
const QUANTIZER_SPEED: i32 = 10;

/// Writes `frames` (all of one size) as an animated GIF into `writer`.
pub(super) fn write(
    writer: impl Write,
    path: &Path,
    rate: Rate,
    frames: impl Iterator<Item = Result<FrameImage, Error>>,
) -> Result<(), Error> {
    let fail = |e: image::ImageError| Error::Output {
        path: path.to_path_buf(),
        message: format!("GIF encoder: {e}"),
    };
    let mut encoder = GifEncoder::new_with_speed(writer, QUANTIZER_SPEED);
    encoder.set_repeat(Repeat::Infinite).map_err(fail)?;
    for (i, frame) in frames.enumerate() {
        let frame = frame?;
        let rgba: Vec<u8> = frame
            .rgb
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect();
        let image = RgbaImage::from_raw(frame.width, frame.height, rgba)
            .expect("a buffer of the frame's size");
        // The image crate takes milliseconds and writes them as hundredths, rounded down:
        // a whole number of hundredths passes through exactly.
        let hundredths = rate.delay(i as u64, 100) as u32;
        let delay = Delay::from_numer_denom_ms(hundredths * 10, 1);
        encoder
            .encode_frame(Frame::from_parts(image, 0, 0, delay))
            .map_err(fail)?;
    }
    Ok(())
}
