//! The scratch space of traversals ([`TraversalStack`]): the fixed stack of one ray's walk
//! (`walks`), that of a packet's (`packet`), and those of walks in turns, made once per thread
//! of work.

use super::build::MAX_SAH_DEPTH;
use super::lanes::LANES;
use super::links::Links;
use super::walks::WalkStack;

/// The most rays in a packet.
pub(crate) const PACKET: usize = 8;

/// The most walks under way at once in turns ([`BvhView::closest_hits_in_turns`]): 32. On a
/// frame of ten million points at 4 samples (2 threads, medians of 3 alternated runs) the
/// render took 2.19 s with 32, 2.26 s with 24, 2.29 s with 16 and 2.33 s with 8 (48 and 64 no
/// faster than 32); on a frame of a million points, whose misses matter less, the same with
/// 8, 16 or 32 (docs/performance.md). On an Intel Xeon, 64 (the sets below widened) rendered
/// that frame at 16 samples in 15.8 and 17.5 s against 15.4 and 16.4 s (2 alternated pairs, the
/// same bytes). At most 32: the turns keep their walks' sets as bits of a `u32` (a compile-time
/// check in `walks.rs`). A walk's stack is 6 KiB (on the heap, made once a thread), its state
/// on the stack about 400 bytes.
///
/// [`BvhView::closest_hits_in_turns`]: super::BvhView::closest_hits_in_turns
pub(crate) const TURNS: usize = 32;

/// The most bytes a walk under way in turns takes on its thread's stack: its ray's lanes and
/// its bookkeeping (about 400; a unit test checks).
const WALK_BYTES: usize = 512;

/// The bytes of the walks in turns a thread holds: [`TURNS`] walks' stacks (on the heap, made
/// at its first walk in turns) and their state (on its stack).
pub(crate) const TURNS_WALKS_BYTES: usize = TURNS * (std::mem::size_of::<WalkStack>() + WALK_BYTES);

/// Traversal stack size: an 8-wide node pushes at most 7 entries beyond the one it replaces,
/// and the 8-wide tree is no deeper than the binary one.
pub(super) const STACK: usize = (LANES - 1) * (MAX_SAH_DEPTH + 40) + LANES;

/// Scratch space for traversals. Made once per thread of work and reused for every ray:
/// clearing a fresh stack array per ray cost about 8% of a render.
#[derive(Clone, Debug, Default)]
pub struct TraversalStack {
    /// The stack of one ray's walk ([`BvhView::closest_hit`]).
    ///
    /// [`BvhView::closest_hit`]: super::BvhView::closest_hit
    pub(super) walk: WalkStack,
    /// The stack of packet traversals ([`BvhView::closest_hits`]).
    ///
    /// [`BvhView::closest_hits`]: super::BvhView::closest_hits
    pub(super) packet: PacketStack,
    /// The stacks of the walks taken in turns ([`BvhView::closest_hits_in_turns`]), one a
    /// ray; made at the first such walk (a frame without points never needs them).
    ///
    /// [`BvhView::closest_hits_in_turns`]: super::BvhView::closest_hits_in_turns
    walks: Vec<WalkStack>,
}

impl TraversalStack {
    /// The stacks of [`TURNS`] walks taken in turns.
    pub(super) fn walks(&mut self) -> &mut [WalkStack] {
        if self.walks.is_empty() {
            self.walks = vec![WalkStack::default(); TURNS];
        }
        &mut self.walks
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::lanes::{Lanes, Plain};
    use crate::bvh::slab::RayLanes;
    use crate::bvh::walks::Walk;

    /// A walk under way, as the turns hold it (with its ray's number), on each machine's
    /// lanes: within the bytes the memory estimate counts for it.
    fn fits<M: Lanes>(_: M) {
        let bytes = std::mem::size_of::<(usize, Walk<RayLanes<M>>)>();
        assert!(bytes <= WALK_BYTES, "{bytes}");
    }

    #[test]
    fn a_walk_under_way_fits_its_count() {
        fits(Plain);
        #[cfg(target_arch = "x86_64")]
        {
            use crate::bvh::lanes::{Avx, Sse};
            fits(Sse);
            if let Some(v3) = crate::bvh::lanes::avx_where_available() {
                fits(Avx(v3));
            }
        }
    }
}
