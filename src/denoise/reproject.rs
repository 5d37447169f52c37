//! A frame's pixels carried back to the frames before it along their motion vectors, and the
//! noisy colour averaged over the frames where they show the same surface: what a temporal
//! denoiser takes in place of one frame's colour, so that a denoised sequence does not
//! flicker.
//!
//! Each pixel follows its backward motion vector (where its surface was one frame period
//! earlier, in pixels) into the frame before, then that frame's vector into the one before
//! it, up to [`HISTORY`] frames back. At each step the earlier frame's images are read
//! bilinearly, and the step is taken only where the surface is the same: unit normals within
//! [`MIN_NORMAL_DOT`] and depths within [`DEPTH_TOLERANCE`] of the later frame's, or both
//! background; the position inside the image; and a colour within the noise of the pixel's
//! own 3x3 neighbourhood mean ([`COLOUR_SIGMAS`], [`COLOUR_TOLERANCE`]), which catches what the
//! geometry does not: a shadow or reflection moving over a still surface. The first step
//! that fails ends the walk:
//! a pixel uncovered in frame `n - 1` does not borrow from `n - 2`. The pixel's colour is
//! then the plain mean of its own and the earlier frames' colours it reached (each an
//! unbiased mean of its own samples), per replicate, so the two replicates stay independent.
//!
//! Averaging three frames' samples divides the noise's variance by about three where a surface
//! is seen in all three, and the noise left is shared by consecutive frames, so it moves with
//! the surface instead of flickering in place. The prices: reading earlier frames between
//! pixel centres blurs them a little, and a change of shading smaller than the noise passes
//! the colour test; `converge --flicker` measures both against references.

/// The frames before a frame that its temporal denoising reads.
pub const HISTORY: usize = 2;

/// The least cosine between the unit normals of a pixel and where it lands in an earlier
/// frame for both to show one surface (about 25 degrees).
pub const MIN_NORMAL_DOT: f32 = 0.9;

/// The largest relative difference of depth between a pixel and where it lands in an earlier
/// frame for both to show one surface: a surface moving toward the camera at a tenth of its
/// distance a frame still passes; the sphere behind it does not.
pub const DEPTH_TOLERANCE: f32 = 0.1;

/// How many standard deviations apart a pixel's colour (the mean of its 3x3 neighbourhood)
/// and the earlier frame's colour where it lands may be, and still be taken for one: beyond,
/// what the surface shows has changed (a shadow or a reflection moved over it).
pub const COLOUR_SIGMAS: f32 = 3.0;

/// The relative difference of colour always allowed between a pixel's neighbourhood mean and
/// the earlier frame's colour: the neighbourhood mean itself blurs edges.
pub const COLOUR_TOLERANCE: f32 = 0.1;

/// Depths at or beyond this are the background (`passes::NO_DEPTH` is written where no sample
/// hit).
const BACKGROUND_DEPTH: f32 = 1e9;

/// One frame's images that temporal denoising reads: row-major, `width` pixels a row;
/// colours and normals interleaved RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct TemporalFrame {
    pub width: usize,
    pub height: usize,
    /// The means of the pixel's even (`a`) and odd (`b`) samples.
    pub a: Vec<f32>,
    pub b: Vec<f32>,
    /// Each pixel's estimated variance of its mean, per channel (interleaved RGB).
    pub variance: Vec<f32>,
    /// The first hit's depth along the view axis (the background's: 1e10 or more).
    pub depth: Vec<f32>,
    /// The first hit's mean shading normal (zero for the background).
    pub normal: Vec<f32>,
    /// Where the pixel's surface was one frame period earlier, in pixels: `u` right, `v` up,
    /// interleaved.
    pub backward: Vec<f32>,
}

/// The colour of a frame averaged with its earlier frames ([`accumulate`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Accumulated {
    /// The means of the replicates over the frames each pixel reached, interleaved RGB.
    pub a: Vec<f32>,
    pub b: Vec<f32>,
    /// How many frames each pixel's colour averages (1: its own only).
    pub frames: Vec<u8>,
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

/// `current`'s replicates averaged, pixel by pixel, with those of `earlier` (the frame
/// before it first, then the one before that) where the pixel's surface is found there (see
/// the module's notes). Every frame has `current`'s size.
pub fn accumulate(current: &TemporalFrame, earlier: &[&TemporalFrame]) -> Accumulated {
    let (w, h) = (current.width, current.height);
    assert!(
        earlier.iter().all(|f| f.width == w && f.height == h),
        "frames of different sizes"
    );
    let n = w * h;
    // Each pixel's 3x3 neighbourhood mean of its full mean and that mean's variance.
    let full: Vec<f32> = current
        .a
        .iter()
        .zip(&current.b)
        .map(|(a, b)| 0.5 * (a + b))
        .collect();
    let (around, around_var) = neighbourhood(&full, &current.variance, w, h);
    let mut out = Accumulated {
        a: current.a.clone(),
        b: current.b.clone(),
        frames: vec![1; n],
    };
    for i in 0..n {
        let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
        let rgb = |v: &[f32]| [v[3 * i], v[3 * i + 1], v[3 * i + 2]];
        let mut here = Surface::new(current.depth[i], rgb(&current.normal));
        let mut motion = [current.backward[2 * i], current.backward[2 * i + 1]];
        let mut pos = (x, y);
        let (mut sum_a, mut sum_b) = (rgb(&current.a), rgb(&current.b));
        let mut frames = 1u8;
        for frame in earlier {
            // u right, v up; rows grow downward.
            pos = (pos.0 + motion[0], pos.1 - motion[1]);
            let read = |image: &[f32]| bilinear::<3>(image, w, h, pos.0, pos.1);
            let (Some(normal), Some([depth]), Some(a), Some(b), Some(m)) = (
                read(&frame.normal),
                bilinear::<1>(&frame.depth, w, h, pos.0, pos.1),
                read(&frame.a),
                read(&frame.b),
                bilinear::<2>(&frame.backward, w, h, pos.0, pos.1),
            ) else {
                break;
            };
            let there = Surface::new(depth, normal);
            if !here.same_as(&there) {
                break;
            }
            // The earlier pixel's own variance has one degree of freedom; the neighbourhood's
            // mean variance (nine pixels') stands in for it.
            let consistent = (0..3).all(|c| {
                let d = 0.5 * (a[c] + b[c]) - around[3 * i + c];
                let v = around_var[3 * i + c];
                let allowed = COLOUR_SIGMAS * COLOUR_SIGMAS * (9.0 * v + v)
                    + (COLOUR_TOLERANCE * around[3 * i + c]).powi(2);
                d * d <= allowed
            });
            if !consistent {
                break;
            }
            for c in 0..3 {
                sum_a[c] += a[c];
                sum_b[c] += b[c];
            }
            frames += 1;
            here = there;
            motion = m;
        }
        let k = frames as f32;
        for c in 0..3 {
            out.a[3 * i + c] = sum_a[c] / k;
            out.b[3 * i + c] = sum_b[c] / k;
        }
        out.frames[i] = frames;
    }
    out
}

/// The mean of `image` (interleaved RGB, `w` x `h`) over each pixel's 3x3 neighbourhood
/// (cut at the edges), and that mean's variance from the pixels' `variance`s (independent
/// pixels: their sum over the count squared).
fn neighbourhood(image: &[f32], variance: &[f32], w: usize, h: usize) -> (Vec<f32>, Vec<f32>) {
    let mut mean = vec![0.0; image.len()];
    let mut var = vec![0.0; image.len()];
    for y in 0..h {
        for x in 0..w {
            let mut count = 0.0;
            let (mut s, mut v) = ([0.0f32; 3], [0.0f32; 3]);
            for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in x.saturating_sub(1)..(x + 2).min(w) {
                    let j = ny * w + nx;
                    for c in 0..3 {
                        s[c] += image[3 * j + c];
                        v[c] += variance[3 * j + c];
                    }
                    count += 1.0;
                }
            }
            let i = y * w + x;
            for c in 0..3 {
                mean[3 * i + c] = s[c] / count;
                var[3 * i + c] = v[c] / (count * count);
            }
        }
    }
    (mean, var)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame of `w` x `h` whose colour at pixel (x, y) is `colour(x, y)` (both replicates,
    /// each pixel's variance of its mean 1), at depth 5 with normal +z everywhere, moving by
    /// `motion` (u, v) pixels a frame.
    fn frame(
        w: usize,
        h: usize,
        colour: impl Fn(usize, usize) -> f32,
        motion: [f32; 2],
    ) -> TemporalFrame {
        let n = w * h;
        let c: Vec<f32> = (0..n)
            .flat_map(|i| {
                let v = colour(i % w, i / w);
                [v, v, v]
            })
            .collect();
        TemporalFrame {
            width: w,
            height: h,
            a: c.clone(),
            b: c,
            variance: vec![1.0; 3 * n],
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
    fn a_still_frame_averages_all_three() {
        let cur = frame(4, 3, |_, _| 3.0, [0.0, 0.0]);
        let one = frame(4, 3, |_, _| 6.0, [0.0, 0.0]);
        let two = frame(4, 3, |_, _| 0.0, [0.0, 0.0]);
        let acc = accumulate(&cur, &[&one, &two]);
        assert!(acc.frames.iter().all(|&f| f == 3));
        assert!(acc.a.iter().all(|&v| v == 3.0));
        assert_eq!(acc.a, acc.b);
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
        let acc = accumulate(&cur, &[&one, &two]);
        for x in 0..w {
            let f = acc.frames[x];
            // Pixels 0 and 1 leave the image two and one steps back.
            assert_eq!(f as usize, 3.min(x + 1), "pixel {x}");
            assert_eq!(acc.a[3 * x], x as f32, "pixel {x}");
        }
    }

    #[test]
    fn a_colour_beyond_the_noise_ends_the_walk() {
        // Variance 1 a pixel: the neighbourhood mean's is 1/9 in the middle (1/4 in a
        // corner), and the allowed difference sqrt(9 (9 v + v) + (0.1 m)^2) about 3.2 (4.7 in a
        // corner) for m = 3.
        let cur = frame(3, 3, |_, _| 3.0, [0.0, 0.0]);
        let close = frame(3, 3, |_, _| 6.0, [0.0, 0.0]);
        let far = frame(3, 3, |_, _| 8.0, [0.0, 0.0]);
        assert!(accumulate(&cur, &[&close]).frames.iter().all(|&f| f == 2));
        assert!(accumulate(&cur, &[&far]).frames.iter().all(|&f| f == 1));
        // A shadow moving over the frame before: where it was, that frame is not used.
        let mut shadowed = frame(3, 3, |_, _| 3.0, [0.0, 0.0]);
        shadowed.a[12..15].copy_from_slice(&[-20.0; 3]);
        shadowed.b[12..15].copy_from_slice(&[-20.0; 3]);
        let acc = accumulate(&cur, &[&shadowed]);
        assert_eq!(acc.frames[4], 1);
        assert_eq!(acc.frames.iter().filter(|&&f| f == 2).count(), 8);
    }

    #[test]
    fn another_surface_ends_the_walk() {
        let cur = frame(3, 1, |_, _| 1.0, [0.0, 0.0]);
        let mut nearer = frame(3, 1, |_, _| 2.0, [0.0, 0.0]);
        nearer.depth[1] = 3.0; // something in front at pixel 1 in the frame before
        let mut tilted = frame(3, 1, |_, _| 3.0, [0.0, 0.0]);
        // Pixel 2's normal turned 90 degrees in the frame two back.
        tilted.normal[6..9].copy_from_slice(&[1.0, 0.0, 0.0]);
        let acc = accumulate(&cur, &[&nearer, &tilted]);
        assert_eq!(acc.frames, vec![3, 1, 2]);
        assert_eq!(&acc.a[3..6], &[1.0; 3]);
        assert_eq!(acc.a[6], 1.5); // (1 + 2) / 2
        assert_eq!(acc.a[0], 2.0); // (1 + 2 + 3) / 3
        // The background matches only the background.
        let mut sky = frame(3, 1, |_, _| 1.0, [0.0, 0.0]);
        sky.depth = vec![1e10; 3];
        sky.normal = vec![0.0; 9];
        let acc = accumulate(&sky, &[&sky.clone(), &cur]);
        assert_eq!(acc.frames, vec![2, 2, 2]);
    }
}
