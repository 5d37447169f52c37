//! The slab test of a ray against a node's eight children at once: in `f32` lanes with every
//! rounding bounded outward, and in `f64` for the rare rays the lanes cannot take.

use glam::DVec3;

use super::boxes::{Boxes, Nodes};
use super::lanes::{LANES, Lanes};
use super::rounding::f32_below;

/// The relative error of an entry or exit distance computed in `f32` as
/// `(side - origin) * inverse`, with the side and origin `f32` and the inverse the `f32`
/// rounding of the `f64` reciprocal: at most three roundings to `f32` and one to `f64`, so
/// within `(1 + u)^3 (1 + 2^-53) < 1 + 3.01 u` with `u = 2^-24` (pbrt-v4, section 6.8.2),
/// unless the product is subnormal (then off by at most `2^-150`) or overflows (then
/// infinite, beyond every finite `f32` limit).
///
/// An entry distance is scaled by `NEAR_SCALE = 1 - 8u` (rounded, below `1 - 4u` of it):
/// below the exact one. An exit distance is scaled by `FAR_SCALE = 1 + 16u` and `TINY` added
/// (the smallest normal `f32`, for the subnormal case): above the exact one. pbrt-v4's
/// robust slab test widens the exit only (by `1 + 2 gamma(3)`); here both are bounded, since
/// entry distances also prune the stack.
const NEAR_SCALE: f32 = 1.0 - 1.0 / (1 << 21) as f32;
const FAR_SCALE: f32 = 1.0 + 1.0 / (1 << 20) as f32;
const TINY: f32 = f32::MIN_POSITIVE;

/// An `f32` at or above `t * (1 + 16u)` (see [`NEAR_SCALE`]) past any nonnegative `f64`
/// `t`: children entered beyond it are not visited. `+inf` for `t` beyond the `f32` range.
#[inline]
pub(super) fn widened_limit(t: f64) -> f32 {
    // Rounded up past `t` without a branch: `t (1 + 2^-22)` exceeds `t` by more than its
    // rounding to `f32` (2^-24 of it), and `TINY` covers a subnormal `t`.
    (t * (1.0 + f64::from(2f32.powi(-22)))) as f32 * FAR_SCALE + TINY
}

/// A ray's test against the children of a node.
pub(super) trait SlabTest {
    /// The children of `node` (with `boxes`) the ray may enter before the distance `t_max`,
    /// or `limit` (an `f32` at or above it, [`widened_limit`]), as bits, and their entry
    /// distances, at most the true ones.
    fn test(&self, boxes: &Boxes, node: usize, limit: f32, t_max: f64) -> (u32, [f32; LANES]);

    /// [`SlabTest::test`] as walks in turns make it (`walks.rs`), one walk's after another's:
    /// the same result, without a branch on the ray.
    #[inline(always)]
    fn test_in_turns(
        &self,
        boxes: &Boxes,
        node: usize,
        limit: f32,
        t_max: f64,
    ) -> (u32, [f32; LANES]) {
        self.test(boxes, node, limit, t_max)
    }
}

/// A ray as the `f32` slab test reads it, on the lanes of machine `M`: per axis, its
/// reciprocal direction, and its origin rounded to `f32` both ways; whether its direction is
/// negative; the shutter time. (A copy per ray and per walk: the per-axis masks a select
/// takes are made at each test, where holding them made the books' spheres, which walk
/// alone, 3% to 4% slower.)
#[derive(Clone, Copy)]
pub(super) struct RayLanes<M: Lanes> {
    m: M,
    inv: [M::V; 3],
    /// The origin rounded up, subtracted from lower sides: `lower - origin` comes out at
    /// most the exact difference, so a positive direction's entry distance is not
    /// overestimated, nor a negative one's exit distance underestimated.
    o_up: [M::V; 3],
    /// The origin rounded down, for upper sides (the mirror image).
    o_down: [M::V; 3],
    /// Per axis, whether the direction is negative: the ray enters through the upper side.
    negative: [bool; 3],
    s: M::V,
    /// The shutter time in `f32`, for compact nodes' per-node terms.
    s32: f32,
}

impl<M: Lanes> RayLanes<M> {
    /// `None` if some origin coordinate exceeds 1e30 in magnitude or some direction
    /// component is below 1e-30 (its reciprocal would be beyond the `f32` range).
    #[inline(always)]
    pub(super) fn new(m: M, origin: DVec3, dir: DVec3, s: f64) -> Option<RayLanes<M>> {
        if !(origin.abs().max_element() <= 1e30 && dir.abs().min_element() >= 1e-30) {
            return None;
        }
        let inv = (DVec3::ONE / dir).as_vec3();
        // `origin -+ m` rounded to the nearest `f32` is below (above) `origin`: `m` exceeds
        // the rounding to `f32` (at most 2^-24 of the magnitude, or 2^-150 below the normal
        // range) and the two `f64` roundings before it. Without the branches of
        // `f32_below`, whose outcome is a coin toss per ray; one `f32` ulp looser.
        let margin = origin.abs() * f64::from(2f32.powi(-23)) + f64::from(f32::MIN_POSITIVE);
        let (up, down) = ((origin + margin).as_vec3(), (origin - margin).as_vec3());
        Some(RayLanes {
            m,
            inv: splat3(m, inv),
            o_up: splat3(m, up),
            o_down: splat3(m, down),
            negative: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0],
            s: m.splat(s as f32),
            s32: s as f32,
        })
    }

    /// Along axis `a`, the distances to a box's lower and upper sides, with the rounded
    /// origins they take, as (entry, exit), ordered by `O`.
    #[inline(always)]
    fn axis<O: Orient>(&self, a: usize, lower: M::V, upper: M::V) -> (M::V, M::V) {
        let m = self.m;
        let lower = m.mul(m.sub(lower, self.o_up[a]), self.inv[a]);
        let upper = m.mul(m.sub(upper, self.o_down[a]), self.inv[a]);
        O::entry_exit(self, a, lower, upper)
    }

    /// The slab test of the children of `node`, each axis's distances ordered by `O`.
    #[inline(always)]
    fn test_by<O: Orient>(&self, boxes: &Boxes, node: usize, limit: f32) -> (u32, [f32; LANES]) {
        let m = self.m;
        let mut near = m.splat(0.0);
        let mut far = m.splat(f32::INFINITY);
        // `max` and `min` keep the running value when the new one is NaN (0 * inf cannot
        // arise with a finite reciprocal, but a NaN side can), which leaves that axis out.
        for a in 0..3 {
            let (lower, upper) = match &boxes.nodes {
                Nodes::Still(n) => {
                    let planes = &n[node].planes;
                    (m.load(&planes[a]), m.load(&planes[3 + a]))
                }
                Nodes::Moving(n) => {
                    let [planes, d] = &n[node];
                    let (planes, d) = (&planes.planes, &d.planes);
                    // Evaluated in `f32` (a product, then a sum: no fused multiply-add), as
                    // `moving_lower` allows for.
                    (
                        m.add(m.load(&planes[a]), m.mul(self.s, m.load(&d[a]))),
                        m.add(m.load(&planes[3 + a]), m.mul(self.s, m.load(&d[3 + a]))),
                    )
                }
                Nodes::Compact(n) => n[node].sides(m, a, self.s32),
            };
            let (n, f) = self.axis::<O>(a, lower, upper);
            near = m.max_keep(n, near);
            far = m.min_keep(f, far);
        }
        let near = m.mul(near, m.splat(NEAR_SCALE));
        let far = m.min_keep(
            m.add(m.mul(far, m.splat(FAR_SCALE)), m.splat(TINY)),
            m.splat(limit),
        );
        (m.le_mask(near, far), m.to_array(near))
    }
}

/// How a ray's test orders an axis's distances to a box's lower and upper sides into entry
/// and exit (the upper first for a negative direction): the same values either way.
trait Orient {
    fn entry_exit<M: Lanes>(ray: &RayLanes<M>, a: usize, lower: M::V, upper: M::V) -> (M::V, M::V);
}

/// By a branch on the direction's sign: a walk alone tests node after node with the same
/// signs, so the branch is predicted, and it adds nothing to the distances' latency, which
/// bounds a walk alone.
struct ByBranch;

impl Orient for ByBranch {
    #[inline(always)]
    fn entry_exit<M: Lanes>(ray: &RayLanes<M>, a: usize, lower: M::V, upper: M::V) -> (M::V, M::V) {
        // A select of values, not of indices: no bounds checks in the loop.
        if ray.negative[a] {
            (upper, lower)
        } else {
            (lower, upper)
        }
    }
}

/// By a select ([`Lanes::select`]): walks in turns test one walk's node after another's,
/// whose signs differ, and a mispredicted branch threw away the tests started after it
/// (`walks.rs`).
struct BySelect;

impl Orient for BySelect {
    #[inline(always)]
    fn entry_exit<M: Lanes>(ray: &RayLanes<M>, a: usize, lower: M::V, upper: M::V) -> (M::V, M::V) {
        let (m, negative) = (ray.m, ray.m.all_ones(ray.negative[a]));
        (
            m.select(negative, upper, lower),
            m.select(negative, lower, upper),
        )
    }
}

/// Each coordinate of `v` in all lanes. A function of its own, always inlined: a closure or
/// `array::from_fn` here was left out of line, compiled without the AVX kernel's features.
#[inline(always)]
fn splat3<M: Lanes>(m: M, v: glam::Vec3) -> [M::V; 3] {
    [m.splat(v.x), m.splat(v.y), m.splat(v.z)]
}

impl<M: Lanes> SlabTest for RayLanes<M> {
    /// Entry distances at most the exact ones (computed in real arithmetic from the `f64`
    /// origin and direction, against the box a traversal's `f32` evaluation gives).
    #[inline(always)]
    fn test(&self, boxes: &Boxes, node: usize, limit: f32, _: f64) -> (u32, [f32; LANES]) {
        self.test_by::<ByBranch>(boxes, node, limit)
    }

    #[inline(always)]
    fn test_in_turns(&self, boxes: &Boxes, node: usize, limit: f32, _: f64) -> (u32, [f32; LANES]) {
        self.test_by::<BySelect>(boxes, node, limit)
    }
}

/// A ray as the `f64` slab test reads it, for rays [`RayLanes`] cannot take.
pub(super) struct RayF64 {
    inv: [f64; 3],
    o: [f64; 3],
    entry: [usize; 3],
    exit: [usize; 3],
    s: f32,
}

impl RayF64 {
    // Out of line, as `test` is: the rare path stays out of the traversal's code.
    #[inline(never)]
    pub(super) fn new(origin: DVec3, dir: DVec3, s: f64) -> RayF64 {
        let inv = (DVec3::ONE / dir).to_array();
        // Per axis, the index in `ChildBoxes::planes` of the planes through which the ray
        // enters and leaves boxes: the upper one first for a negative direction. Taken from
        // the reciprocal so that a direction of -0 (reciprocal -inf) counts as negative.
        RayF64 {
            inv,
            o: origin.to_array(),
            entry: std::array::from_fn(|a| if inv[a] < 0.0 { 3 + a } else { a }),
            exit: std::array::from_fn(|a| if inv[a] < 0.0 { a } else { 3 + a }),
            s: s as f32,
        }
    }
}

impl SlabTest for RayF64 {
    /// Tested against `t_max`, with the entry distances rounded down to `f32`.
    #[inline(never)]
    fn test(&self, boxes: &Boxes, node: usize, _: f32, t_max: f64) -> (u32, [f32; LANES]) {
        let (o, inv, s32) = (&self.o, &self.inv, self.s);
        let mut near = [0.0f64; LANES];
        let mut far = [t_max; LANES];
        // `max` and `min` ignore a NaN (0 * inf: a ray in a box's face plane, parallel
        // to it), which leaves that axis out of the interval.
        // Per side (as `ChildBoxes::planes` numbers them), its eight children's values.
        let side = |i: usize| -> [f64; LANES] {
            match &boxes.nodes {
                Nodes::Still(n) => n[node].planes[i].map(f64::from),
                // In `f32`, which `moving_lower`'s margin allows for.
                Nodes::Moving(n) => {
                    let [planes, d] = &n[node];
                    std::array::from_fn(|k| f64::from(planes.planes[i][k] + s32 * d.planes[i][k]))
                }
                Nodes::Compact(n) => n[node].side_values(i, s32).map(f64::from),
            }
        };
        for a in 0..3 {
            let (entry, exit) = (side(self.entry[a]), side(self.exit[a]));
            for k in 0..LANES {
                near[k] = near[k].max((entry[k] - o[a]) * inv[a]);
                far[k] = far[k].min((exit[k] - o[a]) * inv[a]);
            }
        }
        let mut mask = 0;
        for k in 0..LANES {
            mask |= u32::from(near[k] <= far[k]) << k;
        }
        (mask, near.map(f32_below))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aabb::Aabb;
    use crate::bvh::boxes::{ChildBoxes, set_moving};
    use crate::bvh::compact::CompactNode;
    use crate::bvh::lanes::Plain;
    use crate::rng::Pcg32;

    /// The `f32` slab test on machine `m` never misses a child the `f64` one hits, and never
    /// puts a child's entry beyond the `f64` one's, and gives the bits plain arrays give:
    /// random boxes and rays at scales from 1e-6 to 1e6 and far from the origin, rays
    /// starting on or a few ulps off a face, running along faces, and nearly axis-parallel
    /// (reciprocals up to 1e29); still and moving nodes, any time and limit.
    fn conservative_on<M: Lanes>(m: M) {
        let mut r = Pcg32::new(41, 3);
        let (mut checked, mut hits) = (0u32, 0u32);
        for round in 0..40_000 {
            let offset = [0.0, 1e6, -3e4, 2e-6][round % 4];
            let scale = [1.0, 30.0, 1e-6, 1e-3][(round / 4) % 4];
            let v = |r: &mut Pcg32| {
                (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5) * scale
            };
            let boxes: Vec<Aabb> = (0..LANES)
                .map(|_| {
                    let c = DVec3::splat(offset) + v(&mut r);
                    Aabb {
                        min: c - v(&mut r).abs(),
                        max: c + v(&mut r).abs(),
                    }
                })
                .collect();
            let moved: Vec<Aabb> = boxes
                .iter()
                .map(|b| Aabb {
                    min: b.min + v(&mut r) * 0.3,
                    max: b.max + v(&mut r) * 0.3,
                })
                .collect();
            let mut still = ChildBoxes::EMPTY;
            let mut moving = [ChildBoxes::EMPTY, ChildBoxes::ZERO];
            // The last slots stay empty one time in four.
            for k in 0..LANES - 3 * usize::from(round % 4 == 1) {
                still.set(k, &boxes[k]);
                set_moving(&mut moving, k, &boxes[k], &moved[k]);
            }
            let nodes = [
                Boxes {
                    nodes: Nodes::Still(vec![still]),
                    ..Boxes::default()
                },
                Boxes {
                    nodes: Nodes::Moving(vec![moving]),
                    ..Boxes::default()
                },
                Boxes {
                    nodes: Nodes::Compact(vec![CompactNode::new(
                        &std::array::from_fn(|k| {
                            (k < LANES - 3 * usize::from(round % 4 == 1))
                                .then(|| (boxes[k], moved[k]))
                        }),
                        &crate::bvh::links::Links::default(),
                    )]),
                    ..Boxes::default()
                },
            ];
            // A point on a face of a box (as stored), or a few ulps off it, or anywhere.
            let k = (r.next_f64() * 5.0) as usize % 5;
            let axis = (r.next_f64() * 3.0) as usize;
            let mut origin = DVec3::splat(offset) + v(&mut r) * 1.5;
            let side = if r.next_f64() < 0.5 { axis } else { 3 + axis };
            match round % 3 {
                0 => origin[axis] = f64::from(still.planes[side][k]),
                1 => {
                    let p = f64::from(still.planes[side][k]);
                    origin[axis] = p + (r.next_f64() - 0.5) * 8.0 * f64::EPSILON * p.abs();
                }
                _ => {}
            }
            let mut dir = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5;
            // Along a face, or nearly axis-parallel.
            match (round / 3) % 4 {
                0 => dir[axis] = 0.0,
                1 => dir[axis] = 1e-29 * (r.next_f64() - 0.5),
                _ => {}
            }
            let dir = dir.normalize();
            let s = [0.0, 1.0, r.next_f64()][round % 3];
            let t_max = [f64::INFINITY, r.next_f64() * 2.0 * scale][round % 2];
            let Some(lanes) = RayLanes::new(m, origin, dir, s) else {
                assert!(dir.abs().min_element() < 1e-30);
                continue;
            };
            let plain = RayLanes::new(Plain, origin, dir, s).unwrap();
            let exact = RayF64::new(origin, dir, s);
            for boxes in &nodes {
                let limit = widened_limit(t_max);
                let (mask, near) = lanes.test(boxes, 0, limit, t_max);
                let (want, want_near) = exact.test(boxes, 0, limit, t_max);
                let (plain_mask, plain_near) = plain.test(boxes, 0, limit, t_max);
                assert_eq!(mask, plain_mask);
                assert_eq!(near.map(f32::to_bits), plain_near.map(f32::to_bits));
                // In turns (a select on the direction's signs) the same bits.
                let (turns_mask, turns_near) = lanes.test_in_turns(boxes, 0, limit, t_max);
                assert_eq!(turns_mask, mask);
                assert_eq!(turns_near.map(f32::to_bits), near.map(f32::to_bits));
                // The `f64` entry, as exact: `RayF64` rounds it down to `f32`.
                assert_eq!(mask & want, want, "{origin:?} {dir:?} {s} {t_max}");
                for k in 0..LANES {
                    if want & (1 << k) != 0 {
                        assert!(near[k] <= want_near[k], "{origin:?} {dir:?} {k}");
                        assert!(near[k] <= limit);
                    }
                }
                checked += 1;
                hits += want.count_ones();
            }
        }
        // Most rays are taken by the `f32` test, and a fair share of children are hit.
        assert!(checked > 50_000 && hits > 40_000, "{checked} {hits}");
    }

    #[test]
    fn f32_slab_test_is_conservative() {
        conservative_on(Plain);
        #[cfg(target_arch = "x86_64")]
        {
            use crate::bvh::lanes::{Avx, Sse};
            conservative_on(Sse);
            let v3 = crate::bvh::lanes::avx_where_available();
            if let Some(v3) = v3 {
                v3.vectorize(|| conservative_on(Avx(v3)));
            }
        }
    }
}
