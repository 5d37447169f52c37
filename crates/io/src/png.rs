//! PNG frames: 8-bit RGB, sRGB encoded, clamped to [0, 1].

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use raytrace_core::error::Error;
use raytrace_core::image::{COLOUR, Image, RgbPlanes};

/// Encodes a linear value as an 8-bit sRGB value with the exact piecewise sRGB curve,
/// clamped to [0, 1] and rounded to nearest. Non-finite values give 0.
pub fn linear_to_srgb8(v: f32) -> u8 {
    if !v.is_finite() {
        return 0;
    }
    let x = (v as f64).clamp(0.0, 1.0);
    let e = if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
}

/// Writes the frame as 8-bit sRGB PNG into `writer`.
pub(super) fn write(writer: &mut BufWriter<File>, path: &Path, image: &Image) -> Result<(), Error> {
    encode(&mut *writer, image).map_err(|e| match e {
        ::image::ImageError::IoError(e) => Error::io(path, e),
        other => Error::Output {
            path: path.to_path_buf(),
            message: format!("PNG encoder: {other}"),
        },
    })?;
    writer.flush().map_err(|e| Error::io(path, e))
}

/// Encodes the frame as the 8-bit sRGB PNG a frame file holds (RGB, or RGBA with straight
/// alpha when `image` has an `A` channel) into `writer`.
pub fn encode(writer: impl Write, image: &Image) -> Result<(), ::image::ImageError> {
    use ::image::ImageEncoder;
    use ::image::codecs::png::PngEncoder;

    let rgb = image.rgb(COLOUR).expect("a frame's colour");
    let (bytes, kind) = match image.floats("A") {
        None => (
            (0..image.pixels())
                .flat_map(|i| rgb.at(i).to_array().map(linear_to_srgb8))
                .collect(),
            ::image::ExtendedColorType::Rgb8,
        ),
        Some(a) => (
            rgba_straight(rgb, a, image.premultiplied),
            ::image::ExtendedColorType::Rgba8,
        ),
    };
    PngEncoder::new(writer).write_image(&bytes, image.width(), image.height(), kind)
}

/// 8-bit RGBA with straight alpha, as PNG requires: the colour sRGB encoded, divided by the
/// alpha first where it is `premultiplied` (and the alpha above 0), the alpha linear.
fn rgba_straight(rgb: RgbPlanes, alpha: &[f32], premultiplied: bool) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(alpha.len() * 4);
    for (i, &a) in alpha.iter().enumerate() {
        let c = rgb.at(i).to_array();
        let scale = if premultiplied && a > 0.0 {
            1.0 / a
        } else {
            1.0
        };
        bytes.extend(c.iter().map(|&v| linear_to_srgb8(v * scale)));
        let a = if a.is_finite() {
            a.clamp(0.0, 1.0)
        } else {
            0.0
        };
        bytes.push((a * 255.0 + 0.5).floor() as u8);
    }
    bytes
}

/// Whether the PNG file at `path` is whole, cheaply: it starts with the PNG signature and an
/// `IHDR` chunk and ends with the `IEND` chunk. The error says what is wrong.
pub(super) fn check_complete(path: &Path) -> Result<(), String> {
    use std::io::{Read, Seek, SeekFrom};
    const SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];
    const IEND: [u8; 12] = [0, 0, 0, 0, b'I', b'E', b'N', b'D', 0xae, 0x42, 0x60, 0x82];
    let mut file = File::open(path).map_err(|e| e.to_string())?;
    let mut start = [0u8; 16];
    let mut end = [0u8; 12];
    let len = file.metadata().map_err(|e| e.to_string())?.len();
    if len < (SIGNATURE.len() + 25 + IEND.len()) as u64
        || file.read_exact(&mut start).is_err()
        || start[..8] != SIGNATURE
        || &start[12..16] != b"IHDR"
    {
        return Err("not a readable PNG file".to_string());
    }
    file.seek(SeekFrom::End(-(IEND.len() as i64)))
        .and_then(|_| file.read_exact(&mut end))
        .map_err(|e| e.to_string())?;
    if end != IEND {
        return Err("truncated (it does not end with the IEND chunk)".to_string());
    }
    Ok(())
}
