//! A frame's pixels as the encoders take them.

use raytrace_core::pass::Channel;

/// A frame's colour as the encoders take it: pixel `i` (row-major, top row first) to its
/// linear RGB, computed as the encoder asks, so no copy of the image is made.
pub(crate) type RgbSource<'a> = &'a (dyn Fn(usize) -> [f32; 3] + Sync);

/// A frame's pixels as the encoders take them: linear RGB and the passes' channels, `width`
/// x `height`.
pub struct Image<'a> {
    pub width: u32,
    pub height: u32,
    pub rgb: RgbSource<'a>,
    /// The passes' channels, one value per pixel each (EXR: all; PNG: only `A`).
    pub channels: &'a [Channel],
    /// Whether `rgb` is premultiplied by the `A` channel (a transparent background).
    pub premultiplied: bool,
}
