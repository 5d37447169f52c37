//! A clip's frames as they are read from disk: EXR or PNG frame files named by a path
//! pattern, shown as 8-bit sRGB exactly as the PNG frame output writes them.

use raytrace_core::image::COLOUR;
use std::path::{Path, PathBuf};

use raytrace_core::error::{Error, elide_path};
use raytrace_core::format::Format;
use raytrace_core::path_pattern::{self, FramePattern};

/// One frame as a clip shows it: 8-bit sRGB, three bytes a pixel, row-major, top row first.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameImage {
    pub frame: u32,
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

/// Where a clip's frames come from: a path pattern (`renders/shot_####.exr`), and the
/// exposure in stops applied to EXR frames before their sRGB encoding.
#[derive(Clone, Copy, Debug)]
pub struct Source<'a> {
    pub pattern: &'a FramePattern,
    pub exposure: f64,
}

impl Source<'_> {
    /// The file of `frame`.
    pub fn path(&self, frame: u32) -> PathBuf {
        path_pattern::frame_path(self.pattern, frame)
    }

    /// Checks that every frame's file is there and complete, cheaply (no pixel is decoded):
    /// the first that is not is a usage error naming the frame and its file.
    pub(crate) fn check_present(&self, frames: impl Iterator<Item = u32>) -> Result<(), Error> {
        for frame in frames {
            let path = self.path(frame);
            if !path.exists() {
                return Err(Error::Usage(format!(
                    "frame {frame} is missing: {} does not exist (render it first, or choose \
                     frames with --frames)",
                    elide_path(&path)
                )));
            }
            crate::check_frame_file(&path).map_err(|why| {
                Error::Usage(format!(
                    "frame {frame}: {} is not a complete frame ({why})",
                    elide_path(&path)
                ))
            })?;
        }
        Ok(())
    }

    /// Reads and encodes `frame`. A frame whose size differs from `size` (when given) is a
    /// usage error, as is a file that does not decode.
    pub fn read(&self, frame: u32, size: Option<(u32, u32)>) -> Result<FrameImage, Error> {
        let path = self.path(frame);
        let bad =
            |why: String| Error::Usage(format!("frame {frame}: {}: {why}", elide_path(&path)));
        let image = match Format::from_extension(&path, raytrace_core::format::FRAME_FORMATS) {
            Some(Format::Exr) => read_exr(&path, frame, self.exposure).map_err(bad)?,
            _ => read_png(&path, frame).map_err(bad)?,
        };
        if let Some((w, h)) = size
            && (image.width, image.height) != (w, h)
        {
            return Err(bad(format!(
                "the frame is {}x{}, and the clip's first frame {w}x{h}",
                image.width, image.height
            )));
        }
        Ok(image)
    }
}

/// An EXR frame, its linear values times 2^exposure encoded as the PNG frame output encodes
/// them ([`crate::linear_to_srgb8`]). At 0 stops the bytes are those of a PNG frame of the same
/// render.
fn read_exr(path: &Path, frame: u32, exposure: f64) -> Result<FrameImage, String> {
    let image = crate::read_exr_colour(path)?;
    let gain = exposure.exp2();
    let colour = image.rgb(COLOUR).expect("a colour read");
    let rgb = (0..image.pixels())
        .flat_map(|i| colour.at_f64(i).to_array())
        .map(|v| crate::linear_to_srgb8((v * gain) as f32))
        .collect();
    Ok(FrameImage {
        frame,
        width: image.width(),
        height: image.height(),
        rgb,
    })
}

/// A PNG frame, as its 8-bit RGB values (any alpha dropped).
fn read_png(path: &Path, frame: u32) -> Result<FrameImage, String> {
    let image = image::open(path).map_err(|e| e.to_string())?.into_rgb8();
    Ok(FrameImage {
        frame,
        width: image.width(),
        height: image.height(),
        rgb: image.into_raw(),
    })
}
