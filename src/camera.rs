//! The camera: a thin lens that may move during the shot.

use glam::DVec3;

use crate::motion::Motion;

/// The camera as the scene describes it, for the whole shot.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraRig {
    /// Where the camera is. A turntable (`orbit`) is a [`Motion::Orbit`] about `look_at` and
    /// `up`; `keyframes` become [`Motion::Keyframes`] of both points.
    pub look_from: Motion,
    /// Where it looks.
    pub look_at: Motion,
    /// The up direction (not necessarily unit length; not parallel to the view direction).
    pub up: DVec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub vfov: f64,
    /// Lens diameter; 0 is a pinhole.
    pub aperture: f64,
    /// Distance to the plane in focus; `None`: the distance from `look_from` to `look_at` at
    /// the ray's time.
    pub focus_distance: Option<f64>,
}

impl CameraRig {
    /// Whether the camera moves during `interval`.
    pub fn moves_in(&self, interval: crate::shutter::Interval) -> bool {
        self.look_from.prepare(interval).is_moving() || self.look_at.prepare(interval).is_moving()
    }

    /// The camera's view at time `t`, for an image of `width` x `height` pixels.
    pub fn view_at(&self, t: f64, width: u32, height: u32) -> View {
        View::new(
            self,
            self.look_from.at(t),
            self.look_at.at(t),
            width,
            height,
        )
    }
}

/// The camera at one instant: the books' thin-lens camera ("Ray Tracing in One Weekend",
/// section 12), with pixel centres at half-integer offsets and row 0 at the top of the image.
#[derive(Clone, Copy, Debug)]
pub struct View {
    origin: DVec3,
    u: DVec3,
    v: DVec3,
    pixel00: DVec3,
    du: DVec3,
    dv: DVec3,
    lens_radius: f64,
}

impl View {
    fn new(rig: &CameraRig, from: DVec3, at: DVec3, width: u32, height: u32) -> View {
        let focus = rig.focus_distance.unwrap_or_else(|| (from - at).length());
        let h = (rig.vfov.to_radians() / 2.0).tan();
        let viewport_h = 2.0 * h * focus;
        let viewport_w = viewport_h * (width as f64 / height as f64);
        let w = (from - at).normalize();
        let u = rig.up.cross(w).normalize();
        let v = w.cross(u);
        let vu = viewport_w * u;
        let vv = -viewport_h * v;
        let du = vu / width as f64;
        let dv = vv / height as f64;
        let upper_left = from - focus * w - 0.5 * vu - 0.5 * vv;
        View {
            origin: from,
            u,
            v,
            pixel00: upper_left + 0.5 * (du + dv),
            du,
            dv,
            lens_radius: rig.aperture / 2.0,
        }
    }

    /// Whether the lens has an aperture (otherwise it is a pinhole and needs no lens sample).
    pub fn has_lens(&self) -> bool {
        self.lens_radius > 0.0
    }

    /// The ray through pixel (`x`, `y`) at offset `(jx, jy)` in [0, 1)^2 inside the pixel,
    /// through the lens point given by `lens` in [0, 1)^2 (ignored for a pinhole), at `time`.
    #[inline]
    pub fn ray(
        &self,
        x: u32,
        y: u32,
        (jx, jy): (f64, f64),
        lens: (f64, f64),
        time: f64,
    ) -> crate::ray::Ray {
        let target =
            self.pixel00 + (x as f64 + jx - 0.5) * self.du + (y as f64 + jy - 0.5) * self.dv;
        let origin = if self.has_lens() {
            let (lx, ly) = concentric_disk(lens);
            self.origin + self.lens_radius * (lx * self.u + ly * self.v)
        } else {
            self.origin
        };
        crate::ray::Ray {
            origin,
            dir: (target - origin).normalize(),
            time,
        }
    }
}

/// Maps [0, 1)^2 to the unit disk uniformly, preserving stratification (Shirley and Chiu's
/// concentric mapping, as in pbrt-v4 `SampleUniformDiskConcentric`).
pub fn concentric_disk((a, b): (f64, f64)) -> (f64, f64) {
    let (x, y) = (2.0 * a - 1.0, 2.0 * b - 1.0);
    if x == 0.0 && y == 0.0 {
        return (0.0, 0.0);
    }
    let (r, theta) = if x.abs() > y.abs() {
        (x, std::f64::consts::FRAC_PI_4 * (y / x))
    } else {
        (
            y,
            std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (x / y),
        )
    };
    let (s, c) = theta.sin_cos();
    (r * c, r * s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Orbit;

    fn rig() -> CameraRig {
        CameraRig {
            look_from: Motion::Still(DVec3::new(0.0, 0.0, 0.0)),
            look_at: Motion::Still(DVec3::new(0.0, 0.0, -1.0)),
            up: DVec3::Y,
            vfov: 90.0,
            aperture: 0.0,
            focus_distance: None,
        }
    }

    #[test]
    fn centre_ray_looks_at_look_at_and_corners_span_the_fov() {
        let view = rig().view_at(0.0, 200, 100);
        // Pixel (100, 50) at offset (0, 0) is the exact image centre.
        let r = view.ray(100, 50, (0.0, 0.0), (0.5, 0.5), 0.0);
        assert!((r.dir - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
        // Top-left corner of the image: vfov 90 means y = tan(45) = 1 at distance 1.
        let r = view.ray(0, 0, (0.0, 0.0), (0.5, 0.5), 0.0);
        let d = r.dir / -r.dir.z;
        assert!((d.y - 1.0).abs() < 1e-12 && (d.x + 2.0).abs() < 1e-12);
    }

    #[test]
    fn lens_rays_converge_on_the_focus_plane() {
        let mut rig = rig();
        rig.aperture = 0.5;
        rig.focus_distance = Some(3.0);
        let view = rig.view_at(0.0, 64, 64);
        let a = view.ray(10, 20, (0.3, 0.3), (0.1, 0.9), 0.0);
        let b = view.ray(10, 20, (0.3, 0.3), (0.8, 0.2), 0.0);
        assert!((a.origin - b.origin).length() > 0.01);
        let pa = a.at((-3.0 - a.origin.z) / a.dir.z);
        let pb = b.at((-3.0 - b.origin.z) / b.dir.z);
        assert!((pa - pb).length() < 1e-12);
        assert!(a.origin.length() <= 0.25 + 1e-12);
    }

    #[test]
    fn concentric_disk_stays_in_the_disk() {
        let mut r = crate::rng::Pcg32::new(1, 1);
        for _ in 0..10000 {
            let (x, y) = concentric_disk((r.next_f64(), r.next_f64()));
            assert!(x * x + y * y <= 1.0 + 1e-12);
        }
        assert_eq!(concentric_disk((0.5, 0.5)), (0.0, 0.0));
    }

    #[test]
    fn orbiting_camera_moves_and_keeps_looking_at_the_pivot() {
        let mut rig = rig();
        rig.look_from = Motion::Orbit {
            origin: DVec3::new(0.0, 1.0, 5.0),
            orbit: Orbit {
                pivot: DVec3::ZERO,
                axis: DVec3::Y,
                degrees_per_second: 90.0,
            },
        };
        rig.look_at = Motion::Still(DVec3::ZERO);
        assert!(rig.moves_in(crate::shutter::Interval {
            open: 0.0,
            close: 0.1
        }));
        assert!(!rig.moves_in(crate::shutter::Interval::instant(0.3)));
        let v = rig.view_at(1.0, 32, 32);
        let r = v.ray(16, 16, (0.0, 0.0), (0.5, 0.5), 1.0);
        assert!((r.origin - DVec3::new(5.0, 1.0, 0.0)).length() < 1e-12);
        assert!(r.dir.cross(-r.origin.normalize()).length() < 1e-12);
    }
}
