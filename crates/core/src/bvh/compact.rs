//! A moving node's eight children's boxes in 128 bytes instead of 384: each side of each
//! child at the shutter's opening and at its closing as an 8-bit step on a grid of the node's
//! own (its lower corner and a power-of-two step per axis, at each end of the shutter), as
//! Embree's compressed nodes quantise a child's box in its parent's (Ylitie, Karras and
//! Laine 2017, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs").
//! With a copy of the node's children (its links) beside them, a node is 160 bytes on three
//! cache lines of one page, where a moving node and its links are seven lines on two pages;
//! each side rounded outward, so a box only grows. For hierarchies far larger than the cache
//! (a frame of ten million points), whose every node a ray reads is a miss.
//!
//! **Why the evaluated box holds the primitives.** Per axis and end `e` (0 the opening, 1 the
//! closing) a node stores an `f32` origin `O_e` and a step `S_e = 2^x_e`; a child's lower side
//! at that end is `P_e = O_e + q_e S_e` (exact in real arithmetic) with an integer `q_e` in
//! 0..=255 chosen so that `P_e <= L_e - δ`, `L_e` the side it stands for and `δ` a margin
//! (upper sides the mirror: `P_e >= U_e + δ`). A traversal at shutter time `s` evaluates, in
//! `f32` (`s` rounded to `f32`: `σ`),
//!
//! `lower = (Os + q_0 * A_0) + q_1 * A_1`, with `Os = O_0 + σ * (O_1 - O_0)`,
//! `A_0 = (1 - σ) * S_0` and `A_1 = σ * S_1`
//!
//! (`Os`, `A_0`, `A_1` once per node and axis, the rest in lanes; a product, then a sum, no
//! fused multiply-add, so every machine gives the same bits). In real arithmetic that is
//! `P(σ) = (1 - σ) P_0 + σ P_1`, at most `(1 - σ) L_0 + σ L_1 - δ`: the interpolation every
//! box of a moving hierarchy stands for, less `δ`. Let `M` be the largest magnitude of the
//! node's own box's sides at either end; then `|O_e| <= 1.01 M` and `255 S_e < 2 (2M + 2δ)`.
//! The roundings (pbrt-v4's reasoning, `u = 2^-24`): `Os` three, at most `7u` of `1.01 M`;
//! `A_1` none (a power of two times `σ`), `A_0` one; each product one and each sum one, at most
//! `u` of their magnitudes (below `K + 2Q`, `K = 1.01 M`, `Q = 4.1 M`): in all under
//! `9uK + 6uQ + 2u (K + 2Q)`; and `σ` is off `s` by at most `u`, which moves `P` by at most
//! `u |P_1 - P_0| <= 2u (K + Q)`. Together under `63 u M < 2^-18 M`, and
//! `δ = 2^-16 M + 2^-130` is four times that (its last term for the roundings of nodes below
//! the normal range, whose steps are at least `2^-126`): the evaluated lower side lies
//! below the exact interpolation at every `s` in [0, 1], the upper side above it. The rare
//! rays the lanes cannot take (`RayF64`) read the same `f32` sides.
//!
//! The grid needs the node's sides finite and within `2^100` of the origin (so no step or
//! sum overflows); [`representable`] says whether a hierarchy's box is, and a hierarchy
//! beyond it keeps `f32` sides (`Topology::refit_compact_with`). An empty slot is stored as
//! the node's whole grid turned inside out (lower sides at step 255, upper at 0), which no
//! ray enters but by the rounding of a distance hundreds of millions of steps away, and a
//! traversal skips an empty slot it enters.

use crate::aabb::Aabb;

use super::lanes::{LANES, Lanes};
use super::links::Links;

/// The margin `δ` of a node whose sides are at most `m` in magnitude (see the module's
/// documentation): `2^-16 m + 2^-130`.
fn margin(m: f64) -> f64 {
    m * 2f64.powi(-16) + 2f64.powi(-130)
}

/// The largest magnitude a hierarchy's box may have for its nodes to be stored compact.
const LARGEST: f64 = 1.2676506002282294e30; // 2^100

/// Whether boxes inside `bounds` can be stored compact: finite and within `2^100` of the
/// origin (an empty box, infinite, cannot).
pub(super) fn representable(bounds: &Aabb) -> bool {
    // Written so that a NaN side is not representable.
    (0..3).all(|a| bounds.min[a].abs() <= LARGEST && bounds.max[a].abs() <= LARGEST)
}

/// The sides of eight children, quantised on the node's grid at the shutter's opening and
/// closing, and the node's children: 32 bytes of links, 96 of steps, 24 of origins and the
/// steps' exponents, 160 in all, on three cache lines.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub(super) struct CompactNode {
    /// The node's children, a copy of the topology's: read with the boxes, from the same
    /// lines (in a hierarchy far larger than the cache, one page walk a node instead of two).
    pub(super) links: Links,
    /// `q[e][side][child]`: end `e` (0 opening, 1 closing), sides as
    /// `ChildBoxes::planes` orders them (lower x, y, z, then upper x, y, z).
    q: [[[u8; LANES]; 6]; 2],
    /// `origin[e][axis]`: the grid's lower corner at end `e`.
    origin: [[f32; 3]; 2],
    /// `exponent[e][axis]`: the grid's step at end `e` is `2^exponent`, at least `2^-126`.
    exponent: [[i8; 3]; 2],
}

/// The exponent of the smallest `f32` power of two at or above `span`, within -126..=127
/// (read from the bits of `span`, positive and normal, or -126).
fn exponent_above(span: f64) -> i8 {
    // Also a NaN.
    if span.is_nan() || span < f64::MIN_POSITIVE {
        return -126;
    }
    let bits = span.to_bits();
    let exponent = ((bits >> 52) & 0x7ff) as i64 - 1023;
    // Above the power of two its exponent gives, unless the mantissa is zero.
    let up = exponent + i64::from(bits & ((1 << 52) - 1) != 0);
    up.clamp(-126, 127) as i8
}

/// The `f32` power of two `2^x`, for `x` in -126..=127.
#[inline(always)]
fn power_of_two(x: i8) -> f32 {
    f32::from_bits(((i32::from(x) + 127) as u32) << 23)
}

/// An end's sides of eight empty slots: the grid inside out, lower sides at its last step and
/// upper sides at its first.
const EMPTY_END: [[u8; LANES]; 6] = [
    [255; LANES],
    [255; LANES],
    [255; LANES],
    [0; LANES],
    [0; LANES],
    [0; LANES],
];

/// A node's grid along one axis at one end: its origin, its step (a power of two) and the
/// step's reciprocal (exact, a power of two too).
#[derive(Clone, Copy, Debug)]
struct Grid {
    o: f64,
    step: f64,
    per_step: f64,
}

impl Grid {
    /// Per slot `k`, the largest step `lo` in 0..=255 whose side `o + lo * step` lies at or
    /// below `low[k]`, and the smallest `hi` whose side lies at or above `high[k]` (255 where
    /// none does, 0 for a NaN): each side down (up) to the grid, then checked, as the quotient
    /// may round across a step (`o + q step` is exact but for the sum's last bit, well inside
    /// the margin `δ` the caller's sides carry). Eight slots in two sets of four `f64` lanes
    /// where the build has AVX, with the same operations in the same order as
    /// [`Grid::steps_one_by_one`], so the same steps (a test checks): the compact nodes of a
    /// frame of ten million points took a thirteenth of its hierarchy's threads' time one by
    /// one.
    #[inline]
    fn steps(&self, low: &[f64; LANES], high: &[f64; LANES]) -> ([u8; LANES], [u8; LANES]) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
        {
            use safe_arch::*;
            let splat = set_splat_m256d;
            let (o, step, per_step) = (splat(self.o), splat(self.step), splat(self.per_step));
            let (zero, one, last) = (splat(0.0), splat(1.0), splat(255.0));
            let lt = cmp_op_mask_m256d::<{ cmp_op!(LessThanOrdered) }>;
            let gt = cmp_op_mask_m256d::<{ cmp_op!(GreaterThanOrdered) }>;
            // `as u8` in lanes: a NaN to 0 (`max` gives its second operand for a NaN first),
            // below 0 to 0, above 255 to 255, then truncated.
            let as_step = |x: m256d| {
                convert_to_m256d_from_i32_m128i(convert_truncate_to_i32_m128i_from_m256d(
                    min_m256d(max_m256d(x, zero), last),
                ))
            };
            let mut lo = [0u8; LANES];
            let mut hi = [0u8; LANES];
            for half in 0..2 {
                let four = |v: &[f64; LANES]| {
                    m256d::from_array([
                        v[4 * half],
                        v[4 * half + 1],
                        v[4 * half + 2],
                        v[4 * half + 3],
                    ])
                };
                let (low, high) = (four(low), four(high));
                let mut l = as_step((low - o) * per_step);
                loop {
                    let down = gt(l, zero) & gt(o + l * step, low);
                    if move_mask_m256d(down) == 0 {
                        break;
                    }
                    l -= one & down;
                }
                let up = (high - o) * per_step;
                let mut h = as_step(up);
                h += one & (lt(h, up) & lt(h, last));
                loop {
                    let rise = lt(h, last) & lt(o + h * step, high);
                    if move_mask_m256d(rise) == 0 {
                        break;
                    }
                    h += one & rise;
                }
                let (l, h) = (l.to_array(), h.to_array());
                for j in 0..4 {
                    lo[4 * half + j] = l[j] as u8;
                    hi[4 * half + j] = h[j] as u8;
                }
            }
            (lo, hi)
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
        self.steps_one_by_one(low, high)
    }

    /// [`Grid::steps`], one slot after another.
    #[cfg(any(test, not(all(target_arch = "x86_64", target_feature = "avx"))))]
    fn steps_one_by_one(
        &self,
        low: &[f64; LANES],
        high: &[f64; LANES],
    ) -> ([u8; LANES], [u8; LANES]) {
        let Grid { o, step, per_step } = *self;
        let mut lo = [0u8; LANES];
        let mut hi = [0u8; LANES];
        for k in 0..LANES {
            // `as u8` truncates, which for the nonnegative quotients is the floor, and
            // saturates (a NaN to 0).
            let mut l = ((low[k] - o) * per_step) as u8;
            while l > 0 && o + f64::from(l) * step > low[k] {
                l -= 1;
            }
            let up = (high[k] - o) * per_step;
            let mut h = up as u8;
            if f64::from(h) < up && h < 255 {
                h += 1;
            }
            while h < 255 && o + f64::from(h) * step < high[k] {
                h += 1;
            }
            (lo[k], hi[k]) = (l, h);
        }
        (lo, hi)
    }
}

impl CompactNode {
    /// Every slot empty (see the module's documentation).
    pub(super) const EMPTY: CompactNode = CompactNode {
        links: Links { child: [0; LANES] },
        q: [EMPTY_END; 2],
        origin: [[0.0; 3]; 2],
        exponent: [[0; 3]; 2],
    };

    /// The node whose slot `k` holds `children[k]`, its boxes at the shutter's opening and
    /// closing (a slot of `None` is empty), every side rounded outward on the node's grid.
    /// Boxes beyond [`representable`] give a node of no use, which the caller discards.
    pub(super) fn new(children: &[Option<(Aabb, Aabb)>; LANES], links: &Links) -> CompactNode {
        let mut node = CompactNode::EMPTY;
        node.links = *links;
        // Per axis, the margin of the largest magnitude at either end, as the bound on the
        // roundings takes it.
        let delta: [f64; 3] = std::array::from_fn(|a| {
            margin(
                children
                    .iter()
                    .flatten()
                    .flat_map(|(o, c)| [o, c])
                    .map(|b| b.min[a].abs().max(b.max[a].abs()))
                    .fold(0.0, f64::max),
            )
        });
        for e in 0..2 {
            let end = |c: &(Aabb, Aabb)| if e == 0 { c.0 } else { c.1 };
            let whole = children
                .iter()
                .flatten()
                .fold(Aabb::EMPTY, |b, c| b.union(&end(c)));
            for (a, &delta) in delta.iter().enumerate() {
                let origin = super::rounding::f32_below(whole.min[a] - delta);
                let o = f64::from(origin);
                // The smallest power of two whose 255 steps reach past the upper side.
                // Rounded up past the `f64` division's last bit.
                let span = (whole.max[a] + delta - o) / 255.0 * (1.0 + 2f64.powi(-50));
                let x = exponent_above(span);
                let step = f64::from(power_of_two(x));
                // A power of two, so dividing by the step is multiplying by this, exactly:
                // `1 / step`, made from its exponent without a division.
                let per_step = f64::from_bits(((1023 - i64::from(x)) as u64) << 52);
                debug_assert_eq!(per_step, 1.0 / step);
                node.origin[e][a] = origin;
                node.exponent[e][a] = x;
                // An empty slot's sides are any number: its steps are not kept.
                let side = |k: usize, upper: bool| match &children[k] {
                    Some(c) if upper => end(c).max[a] + delta,
                    Some(c) => end(c).min[a] - delta,
                    None => o,
                };
                let grid = Grid { o, step, per_step };
                let (lo, hi) = grid.steps(
                    &std::array::from_fn(|k| side(k, false)),
                    &std::array::from_fn(|k| side(k, true)),
                );
                for (k, child) in children.iter().enumerate() {
                    if child.is_some() {
                        node.q[e][a][k] = lo[k];
                        node.q[e][3 + a][k] = hi[k];
                    }
                }
            }
        }
        node
    }

    /// Asks for the node's three lines to be loaded: 160 bytes aligned to 32 lie on exactly
    /// three, the first holding its start, the last its 129th byte.
    #[inline(always)]
    pub(super) fn prefetch<M: Lanes>(&self, m: M) {
        m.prefetch(&self.links);
        m.prefetch(&self.q[0][4]);
        m.prefetch(&self.origin);
    }

    /// Along axis `a` at shutter time `s`, the terms every side takes, `[Os, A_0, A_1]` (see
    /// the module's documentation).
    #[inline(always)]
    fn terms(&self, a: usize, s: f32) -> [f32; 3] {
        let [o0, o1] = [self.origin[0][a], self.origin[1][a]];
        [
            o0 + s * (o1 - o0),
            (1.0 - s) * power_of_two(self.exponent[0][a]),
            s * power_of_two(self.exponent[1][a]),
        ]
    }

    /// Along axis `a` at shutter time `s` (in [0, 1], as `f32`), the eight children's lower
    /// and upper sides, evaluated as the module's documentation derives.
    #[inline(always)]
    pub(super) fn sides<M: Lanes>(&self, m: M, a: usize, s: f32) -> (M::V, M::V) {
        let [os, a0, a1] = self.terms(a, s).map(|x| m.splat(x));
        let side = |i: usize| {
            let q0 = m.load_u8(&self.q[0][i]);
            let q1 = m.load_u8(&self.q[1][i]);
            m.add(m.add(os, m.mul(q0, a0)), m.mul(q1, a1))
        };
        (side(a), side(3 + a))
    }

    /// [`CompactNode::sides`] one child after another, for the rays the lanes cannot take
    /// (whose test is in `f64` against the box the lanes evaluate): per child, the side `side`
    /// (as `ChildBoxes::planes` numbers them) at `s`, the same bits.
    pub(super) fn side_values(&self, side: usize, s: f32) -> [f32; LANES] {
        let [os, a0, a1] = self.terms(side % 3, s);
        std::array::from_fn(|k| {
            let [q0, q1] = [self.q[0][side][k], self.q[1][side][k]].map(f32::from);
            (os + q0 * a0) + q1 * a1
        })
    }

    /// Slot `k`'s boxes at the shutter's opening and closing, exactly as stored (each side an
    /// `f32` plus a whole number of power-of-two steps, in `f64`).
    pub(super) fn child(&self, k: usize) -> (Aabb, Aabb) {
        let end = |e: usize| {
            let mut b = Aabb::EMPTY;
            for a in 0..3 {
                let o = f64::from(self.origin[e][a]);
                let step = f64::from(power_of_two(self.exponent[e][a]));
                b.min[a] = o + f64::from(self.q[e][a][k]) * step;
                b.max[a] = o + f64::from(self.q[e][3 + a][k]) * step;
            }
            b
        };
        (end(0), end(1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::lanes::Plain;
    use crate::rng::Pcg32;
    use glam::DVec3;

    /// Three cache lines wherever it lies: 160 bytes, aligned to 32; the lines
    /// `prefetch` asks for are the node's.
    #[test]
    fn a_node_is_three_lines() {
        assert_eq!(std::mem::size_of::<CompactNode>(), 160);
        assert_eq!(std::mem::align_of::<CompactNode>(), 32);
        let node = CompactNode::EMPTY;
        let at = |r: *const u8| r as usize - &node as *const CompactNode as usize;
        assert_eq!(at((&node.links as *const Links).cast()), 0);
        assert_eq!(at(node.q[0][4].as_ptr()), 64);
        assert_eq!(at(node.origin.as_ptr().cast()), 128);
    }

    /// Children at every scale from 1e-30 to 1e30, near and far from the origin, still, slow
    /// and fast, some slots empty: at any shutter time the sides a traversal evaluates (on
    /// every machine and one child after another, the same bits) hold the exact
    /// interpolation of the children's boxes; and they are not loose: within a few of the node's steps.
    fn conservative_on<M: Lanes>(m: M) {
        let mut r = Pcg32::new(43, 11);
        for round in 0..20_000 {
            let scale = 10f64.powi((round % 61) - 30);
            let offset = [0.0, 1e6, -3e4, 2e-6, 7.0][round as usize % 5] * scale.max(1.0);
            let v = |r: &mut Pcg32| {
                (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5) * scale
            };
            let speed = [0.0, 0.1, 3.0][(round / 5) as usize % 3];
            let children: [Option<(Aabb, Aabb)>; LANES] = std::array::from_fn(|k| {
                if k >= LANES - (round as usize % 4) {
                    return None;
                }
                let c = DVec3::splat(offset) + v(&mut r);
                let open = Aabb {
                    min: c - v(&mut r).abs(),
                    max: c + v(&mut r).abs(),
                };
                let shift = v(&mut r) * speed;
                let grow = v(&mut r).abs() * speed * 0.1;
                let close = Aabb {
                    min: open.min + shift - grow,
                    max: open.max + shift + grow,
                };
                Some((open, close))
            });
            let node = CompactNode::new(&children, &Links::default());
            for s in [0.0, 1.0, 0.5, r.next_f64(), 1e-9, 1.0 - 1e-9] {
                let s32 = s as f32;
                for a in 0..3 {
                    let (lo, hi) = node.sides(m, a, s32);
                    let (plo, phi) = node.sides(Plain, a, s32);
                    let (lo, hi) = (m.to_array(lo), m.to_array(hi));
                    assert_eq!(lo.map(f32::to_bits), plo.map(f32::to_bits));
                    assert_eq!(hi.map(f32::to_bits), phi.map(f32::to_bits));
                    let (one_lo, one_hi) = (node.side_values(a, s32), node.side_values(3 + a, s32));
                    assert_eq!(one_lo.map(f32::to_bits), lo.map(f32::to_bits));
                    assert_eq!(one_hi.map(f32::to_bits), hi.map(f32::to_bits));
                    for (k, child) in children.iter().enumerate() {
                        let Some((open, close)) = child else {
                            assert!(lo[k] > hi[k], "an empty slot is inside out");
                            continue;
                        };
                        let lerp = |x: f64, y: f64| if s == 1.0 { y } else { x + s * (y - x) };
                        let exact_lo = lerp(open.min[a], close.min[a]);
                        let exact_hi = lerp(open.max[a], close.max[a]);
                        assert!(f64::from(lo[k]) <= exact_lo, "{round} {s} {a} {k}");
                        assert!(f64::from(hi[k]) >= exact_hi, "{round} {s} {a} {k}");
                        // Tight: within two steps of either end and the margin.
                        let step = |e: usize| f64::from(power_of_two(node.exponent[e][a]));
                        let slack = 2.0 * step(0).max(step(1));
                        assert!(exact_lo - f64::from(lo[k]) <= slack + 1e-4 * exact_lo.abs());
                        assert!(f64::from(hi[k]) - exact_hi <= slack + 1e-4 * exact_hi.abs());
                    }
                }
            }
            // The stored ends hold the children too.
            for (k, child) in children.iter().enumerate() {
                if let Some((open, close)) = child {
                    let (o, c) = node.child(k);
                    assert!(o.union(open) == o && c.union(close) == c, "{round} {k}");
                }
            }
        }
    }

    #[test]
    fn compact_sides_are_conservative() {
        conservative_on(Plain);
        #[cfg(target_arch = "x86_64")]
        {
            use crate::bvh::lanes::{Avx, Sse, avx_where_available};
            conservative_on(Sse);
            if let Some(v3) = avx_where_available() {
                v3.vectorize(|| conservative_on(Avx(v3)));
            }
        }
    }

    /// The lanes give the steps one slot after another gives, bit for bit: sides on the grid
    /// and an ulp either side of a step, below the origin and past its 255 steps, infinite and
    /// NaN, on grids from 2^-126 to 2^60. (Fails with either correction of the lanes left
    /// out, or the `max` of a NaN turned around.)
    #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
    #[test]
    fn steps_in_lanes_are_the_steps_one_by_one() {
        let mut r = Pcg32::new(45, 3);
        for _ in 0..200_000 {
            let x = (r.next_u32() % 187) as i32 - 126;
            let (step, per_step) = (2f64.powi(x), 2f64.powi(-x));
            let o = f64::from((r.next_f64() - 0.5) as f32) * step * 1e3;
            let grid = Grid { o, step, per_step };
            let mut side = || {
                let on = o + f64::from(r.next_u32() % 270) * step - 5.0 * step;
                match r.next_u32() % 10 {
                    0 => on,
                    1 => on.next_up(),
                    2 => on.next_down(),
                    3 => f64::NAN,
                    4 => [f64::INFINITY, f64::NEG_INFINITY][r.next_u32() as usize % 2],
                    5 => o + (r.next_f64() - 0.2) * 1e4 * step,
                    _ => o + r.next_f64() * 255.0 * step,
                }
            };
            let low: [f64; LANES] = std::array::from_fn(|_| side());
            let high: [f64; LANES] = std::array::from_fn(|_| side());
            assert_eq!(
                grid.steps(&low, &high),
                grid.steps_one_by_one(&low, &high),
                "{grid:?} {low:?} {high:?}"
            );
        }
    }

    #[test]
    fn the_exponent_above_a_span_is_the_smallest_power_of_two_at_or_above_it() {
        assert_eq!(exponent_above(1.0), 0);
        assert_eq!(exponent_above(1.0 + f64::EPSILON), 1);
        assert_eq!(exponent_above(0.75), 0);
        assert_eq!(exponent_above(0.5), -1);
        assert_eq!(exponent_above(3e-40), -126);
        assert_eq!(exponent_above(0.0), -126);
        assert_eq!(exponent_above(f64::NAN), -126);
        assert_eq!(exponent_above(1e300), 127);
        let mut r = Pcg32::new(44, 1);
        for _ in 0..10_000 {
            let span = r.next_f64() * 2f64.powi((r.next_f64() * 200.0) as i32 - 110);
            let x = exponent_above(span);
            if (-126..127).contains(&x) && span >= f64::MIN_POSITIVE {
                let p = f64::from(power_of_two(x));
                assert!(p >= span && p / 2.0 < span, "{span:e} {x}");
            }
        }
    }

    #[test]
    fn only_finite_boxes_within_range_are_representable() {
        let b = |lo: f64, hi: f64| Aabb {
            min: DVec3::splat(lo),
            max: DVec3::splat(hi),
        };
        assert!(representable(&b(-1e29, 1e29)));
        assert!(!representable(&b(-1e31, 0.0)));
        assert!(!representable(&b(0.0, f64::INFINITY)));
        assert!(!representable(&b(f64::NAN, 0.0)));
        assert!(!representable(&Aabb::EMPTY));
    }
}
