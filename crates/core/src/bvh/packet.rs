//! Walking a hierarchy with a packet of rays at once: coherent rays (the camera rays of one
//! pixel's samples) share one traversal, its order, its stack and its branches, each node
//! tested by each of the packet's rays still in it, as [`BvhView::closest_hit`] tests it.
//! Every ray finds the hit it finds alone.
//!
//! A packet's traversal visits the nodes any of its rays enters, nearest first by the
//! smallest entry distance among the rays entering; a ray takes part only in the nodes it
//! enters itself (its bit in the node's lane mask) and tests them as alone. The order can
//! differ from the ray's own, and with it how soon a nearer hit culls farther nodes, but not
//! the nearest hit, which is the nearest of all the primitives the ray's boxes lead to.

use glam::DVec3;

use super::lanes::{LANES, Lanes};
use super::leaves::PacketLeaves;
use super::links::{COUNT_SHIFT, POSITION_MASK};
use super::slab::{RayLanes, SlabTest, widened_limit};
use super::stack::{PACKET, TraversalStack};
use super::traverse::BvhView;

/// One ray of a packet: `origin + t dir` at shutter time `s` in [0, 1] (as
/// [`BvhView::closest_hit`] takes them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PacketRay {
    pub origin: DVec3,
    pub dir: DVec3,
    pub s: f64,
}

impl BvhView<'_> {
    /// [`BvhView::closest_hit`] for up to [`PACKET`] rays at once: per ray `r` of `rays`, the
    /// closest primitive it hits at `t` in `(0, t_max[r])`, with `leaves` the primitive test
    /// of ray `r` ([`PacketLeaves::hit`]: a closure `hit(r, pos, t_max)`). The same hits, distance for distance, as one call of
    /// `closest_hit` per ray (a test checks); cheaper for rays that enter the same nodes.
    #[inline]
    pub(crate) fn closest_hits(
        &self,
        rays: &[PacketRay],
        t_max: [f64; PACKET],
        stack: &mut TraversalStack,
        leaves: impl PacketLeaves,
    ) -> [Option<(f64, u32)>; PACKET] {
        assert!(rays.len() <= PACKET, "more rays than a packet holds");
        if self.topology.links.is_empty() {
            return [None; PACKET];
        }
        #[cfg(target_arch = "x86_64")]
        {
            use super::lanes::{Avx, Sse};
            match pulp::x86::V3::try_new() {
                // The closure holds references and `leaves` (keep it small: up to eight words
                // in all are passed in registers, see `BvhView::closest_hit`); `leaves` is
                // moved in, not borrowed, which the compiler inlines where a borrow was not.
                Some(v3) => {
                    let t_max = &t_max;
                    v3.vectorize(
                        #[inline(always)]
                        move || self.closest_hits_on(Avx(v3), rays, *t_max, stack, leaves),
                    )
                }
                None => self.closest_hits_on(Sse, rays, t_max, stack, leaves),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.closest_hits_on(super::lanes::Plain, rays, t_max, stack, leaves)
    }

    /// [`BvhView::closest_hits`] on the lanes of machine `m`.
    ///
    /// One function on purpose: split into named steps (the lanes, the entering test, the
    /// sort, the push and pop, the leaf hits; commit 1969e91), every step
    /// `#[inline(always)]`, the same frames rendered 3 to 6% slower (held-out books' scene,
    /// 400x225, 100 spp, 2 cores, user time of 9 to 11 runs each), so the steps are named by
    /// the comments inside. (A single ray's walk, `walks.rs`, is a step function the
    /// traversal loops over, measured as fast as the one function it replaced.)
    #[inline(always)]
    pub(super) fn closest_hits_on<M: Lanes>(
        &self,
        m: M,
        rays: &[PacketRay],
        mut t_max: [f64; PACKET],
        stack: &mut TraversalStack,
        mut leaves: impl PacketLeaves,
    ) -> [Option<(f64, u32)>; PACKET] {
        let mut best = [None; PACKET];
        // The rays the `f32` test takes; the rare others (an origin beyond 1e30, a direction
        // component below 1e-30) traverse alone. Non-finite rays find nothing, as alone. The
        // lanes of rays not in the packet hold a placeholder, never read.
        let placeholder = RayLanes::new(m, DVec3::ZERO, DVec3::ONE, 0.0).expect("a plain ray");
        let mut lanes = [placeholder; PACKET];
        let mut active = 0u32;
        for (r, ray) in rays.iter().enumerate() {
            if !(ray.origin.is_finite() && ray.dir.is_finite() && !ray.s.is_nan()) {
                continue;
            }
            match RayLanes::new(m, ray.origin, ray.dir, ray.s) {
                Some(lane) => {
                    lanes[r] = lane;
                    active |= 1 << r;
                }
                None => best[r] = self.closest_hit_alone(m, rays, r, t_max[r], stack, &mut leaves),
            }
        }
        if active == 0 {
            return best;
        }
        let stack = &mut stack.packet;
        let mut limit = [0.0f32; PACKET];
        for r in 0..PACKET {
            limit[r] = widened_limit(t_max[r]);
        }
        let mut sp = 0usize;
        let mut current = 0usize;
        let mut node = self.links(0);
        // Per ray, the entry distances into the current node's children. Filled once here:
        // a node overwrites the rows of the rays in it, and only those are read.
        let mut near = [[f32::INFINITY; LANES]; PACKET];
        loop {
            // Each ray still in the node tests its children: per ray, the children it enters
            // (a byte of `entered`) and their entry distances.
            let mut entered = 0u64;
            let mut bits = active;
            while bits != 0 {
                let r = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let (mask, n) = lanes[r].test(self.boxes, current, limit[r], t_max[r]);
                entered |= u64::from(mask) << (8 * r);
                near[r] = n;
            }
            // Per child, the rays entering it (transposed: byte k of `by_child`).
            let by_child = transpose8(entered);
            let any = by_child_nonzero(by_child);
            // Every child entered is asked for now, as in a ray's traversal.
            let mut bits = any;
            while bits != 0 {
                let w = node.child[bits.trailing_zeros() as usize];
                bits &= bits - 1;
                match w >> COUNT_SHIFT {
                    0 => self.boxes.prefetch(m, w as usize),
                    count => leaves.prefetch(w & POSITION_MASK, count),
                }
            }
            // The children entered, nearest first by their smallest entry distance; all but
            // the nearest are pushed (nearest last, so popped first).
            let mut next = 0;
            let mut next_lanes = 0;
            if any != 0 {
                let mut order = [0usize; LANES];
                let mut key = [0f32; LANES];
                let mut n = 0;
                let mut bits = any;
                while bits != 0 {
                    let k = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let lanes_k = ((by_child >> (8 * k)) & 0xff) as u32;
                    let mut smallest = f32::INFINITY;
                    let mut b = lanes_k;
                    while b != 0 {
                        let r = b.trailing_zeros() as usize;
                        b &= b - 1;
                        smallest = smallest.min(near[r][k]);
                    }
                    // Sorted farthest first.
                    let mut j = n;
                    while j > 0 && key[j - 1] < smallest {
                        order[j] = order[j - 1];
                        key[j] = key[j - 1];
                        j -= 1;
                    }
                    order[j] = k;
                    key[j] = smallest;
                    n += 1;
                }
                for &k in &order[..n - 1] {
                    let w = node.child[k];
                    stack.links[sp] = self.links_of(w);
                    stack.entry[sp] = w;
                    let lanes_k = ((by_child >> (8 * k)) & 0xff) as u32;
                    stack.lanes[sp] = lanes_k;
                    // Only the rays that entered the child (`lanes_k`) read their entry.
                    for (entry, near_r) in stack.near[sp].iter_mut().zip(&near) {
                        *entry = near_r[k];
                    }
                    sp += 1;
                }
                let k = order[n - 1];
                next = node.child[k];
                next_lanes = ((by_child >> (8 * k)) & 0xff) as u32;
            }
            let mut next_links = self.links_of(next);
            // Intersect leaves until an inner node to descend into, popping the stack.
            loop {
                let count = next >> COUNT_SHIFT;
                if count == 0 {
                    // An empty slot (0), entered only through NaN boxes: skipped (see
                    // a ray's walk, `Walk::step`).
                    if next != 0 && next_lanes != 0 {
                        current = next as usize;
                        node = next_links;
                        active = next_lanes;
                        break;
                    }
                } else {
                    let first = next & POSITION_MASK;
                    let mut b = next_lanes;
                    while b != 0 {
                        let r = b.trailing_zeros() as usize;
                        b &= b - 1;
                        let mut bits = leaves.candidates(r, first, count);
                        while bits != 0 {
                            let pos = first + bits.trailing_zeros();
                            bits &= bits - 1;
                            if let Some(t) = leaves.hit(r, pos, t_max[r]) {
                                t_max[r] = t;
                                limit[r] = widened_limit(t);
                                best[r] = Some((t, pos));
                            }
                        }
                    }
                }
                // Pop the nearest child pushed that some of its rays may still hit nearer
                // than their nearest hit so far.
                loop {
                    if sp == 0 {
                        return best;
                    }
                    sp -= 1;
                    let still = m.le_mask(m.load(&stack.near[sp]), m.load(&limit));
                    let lanes_k = stack.lanes[sp] & still;
                    if lanes_k != 0 {
                        next = stack.entry[sp];
                        next_links = stack.links[sp];
                        next_lanes = lanes_k;
                        break;
                    }
                }
            }
        }
    }
}

/// The transpose of an 8 x 8 bit matrix: bit `8 r + k` of the result is bit `8 k + r` of
/// `x` (Hacker's Delight, 7-3).
#[inline(always)]
fn transpose8(mut x: u64) -> u64 {
    let t = (x ^ (x >> 7)) & 0x00aa_00aa_00aa_00aa;
    x ^= t ^ (t << 7);
    let t = (x ^ (x >> 14)) & 0x0000_cccc_0000_cccc;
    x ^= t ^ (t << 14);
    let t = (x ^ (x >> 28)) & 0x0000_0000_f0f0_f0f0;
    x ^ t ^ (t << 28)
}

/// Bit `k` set where byte `k` of `x` is not zero.
#[inline(always)]
fn by_child_nonzero(x: u64) -> u32 {
    let mut any = 0;
    for k in 0..8 {
        any |= u32::from((x >> (8 * k)) & 0xff != 0) << k;
    }
    any
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transpose8_transposes() {
        let mut r = crate::rng::Pcg32::new(3, 9);
        for _ in 0..1000 {
            let x = (u64::from(r.next_u32()) << 32) | u64::from(r.next_u32());
            let t = transpose8(x);
            for i in 0..8 {
                for j in 0..8 {
                    assert_eq!((t >> (8 * i + j)) & 1, (x >> (8 * j + i)) & 1);
                }
            }
            assert_eq!(transpose8(t), x);
        }
    }
}
