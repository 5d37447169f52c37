//! An earlier frame's written colour carried to a frame's pixels along their motion vectors,
//! where it shows the same surface: what `denoise::history` combines with the frame, so that
//! a denoised sequence does not flicker.
//!
//! Each pixel follows its backward motion vector (where its surface was one frame period
//! earlier, in pixels) into the frame before, then that frame's vector into the one before
//! it, up to [`HISTORY`] frames back. At each step the earlier frame's images are read
//! bilinearly, and the step is taken only where the surface is the same: unit normals within
//! [`MIN_NORMAL_DOT`] and depths within [`DEPTH_TOLERANCE`] of the later frame's, or both
//! background, and the position inside the image. The first step that fails ends the walk: a
//! pixel uncovered in frame `n - 1` does not borrow from `n - 2`. What the geometry does not
//! catch (a shadow or a reflection moving over a still surface, shading that changes) the
//! combination weighs by its estimated error (`denoise::history`).

/// The frames before a frame that its temporal denoising reads.
pub const HISTORY: usize = 2;

/// The least cosine between the unit normals of a pixel and where it lands in an earlier
/// frame for both to show one surface (about 25 degrees).
pub(crate) const MIN_NORMAL_DOT: f32 = 0.9;

/// The largest relative difference of depth between a pixel and where it lands in an earlier
/// frame for both to show one surface: a surface moving toward the camera at a tenth of its
/// distance a frame still passes; the sphere behind it does not.
pub(crate) const DEPTH_TOLERANCE: f32 = 0.1;

/// Depths at or beyond this are the background (`passes::NO_DEPTH` is written where no sample
/// hit).
const BACKGROUND_DEPTH: f32 = 1e9;

/// One frame's images that a later frame's history reads: row-major, `width` pixels a row;
/// colours and normals interleaved RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct TemporalFrame {
    pub width: usize,
    pub height: usize,
    /// The frame's written colour (before its own history).
    pub colour: Vec<f32>,
    /// The first hit's depth along the view axis (the background's: 1e10 or more).
    pub depth: Vec<f32>,
    /// The first hit's mean shading normal (zero for the background).
    pub normal: Vec<f32>,
    /// Where the pixel's surface was one frame period earlier, in pixels: `u` right, `v` up,
    /// interleaved.
    pub backward: Vec<f32>,
}

/// An earlier frame's colour at a frame's pixels ([`reproject`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Reprojected {
    /// Interleaved RGB, row-major; 0 where not valid.
    pub colour: Vec<f32>,
    /// Whether the pixel's surface was found in the earlier frame.
    pub valid: Vec<bool>,
}

/// The channels `k..k + n` of the pixel at the continuous position (`x`, `y`) of an image of
/// `width` x `height` pixels with `n` channels a pixel, read bilinearly (pixel centres at
/// half-integers); `None` outside the image.
fn bilinear<const N: usize>(
    image: &[f32],
    width: usize,
    height: usize,
    x: f32,
    y: f32,
) -> Option<[f32; N]> {
    if !(x >= 0.0 && y >= 0.0 && x <= width as f32 && y <= height as f32) {
        return None;
    }
    let (fx, fy) = (x - 0.5, y - 0.5);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n - 1);
    let (xa, xb) = (clamp(x0, width), clamp(x0 + 1.0, width));
    let (ya, yb) = (clamp(y0, height), clamp(y0 + 1.0, height));
    let at = |px: usize, py: usize, c: usize| image[(py * width + px) * N + c];
    let mut out = [0.0; N];
    for (c, o) in out.iter_mut().enumerate() {
        let top = at(xa, ya, c) * (1.0 - tx) + at(xb, ya, c) * tx;
        let bottom = at(xa, yb, c) * (1.0 - tx) + at(xb, yb, c) * tx;
        *o = top * (1.0 - ty) + bottom * ty;
    }
    Some(out)
}

/// What a step compares: a surface's depth and unit normal (zero for the background).
#[derive(Clone, Copy, Debug)]
struct Surface {
    depth: f32,
    normal: [f32; 3],
}

impl Surface {
    fn new(depth: f32, normal: [f32; 3]) -> Surface {
        let len = normal.iter().map(|c| c * c).sum::<f32>().sqrt();
        let normal = if len > 1e-6 {
            normal.map(|c| c / len)
        } else {
            [0.0; 3]
        };
        Surface { depth, normal }
    }

    fn is_background(&self) -> bool {
        self.depth >= BACKGROUND_DEPTH
    }

    /// Whether `self` and `other` show one surface (see the module's notes).
    fn same_as(&self, other: &Surface) -> bool {
        match (self.is_background(), other.is_background()) {
            (true, true) => true,
            (false, false) => {
                let dot: f32 = self
                    .normal
                    .iter()
                    .zip(other.normal)
                    .map(|(a, b)| a * b)
                    .sum();
                let close = (self.depth - other.depth).abs() <= DEPTH_TOLERANCE * self.depth;
                dot >= MIN_NORMAL_DOT && close
            }
            _ => false,
        }
    }
}

/// The colours of `earlier` (the frame before `current` first, then the one before that)
/// carried to `current`'s pixels, where each pixel's surface is found there (see the module's
/// notes). Every frame has `current`'s size.
pub fn reproject(current: &TemporalFrame, earlier: &[&TemporalFrame]) -> Vec<Reprojected> {
    let (w, h) = (current.width, current.height);
    assert!(
        earlier.iter().all(|f| f.width == w && f.height == h),
        "frames of different sizes"
    );
    let n = w * h;
    let mut out: Vec<Reprojected> = earlier
        .iter()
        .map(|_| Reprojected {
            colour: vec![0.0; 3 * n],
            valid: vec![false; n],
        })
        .collect();
    for i in 0..n {
        let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
        let rgb = |v: &[f32]| [v[3 * i], v[3 * i + 1], v[3 * i + 2]];
        let mut here = Surface::new(current.depth[i], rgb(&current.normal));
        let mut motion = [current.backward[2 * i], current.backward[2 * i + 1]];
        let mut pos = (x, y);
        for (frame, into) in earlier.iter().zip(&mut out) {
            // u right, v up; rows grow downward.
            pos = (pos.0 + motion[0], pos.1 - motion[1]);
            let read = |image: &[f32]| bilinear::<3>(image, w, h, pos.0, pos.1);
            let (Some(normal), Some([depth]), Some(colour), Some(m)) = (
                read(&frame.normal),
                bilinear::<1>(&frame.depth, w, h, pos.0, pos.1),
                read(&frame.colour),
                bilinear::<2>(&frame.backward, w, h, pos.0, pos.1),
            ) else {
                break;
            };
            let there = Surface::new(depth, normal);
            if !here.same_as(&there) {
                break;
            }
            into.colour[3 * i..3 * i + 3].copy_from_slice(&colour);
            into.valid[i] = true;
            here = there;
            motion = m;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame of `w` x `h` whose colour at pixel (x, y) is `colour(x, y)`, at depth 5 with
    /// normal +z everywhere, moving by `motion` (u, v) pixels a frame.
    fn frame(
        w: usize,
        h: usize,
        colour: impl Fn(usize, usize) -> f32,
        motion: [f32; 2],
    ) -> TemporalFrame {
        let n = w * h;
        TemporalFrame {
            width: w,
            height: h,
            colour: (0..n)
                .flat_map(|i| {
                    let v = colour(i % w, i / w);
                    [v, v, v]
                })
                .collect(),
            depth: vec![5.0; n],
            normal: (0..n).flat_map(|_| [0.0, 0.0, 1.0]).collect(),
            backward: (0..n).flat_map(|_| motion).collect(),
        }
    }

    #[test]
    fn bilinear_reads_pixel_centres_exactly_and_interpolates_between() {
        let image = [0.0f32, 1.0, 2.0, 3.0]; // 2 x 2, one channel
        assert_eq!(bilinear::<1>(&image, 2, 2, 0.5, 0.5), Some([0.0]));
        assert_eq!(bilinear::<1>(&image, 2, 2, 1.5, 1.5), Some([3.0]));
        assert_eq!(bilinear::<1>(&image, 2, 2, 1.0, 0.5), Some([0.5]));
        assert_eq!(bilinear::<1>(&image, 2, 2, 1.0, 1.0), Some([1.5]));
        assert_eq!(bilinear::<1>(&image, 2, 2, 2.5, 1.0), None);
        assert_eq!(bilinear::<1>(&image, 2, 2, f32::NAN, 1.0), None);
    }

    #[test]
    fn a_still_frame_reads_its_earlier_frames_in_place() {
        let cur = frame(4, 3, |_, _| 3.0, [0.0, 0.0]);
        let one = frame(4, 3, |_, _| 6.0, [0.0, 0.0]);
        let two = frame(4, 3, |_, _| 0.5, [0.0, 0.0]);
        let r = reproject(&cur, &[&one, &two]);
        assert!(r.iter().all(|r| r.valid.iter().all(|&v| v)));
        assert!(r[0].colour.iter().all(|&v| v == 6.0));
        assert!(r[1].colour.iter().all(|&v| v == 0.5));
    }

    #[test]
    fn a_moving_pattern_is_followed_along_its_vectors() {
        // A ramp moving right by one pixel a frame: the colour at x in frame n was at x - 1
        // in frame n - 1 and x - 2 in n - 2. Following the vectors reads the same value.
        let ramp = |shift: f32| move |x: usize, _y: usize| x as f32 - shift;
        let (w, h) = (8, 2);
        let cur = frame(w, h, ramp(0.0), [-1.0, 0.0]);
        let one = frame(w, h, ramp(-1.0), [-1.0, 0.0]);
        let two = frame(w, h, ramp(-2.0), [-1.0, 0.0]);
        let r = reproject(&cur, &[&one, &two]);
        for x in 0..w {
            // Pixels 0 and 1 leave the image two and one steps back.
            assert_eq!(r[0].valid[x], x >= 1, "pixel {x}");
            assert_eq!(r[1].valid[x], x >= 2, "pixel {x}");
            for (k, back) in r.iter().enumerate() {
                if back.valid[x] {
                    assert_eq!(back.colour[3 * x], x as f32, "pixel {x}, {k} back");
                }
            }
        }
    }

    #[test]
    fn another_surface_ends_the_walk() {
        let cur = frame(3, 1, |_, _| 1.0, [0.0, 0.0]);
        let mut nearer = frame(3, 1, |_, _| 2.0, [0.0, 0.0]);
        nearer.depth[1] = 3.0; // something in front at pixel 1 in the frame before
        let mut tilted = frame(3, 1, |_, _| 3.0, [0.0, 0.0]);
        // Pixel 2's normal turned 90 degrees in the frame two back.
        tilted.normal[6..9].copy_from_slice(&[1.0, 0.0, 0.0]);
        let r = reproject(&cur, &[&nearer, &tilted]);
        assert_eq!(r[0].valid, vec![true, false, true]);
        assert_eq!(r[1].valid, vec![true, false, false]);
        // The background matches only the background.
        let mut sky = frame(3, 1, |_, _| 1.0, [0.0, 0.0]);
        sky.depth = vec![1e10; 3];
        sky.normal = vec![0.0; 9];
        let r = reproject(&sky, &[&sky.clone(), &cur]);
        assert_eq!(r[0].valid, vec![true; 3]);
        assert_eq!(r[1].valid, vec![false; 3]);
    }
}
