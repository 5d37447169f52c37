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
    pub(crate) fn moves_in(&self, interval: crate::shutter::Interval) -> bool {
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

    /// The view's vectors, for a tracer that makes its rays elsewhere (the GPU's): the lens
    /// centre, its unit axes right (`u`) and up (`v`), the centre of pixel (0, 0) on the
    /// plane in focus, the steps from a pixel to the next one right and down; and the lens
    /// radius.
    pub fn vectors(&self) -> ([DVec3; 6], f64) {
        (
            [self.origin, self.u, self.v, self.pixel00, self.du, self.dv],
            self.lens_radius,
        )
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

impl View {
    /// The unit direction the camera looks along (from `look_from` toward `look_at`).
    pub fn forward(&self) -> DVec3 {
        // u = normalize(up x w), v = w x u, so v x u = -w.
        self.v.cross(self.u)
    }

    /// The distance of `q` from the lens centre along the view direction (not along the ray):
    /// negative behind the camera.
    pub fn depth(&self, q: DVec3) -> f64 {
        (q - self.origin).dot(self.forward())
    }

    /// Where `q` appears in the image through the lens centre (a pinhole projection), in
    /// continuous pixel coordinates: x to the right, y downward, (0, 0) at the top-left
    /// corner of the image, pixel (i, j)'s centre at (i + 0.5, j + 0.5). Points outside the
    /// view project outside the image (nothing is clipped); a point on the plane of the lens
    /// has no image and gives infinities or NaN.
    pub fn project(&self, q: DVec3) -> glam::DVec2 {
        let f = self.forward();
        let d = q - self.origin;
        // The image plane passes through pixel00, perpendicular to the view direction.
        let to_plane = self.pixel00 - self.origin;
        let on_plane = d * (to_plane.dot(f) / d.dot(f)) - to_plane;
        glam::DVec2::new(
            on_plane.dot(self.du) / self.du.length_squared() + 0.5,
            on_plane.dot(self.dv) / self.dv.length_squared() + 0.5,
        )
    }
}

/// Maps [0, 1)^2 to the unit disk uniformly, preserving stratification (Shirley and Chiu's
/// concentric mapping, as in pbrt-v4 `SampleUniformDiskConcentric`).
pub(crate) fn concentric_disk((a, b): (f64, f64)) -> (f64, f64) {
    let (x, y) = (2.0 * a - 1.0, 2.0 * b - 1.0);
    if x == 0.0 && y == 0.0 {
        return (0.0, 0.0);
    }
    // The angle in turns: pi/4 is 1/8 of a turn.
    let (r, turns) = if x.abs() > y.abs() {
        (x, 0.125 * (y / x))
    } else {
        (y, 0.25 - 0.125 * (x / y))
    };
    let (s, c) = crate::trig::sin_cos_turns(turns);
    (r * c, r * s)
}

/// A view direction (`look_at - look_from`) no longer than this fraction of the larger of
/// `|look_from|` and `|look_at|` (about 4500 units in the last place of the points) is
/// degenerate. Within a few units in the last place the image plane, which lies that far from
/// `look_from` when no focus distance is given, rounds onto `look_from` itself and camera rays
/// come out 0/0 (NaN); at this bound the view is resolved to 2.2e-4 relative at worst. The
/// stability suite's closest camera, 2e-4 from a sphere 1e6 from the origin (2e-10 relative,
/// rendered exactly), is 200 times above it.
pub const DEGENERATE_VIEW: f64 = 1e-12;

/// A view direction whose angle to `up` has a sine no larger than this is degenerate: the
/// camera's sideways axis `normalize(up x view)` is then known only to about 2.2e-7 radians
/// (the cross product's rounding, 2.2e-16, over 1e-9), and at zero it is NaN.
pub const DEGENERATE_UP: f64 = 1e-9;

/// The shortest view direction or `up` vector, whatever the scale: squares of shorter vectors
/// approach the subnormal range (below 2.2e-308), where normalizing loses digits or returns
/// NaN.
pub const TINY: f64 = 1e-100;

/// The length of `v`, without overflow or underflow in the squares.
pub fn robust_length(v: DVec3) -> f64 {
    let m = v.abs().max_element();
    if m == 0.0 || !m.is_finite() {
        return m;
    }
    (v / m).length() * m
}

/// For a vector moving linearly from `d0` to `d1` (`d(s) = (1 - s) d0 + s d1`, s in [0, 1]),
/// where it is shortest: `(s, |d(s)|)`. Between two camera keys look_from and look_at move
/// linearly, so the view direction `look_at - look_from` does too.
pub fn shortest_on_segment(d0: DVec3, d1: DVec3) -> (f64, f64) {
    // Scaled so that no square overflows or underflows; s does not depend on the scale.
    let m = d0.abs().max_element().max(d1.abs().max_element());
    if m == 0.0 || !m.is_finite() {
        return (0.0, m);
    }
    let (a, b) = (d0 / m, d1 / m);
    let e = b - a;
    let ee = e.length_squared();
    let s = if ee > 0.0 {
        (-a.dot(e) / ee).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (s, ((1.0 - s) * a + s * b).length() * m)
}

/// For a direction moving linearly from `d0` to `d1` as in [`shortest_on_segment`] (and never
/// vanishing on the way), where it is most nearly parallel (or antiparallel) to `up`:
/// `(s, sine of the angle between them)`.
///
/// The squared sine is `N(s) / D(s)` with `N = |up x d(s)|^2` and `D = |d(s)|^2` (`up` of unit
/// length), both quadratic in s; its extremes inside [0, 1] are the roots of the quadratic
/// `N'D - ND'` (the cubic terms cancel), so the minimum is found exactly among those roots and
/// the ends.
pub fn most_parallel_on_segment(up: DVec3, d0: DVec3, d1: DVec3) -> (f64, f64) {
    let ul = robust_length(up);
    let m = d0.abs().max_element().max(d1.abs().max_element());
    if ul == 0.0 || m == 0.0 || !ul.is_finite() || !m.is_finite() {
        return (0.0, 0.0);
    }
    let u = (up / up.abs().max_element()).normalize();
    let (a, b) = (d0 / m, d1 / m);
    let sine = |s: f64| {
        let d = (1.0 - s) * a + s * b;
        let len = d.length();
        if len > 0.0 {
            u.cross(d).length() / len
        } else {
            0.0
        }
    };
    let (c0, c1) = (u.cross(a), u.cross(b));
    let (ce, de) = (c1 - c0, b - a);
    let (n2, n1, n0) = (ce.length_squared(), 2.0 * c0.dot(ce), c0.length_squared());
    let (q2, q1, q0) = (de.length_squared(), 2.0 * a.dot(de), a.length_squared());
    let qa = n2 * q1 - n1 * q2;
    let qb = 2.0 * (n2 * q0 - n0 * q2);
    let qc = n1 * q0 - n0 * q1;
    let mut candidates = vec![0.0, 1.0];
    let scale = qa.abs().max(qb.abs()).max(qc.abs());
    if scale > 0.0 {
        let (qa, qb, qc) = (qa / scale, qb / scale, qc / scale);
        if qa.abs() > 1e-12 {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc >= 0.0 {
                // The stable pair of roots.
                let q = -0.5 * (qb + qb.signum() * disc.sqrt());
                candidates.push(q / qa);
                if q != 0.0 {
                    candidates.push(qc / q);
                }
            }
        } else if qb != 0.0 {
            candidates.push(-qc / qb);
        }
    }
    candidates
        .into_iter()
        .filter(|s| (0.0..=1.0).contains(s))
        .map(|s| (s, sine(s)))
        .fold(
            (0.0, f64::INFINITY),
            |best, c| if c.1 < best.1 { c } else { best },
        )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Orbit;

    #[test]
    fn projection_inverts_the_camera_rays() {
        let mut r = rig();
        r.look_from = Motion::Still(DVec3::new(1.0, 2.0, 3.0));
        r.look_at = Motion::Still(DVec3::new(-2.0, 0.5, -4.0));
        r.aperture = 0.5;
        let view = r.view_at(0.0, 64, 48);
        for (x, y, j) in [
            (0, 0, (0.5, 0.5)),
            (63, 47, (0.25, 0.75)),
            (10, 30, (0.0, 0.9)),
        ] {
            // The ray through the lens centre (a pinhole's) hits the pixel position it names,
            // at any distance along it, and its depth is that distance times the cosine.
            let mut pinhole = r.clone();
            pinhole.aperture = 0.0;
            let ray = pinhole.view_at(0.0, 64, 48).ray(x, y, j, (0.5, 0.5), 0.0);
            for s in [0.5, 7.0, 1000.0] {
                let q = ray.origin + s * ray.dir;
                let p = view.project(q);
                assert!((p.x - (x as f64 + j.0)).abs() < 1e-9, "{p}");
                assert!((p.y - (y as f64 + j.1)).abs() < 1e-9, "{p}");
                let cos = ray.dir.dot(view.forward());
                assert!((view.depth(q) - s * cos).abs() < 1e-9 * s);
            }
        }
        // Far outside the view: projected, not clipped.
        let off = view.project(DVec3::new(1.0, 2.0, 3.0) + 10.0 * view.forward() + 50.0 * DVec3::Y);
        assert!(off.y < -100.0 && off.is_finite());
    }

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
    fn shortest_on_segment_finds_where_the_view_vanishes() {
        // look_from from (0, 0, 1) to (0, 0, -1), look_at at the origin: meets it half-way.
        let (s, d) = shortest_on_segment(DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.0, 0.0, 1.0));
        assert_eq!((s, d), (0.5, 0.0));
        // Misses by 0.1 at a quarter of the way.
        let (s, d) = shortest_on_segment(DVec3::new(-1.0, 0.1, 0.0), DVec3::new(3.0, 0.1, 0.0));
        assert_eq!(s, 0.25);
        assert!((d - 0.1).abs() < 1e-15);
        // Ends: the nearest end when the closest point lies outside.
        assert_eq!(shortest_on_segment(DVec3::X, DVec3::X * 2.0), (0.0, 1.0));
        assert_eq!(shortest_on_segment(DVec3::X * 2.0, DVec3::X), (1.0, 1.0));
        // No overflow or underflow at the ends of the range.
        let (s, d) = shortest_on_segment(DVec3::splat(3e38), DVec3::splat(-3e38));
        assert_eq!((s, d), (0.5, 0.0));
        let (_, d) = shortest_on_segment(DVec3::splat(1e-300), DVec3::splat(1e-300));
        assert!((d / (1e-300 * 3f64.sqrt()) - 1.0).abs() < 1e-12, "{d}");
        assert_eq!(robust_length(DVec3::new(3e300, 4e300, 0.0)), 5e300);
        assert_eq!(robust_length(DVec3::new(3e-300, 4e-300, 0.0)), 5e-300);
    }

    #[test]
    fn most_parallel_on_segment_finds_where_the_view_meets_up() {
        // look_from from (-1, 1, 0) to (1, 1, 0), look_at at the origin: straight down at s = 0.5.
        let (s, sine) = most_parallel_on_segment(
            DVec3::Y,
            DVec3::new(1.0, -1.0, 0.0),
            DVec3::new(-1.0, -1.0, 0.0),
        );
        assert!((s - 0.5).abs() < 1e-12 && sine < 1e-15, "{s} {sine}");
        // Passing 26.6 degrees from up half-way, with no root of the sine: from (1, 1, 0.5) to
        // (-1, 1, 0.5) against up (0, 1, 0); compared with a fine search.
        let up = DVec3::Y;
        let (a, b) = (DVec3::new(1.0, 1.0, 0.5), DVec3::new(-1.0, 1.0, 0.5));
        let (s, sine) = most_parallel_on_segment(up, a, b);
        let brute = (0..=100_000)
            .map(|i| {
                let s = i as f64 / 100_000.0;
                let d = a.lerp(b, s);
                (s, up.cross(d).length() / d.length())
            })
            .fold((0.0, f64::INFINITY), |x, y| if y.1 < x.1 { y } else { x });
        assert!((s - 0.5).abs() < 1e-12, "{s}");
        assert!((sine - 0.5 / 1.25f64.sqrt()).abs() < 1e-15, "{sine}");
        assert!(sine <= brute.1, "{brute:?}");
        // A still direction; up of any length.
        let (_, sine) = most_parallel_on_segment(DVec3::Y * 1e-200, DVec3::X, DVec3::X);
        assert!((sine - 1.0).abs() < 1e-15);
        let (_, sine) = most_parallel_on_segment(DVec3::Y * 3e38, DVec3::Y, DVec3::Y * 2.0);
        assert_eq!(sine, 0.0);
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
