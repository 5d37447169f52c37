//! What a traversal tests in the leaves it reaches: a primitive test ([`Leaves`] for one
//! ray, [`PacketLeaves`] for a packet's), which of a leaf's primitives are worth the test, and a
//! hint that a leaf is about to be tested.
//!
//! A closure is a test without a hint (a blanket implementation), which suits primitives that
//! stay in the cache (the spheres of a scene). Primitives far larger than the cache (a frame's
//! millions of points) implement the hint: a traversal gives it for every leaf child a ray
//! enters, as it asks for the boxes of every node child, so the leaf's memory is loaded while
//! the node's other children are sorted and pushed instead of when the leaf is tested.

/// The primitive test of one ray's traversal ([`BvhView::closest_hit`]).
///
/// [`BvhView::closest_hit`]: super::BvhView::closest_hit
pub trait Leaves {
    /// The distance in `(0, t_max)` at which the ray hits the primitive at position `pos` of
    /// [`Topology::order`], if it does.
    ///
    /// [`Topology::order`]: super::Topology::order
    fn hit(&mut self, pos: u32, t_max: f64) -> Option<f64>;

    /// Of the leaf at positions `first..first + count` (`count` in `1..=4`), a bit for each
    /// primitive [`Leaves::hit`] is asked about (bit `k` for `first + k`, asked in that order): a
    /// primitive left out is one `hit` certainly misses whatever `t_max`, so the traversal
    /// finds the same hits. Every primitive by default.
    #[inline(always)]
    fn candidates(&mut self, first: u32, count: u32) -> u32 {
        let _ = first;
        every(count)
    }

    /// Asks for the primitives at positions `first..first + count` (a leaf the ray has just
    /// entered) to be loaded into the cache, without waiting for them. Nothing by default.
    #[inline(always)]
    fn prefetch(&self, first: u32, count: u32) {
        let _ = (first, count);
    }
}

/// A bit for each of a leaf's `count` primitives.
#[inline(always)]
pub(crate) fn every(count: u32) -> u32 {
    (1 << count) - 1
}

impl<F: FnMut(u32, f64) -> Option<f64>> Leaves for F {
    #[inline(always)]
    fn hit(&mut self, pos: u32, t_max: f64) -> Option<f64> {
        self(pos, t_max)
    }
}

/// The primitive test of a packet's traversal ([`BvhView::closest_hits`]): [`Leaves`] for
/// the packet's ray `r`.
///
/// [`BvhView::closest_hits`]: super::BvhView::closest_hits
pub(crate) trait PacketLeaves {
    /// [`Leaves::hit`] for ray `r` of the packet.
    fn hit(&mut self, r: usize, pos: u32, t_max: f64) -> Option<f64>;

    /// [`Leaves::candidates`] for ray `r` of the packet.
    #[inline(always)]
    fn candidates(&mut self, r: usize, first: u32, count: u32) -> u32 {
        let _ = (r, first);
        every(count)
    }

    /// [`Leaves::prefetch`], for a leaf some of the packet's rays entered.
    #[inline(always)]
    fn prefetch(&self, first: u32, count: u32) {
        let _ = (first, count);
    }
}

impl<F: FnMut(usize, u32, f64) -> Option<f64>> PacketLeaves for F {
    #[inline(always)]
    fn hit(&mut self, r: usize, pos: u32, t_max: f64) -> Option<f64> {
        self(r, pos, t_max)
    }
}

/// A packet's test for its ray `r` alone (a ray the packet's `f32` test cannot take).
pub(super) struct OneOf<'a, P> {
    pub(super) packet: &'a mut P,
    pub(super) r: usize,
}

impl<P: PacketLeaves> Leaves for OneOf<'_, P> {
    #[inline(always)]
    fn hit(&mut self, pos: u32, t_max: f64) -> Option<f64> {
        self.packet.hit(self.r, pos, t_max)
    }

    #[inline(always)]
    fn candidates(&mut self, first: u32, count: u32) -> u32 {
        self.packet.candidates(self.r, first, count)
    }

    #[inline(always)]
    fn prefetch(&self, first: u32, count: u32) {
        self.packet.prefetch(first, count);
    }
}
