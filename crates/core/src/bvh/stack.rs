//! The scratch space of traversals ([`TraversalStack`]): the fixed stack of one ray's walk
//! (`traverse`) and that of a packet's (`packet`), made once per thread of work.

use super::build::MAX_SAH_DEPTH;
use super::lanes::LANES;
use super::links::Links;

/// The most rays in a packet.
pub(crate) const PACKET: usize = 8;

/// Traversal stack size: an 8-wide node pushes at most 7 entries beyond the one it replaces,
/// and the 8-wide tree is no deeper than the binary one.
pub(super) const STACK: usize = (LANES - 1) * (MAX_SAH_DEPTH + 40) + LANES;

/// Scratch space for traversals. Made once per thread of work and reused for every ray:
/// clearing a fresh stack array per ray cost about 8% of a render.
#[derive(Clone, Debug)]
pub struct TraversalStack {
    /// A child slot ([`COUNT_SHIFT`]): a node index, or a leaf's first position and count.
    ///
    /// [`COUNT_SHIFT`]: super::links::COUNT_SHIFT
    pub(super) entry: [u32; STACK],
    /// For a node entry, its children, read from the topology when the entry is pushed.
    pub(super) links: [Links; STACK],
    /// The ray's entry distance into the entry's box: entries beyond the nearest hit so far
    /// are skipped.
    pub(super) near: [f32; STACK],
    /// The stack of packet traversals ([`BvhView::closest_hits`]).
    ///
    /// [`BvhView::closest_hits`]: super::BvhView::closest_hits
    pub(super) packet: PacketStack,
}

impl Default for TraversalStack {
    fn default() -> Self {
        TraversalStack {
            entry: [0; STACK],
            links: [Links::default(); STACK],
            near: [0.0; STACK],
            packet: PacketStack::default(),
        }
    }
}

/// The stack of a packet traversal: per entry, the child slot, the lanes (rays) that entered
/// it, and their entry distances.
#[derive(Clone, Debug)]
pub(super) struct PacketStack {
    pub(super) entry: [u32; STACK],
    pub(super) links: [Links; STACK],
    pub(super) lanes: [u32; STACK],
    pub(super) near: [[f32; PACKET]; STACK],
}

impl Default for PacketStack {
    fn default() -> Self {
        PacketStack {
            entry: [0; STACK],
            links: [Links::default(); STACK],
            lanes: [0; STACK],
            near: [[0.0; PACKET]; STACK],
        }
    }
}
