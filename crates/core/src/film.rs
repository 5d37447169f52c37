//! The film: each pixel's running sums of one frame, in linear radiance, from which its mean
//! and an estimate of that mean's error are read.
//!
//! A pixel keeps 40 bytes (see [`Pixel`]): the sum of its samples in `f64`, the sum of its odd
//! samples (the second replicate, `sampler::REPLICATES`) in `f32`, and its sample count. The
//! film is the frame's only per-pixel store: the renderer's tiles sample into it in place and
//! the writers read the means from it, so a frame without passes holds 40 bytes a pixel.
//!
//! A frame with passes for compositing keeps their per-sample sums in the film too (as pbrt's
//! `GBufferFilm` does): `pass_stride` numbers per pixel, stored tile by tile like the pixels,
//! handed to the same tiles ([`FilmTile`]). The film does not know what they mean:
//! [`crate::passes`] says what each number sums and makes the pass channels from them.
//!
//! A finished film gives its images: the colour as written ([`Film::colour`]) and its
//! replicates ([`Film::replicates`]), each an [`Image`] of named channels.

use glam::DVec3;

use crate::image::{COLOUR, Image, Precision, Rgb, Values};
use crate::pass::{SAMPLES, VARIANCE};
use crate::replicates::{REPLICATE_A, REPLICATE_B, replicate_counts};

/// Side of the square tiles the image is split into for parallel work: a 400x225 frame has
/// 375, handed to the threads one at a time.
pub(crate) const TILE: u32 = 16;

/// One pixel's running sums.
///
/// The mean is the plain sum over the count, so it is the same bits however the samples were
/// split into passes. The samples alternate between two independent replicates (even and odd
/// indices); the difference of the replicates' means gives an unbiased estimate of the mean's
/// variance for any sampler, stratified or not ([`variance_of_mean`](Self::variance_of_mean)).
/// The odd samples' sum is kept in `f32`: it only feeds that estimate, whose own noise is far
/// larger than an `f32` sum's rounding.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pixel {
    sum: DVec3,
    odd: [f32; 3],
    taken: u32,
}

impl Pixel {
    /// Adds the pixel's next sample (index [`taken`](Self::taken)). A sample with a component
    /// that is NaN or infinite is counted as black (as pbrt-v4 does), so every sample index
    /// has its place in its replicate; returns false for such a sample.
    #[inline]
    pub fn add(&mut self, v: DVec3) -> bool {
        let finite = v.is_finite();
        let v = if finite { v } else { DVec3::ZERO };
        self.sum += v;
        if self.taken % 2 == 1 {
            self.odd[0] += v.x as f32;
            self.odd[1] += v.y as f32;
            self.odd[2] += v.z as f32;
        }
        self.taken += 1;
        finite
    }

    /// Adds a run of `count` consecutive samples, from index [`taken`](Self::taken) on, summed
    /// by a tracer elsewhere (the GPU's): `sum` over all of them, `odd` over those of odd
    /// index (the second replicate). Non-finite samples must already be counted as black in
    /// both.
    pub fn add_run(&mut self, sum: DVec3, odd: [f32; 3], count: u32) {
        self.sum += sum;
        for (o, v) in self.odd.iter_mut().zip(odd) {
            *o += v;
        }
        self.taken += count;
    }

    /// The samples taken.
    pub fn taken(&self) -> u32 {
        self.taken
    }

    /// The mean of the samples (black if none was taken).
    pub fn mean(&self) -> DVec3 {
        if self.taken == 0 {
            DVec3::ZERO
        } else {
            self.sum / self.taken as f64
        }
    }

    /// The samples of the two replicates ([`replicate_counts`] of its samples).
    #[inline]
    pub(crate) fn replicate_counts(&self) -> (u32, u32) {
        replicate_counts(self.taken)
    }

    /// The means of the two replicates: `a` of the even samples, `b` of the odd ones (black
    /// where a replicate has no sample).
    pub fn replicate_means(&self) -> (DVec3, DVec3) {
        let (n_a, n_b) = self.replicate_counts();
        let odd = DVec3::new(self.odd[0] as f64, self.odd[1] as f64, self.odd[2] as f64);
        let mean = |sum: DVec3, n: u32| if n == 0 { DVec3::ZERO } else { sum / n as f64 };
        (mean(self.sum - odd, n_a), mean(odd, n_b))
    }

    /// The mean as written: `f32` RGB, black if a component is not finite as an `f32` (NaN,
    /// infinite, or beyond `f32::MAX`, which the conversion rounds to infinity).
    pub(crate) fn rgb_f32(&self) -> [f32; 3] {
        let m = self.mean();
        let v = [m.x as f32, m.y as f32, m.z as f32];
        if v.iter().all(|c| c.is_finite()) {
            v
        } else {
            [0.0; 3]
        }
    }

    /// The estimated variance of [`mean`](Self::mean) per channel, from the two replicates'
    /// means `a` (the `n_a` even samples) and `b` (the `n_b` odd ones): each sample's variance
    /// is estimated as `(a - b)^2 / (1/n_a + 1/n_b)` (the replicates are independent, so
    /// `E[(a - b)^2] = var(a) + var(b)`), and the mean's as that over `n`. Unbiased for any
    /// sampler whose replicates are independent, with one degree of freedom: a single pixel's
    /// estimate is rough, a region's or the image's mean of them is not. Infinite with fewer
    /// than two samples (nothing is known).
    pub fn variance_of_mean(&self) -> DVec3 {
        if self.taken < 2 {
            return DVec3::INFINITY;
        }
        let n = self.taken as f64;
        let (n_a, n_b) = self.replicate_counts();
        let (n_a, n_b) = (n_a as f64, n_b as f64);
        let odd = DVec3::new(self.odd[0] as f64, self.odd[1] as f64, self.odd[2] as f64);
        let d = (self.sum - odd) / n_a - odd / n_b;
        d * d / ((1.0 / n_a + 1.0 / n_b) * n)
    }
}

/// Sets the three float channels `names` of `image` to `planes`.
fn set_planes(image: &mut Image, names: Rgb, planes: [Vec<f32>; 3]) {
    for (name, plane) in names.0.into_iter().zip(planes) {
        image.set(name, Precision::Float, Values::Float(plane));
    }
}

/// Each pixel's estimated relative squared error, in the tile's order: its
/// [`variance_of_mean`](Pixel::variance_of_mean) over `(m + 0.01)^2`, averaged over the
/// channels (`metrics::estimated_rel_mse_term`), where `m` is, per channel, the smaller of the
/// pixel's own mean and the mean of its 3x3 neighbourhood inside the tile (fewer neighbours at
/// the tile's edges).
///
/// The true relative error divides by the converged value. A pixel's own mean is correlated
/// with its replicates' difference (a rare bright sample raises both), which made the
/// estimate 23 percent low at 16 samples on `scenes/defocus.toml`, whose yellow ground has no
/// blue at all. The neighbourhood's mean carries little of the pixel's own noise but blurs
/// edges (4 percent low on `bouncing_spheres`, 13 percent on a 48x32 frame of small spheres).
/// The smaller of the two keeps a dark pixel beside bright ones dark and a pixel raised by a
/// bright sample at its neighbours' level; it errs slightly high: measured 1.01 to 1.05 of the
/// true error at 16 and 128 samples on `defocus` and `bouncing_spheres`.
pub(crate) fn relative_variances(rect: &TileRect, pixels: &[Pixel]) -> Vec<f64> {
    let means: Vec<DVec3> = pixels.iter().map(Pixel::mean).collect();
    rect.neighbourhood_means(&means)
        .into_iter()
        .zip(means.iter().zip(pixels))
        .map(|(around, (own, p))| {
            crate::metrics::estimated_rel_mse_term(own.min(around), p.variance_of_mean())
        })
        .collect()
}

/// Where a tile lies in the image: pixels `x0..x1` by `y0..y1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileRect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl TileRect {
    /// The tile's width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// The tile's pixels.
    pub fn len(&self) -> usize {
        ((self.x1 - self.x0) * (self.y1 - self.y0)) as usize
    }

    /// True for a tile without pixels (never made by a film).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The image position of the tile's `i`-th pixel (row-major in the tile).
    pub fn position(&self, i: usize) -> (u32, u32) {
        let w = self.width();
        (self.x0 + i as u32 % w, self.y0 + i as u32 / w)
    }

    /// The tile's index of pixel (`x`, `y`), which lies in it: the inverse of
    /// [`position`](Self::position).
    pub fn index(&self, x: u32, y: u32) -> usize {
        debug_assert!((self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y));
        ((y - self.y0) * self.width() + (x - self.x0)) as usize
    }

    /// For each of the tile's pixels (row-major), the mean of `values` over its 3x3
    /// neighbourhood inside the tile: fewer neighbours at the tile's edges, never another
    /// tile's, so tiles can be read in parallel and alike on any thread count. Summed row by
    /// row, from zero.
    pub(crate) fn neighbourhood_means<T>(&self, values: &[T]) -> Vec<T>
    where
        T: Copy + Default + std::ops::AddAssign + std::ops::Div<f64, Output = T>,
    {
        let w = self.width() as usize;
        let h = values.len() / w;
        let mut out = Vec::with_capacity(values.len());
        for y in 0..h {
            for x in 0..w {
                let (mut sum, mut n) = (T::default(), 0.0);
                for ny in y.saturating_sub(1)..(y + 2).min(h) {
                    for nx in x.saturating_sub(1)..(x + 2).min(w) {
                        sum += values[ny * w + nx];
                        n += 1.0;
                    }
                }
                out.push(sum / n);
            }
        }
        out
    }
}

/// A frame's pixels, stored tile by tile ([`TILE`] x [`TILE`], row-major inside a tile, the
/// tiles row-major), so that each tile is one contiguous run the renderer can hand to a thread.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pixels: Vec<Pixel>,
    /// Numbers of pass sums per pixel (0: no passes).
    pass_stride: usize,
    /// The pass sums, `pass_stride` per pixel, in the pixels' order (tile by tile).
    pass_sums: Vec<f64>,
}

/// One tile of a film, mutable: where it lies, its pixels and their pass sums
/// ([`Film::pass_stride`] numbers per pixel, in the pixels' order; empty without passes).
pub(crate) struct FilmTile<'f> {
    pub rect: TileRect,
    pub pixels: &'f mut [Pixel],
    pub(crate) pass_sums: &'f mut [f64],
}

impl Film {
    /// The bytes a film of `pixels` pixels that keeps `pass_stride` pass sums a pixel holds:
    /// its [`Pixel`]s and its pass sums.
    pub fn bytes_for(pixels: u64, pass_stride: usize) -> u64 {
        pixels * (std::mem::size_of::<Pixel>() + pass_stride * std::mem::size_of::<f64>()) as u64
    }

    /// A film with no samples and no pass sums.
    pub fn new(width: u32, height: u32) -> Film {
        Film::with_pass_sums(width, height, 0)
    }

    /// A film with no samples that also keeps `pass_stride` pass sums per pixel, all 0.
    pub(crate) fn with_pass_sums(width: u32, height: u32, pass_stride: usize) -> Film {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            pixels: vec![Pixel::default(); n],
            pass_stride,
            pass_sums: vec![0.0; n * pass_stride],
        }
    }

    /// Numbers of pass sums per pixel (0 without passes).
    pub(crate) fn pass_stride(&self) -> usize {
        self.pass_stride
    }

    /// A film whose pixels each hold one sample, `f(x, y)`: an image given by its values.
    pub fn from_fn(width: u32, height: u32, f: impl Fn(u32, u32) -> DVec3) -> Film {
        let mut film = Film::new(width, height);
        for tile in film.tiles_mut() {
            for (i, p) in tile.pixels.iter_mut().enumerate() {
                let (x, y) = tile.rect.position(i);
                p.add(f(x, y));
            }
        }
        film
    }

    /// The index in `pixels` of pixel (`x`, `y`). Rows of tiles above hold `TILE` full rows of
    /// the image each; tiles to the left in the same row of tiles are `TILE` wide.
    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the film"
        );
        let (tx, ty) = (x / TILE, y / TILE);
        let (x0, y0) = (tx * TILE, ty * TILE);
        let tile_height = TILE.min(self.height - y0) as usize;
        let tile_width = TILE.min(self.width - x0) as usize;
        y0 as usize * self.width as usize
            + x0 as usize * tile_height
            + (y - y0) as usize * tile_width
            + (x - x0) as usize
    }

    /// Pixel (`x`, `y`)'s sums.
    pub fn pixel(&self, x: u32, y: u32) -> &Pixel {
        &self.pixels[self.index(x, y)]
    }

    /// The mean of pixel (`x`, `y`).
    pub fn get(&self, x: u32, y: u32) -> DVec3 {
        self.pixel(x, y).mean()
    }

    /// The tiles' rectangles, in storage order.
    pub fn tile_rects(&self) -> Vec<TileRect> {
        let (tiles_x, tiles_y) = (self.width.div_ceil(TILE), self.height.div_ceil(TILE));
        (0..tiles_x * tiles_y)
            .map(|t| {
                let (x0, y0) = ((t % tiles_x) * TILE, (t / tiles_x) * TILE);
                TileRect {
                    x0,
                    y0,
                    x1: (x0 + TILE).min(self.width),
                    y1: (y0 + TILE).min(self.height),
                }
            })
            .collect()
    }

    /// Each tile with its pixels, in storage order.
    pub fn tiles(&self) -> Vec<(TileRect, &[Pixel])> {
        let mut rest = &self.pixels[..];
        self.tile_rects()
            .into_iter()
            .map(|rect| {
                let (tile, after) = rest.split_at(rect.len());
                rest = after;
                (rect, tile)
            })
            .collect()
    }

    /// Each tile with its pixels and pass sums, mutable, in storage order: disjoint, for
    /// parallel work.
    pub(crate) fn tiles_mut(&mut self) -> Vec<FilmTile<'_>> {
        let rects = self.tile_rects();
        let stride = self.pass_stride;
        let mut rest = &mut self.pixels[..];
        let mut sums_rest = &mut self.pass_sums[..];
        rects
            .into_iter()
            .map(|rect| {
                let (pixels, after) = std::mem::take(&mut rest).split_at_mut(rect.len());
                rest = after;
                let (pass_sums, after) =
                    std::mem::take(&mut sums_rest).split_at_mut(rect.len() * stride);
                sums_rest = after;
                FilmTile {
                    rect,
                    pixels,
                    pass_sums,
                }
            })
            .collect()
    }

    /// Every pixel and its pass sums, mutable, in storage order (tile by tile, as
    /// [`tile_rects`](Self::tile_rects) lists the tiles): for a tracer that adds runs of
    /// samples to pixels wherever they are (the GPU's).
    pub fn storage_mut(&mut self) -> (&mut [Pixel], &mut [f64]) {
        (&mut self.pixels, &mut self.pass_sums)
    }

    /// Each tile with its pixels and their pass sums, in storage order.
    pub(crate) fn tiles_with_pass_sums(&self) -> Vec<(TileRect, &[Pixel], &[f64])> {
        let stride = self.pass_stride;
        let mut rest = &self.pass_sums[..];
        self.tiles()
            .into_iter()
            .map(|(rect, pixels)| {
                let (sums, after) = rest.split_at(rect.len() * stride);
                rest = after;
                (rect, pixels, sums)
            })
            .collect()
    }

    /// Every pixel's sums, in storage order (tile by tile).
    pub fn all_pixels(&self) -> &[Pixel] {
        &self.pixels
    }

    /// The samples every pixel has taken, summed.
    pub fn samples_taken(&self) -> u64 {
        self.pixels.iter().map(|p| p.taken as u64).sum()
    }

    /// The pixels' means, row-major, top row first.
    pub fn means(&self) -> Vec<DVec3> {
        self.row_major(Pixel::mean)
    }

    /// The pixels' estimated variances of their means as an image ([`VARIANCE`], `f32`, as a
    /// film's replicates image and the variance pass hold them), row-major.
    pub fn variances(&self) -> Image {
        let mut image = Image::new(self.width, self.height);
        let variances = self.row_major(Pixel::variance_of_mean);
        image.set_rgb(VARIANCE, variances.into_iter().map(|v| v.as_vec3()));
        image
    }

    /// The film's replicates as an image, row-major: each pixel's replicate means
    /// ([`REPLICATE_A`], [`REPLICATE_B`]) and its whole mean's estimated variance
    /// ([`VARIANCE`]) as `f32`, kept as an `f32` rounds them (infinite where nothing is
    /// known, so that nothing unknown looks known), and its samples ([`SAMPLES`], as counts):
    /// what the denoiser and the written frame's estimate read of the film
    /// ([`crate::replicates::Replicates`]).
    pub fn replicates(&self) -> Image {
        let mut planes = [REPLICATE_A, REPLICATE_B, VARIANCE].map(|names| (names, self.planes()));
        let mut taken = vec![0; self.pixels.len()];
        self.each_row_major(|i, p| {
            let (a, b) = p.replicate_means();
            let values = [a, b, p.variance_of_mean()];
            for ((_, plane), v) in planes.iter_mut().zip(values) {
                for (c, x) in plane.iter_mut().zip(v.as_vec3().to_array()) {
                    c[i] = x;
                }
            }
            taken[i] = p.taken;
        });
        let mut image = Image::new(self.width, self.height);
        for (names, plane) in planes {
            set_planes(&mut image, names, plane);
        }
        image.set(SAMPLES, Precision::Float, Values::Count(taken));
        image
    }

    /// Three planes of the film's size, zero.
    fn planes(&self) -> [Vec<f32>; 3] {
        std::array::from_fn(|_| vec![0.0; self.pixels.len()])
    }

    /// The film's colour as written ([`COLOUR`], row-major): each pixel's mean as an `f32`,
    /// black where that is not finite ([`Pixel::rgb_f32`]).
    pub fn colour(&self) -> Image {
        let mut plane = self.planes();
        self.each_row_major(|i, p| {
            for (c, x) in plane.iter_mut().zip(p.rgb_f32()) {
                c[i] = x;
            }
        });
        let mut image = Image::new(self.width, self.height);
        set_planes(&mut image, COLOUR, plane);
        image
    }

    /// Calls `f` with each pixel's row-major index and its sums, tile by tile.
    fn each_row_major(&self, mut f: impl FnMut(usize, &Pixel)) {
        for (rect, pixels) in self.tiles() {
            for (i, p) in pixels.iter().enumerate() {
                let (x, y) = rect.position(i);
                f(y as usize * self.width as usize + x as usize, p);
            }
        }
    }

    /// `f` of each pixel's sums, row-major, top row first.
    pub(crate) fn row_major<T: Copy + Default>(&self, f: impl Fn(&Pixel) -> T) -> Vec<T> {
        let mut out = vec![T::default(); self.pixels.len()];
        self.each_row_major(|i, p| out[i] = f(p));
        out
    }

    /// The number of pixels [`colour`](Self::colour) writes as black because their means are
    /// not finite as `f32`.
    pub fn non_finite(&self) -> u64 {
        self.pixels
            .iter()
            .filter(|p| {
                let m = p.mean();
                ![m.x as f32, m.y as f32, m.z as f32]
                    .iter()
                    .all(|c| c.is_finite())
            })
            .count() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pixel_is_forty_bytes() {
        assert_eq!(std::mem::size_of::<Pixel>(), 40);
    }

    #[test]
    fn non_finite_samples_count_as_black() {
        let mut a = Pixel::default();
        assert!(a.add(DVec3::splat(1.0)));
        assert!(!a.add(DVec3::new(f64::NAN, 0.0, 0.0)));
        assert!(a.add(DVec3::splat(3.0)));
        assert!(!a.add(DVec3::new(0.0, f64::INFINITY, 0.0)));
        assert_eq!(a.taken(), 4);
        assert_eq!(a.mean(), DVec3::splat(1.0));
        assert_eq!(Pixel::default().mean(), DVec3::ZERO);
    }

    #[test]
    fn the_variance_is_that_of_the_two_replicates_means() {
        // Even samples {1, 3} (mean 2), odd {2, 6} (mean 4): d = -2, per-sample variance
        // 4 / (1/2 + 1/2) = 4, variance of the mean of 4 samples 1.
        let mut a = Pixel::default();
        for v in [1.0, 2.0, 3.0, 6.0] {
            a.add(DVec3::splat(v));
        }
        assert_eq!(a.mean(), DVec3::splat(3.0));
        assert_eq!(a.variance_of_mean(), DVec3::ONE);
        // Three samples: even {1, 3} (mean 2), odd {5}: d = -3, per-sample variance
        // 9 / (1/2 + 1) = 6, over 3 samples: 2.
        let mut b = Pixel::default();
        for v in [1.0, 5.0, 3.0] {
            b.add(DVec3::splat(v));
        }
        assert_eq!(b.variance_of_mean(), DVec3::splat(2.0));
        let mut one = Pixel::default();
        one.add(DVec3::ONE);
        assert_eq!(one.variance_of_mean(), DVec3::INFINITY);
    }

    #[test]
    fn neighbourhood_means_stay_inside_the_tile() {
        // A 3x2 tile holding 0..6 row by row.
        let rect = TileRect {
            x0: 16,
            y0: 0,
            x1: 19,
            y1: 2,
        };
        let m = rect.neighbourhood_means(&[0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
        // Corner (0, 0): {0, 1, 3, 4}; middle (1, 0): all six; corner (2, 1): {1, 2, 4, 5}.
        assert_eq!(m, [2.0, 2.5, 3.0, 2.0, 2.5, 3.0]);
    }

    #[test]
    fn relative_variances_divide_by_the_smaller_of_own_and_neighbourhood_mean() {
        // A 3x2 tile: means 1 everywhere but 4 at (1, 0); every variance of the mean 1 (even
        // samples {m - 1}, odd {m + 1}).
        let rect = TileRect {
            x0: 0,
            y0: 0,
            x1: 3,
            y1: 2,
        };
        let pixels: Vec<Pixel> = (0..6)
            .map(|i| {
                let m = if i == 1 { 4.0 } else { 1.0 };
                let mut p = Pixel::default();
                p.add(DVec3::splat(m - 1.0));
                p.add(DVec3::splat(m + 1.0));
                p
            })
            .collect();
        assert_eq!(pixels[0].variance_of_mean(), DVec3::ONE);
        let r = relative_variances(&rect, &pixels);
        // Corner (0, 0): its own mean 1 is below its neighbourhood's, (1 + 4 + 1 + 1) / 4 =
        // 1.75. Middle (1, 0): its own 4 is above its neighbourhood's (all six), 1.5.
        let expect = |m: f64| 1.0 / ((m + 0.01) * (m + 0.01));
        assert!((r[0] - expect(1.0)).abs() < 1e-15, "{}", r[0]);
        assert!((r[1] - expect(1.5)).abs() < 1e-15, "{}", r[1]);
    }

    #[test]
    fn the_estimate_is_unbiased_for_independent_samples() {
        // Uniform samples on [0, 1) (variance 1/12): over 20,000 pixels of 16 samples each,
        // the mean estimate of the mean's variance is 1/192 within 3 percent (its relative
        // standard error, with one degree of freedom a pixel, is sqrt(2 / 20000) = 1%).
        let mut rng = crate::rng::Pcg32::new(7, 1);
        let pixels = 20_000;
        let mut total = 0.0;
        for _ in 0..pixels {
            let mut p = Pixel::default();
            for _ in 0..16 {
                p.add(DVec3::splat(rng.next_f64()));
            }
            total += p.variance_of_mean().x;
        }
        let estimate = total / pixels as f64;
        assert!(
            (estimate * 192.0 - 1.0).abs() < 0.03,
            "{}",
            estimate * 192.0
        );
    }

    #[test]
    fn tiles_cover_the_image_once_and_index_where_they_store() {
        // 37 x 20: tiles of 16, 16 and 5 columns by 16 and 4 rows.
        let film = Film::from_fn(37, 20, |x, y| DVec3::new(x as f64, y as f64, 0.0));
        let rects = film.tile_rects();
        assert_eq!(rects.len(), 6);
        assert_eq!(rects.iter().map(TileRect::len).sum::<usize>(), 37 * 20);
        for (rect, pixels) in film.tiles() {
            for (i, p) in pixels.iter().enumerate() {
                let (x, y) = rect.position(i);
                assert_eq!(p.mean(), DVec3::new(x as f64, y as f64, 0.0));
                assert_eq!(film.get(x, y), p.mean());
            }
        }
        let means = film.means();
        assert_eq!(means[19 * 37 + 36], DVec3::new(36.0, 19.0, 0.0));
        let colour = film.colour();
        let rgb = colour.rgb(COLOUR).unwrap();
        assert_eq!(rgb.at(37 + 2), glam::Vec3::new(2.0, 1.0, 0.0));
        assert_eq!(film.non_finite(), 0);
    }

    #[test]
    fn values_beyond_f32_are_written_as_black_and_counted() {
        let values = [
            DVec3::new(1.0, 1e300, 1.0),
            DVec3::new(-0.0, 0.0, -1e300),
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.5, f32::MAX as f64, 0.25),
        ];
        let f = Film::from_fn(2, 2, |x, y| values[(y * 2 + x) as usize]);
        let rgb = f.colour().interleaved(COLOUR).unwrap();
        assert_eq!(f.non_finite(), 2);
        assert!(rgb.iter().all(|c| c.is_finite()));
        assert_eq!(&rgb[..6], &[0.0; 6]);
        assert_eq!(&rgb[9..], &[0.5, f32::MAX, 0.25]);
    }
}
