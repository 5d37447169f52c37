//! The boxes of a hierarchy's nodes: per 8-wide node, its eight children's boxes as `f32`
//! structure-of-arrays, still or moving over the shutter, or moving and compact
//! (`compact.rs`).

use crate::aabb::Aabb;

use super::compact::CompactNode;
use super::lanes::LANES;
use super::rounding::{f32_above, f32_below, moving_lower};

/// Eight children's boxes, structure-of-arrays: `planes[axis][child]` is the lower side,
/// `planes[3 + axis][child]` the upper side (axes x, y, z), as `f32` rounded outward
/// ([`f32_below`], [`f32_above`]) so a stored box always contains the `f64` box it stands
/// for. An empty slot has lower sides `+inf` and upper sides `-inf`, which no ray hits. 192
/// bytes, aligned to 64, so a node's boxes always lie on exactly three cache lines, and each
/// side's eight lanes are one aligned 32-byte load.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(align(64))]
pub(super) struct ChildBoxes {
    pub(super) planes: [[f32; LANES]; 6],
}

impl ChildBoxes {
    pub(super) const EMPTY: ChildBoxes = ChildBoxes {
        planes: [
            [f32::INFINITY; LANES],
            [f32::INFINITY; LANES],
            [f32::INFINITY; LANES],
            [f32::NEG_INFINITY; LANES],
            [f32::NEG_INFINITY; LANES],
            [f32::NEG_INFINITY; LANES],
        ],
    };

    pub(super) const ZERO: ChildBoxes = ChildBoxes {
        planes: [[0.0; LANES]; 6],
    };

    /// Sets slot `k` to the smallest `f32` box containing `b`.
    pub(super) fn set(&mut self, k: usize, b: &Aabb) {
        for a in 0..3 {
            self.planes[a][k] = f32_below(b.min[a]);
            self.planes[3 + a][k] = f32_above(b.max[a]);
        }
    }
}

/// The boxes of the nodes of a [`Topology`], which a refit recomputes: per node, its eight
/// children's boxes, still, moving over the shutter, or moving and compact.
///
/// [`Topology`]: super::topology::Topology
#[derive(Clone, Debug, PartialEq)]
pub struct Boxes {
    pub(super) nodes: Nodes,
    /// The box of everything (over the whole shutter, for a moving hierarchy).
    pub(super) bounds: Aabb,
}

/// Every node's children's boxes, in one of three layouts.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Nodes {
    /// Per node, its children's boxes.
    Still(Vec<ChildBoxes>),
    /// Per node, its children's boxes at the shutter's opening and their change until its
    /// closing (about `close - open`, widened: see [`moving_lower`]), side by side: a
    /// traversal step reads both, with one bounds check.
    Moving(Vec<[ChildBoxes; 2]>),
    /// Per node, its children's boxes at the opening and the closing, quantised on a grid of
    /// the node's own ([`CompactNode`]): a third of the bytes of `Moving`, for hierarchies
    /// far larger than the cache.
    Compact(Vec<CompactNode>),
}

impl Default for Boxes {
    fn default() -> Self {
        Boxes {
            nodes: Nodes::Still(Vec::new()),
            bounds: Aabb::default(),
        }
    }
}

impl Boxes {
    /// Number of nodes.
    pub(super) fn len(&self) -> usize {
        match &self.nodes {
            Nodes::Still(n) => n.len(),
            Nodes::Moving(n) => n.len(),
            Nodes::Compact(n) => n.len(),
        }
    }

    /// Slot `k` of node `node`: its boxes at the shutter's opening and closing as stored (in
    /// `f64`; the same box twice for a still node), or `None` for an empty slot.
    pub(super) fn child(&self, node: usize, k: usize) -> Option<(Aabb, Aabb)> {
        let read = |b: &ChildBoxes| {
            let mut out = Aabb::EMPTY;
            for a in 0..3 {
                out.min[a] = f64::from(b.planes[a][k]);
                out.max[a] = f64::from(b.planes[3 + a][k]);
            }
            out
        };
        let (open, close) = match &self.nodes {
            Nodes::Still(n) => {
                let b = read(&n[node]);
                (b, b)
            }
            Nodes::Moving(n) => {
                let [b, d] = &n[node];
                let (b, d) = (read(b), read(d));
                // The box at the closing, from the one at the opening and the change.
                let close = Aabb {
                    min: b.min + d.min,
                    max: b.max + d.max,
                };
                (b, close)
            }
            Nodes::Compact(n) => n[node].child(k),
        };
        // An empty slot: sides not finite (still and moving), or inside out (compact).
        let empty = |b: &Aabb| !(b.min.x.is_finite() && b.min.x <= b.max.x);
        (!empty(&open)).then_some((open, close))
    }

    /// The summed surface areas of every child box of every node, over the whole shutter: the
    /// cost a ray pays to traverse the hierarchy, up to a constant. It grows as refitted
    /// primitives move away from where the topology was built.
    pub fn area(&self) -> f64 {
        let mut sum = 0.0;
        for node in 0..self.len() {
            for k in 0..LANES {
                if let Some((open, close)) = self.child(node, k) {
                    sum += open.union(&close).surface_area();
                }
            }
        }
        sum
    }

    /// The box of everything (over the whole shutter, if moving).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Bytes held.
    #[cfg(test)]
    pub(crate) fn memory_bytes(&self) -> usize {
        match &self.nodes {
            Nodes::Still(n) => n.capacity() * std::mem::size_of::<ChildBoxes>(),
            Nodes::Moving(n) => n.capacity() * std::mem::size_of::<[ChildBoxes; 2]>(),
            Nodes::Compact(n) => n.capacity() * std::mem::size_of::<CompactNode>(),
        }
    }

    /// Asks for node `node`'s boxes to be loaded into the cache (every line of them), to be
    /// read later; nothing for a number past the last node.
    #[inline(always)]
    pub(super) fn prefetch<M: super::lanes::Lanes>(&self, m: M, node: usize) {
        let lines = |b: &ChildBoxes| {
            // Six planes of 32 bytes on three lines of 64.
            for k in [0, 2, 4] {
                m.prefetch(&b.planes[k]);
            }
        };
        match &self.nodes {
            Nodes::Still(n) => {
                if let Some(b) = n.get(node) {
                    lines(b);
                }
            }
            Nodes::Moving(n) => {
                if let Some([b, d]) = n.get(node) {
                    lines(b);
                    lines(d);
                }
            }
            Nodes::Compact(n) => {
                if let Some(c) = n.get(node) {
                    c.prefetch(m);
                }
            }
        }
    }
}

/// Sets child slot `k` of a moving node's `[boxes, delta]` to a box containing, at every
/// shutter time `s` in [0, 1], the box interpolated from `open` (at `s = 0`) to `close` (at
/// `s = 1`): stored as its sides at the opening and their change until the closing, both
/// `f32`, which a traversal evaluates in `f32` as `side + s * change` ([`moving_lower`]).
pub(super) fn set_moving(node: &mut [ChildBoxes; 2], k: usize, open: &Aabb, close: &Aabb) {
    let [boxes, delta] = node;
    for a in 0..3 {
        (boxes.planes[a][k], delta.planes[a][k]) = moving_lower(open.min[a], close.min[a]);
        // An upper side is a lower side of the mirrored box.
        let (o, d) = moving_lower(-open.max[a], -close.max[a]);
        (boxes.planes[3 + a][k], delta.planes[3 + a][k]) = (-o, -d);
    }
}
