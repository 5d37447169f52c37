//! The structure of a hierarchy, which a refit keeps: every 8-wide node's children, packed
//! one word a slot, and the primitives in leaf order; refitting it to new boxes.

use crate::aabb::Aabb;

use super::boxes::{Boxes, Nodes};
use super::build::{Build, BuildBox, build_indexed, build_links};
use super::compact::representable;
use super::links::Links;
use super::refit::refit;

/// The structure of a hierarchy over primitives `0..n`, which a refit keeps: the children of
/// every 8-wide node (nodes in depth-first order, the root first, each node's inner children
/// after it in slot order and each subtree contiguous) and the primitives in leaf order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Topology {
    pub(super) links: Vec<Links>,
    /// Primitive indices in leaf order; empty for a build that reordered the primitives
    /// themselves ([`Topology::build_in_place`]).
    pub(super) order: Vec<u32>,
    /// Number of primitives.
    pub(super) len: usize,
}

impl Topology {
    /// The topology of a hierarchy over primitives `0..n`, where `prim(i)` gives primitive
    /// `i`'s boxes at the shutter's opening and at its closing (one box twice for a still
    /// primitive). The same on any number of threads. At most 2^28 primitives.
    pub fn build(n: usize, prim: &(impl Fn(usize) -> (Aabb, Aabb) + Sync)) -> Topology {
        let (links, order) = build_indexed(n, prim);
        Topology {
            links,
            order,
            len: n,
        }
    }

    /// The topology of a hierarchy over `items`, reordered into leaf order (position `p` is
    /// `items[p]`; [`Topology::order`] is empty), with no copy of them: `bounds(item)` gives
    /// an item's boxes, in `f32`, as the build compares them (it only steers the splits; the
    /// hierarchy's boxes come from [`Topology::refit_moving_with`]). `node_cost` is the cost
    /// of visiting a node relative to testing one item (spheres' hierarchies take 0.5): the
    /// higher, the more items a leaf holds (at most four) and the fewer nodes. The same on
    /// any number of threads. At most 2^28 items.
    pub(crate) fn build_in_place<P: Send + Sync>(
        items: &mut [P],
        bounds: impl Fn(&P) -> BuildBox + Sync,
        node_cost: f64,
    ) -> Topology {
        Topology {
            links: build_links(items, &Build { bounds, node_cost }),
            order: Vec::new(),
            len: items.len(),
        }
    }

    /// Boxes for moving primitives on this topology (refitting): primitive `i` lies inside
    /// the box interpolated from `open[i]` to `close[i]`, as for [`Bvh::build_moving`]. Every
    /// node's boxes are the unions of its children's, bottom up, so the result is exact for
    /// any boxes; only its quality ([`Boxes::area`]) depends on how far they are from those
    /// the topology was built on. Boxes equal to those of the build give its boxes exactly.
    ///
    /// [`Bvh::build_moving`]: super::hierarchy::Bvh::build_moving
    pub(crate) fn refit_moving(&self, open: &[Aabb], close: &[Aabb]) -> Boxes {
        assert!(open.len() == self.order.len() && close.len() == self.order.len());
        self.refit_moving_with(&|pos| {
            let i = self.order[pos as usize] as usize;
            (open[i], close[i])
        })
    }

    /// [`Topology::refit_moving`] with `prim(pos)` the boxes, at the shutter's opening and
    /// closing, of the primitive at position `pos` of the leaf order. In parallel.
    pub(crate) fn refit_moving_with(&self, prim: &(impl Fn(u32) -> (Aabb, Aabb) + Sync)) -> Boxes {
        let (moving, (open, close)) = refit(&self.links, prim);
        Boxes {
            nodes: Nodes::Moving(moving),
            bounds: open.union(&close),
        }
    }

    /// [`Topology::refit_moving_with`] into compact nodes (a third of the bytes, for
    /// hierarchies far larger than the cache; `compact.rs`) where the primitives' boxes are
    /// within the range those take (finite, within `2^100` of the origin), into the `f32`
    /// moving layout otherwise. In parallel.
    pub(crate) fn refit_compact_with(&self, prim: &(impl Fn(u32) -> (Aabb, Aabb) + Sync)) -> Boxes {
        let (compact, (open, close)) = refit(&self.links, prim);
        let bounds = open.union(&close);
        if self.links.is_empty() || representable(&bounds) {
            Boxes {
                nodes: Nodes::Compact(compact),
                bounds,
            }
        } else {
            // Rare: a scene beyond the range (its compact nodes are of no use).
            self.refit_moving_with(prim)
        }
    }

    /// Boxes for still primitives on this topology, with `prim(pos)` the box of the primitive
    /// at position `pos` of the leaf order. In parallel.
    pub(crate) fn refit_still_with(&self, prim: &(impl Fn(u32) -> Aabb + Sync)) -> Boxes {
        let (still, (all, _)) = refit(&self.links, &|pos| {
            let b = prim(pos);
            (b, b)
        });
        Boxes {
            nodes: Nodes::Still(still),
            bounds: all,
        }
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are no primitives.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The primitives in leaf order: position `p` in the callbacks of
    /// [`BvhView::closest_hit`] is primitive `order()[p]`. Empty for a topology built in
    /// place.
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
    #[cfg(test)]
    pub(crate) fn memory_bytes(&self) -> usize {
        self.links.capacity() * std::mem::size_of::<Links>() + self.order.capacity() * 4
    }
}
