//! The film: per-pixel estimates of one frame, in linear radiance.

use glam::DVec3;

/// A frame's pixels, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pixels: Vec<DVec3>,
}

impl Film {
    /// A black film.
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![DVec3::ZERO; width as usize * height as usize],
        }
    }

    /// The value of pixel (`x`, `y`).
    pub fn get(&self, x: u32, y: u32) -> DVec3 {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Sets pixel (`x`, `y`).
    pub fn set(&mut self, x: u32, y: u32, v: DVec3) {
        self.pixels[y as usize * self.width as usize + x as usize] = v;
    }

    /// All pixels, row-major.
    pub fn pixels(&self) -> &[DVec3] {
        &self.pixels
    }

    /// Interleaved RGB as `f32`, the layout the writers take.
    pub fn to_rgb_f32(&self) -> Vec<f32> {
        self.pixels
            .iter()
            .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect()
    }
}

/// The running mean of one pixel's samples, which drops non-finite samples and counts them.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelAccumulator {
    sum: DVec3,
    kept: u32,
    /// Samples dropped because a component was NaN or infinite.
    pub dropped: u32,
}

impl PixelAccumulator {
    /// Adds one sample's radiance.
    #[inline]
    pub fn add(&mut self, v: DVec3) {
        if v.is_finite() {
            self.sum += v;
            self.kept += 1;
        } else {
            self.dropped += 1;
        }
    }

    /// The mean of the kept samples (black if none was kept).
    pub fn mean(&self) -> DVec3 {
        if self.kept == 0 {
            DVec3::ZERO
        } else {
            self.sum / self.kept as f64
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accumulator_drops_non_finite_samples() {
        let mut a = PixelAccumulator::default();
        a.add(DVec3::splat(1.0));
        a.add(DVec3::new(f64::NAN, 0.0, 0.0));
        a.add(DVec3::splat(3.0));
        a.add(DVec3::new(0.0, f64::INFINITY, 0.0));
        assert_eq!(a.mean(), DVec3::splat(2.0));
        assert_eq!(a.dropped, 2);
        assert_eq!(PixelAccumulator::default().mean(), DVec3::ZERO);
    }

    #[test]
    fn film_layout_is_row_major_top_first() {
        let mut f = Film::new(3, 2);
        f.set(2, 1, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(f.get(2, 1), DVec3::new(1.0, 2.0, 3.0));
        let rgb = f.to_rgb_f32();
        assert_eq!(&rgb[15..18], &[1.0, 2.0, 3.0]);
    }
}
