//! Spheres: their description in a scene, their preparation for one frame's shutter interval
//! (the path of the centre during it, and the boxes a hierarchy interpolates over it), and
//! their intersection with rays.
//!
//! The intersection follows "Precision Improvements for Ray/Sphere Intersection" (Haines,
//! Günther and Akenine-Möller, Ray Tracing Gems, chapter 7): the discriminant is computed from
//! the ray's closest approach to the centre, `r^2 - |f - (f.d)d|^2`, which keeps its digits for
//! small or distant spheres and grazing rays, and the roots come from the stable form
//! `q = -(b + sign(b) sqrt(disc))`, `t0 = c/q`, `t1 = q` (with unit `d`), which avoids
//! subtracting nearly equal numbers. The hit point is then projected back onto the sphere
//! (pbrt-v4, section 6.8.5), which bounds its error by `gamma(5) |p - c|` per component.

use glam::DVec3;

use crate::aabb::Aabb;
use crate::motion::{FrameMotion, Motion};
use crate::ray::{Ray, gamma};
use crate::shutter::Interval;

/// A sphere as the scene describes it, for the whole shot.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereDesc {
    /// The path of the centre.
    pub motion: Motion,
    /// Radius, > 0.
    pub radius: f64,
    /// Index into [`crate::scene::Scene::materials`].
    pub material: u32,
}

/// The factor on `r^2` past which [`intersect`]'s early outs reject a squared distance (see
/// there); the points' lanes (`traced_points.rs`) make the same early outs with it.
pub(crate) const EARLY_OUT_SQUARE: f64 = 1.0 + 4.0 * f64::EPSILON;

/// The nearest intersection `t` in `(0, t_max)` of a ray with unit direction and the sphere
/// at `center` of radius `radius`, if any.
#[inline]
pub fn intersect(center: DVec3, radius: f64, ray: &Ray, t_max: f64) -> Option<f64> {
    let f = ray.origin - center;
    let b = f.dot(ray.dir);
    // Early outs for the common misses, taken only where the exact test below certainly
    // misses too, so results are the same bits. r^2 rounded to nearest is within half an ulp
    // of the true square, so `x > rr (1 + 4 eps)` for a computed square `x` means the true
    // x > r^2, hence sqrt(x) rounded (monotone, r representable) is >= r. This needs rr
    // normal (no underflow) and is skipped otherwise; a NaN fails every comparison and falls
    // through.
    let rr = radius * radius;
    let rr_up = rr * EARLY_OUT_SQUARE;
    let checked = rr >= f64::MIN_POSITIVE;
    // The ray starts outside (|f| >= r, so c >= 0) and points away (b > 0): both roots are
    // <= 0 (q < 0, t0 = c/q <= 0).
    if checked && b > 0.0 && f.length_squared() > rr_up {
        return None;
    }
    // Closest approach of the ray's line to the centre: l = f - (f.d) d.
    let l = f - b * ray.dir;
    let l2 = l.length_squared();
    // The line passes farther than r from the centre: disc <= 0 below.
    if checked && l2 > rr_up {
        return None;
    }
    // `l.length()` exactly (glam computes it as the square root of this dot product).
    let l_len = l2.sqrt();
    // r^2 - |l|^2, factored so the difference of nearly equal squares does not cancel.
    let disc = (radius - l_len) * (radius + l_len);
    // Zero is a ray tangent to the sphere to the precision of |l|. Its double root cannot be
    // oriented: the normal there is perpendicular to the ray up to rounding, so the side the
    // ray arrives from would be decided by noise, and a ray from outside taken for one from
    // inside is trapped inside an opaque sphere. A tangent ray misses. Otherwise r - l is at
    // least an ulp of r (it is exact, Sterbenz), so sqrt(disc) >= 1e-8 r and the entry point
    // is oriented reliably (see `surface_point`).
    if disc <= 0.0 {
        return None;
    }
    // c = |f|^2 - r^2, factored likewise.
    let f_len = f.length();
    let c = (f_len - radius) * (f_len + radius);
    // With a = 1 the roots are c/q and q; q != 0 because sqrt(disc) > 0 has the sign of b
    // added to b.
    let q = -(b + b.signum() * disc.sqrt());
    let (t0, t1) = {
        let (x, y) = (c / q, q);
        if x <= y { (x, y) } else { (y, x) }
    };
    if t0 > 0.0 && t0 < t_max {
        Some(t0)
    } else if t1 > 0.0 && t1 < t_max {
        Some(t1)
    } else {
        None
    }
}

/// A point on a sphere's surface with its outward normal and error bound.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// The hit point, projected onto the sphere.
    pub p: DVec3,
    /// Absolute error bound of `p`, per component.
    pub(crate) p_error: DVec3,
    /// Unit outward normal.
    pub normal: DVec3,
}

/// The surface point of the sphere at `center` where `ray` hits it at `t`.
#[inline]
pub fn surface_point(center: DVec3, radius: f64, ray: &Ray, t: f64) -> SurfacePoint {
    // Relative to the centre first, as the intersection computes it: `ray.origin - center` is
    // exact when the origin is near the sphere (Sterbenz), so the normal's direction carries
    // an error of about eps |origin - center| / r instead of ulp(|origin|) / r. For a sphere
    // of radius 1e-4 at 1e6 from the origin the latter is 1e-6, enough to turn the normal of
    // a grazing hit (dir . normal ~ -1e-8) to face the wrong way.
    let rel = (ray.origin - center) + t * ray.dir;
    let len = rel.length();
    // Project onto the sphere: error of the relative point is gamma(5)|rel| (pbrt-v4, eq. 6.30).
    let normal = if len > 0.0 { rel / len } else { -ray.dir };
    let rel = normal * radius;
    let p = center + rel;
    // The addition of the centre adds at most half an ulp of |p|, per component.
    let p_error = gamma(5) * rel.abs() + gamma(1) * p.abs();
    SurfacePoint { p, p_error, normal }
}

/// A sphere prepared for one frame's shutter interval.
#[derive(Clone, Debug, PartialEq)]
pub struct PreparedSphere {
    /// The path of the centre during the interval ([`FrameMotion::Linear`] is relative to
    /// the interval's opening).
    pub motion: FrameMotion,
    /// Radius, > 0.
    pub radius: f64,
}

impl SphereDesc {
    /// The box of a sphere that never moves (its centre at time 0), padded for the rounding
    /// of a hierarchy's `f32` boxes: what the still spheres' hierarchy is built on.
    pub(crate) fn still_box(&self) -> Aabb {
        Aabb::point(self.motion.at(0.0))
            .grow(self.radius)
            .pad_for_rounding()
    }

    /// Prepares the sphere for a frame whose shutter is open over `interval`.
    pub fn prepare(&self, interval: Interval) -> PreparedSphere {
        PreparedSphere {
            motion: self.motion.prepare(interval),
            radius: self.radius,
        }
    }
}

impl PreparedSphere {
    /// The sphere's boxes at the opening and the closing of `interval` (the one it was
    /// prepared for), for a hierarchy that interpolates them linearly over the shutter: at
    /// any time of the interval the sphere lies inside their interpolation. A fixed or
    /// linear path has the boxes of its two ends (the closing one as `start + velocity *
    /// (close - open)`, the centre a tracer computes at the closing); a curved one has the
    /// box of its whole path at both ends.
    pub(crate) fn shutter_boxes(&self, interval: Interval) -> (Aabb, Aabb) {
        let r = self.radius;
        let (open, close) = match &self.motion {
            FrameMotion::Fixed(c) => {
                let b = Aabb::point(*c).grow(r);
                (b, b)
            }
            FrameMotion::Linear {
                start, velocity, ..
            } => (
                Aabb::point(*start).grow(r),
                Aabb::point(*start + *velocity * (interval.close - interval.open)).grow(r),
            ),
            curved => {
                let b = curved.bounds(interval, r);
                (b, b)
            }
        };
        pad_for_interpolation(open, close)
    }
}

/// Grows the boxes a sphere has at the shutter's opening and closing so that their linear
/// interpolation at any time, as a traversal rounds it, still contains the sphere with its
/// centre at `start + velocity * (t - open)` as rounded: by 64 units in the last place of
/// their largest coordinate, which is several times the few roundings of either computation
/// (`lo + s (hi - lo)`, `c + v dt`).
pub(crate) fn pad_for_interpolation(open: Aabb, close: Aabb) -> (Aabb, Aabb) {
    let m = open
        .min
        .abs()
        .max(open.max.abs())
        .max(close.min.abs())
        .max(close.max.abs())
        .max_element();
    let pad = m * 64.0 * f64::EPSILON;
    (open.grow(pad), close.grow(pad))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(origin: DVec3, dir: DVec3) -> Ray {
        Ray {
            origin,
            dir: dir.normalize(),
            time: 0.0,
        }
    }

    /// The boxes at the shutter's ends, interpolated as a traversal does at any time of the
    /// interval, contain the sphere where the tracer places it then: for fixed, linear,
    /// keyframed and circular paths, near the origin and far from it.
    #[test]
    fn interpolated_shutter_boxes_contain_the_sphere() {
        use crate::motion::{Key, Orbit};
        let mut rng = crate::rng::Pcg32::new(17, 3);
        for far in [0.0, 1e5] {
            let at = DVec3::new(far, -0.5 * far, 0.25 * far);
            let motions = [
                Motion::Still(at),
                Motion::Velocity {
                    origin: at,
                    velocity: DVec3::new(30.0, -2.0, 7.0),
                },
                Motion::Keyframes(vec![
                    Key {
                        time: 0.0,
                        position: at,
                    },
                    Key {
                        time: 0.3,
                        position: at + DVec3::new(4.0, 1.0, -2.0),
                    },
                    Key {
                        time: 0.5,
                        position: at - DVec3::Y,
                    },
                ]),
                Motion::Orbit {
                    origin: at + DVec3::X,
                    orbit: Orbit {
                        pivot: at,
                        axis: DVec3::new(0.3, 1.0, 0.1).normalize(),
                        degrees_per_second: 900.0,
                    },
                },
            ];
            for motion in motions {
                let sphere = SphereDesc {
                    motion,
                    radius: 0.7,
                    material: 0,
                };
                for _ in 0..200 {
                    let open = rng.next_f64() * 0.6;
                    let interval = Interval {
                        open,
                        close: open + rng.next_f64() * 0.1,
                    };
                    let p = sphere.prepare(interval);
                    let (lo, hi) = p.shutter_boxes(interval);
                    let duration = interval.close - interval.open;
                    for _ in 0..20 {
                        let t = interval.at(rng.next_f64());
                        let dt = t - interval.open;
                        let center = match &p.motion {
                            FrameMotion::Linear {
                                start, velocity, ..
                            } => *start + *velocity * dt,
                            m => m.at(t),
                        };
                        let s = if duration > 0.0 { dt / duration } else { 0.0 };
                        let b = Aabb {
                            min: lo.min + s * (hi.min - lo.min),
                            max: lo.max + s * (hi.max - lo.max),
                        };
                        let want = Aabb::point(center).grow(p.radius);
                        assert!(b.contains(&want), "{p:?} at {t}: {want:?} not in {b:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn hits_the_near_side_from_outside_and_far_side_from_inside() {
        let c = DVec3::new(0.0, 0.0, -5.0);
        let t = intersect(c, 1.0, &ray(DVec3::ZERO, -DVec3::Z), f64::INFINITY).unwrap();
        assert!((t - 4.0).abs() < 1e-15);
        let t = intersect(c, 1.0, &ray(c, DVec3::X), f64::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-15);
        assert!(intersect(c, 1.0, &ray(DVec3::ZERO, DVec3::Z), f64::INFINITY).is_none());
        assert!(intersect(c, 1.0, &ray(DVec3::ZERO, -DVec3::Z), 3.0).is_none());
        assert!(
            intersect(
                c,
                1.0,
                &ray(DVec3::new(1.5, 0.0, 0.0), -DVec3::Z),
                f64::INFINITY
            )
            .is_none()
        );
    }

    #[test]
    fn tiny_sphere_far_away_keeps_its_digits() {
        // Radius 1e-4 at distance 1e6: the naive discriminant b^2 - c loses every digit.
        let c = DVec3::new(0.0, 0.0, -1e6);
        for k in 0..=20 {
            let off = 0.99e-4 * k as f64 / 20.0;
            let r = ray(DVec3::new(off, 0.0, 0.0), -DVec3::Z);
            let t = intersect(c, 1e-4, &r, f64::INFINITY).expect("hit");
            let exact = 1e6 - (1e-8 - off * off).sqrt();
            assert!((t - exact).abs() <= 1e-9, "offset {off}: t {t} vs {exact}");
            let sp = surface_point(c, 1e-4, &r, t);
            // On the sphere to the precision of coordinates near 1e6 (an ulp is 1.2e-10).
            assert!((((sp.p - c).length()) - 1e-4).abs() < 4e-10);
        }
    }

    /// Rays aimed within a few ulps of the silhouette: every hit of a ray from outside must
    /// face the ray (`dir . normal < 0`), or the material takes it for a ray leaving the
    /// inside and traps it there; every ray from inside must hit and leave.
    #[test]
    fn grazing_hits_are_oriented_by_the_side_the_ray_comes_from() {
        let mut rng = crate::rng::Pcg32::new(5, 11);
        for &(scale, dist) in &[(1e-4, 0.0), (1.0, 0.0), (1e6, 0.0), (1e-4, 1e6), (1.0, 1e6)] {
            let c = DVec3::new(1.0, -0.6, 0.35).normalize() * dist;
            for k in 0..20_000 {
                let mut u = || rng.next_f64() * 2.0 - 1.0;
                let o = c + DVec3::new(u(), u(), u()).normalize() * (3.0 * scale);
                // o - c is exact (Sterbenz), so the impact parameter is exact to an ulp.
                let f = o - c;
                let toward = -f.normalize();
                let side = toward.any_orthonormal_vector();
                let side = (side * u() + toward.cross(side) * u()).normalize();
                let delta = (k % 9) as f64 * 1.1e-16 - 4.4e-16;
                let sin = scale * (1.0 - delta) / f.length();
                let r = ray(o, toward * (1.0 - sin * sin).sqrt() + side * sin);
                if let Some(t) = intersect(c, scale, &r, f64::INFINITY) {
                    let sp = surface_point(c, scale, &r, t);
                    assert!(
                        r.dir.dot(sp.normal) < 0.0,
                        "scale {scale} at {dist}, delta {delta}: hit from outside faces away"
                    );
                }
                // From inside (by more than the rounding of positions near 1e6), nearly
                // tangent: always leaves through the far side.
                let inside = c + DVec3::new(u(), u(), u()).normalize() * (scale * (1.0 - 1e-5));
                let n = (inside - c).normalize();
                let along = n.any_orthonormal_vector();
                let r = ray(inside, along + n * (u() * 1e-9));
                let t = intersect(c, scale, &r, f64::INFINITY).expect("a ray from inside leaves");
                let sp = surface_point(c, scale, &r, t);
                assert!(
                    r.dir.dot(sp.normal) > 0.0,
                    "scale {scale} at {dist}: exit faces in"
                );
            }
        }
    }

    #[test]
    fn leaving_ray_does_not_hit_its_sphere_again() {
        let mut rng = crate::rng::Pcg32::new(9, 9);
        for &(scale, dist) in &[(1e-4, 0.0), (1.0, 1e3), (1e6, 0.0), (1e-3, 1e6), (1.0, 1e6)] {
            let c = DVec3::new(dist, -dist * 0.5, 0.3 * dist);
            for _ in 0..2000 {
                let mut u = || rng.next_f64() * 2.0 - 1.0;
                let o = c + DVec3::new(u(), u(), u()).normalize() * scale * 3.0;
                let r = ray(o, (c + DVec3::new(u(), u(), u()) * scale * 0.5) - o);
                let Some(t) = intersect(c, scale, &r, f64::INFINITY) else {
                    continue;
                };
                let sp = surface_point(c, scale, &r, t);
                // Leave outward and inward; outward must never re-hit, inward must hit the far side.
                let w_out = (sp.normal + DVec3::new(u(), u(), u()).normalize() * 0.99).normalize();
                if w_out.dot(sp.normal) > 0.0 {
                    let o2 = crate::ray::offset_origin(sp.p, sp.p_error, sp.normal, w_out);
                    let r2 = Ray {
                        origin: o2,
                        dir: w_out,
                        time: 0.0,
                    };
                    assert!(
                        intersect(c, scale, &r2, f64::INFINITY).is_none(),
                        "scale {scale} dist {dist}"
                    );
                }
                let o3 = crate::ray::offset_origin(sp.p, sp.p_error, sp.normal, r.dir);
                let r3 = Ray {
                    origin: o3,
                    dir: r.dir,
                    time: 0.0,
                };
                let t3 = intersect(c, scale, &r3, f64::INFINITY).expect("far side");
                assert!(t3 > 1e-6 * scale || (t3 > 0.0 && r.dir.dot(sp.normal).abs() < 1e-3));
            }
        }
    }
}
