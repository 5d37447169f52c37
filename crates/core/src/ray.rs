//! Rays in spacetime, and spawning a new ray from a surface without hitting it again.

use glam::DVec3;

/// A ray: `origin + t * dir` for `t > 0`, at absolute time `time`. `dir` has unit length.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: DVec3,
    pub dir: DVec3,
    pub time: f64,
}

impl Ray {
    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + t * self.dir
    }
}

/// `gamma(n) = n u / (1 - n u)` with `u` the unit roundoff (half an ulp of 1), which bounds the
/// relative error of `n` successive floating-point operations (pbrt-v4, section 6.8.1).
pub const fn gamma(n: u32) -> f64 {
    let nu = n as f64 * (f64::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// The origin for a ray leaving a surface point `p` (with absolute error at most `p_error`
/// per component) in direction `w`, on the side of the geometric normal `n` that `w` points
/// to. Moves `p` along `n` by the projection of the error box onto the normal, then one ulp
/// further away from `p`, so the new origin is certainly on `w`'s side of the true surface
/// (pbrt-v4, `OffsetRayOrigin`, section 6.8.6).
#[inline]
pub(crate) fn offset_origin(p: DVec3, p_error: DVec3, n: DVec3, w: DVec3) -> DVec3 {
    let d = n.abs().dot(p_error);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let mut po = p + offset;
    for i in 0..3 {
        if offset[i] > 0.0 {
            po[i] = po[i].next_up();
        } else if offset[i] < 0.0 {
            po[i] = po[i].next_down();
        }
    }
    po
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_bounds() {
        assert!(gamma(1) > f64::EPSILON * 0.5);
        assert!(gamma(5) < 5.0 * f64::EPSILON);
    }

    #[test]
    fn offset_moves_to_the_side_of_the_direction() {
        let p = DVec3::new(1.0, 2.0, 3.0);
        let err = DVec3::splat(1e-12);
        let n = DVec3::Y;
        let out = offset_origin(p, err, n, DVec3::new(0.3, 1.0, 0.0));
        assert!(out.y > p.y && out.x == p.x && out.z == p.z);
        let inside = offset_origin(p, err, n, DVec3::new(0.3, -1.0, 0.0));
        assert!(inside.y < p.y);
        // A point known exactly is not moved: the offset is zero, so no component is nudged.
        let exact = offset_origin(p, DVec3::ZERO, n, n);
        assert_eq!(exact, p);
    }
}
