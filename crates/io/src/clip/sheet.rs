//! Contact sheets (`.png` clips): the frames as a still grid, left to right and top to
//! bottom in frame order, each with its frame number under it.
//!
//! The grid has `ceil(sqrt(n))` columns. Frames are shown at full size when the grid fits
//! [`TARGET_WIDTH`], and otherwise shrunk by the smallest whole factor that makes it fit, each
//! thumbnail pixel the mean of the 8-bit sRGB values it covers. Numbers are drawn with the
//! built-in digit font ([`super::digits`]) at [`FONT_SCALE`] screen pixels per font pixel.

use std::io::Write;
use std::path::Path;

use super::digits;
use super::source::FrameImage;
use raytrace_core::error::Error;

/// The most frames a sheet shows: beyond that the numbers no longer fit their thumbnails.
pub(crate) const MAX_FRAMES: u64 = 1024;

/// The widest a grid of full-size frames may be before the frames are shrunk, in pixels.
const TARGET_WIDTH: u64 = 2048;
/// Screen pixels per font pixel.
const FONT_SCALE: u32 = 2;
/// Pixels around and between the cells.
const GAP: u32 = 4;
/// Pixels above and below a frame number.
const LABEL_PAD: u32 = 3;
const BACKGROUND: u8 = 40;
const INK: u8 = 235;

/// Where everything goes on a sheet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct SheetGrid {
    columns: u32,
    /// Frame pixels per thumbnail pixel, along each side.
    factor: u32,
    thumb: (u32, u32),
    cell: (u32, u32),
    pub(super) size: (u32, u32),
}

impl SheetGrid {
    /// The layout of `count` frames (1 to [`MAX_FRAMES`]) of `width` x `height`, numbered up
    /// to `last_frame`.
    pub(super) fn new(count: u64, (width, height): (u32, u32), last_frame: u32) -> SheetGrid {
        let columns = (1..=count).find(|c| c * c >= count).unwrap_or(1);
        let rows = count.div_ceil(columns);
        let factor = (columns * width as u64).div_ceil(TARGET_WIDTH).max(1);
        let thumb = (
            (width as u64).div_ceil(factor) as u32,
            (height as u64).div_ceil(factor) as u32,
        );
        let label_width = digits::text_width(last_frame) * FONT_SCALE;
        let cell = (
            thumb.0.max(label_width + 2 * LABEL_PAD),
            thumb.1 + digits::GLYPH.1 * FONT_SCALE + 2 * LABEL_PAD,
        );
        let side = |cells: u64, cell: u32| (cells * (cell + GAP) as u64 + GAP as u64) as u32;
        SheetGrid {
            columns: columns as u32,
            factor: factor as u32,
            thumb,
            cell,
            size: (side(columns, cell.0), side(rows, cell.1)),
        }
    }

    /// The top left corner of cell `index`.
    fn corner(&self, index: u64) -> (u32, u32) {
        let (col, row) = (
            (index % self.columns as u64) as u32,
            (index / self.columns as u64) as u32,
        );
        (
            GAP + col * (self.cell.0 + GAP),
            GAP + row * (self.cell.1 + GAP),
        )
    }
}

/// A sheet being filled.
pub(super) struct Sheet {
    layout: SheetGrid,
    rgb: Vec<u8>,
}

impl Sheet {
    pub(super) fn new(layout: SheetGrid) -> Sheet {
        let (w, h) = layout.size;
        Sheet {
            layout,
            rgb: vec![BACKGROUND; w as usize * h as usize * 3],
        }
    }

    fn put(&mut self, x: u32, y: u32, rgb: [u8; 3]) {
        let i = (y as usize * self.layout.size.0 as usize + x as usize) * 3;
        self.rgb[i..i + 3].copy_from_slice(&rgb);
    }

    /// Draws `frame` into cell `index` (from 0), with its number under it.
    pub(super) fn add(&mut self, index: u64, frame: &FrameImage) {
        let (x0, y0) = self.layout.corner(index);
        let (tw, th) = self.layout.thumb;
        let k = self.layout.factor;
        for ty in 0..th {
            for tx in 0..tw {
                // The mean of the frame pixels this thumbnail pixel covers (fewer at the
                // right and bottom edges when the size is not a multiple of the factor).
                let mut sum = [0u32; 3];
                let mut n = 0;
                for y in ty * k..((ty + 1) * k).min(frame.height) {
                    for x in tx * k..((tx + 1) * k).min(frame.width) {
                        let i = (y as usize * frame.width as usize + x as usize) * 3;
                        for (s, &v) in sum.iter_mut().zip(&frame.rgb[i..i + 3]) {
                            *s += v as u32;
                        }
                        n += 1;
                    }
                }
                let mean = sum.map(|s| ((s + n / 2) / n) as u8);
                self.put(x0 + tx, y0 + ty, mean);
            }
        }
        let (lx, ly) = (x0 + LABEL_PAD, y0 + th + LABEL_PAD);
        let (gw, gh) = (digits::text_width(frame.frame), digits::GLYPH.1);
        for fy in 0..gh * FONT_SCALE {
            for fx in 0..gw * FONT_SCALE {
                if digits::is_set(frame.frame, fx / FONT_SCALE, fy / FONT_SCALE) {
                    self.put(lx + fx, ly + fy, [INK; 3]);
                }
            }
        }
    }

    /// Writes the sheet as an 8-bit sRGB PNG into `writer`.
    pub(super) fn write(&self, writer: impl Write, path: &Path) -> Result<(), Error> {
        use image::ImageEncoder;
        use image::codecs::png::PngEncoder;
        let (w, h) = self.layout.size;
        PngEncoder::new(writer)
            .write_image(&self.rgb, w, h, image::ExtendedColorType::Rgb8)
            .map_err(|e| match e {
                image::ImageError::IoError(e) => Error::io(path, e),
                other => Error::Output {
                    path: path.to_path_buf(),
                    message: format!("PNG encoder: {other}"),
                },
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(frame: u32, width: u32, height: u32) -> FrameImage {
        let rgb = (0..width * height * 3)
            .map(|i| (i * 7 + frame) as u8)
            .collect();
        FrameImage {
            frame,
            width,
            height,
            rgb,
        }
    }

    #[test]
    fn small_frames_are_copied_whole_in_a_square_grid() {
        let layout = SheetGrid::new(12, (320, 180), 12);
        assert_eq!(layout.columns, 4);
        assert_eq!(layout.factor, 1);
        assert_eq!(layout.size.0, 4 * (320 + GAP) + GAP);
        let mut sheet = Sheet::new(layout);
        let f = frame(6, 320, 180);
        sheet.add(5, &f); // second row, second column
        let (x0, y0) = layout.corner(5);
        assert_eq!((x0, y0), (GAP + 324, GAP + layout.cell.1 + GAP));
        for y in 0..180 {
            for x in 0..320 {
                let i = ((y * 320 + x) * 3) as usize;
                let j = (((y0 + y) * layout.size.0 + x0 + x) * 3) as usize;
                assert_eq!(f.rgb[i..i + 3], sheet.rgb[j..j + 3]);
            }
        }
        // The label "6": its top row is ink across the glyph, and it sits under the frame.
        let label_top = y0 + 180 + LABEL_PAD;
        let ink_at = |x: u32, y: u32| sheet.rgb[((y * layout.size.0 + x) * 3) as usize] == INK;
        assert!((0..3 * FONT_SCALE).all(|dx| ink_at(x0 + LABEL_PAD + dx, label_top)));
        assert!(!ink_at(x0 + LABEL_PAD + 3 * FONT_SCALE, label_top));
    }

    #[test]
    fn large_grids_shrink_by_a_whole_factor_to_pixel_means() {
        let layout = SheetGrid::new(100, (400, 225), 100);
        assert_eq!(layout.columns, 10);
        assert_eq!(layout.factor, 2); // 10 x 400 = 4000 > 2048, 2000 fits
        assert_eq!(layout.thumb, (200, 113));
        let mut sheet = Sheet::new(layout);
        let mut f = frame(1, 400, 225);
        f.rgb.fill(0);
        // One 2x2 block at the top left: 0, 10, 20, 30 in red; its mean is 15.
        for (p, v) in [(0usize, 0u8), (1, 10), (400, 20), (401, 30)] {
            f.rgb[p * 3] = v;
        }
        sheet.add(0, &f);
        let (x0, y0) = layout.corner(0);
        assert_eq!(sheet.rgb[((y0 * layout.size.0 + x0) * 3) as usize], 15);
    }
}
