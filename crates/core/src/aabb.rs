//! Axis-aligned bounding boxes.

use glam::DVec3;

/// An axis-aligned box `[min, max]`. [`Aabb::EMPTY`] has `min > max` and contains nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

impl Default for Aabb {
    /// The empty box.
    fn default() -> Aabb {
        Aabb::EMPTY
    }
}

impl Aabb {
    /// The empty box: the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    /// The box of a single point.
    pub fn point(p: DVec3) -> Aabb {
        Aabb { min: p, max: p }
    }

    /// The smallest box containing both.
    pub(crate) fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// The smallest box containing this one and `p`.
    pub(crate) fn union_point(&self, p: DVec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// This box grown by `r` on every side.
    pub fn grow(&self, r: f64) -> Aabb {
        Aabb {
            min: self.min - DVec3::splat(r),
            max: self.max + DVec3::splat(r),
        }
    }

    /// Grows the box by a few units in the last place of its largest coordinate, so that a
    /// point computed by a slightly different rounding of the same formula still lies inside.
    pub(crate) fn pad_for_rounding(&self) -> Aabb {
        let m = self.min.abs().max(self.max.abs()).max_element();
        self.grow(m * 8.0 * f64::EPSILON)
    }

    /// Whether `o` lies entirely inside this box.
    pub fn contains(&self, o: &Aabb) -> bool {
        self.min.cmple(o.min).all() && self.max.cmpge(o.max).all()
    }

    /// The centre of the box.
    pub fn centroid(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }

    /// Surface area; 0 for an empty box.
    pub(crate) fn surface_area(&self) -> f64 {
        let d = (self.max - self.min).max(DVec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// Slab test against a ray given by origin and reciprocal direction. Returns whether the ray
    /// overlaps the box for some `t` in `[t_min, t_max]`. Infinite reciprocals (axis-parallel
    /// rays) are handled by IEEE arithmetic; a NaN from `0 * inf` compares false and is ignored
    /// by `max`/`min`.
    #[inline]
    pub fn hit(&self, origin: DVec3, inv_dir: DVec3, t_min: f64, t_max: f64) -> bool {
        let t0 = (self.min - origin) * inv_dir;
        let t1 = (self.max - origin) * inv_dir;
        let near = t0.min(t1).max_element().max(t_min);
        let far = t0.max(t1).min_element().min(t_max);
        near <= far
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn union_contains_and_area() {
        let a = Aabb::point(DVec3::ZERO).union_point(DVec3::ONE);
        assert_eq!(a.surface_area(), 6.0);
        assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
        assert_eq!(Aabb::EMPTY.union(&a), a);
        assert!(a.contains(&Aabb::point(DVec3::splat(0.5))));
        assert!(!a.contains(&Aabb::point(DVec3::splat(1.5))));
        assert_eq!(a.centroid(), DVec3::splat(0.5));
    }

    #[test]
    fn slab_test() {
        let b = Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::splat(1.0),
        };
        let inv = |d: DVec3| DVec3::ONE / d;
        assert!(b.hit(
            DVec3::new(0.0, 0.0, -5.0),
            inv(DVec3::Z),
            0.0,
            f64::INFINITY
        ));
        assert!(!b.hit(
            DVec3::new(0.0, 0.0, -5.0),
            inv(-DVec3::Z),
            0.0,
            f64::INFINITY
        ));
        assert!(!b.hit(DVec3::new(0.0, 0.0, -5.0), inv(DVec3::Z), 0.0, 3.0));
        // Axis-parallel ray outside the slab of another axis.
        assert!(!b.hit(
            DVec3::new(2.0, 0.0, -5.0),
            inv(DVec3::Z),
            0.0,
            f64::INFINITY
        ));
        // Axis-parallel ray exactly on a face (0 * inf = NaN case) still counts as a hit.
        assert!(b.hit(
            DVec3::new(1.0, 0.0, -5.0),
            inv(DVec3::Z),
            0.0,
            f64::INFINITY
        ));
    }
}
