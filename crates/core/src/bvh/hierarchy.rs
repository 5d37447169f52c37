//! A hierarchy: its topology and its boxes, as built.

use glam::DVec3;

use crate::aabb::Aabb;

use super::boxes::{Boxes, ChildBoxes};
use super::links::Links;
use super::stack::TraversalStack;
use super::topology::Topology;
use super::traverse::BvhView;

/// Bytes of an 8-wide moving node: its children's links and their boxes at the shutter's
/// opening and their change until its closing.
pub(crate) const MOVING_NODE_BYTES: usize =
    std::mem::size_of::<Links>() + std::mem::size_of::<[ChildBoxes; 2]>();

/// Bytes of an 8-wide compact node (`Topology::refit_compact_with`): its children's links
/// and their boxes at the opening and the closing, quantised.
pub(crate) const COMPACT_NODE_BYTES: usize =
    std::mem::size_of::<Links>() + std::mem::size_of::<super::compact::CompactNode>();

/// Bytes per primitive of a hierarchy, at most about: its place in the leaf order, and an
/// 8-wide moving node's children and boxes per two and a half primitives (a leaf holds one
/// to four and a node about four children: 0.38 nodes a primitive over 100 random spheres,
/// 0.27 over 30,000; a test checks the bound).
pub(crate) const BYTES_PER_PRIMITIVE: usize = 4 + MOVING_NODE_BYTES * 2 / 5;

/// A hierarchy over primitives `0..n` given by their boxes: its topology and its boxes.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    topology: Topology,
    boxes: Boxes,
}

impl Bvh {
    /// Builds the hierarchy over `boxes`; primitive `i` has box `boxes[i]`. At most 2^28
    /// primitives.
    pub fn build(boxes: &[Aabb]) -> Bvh {
        let topology = Topology::build(boxes.len(), &|i| (boxes[i], boxes[i]));
        let boxes = topology.refit_still_with(&|pos| boxes[topology.order[pos as usize] as usize]);
        Bvh { topology, boxes }
    }

    /// Builds a hierarchy over moving primitives: primitive `i` lies at every shutter time
    /// `s` in [0, 1] inside the box interpolated linearly from `open[i]` (at `s = 0`) to
    /// `close[i]` (at `s = 1`). Pad the boxes for the rounding of that interpolation (see
    /// [`Aabb::pad_for_rounding`]).
    pub fn build_moving(open: &[Aabb], close: &[Aabb]) -> Bvh {
        assert_eq!(open.len(), close.len());
        let topology = Topology::build(open.len(), &|i| (open[i], close[i]));
        let boxes = topology.refit_moving(open, close);
        Bvh { topology, boxes }
    }

    /// The hierarchy as a traversal reads it.
    #[inline]
    pub fn view(&self) -> BvhView<'_> {
        BvhView {
            topology: &self.topology,
            boxes: &self.boxes,
        }
    }

    /// Its topology.
    #[cfg(test)]
    pub(crate) fn topology(&self) -> &Topology {
        &self.topology
    }

    /// Its boxes.
    pub fn boxes(&self) -> &Boxes {
        &self.boxes
    }

    /// [`Boxes::area`] of its boxes.
    pub fn area(&self) -> f64 {
        self.boxes.area()
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.topology.len()
    }

    /// Whether the hierarchy has no primitives.
    pub fn is_empty(&self) -> bool {
        self.topology.is_empty()
    }

    /// The box of everything in the hierarchy (over the whole shutter, if moving).
    pub fn bounds(&self) -> Aabb {
        self.boxes.bounds
    }

    /// The primitives in leaf order (see [`Topology::order`]).
    pub fn order(&self) -> &[u32] {
        self.topology.order()
    }

    /// Number of 8-wide nodes.
    pub fn node_count(&self) -> usize {
        self.topology.node_count()
    }

    /// Bytes held by the hierarchy (topology and boxes).
    #[cfg(test)]
    pub(crate) fn memory_bytes(&self) -> usize {
        self.topology.memory_bytes() + self.boxes.memory_bytes()
    }

    /// [`BvhView::closest_hit`] on this hierarchy.
    #[inline]
    pub fn closest_hit(
        &self,
        origin: DVec3,
        dir: DVec3,
        s: f64,
        t_max: f64,
        stack: &mut TraversalStack,
        leaves: impl super::Leaves,
    ) -> Option<(f64, u32)> {
        self.view()
            .closest_hit(origin, dir, s, t_max, stack, leaves)
    }
}
