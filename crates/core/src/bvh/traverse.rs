//! A hierarchy as a traversal reads it ([`BvhView`]), and the nearest hit along one ray: the
//! ray made once for the machine's widest lanes (eight children tested at once), then its
//! walk (`walks.rs`), step after step.

use glam::DVec3;

use super::boxes::{Boxes, Nodes};
use super::lanes::Lanes;
use super::leaves::{Leaves, OneOf, PacketLeaves};
use super::links::{COUNT_SHIFT, Links};
use super::packet::PacketRay;
use super::slab::{RayF64, RayLanes, SlabTest};
use super::stack::TraversalStack;
use super::topology::Topology;
use super::walks::Walk;

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
        assert!(
            boxes.len() == topology.links.len(),
            "boxes of another topology"
        );
        BvhView { topology, boxes }
    }

    /// The children of node `node`: beside its boxes in a compact hierarchy, in the
    /// topology otherwise.
    #[inline(always)]
    pub(super) fn links(&self, node: usize) -> Links {
        match &self.boxes.nodes {
            Nodes::Compact(n) => n[node].links,
            _ => self.topology.links[node],
        }
    }

    /// The children of the child word `w`'s node, read ahead of descending into it; a leaf's
    /// word (or an empty slot) reads the root's, which a traversal never uses, so the read
    /// needs no branch on what the traversal does next.
    #[inline(always)]
    pub(super) fn links_of(&self, w: u32) -> Links {
        self.links(if w >> COUNT_SHIFT == 0 { w as usize } else { 0 })
    }

    /// Asks for node `node`'s boxes and children to be loaded (nothing past the last node).
    #[inline(always)]
    pub(super) fn prefetch<M: Lanes>(&self, m: M, node: usize) {
        self.boxes.prefetch(m, node);
        // A compact node's children are on its boxes' lines.
        if !matches!(self.boxes.nodes, Nodes::Compact(_))
            && let Some(l) = self.topology.links.get(node)
        {
            m.prefetch(l);
        }
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
            Some(ray) => self.traverse(m, stack, t_max, leaves, ray),
            // Rare: an origin beyond 1e30 or a direction with a component below 1e-30 (an
            // axis-parallel ray), whose reciprocal has no `f32`.
            None => {
                let ray = RayF64::new(origin, dir, s);
                self.traverse(m, stack, t_max, leaves, ray)
            }
        }
    }

    /// [`BvhView::closest_hit_on`] of ray `r` of `rays` (a packet's, or walks in turns'),
    /// with that ray's test of `leaves`: the way of the rare ray the `f32` lanes cannot take.
    #[inline(always)]
    pub(super) fn closest_hit_alone<M: Lanes>(
        &self,
        m: M,
        rays: &[PacketRay],
        r: usize,
        t_max: f64,
        stack: &mut TraversalStack,
        leaves: &mut impl PacketLeaves,
    ) -> Option<(f64, u32)> {
        let ray = &rays[r];
        let mut one = OneOf { packet: leaves, r };
        self.closest_hit_on(m, ray.origin, ray.dir, ray.s, t_max, stack, &mut one)
    }

    /// The traversal of [`BvhView::closest_hit`]: one ray's [`Walk`], its steps one after
    /// another (walks in turns, `walks.rs`, interleave several).
    #[inline(always)]
    fn traverse<M: Lanes>(
        &self,
        m: M,
        stack: &mut TraversalStack,
        t_max: f64,
        leaves: &mut impl Leaves,
        ray: impl SlabTest,
    ) -> Option<(f64, u32)> {
        let mut walk = Walk::new(ray, t_max);
        while walk.step(m, self, &mut stack.walk, leaves) {}
        walk.best
    }
}
