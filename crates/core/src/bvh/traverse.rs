//! Walking a hierarchy: the nearest hit along a ray, children visited nearest first, with a
//! fixed stack; eight children tested at once, on the machine's widest lanes.

use glam::DVec3;

use super::boxes::Boxes;
use super::lanes::{LANES, Lanes};
use super::leaves::Leaves;
use super::links::{COUNT_SHIFT, POSITION_MASK, links_of};
use super::slab::{RayF64, RayLanes, SlabTest, widened_limit};
use super::stack::TraversalStack;
use super::topology::Topology;

/// A topology with boxes computed for it (by its build or by [`Topology::refit_moving`]), as
/// a traversal reads them.
#[derive(Clone, Copy, Debug)]
pub struct BvhView<'a> {
    pub(super) topology: &'a Topology,
    pub(super) boxes: &'a Boxes,
}

impl<'a> BvhView<'a> {
    /// Pairs `topology` with `boxes` computed for it. Panics if they have different numbers
    /// of nodes.
    #[inline]
    pub fn new(topology: &'a Topology, boxes: &'a Boxes) -> BvhView<'a> {
        // One of the two is empty.
        let n = boxes.still.len().max(boxes.moving.len());
        assert!(n == topology.links.len(), "boxes of another topology");
        BvhView { topology, boxes }
    }

    /// Finds the closest primitive hit by the ray `origin + t dir`, `t` in `(0, t_max)`, at
    /// shutter time `s` in [0, 1] (ignored by a still hierarchy). `leaves` tests the
    /// primitives ([`Leaves::hit`]: a closure `hit(pos, t_max)` returning the hit distance in
    /// `(0, t_max)` of the primitive at position `pos` of [`Topology::order`], if any).
    /// Returns the distance and position.
    ///
    /// Runs on AVX where the processor has AVX2 and FMA (checked once per process), on SSE
    /// otherwise (on other targets, plain arrays): the same hits, the same bits. `leaves` is
    /// compiled into each, inlined.
    #[inline]
    pub fn closest_hit(
        &self,
        origin: DVec3,
        dir: DVec3,
        s: f64,
        t_max: f64,
        stack: &mut TraversalStack,
        mut leaves: impl Leaves,
    ) -> Option<(f64, u32)> {
        // An empty hierarchy (a scene's static part, when everything moves) costs no
        // dispatch.
        if self.topology.links.is_empty() {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        {
            use super::lanes::{Avx, Sse};
            match pulp::x86::V3::try_new() {
                // The closure holds references (four words; `vectorize` passes up to eight in
                // registers, larger closures through a copy in memory).
                Some(v3) => {
                    let leaves = &mut leaves;
                    let ray = &(origin, dir, s, t_max);
                    v3.vectorize(
                        #[inline(always)]
                        move || {
                            let (origin, dir, s, t_max) = *ray;
                            // Moved out, not reborrowed: the closure is then `FnOnce` only,
                            // whose call the compiler inlines into `vectorize`'s AVX code (an
                            // `FnMut` closure's is a shim it left out of line, with the lanes'
                            // intrinsics called one by one: 2.5 times slower).
                            let leaves = leaves;
                            self.closest_hit_on(Avx(v3), origin, dir, s, t_max, stack, leaves)
                        },
                    )
                }
                None => self.closest_hit_on(Sse, origin, dir, s, t_max, stack, &mut leaves),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.closest_hit_on(
            super::lanes::Plain,
            origin,
            dir,
            s,
            t_max,
            stack,
            &mut leaves,
        )
    }

    /// [`BvhView::closest_hit`] on the lanes of machine `m`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn closest_hit_on<M: Lanes>(
        &self,
        m: M,
        origin: DVec3,
        dir: DVec3,
        s: f64,
        t_max: f64,
        stack: &mut TraversalStack,
        leaves: &mut impl Leaves,
    ) -> Option<(f64, u32)> {
        // A ray with a NaN or infinite origin or direction has no meaningful hit, and its
        // slab tests give NaN everywhere (which the tests ignore): it would enter every box.
        // Checked once per ray.
        if self.topology.links.is_empty() || !(origin.is_finite() && dir.is_finite() && !s.is_nan())
        {
            return None;
        }
        match RayLanes::new(m, origin, dir, s) {
            Some(ray) => self.traverse(stack, t_max, leaves, &ray),
            // Rare: an origin beyond 1e30 or a direction with a component below 1e-30 (an
            // axis-parallel ray), whose reciprocal has no `f32`.
            None => {
                let ray = RayF64::new(origin, dir, s);
                self.traverse(stack, t_max, leaves, &ray)
            }
        }
    }

    /// The traversal of [`BvhView::closest_hit`], with `test(node, limit)` the slab test of
    /// the children of `node`: a bit per child the ray may enter before `limit` (a bound on
    /// the distance, [`widened_limit`]), and its entry distance (at most the true one).
    ///
    /// One function on purpose: its steps are named by the comments inside (see
    /// [`BvhView::closest_hits_on`] for what splitting the traversals cost).
    #[inline(always)]
    fn traverse(
        &self,
        stack: &mut TraversalStack,
        mut t_max: f64,
        leaves: &mut impl Leaves,
        ray: &impl SlabTest,
    ) -> Option<(f64, u32)> {
        let links = &self.topology.links[..];
        let mut limit = widened_limit(t_max);
        let mut best = None;
        let mut sp = 0usize;
        let mut current = 0usize;
        let mut node = links[0];
        loop {
            let (mask, near) = ray.test(self.boxes, current, limit, t_max);
            // Every child entered is asked for now, a node's boxes or a leaf's primitives:
            // the loads overlap this node's sorting and pushing and the descent, where a
            // hierarchy far larger than the cache would wait for each (a fifth of a render
            // of a million points).
            let mut bits = mask;
            while bits != 0 {
                let w = node.child[bits.trailing_zeros() as usize];
                bits &= bits - 1;
                match w >> COUNT_SHIFT {
                    0 => ray.prefetch(self.boxes, w as usize),
                    count => leaves.prefetch(w & POSITION_MASK, count),
                }
            }
            // The child to go to next (a child slot, 0 for none): the nearest child hit. The
            // others are pushed, nearest last, so the nearest of them is popped first.
            let mut next = 0;
            if mask & mask.wrapping_sub(1) == 0 {
                // None or one: nothing to sort or push (the most frequent cases).
                if mask != 0 {
                    next = node.child[mask.trailing_zeros() as usize];
                }
            } else {
                // Sorted farthest first: an insertion sort of the children hit.
                let mut hits = [0usize; LANES];
                let mut n = 0;
                let mut bits = mask;
                while bits != 0 {
                    let k = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let mut j = n;
                    while j > 0 && near[hits[j - 1]] < near[k] {
                        hits[j] = hits[j - 1];
                        j -= 1;
                    }
                    hits[j] = k;
                    n += 1;
                }
                for &k in &hits[..n - 1] {
                    let w = node.child[k];
                    // A node's children are read now, when it is pushed, not when it is
                    // visited: the load then overlaps the rest of this node's work instead
                    // of delaying the child's, which measured a few percent faster than
                    // reading them at the visit. A leaf reads the root's (always cached)
                    // without a branch.
                    stack.links[sp] = links_of(links, w);
                    stack.entry[sp] = w;
                    stack.near[sp] = near[k];
                    sp += 1;
                }
                next = node.child[hits[n - 1]];
            }
            // Its children, if it is a node (a leaf reads the root's).
            let mut next_links = links_of(links, next);
            // Intersect leaves until an inner node to descend into, popping the stack.
            loop {
                let count = next >> COUNT_SHIFT;
                if count == 0 {
                    // An empty slot (0), entered only through NaN boxes, would read as the
                    // root, and descending into it would push the root again and again until
                    // the stack overflowed. Skipped, every descent is one level down, so the
                    // stack holds at most 7 entries per level of a tree `STACK` is sized for.
                    if next != 0 {
                        current = next as usize;
                        node = next_links;
                        break;
                    }
                } else {
                    let first = next & POSITION_MASK;
                    for pos in first..first + count {
                        if let Some(t) = leaves.hit(pos, t_max) {
                            t_max = t;
                            limit = widened_limit(t);
                            best = Some((t, pos));
                        }
                    }
                }
                // Pop the nearest child pushed that may still hold a nearer hit.
                loop {
                    if sp == 0 {
                        return best;
                    }
                    sp -= 1;
                    if stack.near[sp] <= limit {
                        next = stack.entry[sp];
                        next_links = stack.links[sp];
                        break;
                    }
                }
            }
        }
    }
}
