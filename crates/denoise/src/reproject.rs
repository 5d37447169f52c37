//! Another frame's channels carried to a frame's pixels along their motion vectors, where it
//! shows the same surface: its written colour, which `denoise::history` combines with the
//! frame, or its raw replicates, which `denoise::accumulate` adds to the frame's, so that a
//! denoised sequence does not flicker.
//!
//! Each pixel follows its backward motion vector (where its surface was one frame period
//! earlier, in pixels) into the frame before, then that frame's vector into the one before
//! it, up to [`HISTORY`] frames back; or its forward vectors ([`Along::Forward`]) into the
//! frames after it. At each step the other frame's images are read bilinearly, and the step
//! is taken only where the surface is the same: unit normals within [`MIN_NORMAL_DOT`] and
//! depths within [`DEPTH_TOLERANCE`] of the nearer frame's, or both background, and the
//! position inside the image. The first step that fails ends the walk: a pixel uncovered in
//! frame `n - 1` does not borrow from `n - 2`. What the geometry does not catch (a shadow or
//! a reflection moving over a still surface, shading that changes) the combination weighs by
//! its estimated error (`denoise::history`).

#[cfg(doc)]
use raytrace_core::image::COLOUR;
use raytrace_core::image::{Image, Precision, Values};
use raytrace_core::pass::{BACKWARD, DEPTH, FORWARD, NORMAL};

/// The frames before a frame that its temporal denoising reads.
pub const HISTORY: usize = 2;

/// Which way a pixel walks to the other frames: which of the motion pass's vectors it follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Along {
    /// Into the frames before, along the backward vectors ([`BACKWARD`]).
    Backward,
    /// Into the frames after, along the forward vectors ([`FORWARD`]).
    Forward,
}

impl Along {
    /// The motion pass's channels the walk follows.
    fn channels(self) -> [&'static str; 2] {
        match self {
            Along::Backward => BACKWARD,
            Along::Forward => FORWARD,
        }
    }
}

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

/// Another frame's channels at a frame's pixels ([`reproject`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Reprojected {
    /// The channels carried (for history, [`COLOUR`]); 0 where not found.
    pub image: Image,
    /// Whether the pixel's surface was found in the other frame.
    pub found: Vec<bool>,
}

/// The bytes a frame held for a later frame's history takes, for `pixels` pixels: its colour,
/// depth, normal and motion (the passes' 4 channels, forward and backward), 11 channels.
pub fn frame_bytes(pixels: u64) -> u64 {
    Image::bytes_for(pixels, 11)
}

/// The bytes [`reproject`] gives for a frame of `pixels` pixels: each other frame's colour
/// carried to it ([`HISTORY`] of them at most), and where it was found.
pub fn reprojected_bytes(pixels: u64) -> u64 {
    HISTORY as u64 * (Image::bytes_for(pixels, 3) + pixels * std::mem::size_of::<bool>() as u64)
}

/// The channels `planes` at the continuous position (`x`, `y`) of an image of `width` x
/// `height` pixels, read bilinearly (pixel centres at half-integers); `None` outside the
/// image.
fn bilinear<const N: usize>(
    planes: [&[f32]; N],
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
    let mut out = [0.0; N];
    for (o, plane) in out.iter_mut().zip(planes) {
        let at = |px: usize, py: usize| plane[py * width + px];
        let top = at(xa, ya) * (1.0 - tx) + at(xb, ya) * tx;
        let bottom = at(xa, yb) * (1.0 - tx) + at(xb, yb) * tx;
        *o = top * (1.0 - ty) + bottom * ty;
    }
    Some(out)
}

/// The planes a frame's history reads of it: the channels carried (none of the frame
/// itself), its depth, normal and the motion the walk follows (see [`reproject`]).
struct Planes<'a> {
    carried: Vec<[&'a [f32]; 1]>,
    depth: [&'a [f32]; 1],
    normal: [&'a [f32]; 3],
    motion: [&'a [f32]; 2],
}

impl<'a> Planes<'a> {
    fn of(frame: &'a Image, carried: &[&str], along: Along) -> Planes<'a> {
        let plane = |name: &str| frame.floats(name).expect("a frame's history channels");
        Planes {
            carried: carried.iter().map(|name| [plane(name)]).collect(),
            depth: [plane(DEPTH)],
            normal: NORMAL.0.map(plane),
            motion: along.channels().map(plane),
        }
    }
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

/// The float channels `carried` of `others` (the frame next to `current` first, then the one
/// next to that, `along` the way they lie) carried to `current`'s pixels, where each pixel's
/// surface is found there (see the module's notes). Every frame has `current`'s size and
/// holds what a frame's history reads: the channels carried (the colour written before its
/// own history, [`COLOUR`], or the raw replicates), the first hit's depth ([`DEPTH`]; the
/// background's: 1e10 or more), its mean shading normal ([`NORMAL`]; zero for the
/// background) and its motion ([`BACKWARD`] and [`FORWARD`]).
pub fn reproject(
    current: &Image,
    others: &[&Image],
    carried: &[&'static str],
    along: Along,
) -> Vec<Reprojected> {
    let (w, h) = (current.width() as usize, current.height() as usize);
    assert!(
        others
            .iter()
            .all(|f| (f.width(), f.height()) == (current.width(), current.height())),
        "frames of different sizes"
    );
    let n = w * h;
    let here_planes = Planes::of(current, &[], along);
    let planes: Vec<Planes> = others
        .iter()
        .map(|f| Planes::of(f, carried, along))
        .collect();
    let mut values: Vec<Vec<Vec<f32>>> = others
        .iter()
        .map(|_| carried.iter().map(|_| vec![0.0; n]).collect())
        .collect();
    let mut found: Vec<Vec<bool>> = others.iter().map(|_| vec![false; n]).collect();
    for i in 0..n {
        let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
        let at = |p: [&[f32]; 3]| [p[0][i], p[1][i], p[2][i]];
        let mut here = Surface::new(here_planes.depth[0][i], at(here_planes.normal));
        let mut motion = [here_planes.motion[0][i], here_planes.motion[1][i]];
        let mut pos = (x, y);
        for ((frame, value), found) in planes.iter().zip(&mut values).zip(&mut found) {
            // u right, v up; rows grow downward.
            pos = (pos.0 + motion[0], pos.1 - motion[1]);
            let read = |p: [&[f32]; 3]| bilinear(p, w, h, pos.0, pos.1);
            let (Some(normal), Some([depth]), Some(m)) = (
                read(frame.normal),
                bilinear(frame.depth, w, h, pos.0, pos.1),
                bilinear(frame.motion, w, h, pos.0, pos.1),
            ) else {
                break;
            };
            let there = Surface::new(depth, normal);
            if !here.same_as(&there) {
                break;
            }
            for (v, plane) in value.iter_mut().zip(&frame.carried) {
                // Inside the image: the depth was read there.
                v[i] = bilinear(*plane, w, h, pos.0, pos.1).map_or(0.0, |[c]| c);
            }
            found[i] = true;
            here = there;
            motion = m;
        }
    }
    values
        .into_iter()
        .zip(found)
        .map(|(value, found)| {
            let mut image = Image::new(current.width(), current.height());
            for (name, plane) in carried.iter().zip(value) {
                image.set(name, Precision::Float, Values::Float(plane));
            }
            Reprojected { image, found }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use raytrace_core::image::COLOUR;

    /// A frame of `w` x `h` whose colour at pixel (x, y) is `colour(x, y)`, at depth 5 with
    /// normal +z everywhere, moving steadily: `motion` (u, v) pixels back to the frame
    /// before, the opposite to the frame after.
    fn frame(w: usize, h: usize, colour: impl Fn(usize, usize) -> f32, motion: [f32; 2]) -> Image {
        let n = w * h;
        let mut f = Image::new(w as u32, h as u32);
        f.set_rgb(COLOUR, (0..n).map(|i| Vec3::splat(colour(i % w, i / w))));
        set(&mut f, DEPTH, vec![5.0; n]);
        f.set_rgb(NORMAL, (0..n).map(|_| Vec3::Z));
        set(&mut f, BACKWARD[0], vec![motion[0]; n]);
        set(&mut f, BACKWARD[1], vec![motion[1]; n]);
        set(&mut f, FORWARD[0], vec![-motion[0]; n]);
        set(&mut f, FORWARD[1], vec![-motion[1]; n]);
        f
    }

    fn set(f: &mut Image, name: &'static str, values: Vec<f32>) {
        f.set(name, Precision::Float, Values::Float(values));
    }

    /// The first channel of a reprojected colour.
    fn red(r: &Reprojected) -> &[f32] {
        r.image.floats("R").unwrap()
    }

    #[test]
    fn bilinear_reads_pixel_centres_exactly_and_interpolates_between() {
        let image: &[f32] = &[0.0, 1.0, 2.0, 3.0]; // 2 x 2, one channel
        assert_eq!(bilinear([image], 2, 2, 0.5, 0.5), Some([0.0]));
        assert_eq!(bilinear([image], 2, 2, 1.5, 1.5), Some([3.0]));
        assert_eq!(bilinear([image], 2, 2, 1.0, 0.5), Some([0.5]));
        assert_eq!(bilinear([image], 2, 2, 1.0, 1.0), Some([1.5]));
        assert_eq!(bilinear([image], 2, 2, 2.5, 1.0), None);
        assert_eq!(bilinear([image], 2, 2, f32::NAN, 1.0), None);
    }

    #[test]
    fn a_still_frame_reads_its_earlier_frames_in_place() {
        let cur = frame(4, 3, |_, _| 3.0, [0.0, 0.0]);
        let one = frame(4, 3, |_, _| 6.0, [0.0, 0.0]);
        let two = frame(4, 3, |_, _| 0.5, [0.0, 0.0]);
        let r = reproject(&cur, &[&one, &two], &COLOUR.0, Along::Backward);
        assert!(r.iter().all(|r| r.found.iter().all(|&v| v)));
        assert!(red(&r[0]).iter().all(|&v| v == 6.0));
        assert!(red(&r[1]).iter().all(|&v| v == 0.5));
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
        let r = reproject(&cur, &[&one, &two], &COLOUR.0, Along::Backward);
        for x in 0..w {
            // Pixels 0 and 1 leave the image two and one steps back.
            assert_eq!(r[0].found[x], x >= 1, "pixel {x}");
            assert_eq!(r[1].found[x], x >= 2, "pixel {x}");
            for (k, back) in r.iter().enumerate() {
                if back.found[x] {
                    assert_eq!(red(back)[x], x as f32, "pixel {x}, {k} back");
                }
            }
        }
    }

    #[test]
    fn the_frames_after_are_followed_along_the_forward_vectors() {
        // The same ramp moving right by one pixel a frame: the colour at x in frame n is at
        // x + 1 in frame n + 1 and x + 2 in n + 2. The backward vectors lead nowhere there
        // (they point to frame n - 1), so reading the same value means the forward ones led.
        let ramp = |shift: f32| move |x: usize, _y: usize| x as f32 - shift;
        let (w, h) = (8, 2);
        let cur = frame(w, h, ramp(0.0), [-1.0, 0.0]);
        let one = frame(w, h, ramp(1.0), [-1.0, 0.0]);
        let two = frame(w, h, ramp(2.0), [-1.0, 0.0]);
        let r = reproject(&cur, &[&one, &two], &COLOUR.0, Along::Forward);
        for x in 0..w {
            // Pixels 7 and 6 leave the image one and two steps ahead.
            assert_eq!(r[0].found[x], x + 1 < w, "pixel {x}");
            assert_eq!(r[1].found[x], x + 2 < w, "pixel {x}");
            for (k, ahead) in r.iter().enumerate() {
                if ahead.found[x] {
                    assert_eq!(red(ahead)[x], x as f32, "pixel {x}, {k} ahead");
                }
            }
        }
        // Backward, the same frames read other values: the pattern is not where they lead.
        let back = reproject(&cur, &[&one], &COLOUR.0, Along::Backward);
        assert!((1..w).all(|x| back[0].found[x] && red(&back[0])[x] == x as f32 - 2.0));
    }

    #[test]
    fn another_surface_ends_the_walk() {
        let cur = frame(3, 1, |_, _| 1.0, [0.0, 0.0]);
        let mut nearer = frame(3, 1, |_, _| 2.0, [0.0, 0.0]);
        // Something in front at pixel 1 in the frame before.
        set(&mut nearer, DEPTH, vec![5.0, 3.0, 5.0]);
        let mut tilted = frame(3, 1, |_, _| 3.0, [0.0, 0.0]);
        // Pixel 2's normal turned 90 degrees in the frame two back.
        tilted.set_rgb(NORMAL, [Vec3::Z, Vec3::Z, Vec3::X].into_iter());
        let r = reproject(&cur, &[&nearer, &tilted], &COLOUR.0, Along::Backward);
        assert_eq!(r[0].found, vec![true, false, true]);
        assert_eq!(r[1].found, vec![true, false, false]);
        // The background matches only the background.
        let mut sky = frame(3, 1, |_, _| 1.0, [0.0, 0.0]);
        set(&mut sky, DEPTH, vec![1e10; 3]);
        sky.set_rgb(NORMAL, [Vec3::ZERO; 3].into_iter());
        let r = reproject(&sky, &[&sky.clone(), &cur], &COLOUR.0, Along::Backward);
        assert_eq!(r[0].found, vec![true; 3]);
        assert_eq!(r[1].found, vec![false; 3]);
    }
}
