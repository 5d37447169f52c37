//! The structure of a hierarchy, which a refit keeps: every 8-wide node's children, packed
//! one word a slot, and the primitives in leaf order; refitting it to new boxes.

use crate::aabb::Aabb;

use super::boxes::{Boxes, ChildBoxes, set_moving};
use super::lanes::LANES;

/// A child slot is one word: a node index, or a leaf's first primitive position with its
/// primitive count in the bits from this one up (a node has count 0). Positions are below
/// 2^28, which a hierarchy of fewer primitives than that guarantees.
pub(super) const COUNT_SHIFT: u32 = 28;
/// The position bits of a child slot.
pub(super) const POSITION_MASK: u32 = (1 << COUNT_SHIFT) - 1;

/// The children of an 8-wide node: per slot, a node index or a leaf's first primitive
/// position and count, packed in one word ([`COUNT_SHIFT`]). An empty slot is 0 (node 0 is the
/// root, nobody's child). Thirty-two bytes, aligned, so a node's children never straddle a
/// cache line: a traversal reads them apart from the node's boxes, one line more per node.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(align(32))]
pub(super) struct Links {
    pub(super) child: [u32; LANES],
}

impl Links {
    /// Slot `k`: a node index and count 0, or a leaf's first position and its count.
    #[inline]
    pub(super) fn slot(&self, k: usize) -> (u32, u32) {
        let w = self.child[k];
        (w & POSITION_MASK, w >> COUNT_SHIFT)
    }
}

/// The children of the child word `w`'s node, read ahead of descending into it; a leaf's word
/// (or an empty slot) reads the root's, which a traversal never uses, so the read needs no
/// branch on what the traversal does next.
#[inline]
pub(super) fn links_of(links: &[Links], w: u32) -> Links {
    links[if w >> COUNT_SHIFT == 0 { w as usize } else { 0 }]
}

/// The structure of a hierarchy over primitives `0..n`, which a refit keeps: the children of
/// every 8-wide node (nodes in depth-first order, the root first) and the primitives in leaf
/// order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Topology {
    pub(super) links: Vec<Links>,
    /// Primitive indices in leaf order.
    pub(super) order: Vec<u32>,
}

impl Topology {
    /// Boxes for moving primitives on this topology (refitting): primitive `i` lies inside
    /// the box interpolated from `open[i]` to `close[i]`, as for [`Bvh::build_moving`]. Every
    /// node's boxes are the unions of its children's, bottom up, so the result is exact for
    /// any boxes; only its quality ([`Boxes::area`]) depends on how far they are from those
    /// the topology was built on. Boxes equal to those of the build give its boxes exactly.
    ///
    /// [`Bvh::build_moving`]: super::hierarchy::Bvh::build_moving
    pub fn refit_moving(&self, open: &[Aabb], close: &[Aabb]) -> Boxes {
        assert!(open.len() == self.order.len() && close.len() == self.order.len());
        let n = self.links.len();
        let mut boxes = Boxes {
            still: Vec::new(),
            moving: vec![[ChildBoxes::EMPTY, ChildBoxes::ZERO]; n],
            bounds: Aabb::EMPTY,
        };
        // Nodes are in depth-first order, so every child comes after its parent: in reverse
        // order, a node's children are done before it.
        let mut unions = vec![(Aabb::EMPTY, Aabb::EMPTY); n];
        for i in (0..n).rev() {
            let links = &self.links[i];
            let mut all = (Aabb::EMPTY, Aabb::EMPTY);
            for k in 0..LANES {
                let (child, count) = links.slot(k);
                let (o, c) = if count > 0 {
                    (child..child + count).fold((Aabb::EMPTY, Aabb::EMPTY), |(o, c), pos| {
                        let p = self.order[pos as usize] as usize;
                        (o.union(&open[p]), c.union(&close[p]))
                    })
                } else if child > 0 {
                    unions[child as usize]
                } else {
                    // An empty slot (the root is nobody's child): it stays empty.
                    continue;
                };
                set_moving(&mut boxes.moving[i], k, &o, &c);
                all = (all.0.union(&o), all.1.union(&c));
            }
            unions[i] = all;
        }
        if let Some(&(o, c)) = unions.first() {
            boxes.bounds = o.union(&c);
        }
        boxes
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// Whether there are no primitives.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// The primitives in leaf order: position `p` in the callbacks of
    /// [`BvhView::closest_hit`] is primitive `order()[p]`.
    ///
    /// [`BvhView::closest_hit`]: super::traverse::BvhView::closest_hit
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// Number of 8-wide nodes.
    pub fn node_count(&self) -> usize {
        self.links.len()
    }

    /// Bytes held (children and order).
    pub fn memory_bytes(&self) -> usize {
        self.links.capacity() * std::mem::size_of::<Links>() + self.order.capacity() * 4
    }
}
