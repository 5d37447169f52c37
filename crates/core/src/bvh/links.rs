//! The children of an 8-wide node, packed one word a slot: a node's index, or a leaf's first
//! primitive position and count. What a build writes, a refit and a traversal read.

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
