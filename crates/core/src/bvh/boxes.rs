//! The boxes of a hierarchy's nodes: per 8-wide node, its eight children's boxes as `f32`
//! structure-of-arrays, still or moving over the shutter.

use crate::aabb::Aabb;

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
/// children's boxes, and for a moving hierarchy their change over the shutter. Only one of
/// `still` and `moving` has entries.
///
/// [`Topology`]: super::topology::Topology
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Boxes {
    /// For a still hierarchy, per node, its children's boxes.
    pub(super) still: Vec<ChildBoxes>,
    /// For a moving hierarchy, per node, its children's boxes at the shutter's opening and
    /// their change until its closing (about `close - open`, widened: see [`moving_lower`]),
    /// side by side: a traversal step reads both, with one bounds check.
    pub(super) moving: Vec<[ChildBoxes; 2]>,
    /// The box of everything (over the whole shutter, for a moving hierarchy).
    pub(super) bounds: Aabb,
}

impl Boxes {
    /// The summed surface areas of every child box of every node, over the whole shutter: the
    /// cost a ray pays to traverse the hierarchy, up to a constant. It grows as refitted
    /// primitives move away from where the topology was built.
    pub fn area(&self) -> f64 {
        let child = |node: &ChildBoxes, k: usize| {
            let mut b = Aabb::EMPTY;
            for a in 0..3 {
                b.min[a] = f64::from(node.planes[a][k]);
                b.max[a] = f64::from(node.planes[3 + a][k]);
            }
            b
        };
        let mut sum = 0.0;
        for node in &self.still {
            for k in 0..LANES {
                let b = child(node, k);
                // Skips an empty slot.
                if b.min.x.is_finite() {
                    sum += b.surface_area();
                }
            }
        }
        for [node, delta] in &self.moving {
            for k in 0..LANES {
                let b = child(node, k);
                if !b.min.x.is_finite() {
                    continue;
                }
                // The box at the closing, from the one at the opening and the change.
                let d = child(delta, k);
                let close = Aabb {
                    min: b.min + d.min,
                    max: b.max + d.max,
                };
                sum += b.union(&close).surface_area();
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
        self.still.capacity() * std::mem::size_of::<ChildBoxes>()
            + self.moving.capacity() * std::mem::size_of::<[ChildBoxes; 2]>()
    }
}

impl Boxes {
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
        if let Some([b, d]) = self.moving.get(node) {
            lines(b);
            lines(d);
        } else if let Some(b) = self.still.get(node) {
            lines(b);
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
