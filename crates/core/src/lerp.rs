//! Linear interpolation, kept in one place so every caller uses the same, exact form.

use glam::DVec3;

/// `a + (b - a) * t` would not return `b` exactly at `t = 1`; this form returns `a` at 0 and
/// `b` at 1 exactly and is monotonic in `t` for finite inputs.
#[inline]
pub(crate) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    (1.0 - t) * a + t * b
}

/// Component-wise [`lerp`].
#[inline]
pub(crate) fn lerp3(a: DVec3, b: DVec3, t: f64) -> DVec3 {
    (1.0 - t) * a + t * b
}

/// Where `x` lies between `a` and `b`, as a fraction in [0, 1]; `a < b` is required and clamps
/// outside. Used for keyframe segments, whose lengths are validated to be positive.
#[inline]
pub(crate) fn inverse_lerp(a: f64, b: f64, x: f64) -> f64 {
    debug_assert!(a < b);
    ((x - a) / (b - a)).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints_are_exact() {
        for &(a, b) in &[(0.1, 0.7), (-3.0, 1e9), (1e-300, 2e-300), (5.0, 5.0)] {
            assert_eq!(lerp(a, b, 0.0), a);
            assert_eq!(lerp(a, b, 1.0), b);
        }
    }

    #[test]
    fn midpoint_and_monotonic() {
        assert_eq!(lerp(2.0, 4.0, 0.5), 3.0);
        let mut prev = lerp(0.1, 0.3, 0.0);
        for i in 1..=1000 {
            let v = lerp(0.1, 0.3, i as f64 / 1000.0);
            assert!(v >= prev);
            prev = v;
        }
    }

    #[test]
    fn vector_form_matches_scalar() {
        let a = DVec3::new(1.0, -2.0, 3.5);
        let b = DVec3::new(-4.0, 8.0, 0.25);
        let v = lerp3(a, b, 0.3);
        assert_eq!(v.x, lerp(1.0, -4.0, 0.3));
        assert_eq!(v.y, lerp(-2.0, 8.0, 0.3));
        assert_eq!(v.z, lerp(3.5, 0.25, 0.3));
    }

    #[test]
    fn inverse_undoes_lerp_and_clamps() {
        assert!((inverse_lerp(2.0, 6.0, lerp(2.0, 6.0, 0.25)) - 0.25).abs() < 1e-15);
        assert_eq!(inverse_lerp(2.0, 6.0, -10.0), 0.0);
        assert_eq!(inverse_lerp(2.0, 6.0, 10.0), 1.0);
    }
}
