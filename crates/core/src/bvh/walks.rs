//! One ray's walk through a hierarchy ([`Walk`]): the nearest hit, children visited nearest
//! first, with a fixed stack, one node or one leaf a step. [`BvhView::closest_hit`] takes the
//! steps one after another; [`BvhView::closest_hits_in_turns`] walks up to [`TURNS`] rays at
//! once, each alone, taking one step of each in turn, so the memory one ray's next step needs
//! loads while the others work, and starts the next of its rays in the place of each walk
//! that ends.
//!
//! Every step asks for what the ray may read next (the boxes and children of every node child
//! it enters, the primitives of every leaf child), a few dozen instructions before a lone
//! walk reads the nearest of them. On a frame of ten million points (0.8 GB of nodes and
//! records) nearly every such read misses the cache, and a lone walk is a chain of misses,
//! one after another. In turns the misses of up to 32 walks are in flight at once
//! (memory-level parallelism, as Kocberber et al. 2015, "Asynchronous Memory Access
//! Chaining", interleave hash-table probes); rays that are not coherent (the bounces of a
//! pixel's samples) gain as much as coherent ones, as nothing is shared but the turns. The
//! turns gain only while they are full: given the eight rays of one packet, walks end one by
//! one and the last go on alone (on that frame 29% of the steps were a walk alone's, 51% of
//! the steps were taken with at most two walks under way); given the rays of several packets
//! ([`crate::tracer::STREAM`]), a walk that ends hands its place to the next ray waiting (at
//! most 5% of the steps alone), as a stream of probes keeps its slots full.
//!
//! **Each turn in two passes.** Where the misses are hidden, what is left is each step's
//! own work, and there a step's branches, not its instructions, set the pace: whether the
//! entry is a leaf, how many children the ray entered, their order, what the stack holds
//! are a coin toss from walk to walk, and a mispredicted branch throws away the work of the
//! walks after it that the processor had started. So a turn first tests every walk at a
//! node against its ray ([`Walk::look`]: no branch on the walk's state, the sides a ray
//! enters through chosen by a select on its direction's signs, `SlabTest::test_in_turns`),
//! one walk after another, which the processor overlaps; then takes each walk's step with
//! its test, by kind (the walks at a leaf, then those whose ray entered no child of its
//! node, one, and several), so that the branches between the kinds go the same way through
//! a run (0.98 of the time of two kinds, leaf and node). On the fountain's frame of a
//! million points (in turns, 4 samples, one thread) the render took 0.90 of the time of one
//! pass a turn; with the steps faster the misses mattered again, and 32 walks under way
//! rendered the frame of ten million points in 0.94 of the time of eight (2.19 s against
//! 2.33 s at 4 samples on two threads; docs/performance.md).
//!
//! A walk in turns takes the same steps, in the same order, as the ray's walk alone: the same
//! hit, distance for distance (tests check, for more rays than walks too). Where the
//! hierarchy fits in the cache there is nothing to wait for and the turns only cost, so the
//! caller chooses ([`crate::world::World`] takes turns for point caches larger than the
//! cache).

use glam::DVec3;

use super::lanes::{LANES, Lanes};
use super::leaves::{Leaves, OneOf, PacketLeaves};
use super::links::{COUNT_SHIFT, POSITION_MASK};
use super::packet::PacketRay;
use super::slab::{RayLanes, SlabTest, widened_limit};
use super::stack::{STACK, TURNS, TraversalStack};
use super::traverse::BvhView;
use crate::bits::Bits;

/// The stack of one ray's walk: per entry, the child slot (a node index, or a leaf's first
/// position and count) and the ray's entry distance into it. A node's children are read
/// when it is visited: asked for when its parent was tested, they have landed by then (read
/// at the push instead, into the stack, measured the same on the books' scene, and the stack
/// is then a fifth of the size).
#[derive(Clone, Debug)]
pub(super) struct WalkStack {
    entry: [u32; STACK],
    near: [f32; STACK],
}

impl Default for WalkStack {
    fn default() -> Self {
        WalkStack {
            entry: [0; STACK],
            near: [0.0; STACK],
        }
    }
}

/// One ray's walk in progress: its nearest hit so far, and the entry it visits next.
pub(super) struct Walk<R> {
    ray: R,
    t_max: f64,
    limit: f32,
    pub(super) best: Option<(f64, u32)>,
    /// Entries on the ray's stack.
    sp: usize,
    /// The child slot visited next: a node (the root, 0, at the start) or a leaf.
    next: u32,
}

impl<R: SlabTest> Walk<R> {
    /// A walk from a hierarchy's root, for hits before `t_max`.
    #[inline(always)]
    pub(super) fn new(ray: R, t_max: f64) -> Walk<R> {
        Walk {
            ray,
            t_max,
            limit: widened_limit(t_max),
            best: None,
            sp: 0,
            next: 0,
        }
    }

    /// Visits the next entry: tests a node's children, asking for the memory of every child
    /// the ray enters and going on to the nearest (the others pushed, nearest last, so the
    /// nearest of them is popped first), or tests a leaf's primitives and pops the nearest
    /// entry pushed that may still hold a nearer hit. Returns whether anything is left.
    ///
    /// Alone (`BvhView::closest_hit`) the steps follow one another; walks in turns
    /// ([`BvhView::closest_hits_in_turns`]) take one step each in turn.
    #[inline(always)]
    pub(super) fn step<M: Lanes>(
        &mut self,
        m: M,
        view: &BvhView<'_>,
        stack: &mut WalkStack,
        leaves: &mut impl Leaves,
    ) -> bool {
        self.step_with(m, view, stack, leaves, None)
    }

    /// Whether the entry this walk visits next is a leaf.
    #[inline(always)]
    fn at_leaf(&self) -> bool {
        self.next >> COUNT_SHIFT != 0
    }

    /// The test of the node this walk visits next (the children the ray enters and their
    /// entry distances), as [`Walk::step`] makes it, for a walk whose next entry is a node
    /// ([`Walk::at_leaf`]). No branch on the walk's state: walks in turns test their nodes
    /// one after another with nothing between them to mispredict.
    #[inline(always)]
    fn look(&self, view: &BvhView<'_>) -> (u32, [f32; LANES]) {
        debug_assert!(!self.at_leaf());
        self.ray
            .test_in_turns(view.boxes, self.next as usize, self.limit, self.t_max)
    }

    /// [`Walk::step`], with the test of the node it visits already made ([`Walk::look`];
    /// unread where the entry is a leaf), or, for `None`, made here (where it is a node).
    #[inline(always)]
    fn step_with<M: Lanes>(
        &mut self,
        m: M,
        view: &BvhView<'_>,
        stack: &mut WalkStack,
        leaves: &mut impl Leaves,
        looked: Option<(u32, [f32; LANES])>,
    ) -> bool {
        let next = self.next;
        let count = next >> COUNT_SHIFT;
        if count != 0 {
            let first = next & POSITION_MASK;
            let mut bits = leaves.candidates(first, count);
            while bits != 0 {
                let pos = first + bits.trailing_zeros();
                bits &= bits - 1;
                if let Some(t) = leaves.hit(pos, self.t_max) {
                    self.t_max = t;
                    self.limit = widened_limit(t);
                    self.best = Some((t, pos));
                }
            }
            return self.pop(stack);
        }
        let current = next as usize;
        let node = view.links(current);
        let (mask, near) = match looked {
            Some(looked) => looked,
            None => self.ray.test(view.boxes, current, self.limit, self.t_max),
        };
        // Every child entered is asked for now, a node's boxes and children or a leaf's
        // primitives: the loads overlap this node's sorting and pushing and the descent (and
        // other rays' steps), where a hierarchy far larger than the cache would wait for each
        // (a fifth of a render of a million points).
        let mut bits = mask;
        while bits != 0 {
            let w = node.child[bits.trailing_zeros() as usize];
            bits &= bits - 1;
            match w >> COUNT_SHIFT {
                0 => view.prefetch(m, w as usize),
                count => leaves.prefetch(w & POSITION_MASK, count),
            }
        }
        if mask & mask.wrapping_sub(1) == 0 {
            // None or one: nothing to sort or push (the most frequent cases).
            self.next = if mask != 0 {
                node.child[mask.trailing_zeros() as usize]
            } else {
                0
            };
        } else {
            // Sorted farthest first: an insertion sort of the children hit.
            let mut hits = [0usize; LANES];
            let mut n = 0;
            let mut bits = mask;
            while bits != 0 {
                let k = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let mut j = n;
                while j > 0 && near[hits[j - 1]] < near[k] {
                    hits[j] = hits[j - 1];
                    j -= 1;
                }
                hits[j] = k;
                n += 1;
            }
            for &k in &hits[..n - 1] {
                let w = node.child[k];
                stack.entry[self.sp] = w;
                stack.near[self.sp] = near[k];
                self.sp += 1;
            }
            self.next = node.child[hits[n - 1]];
        }
        // An empty slot (0), entered only through NaN boxes, would read as the root, and
        // descending into it would push the root again and again until the stack overflowed.
        // Skipped, every descent is one level down, so the stack holds at most 7 entries per
        // level of a tree `STACK` is sized for.
        self.next != 0 || self.pop(stack)
    }

    /// Pops the nearest entry pushed that may still hold a nearer hit (empty slots skipped);
    /// returns whether there was one.
    #[inline(always)]
    fn pop(&mut self, stack: &WalkStack) -> bool {
        while self.sp > 0 {
            self.sp -= 1;
            if stack.near[self.sp] <= self.limit && stack.entry[self.sp] != 0 {
                self.next = stack.entry[self.sp];
                return true;
            }
        }
        false
    }
}

impl BvhView<'_> {
    /// [`BvhView::closest_hit`] for up to `N` rays (at most [`Bits::CAPACITY`], 256), walked
    /// in turns (see the module's documentation): per ray `r` of `rays`, the closest
    /// primitive it hits at `t` in `(0, t_max[r])`, with `leaves` the primitive test of ray
    /// `r`. Up to [`TURNS`] walks are under way at once; when one ends, the next ray waiting
    /// starts in its place, so the turns stay full while rays are left. The same hits,
    /// distance for distance, as one call of `closest_hit` per ray; faster where the
    /// hierarchy is far larger than the cache, slower where it fits.
    #[inline]
    pub(crate) fn closest_hits_in_turns<const N: usize>(
        &self,
        rays: &[PacketRay],
        t_max: [f64; N],
        stack: &mut TraversalStack,
        leaves: impl PacketLeaves,
    ) -> [Option<(f64, u32)>; N] {
        assert!(
            rays.len() <= N,
            "more rays than the turns were given room for"
        );
        if self.topology.links.is_empty() {
            return [None; N];
        }
        #[cfg(target_arch = "x86_64")]
        {
            use super::lanes::{Avx, Sse};
            match pulp::x86::V3::try_new() {
                Some(v3) => {
                    let t_max = &t_max;
                    v3.vectorize(
                        #[inline(always)]
                        move || self.closest_hits_in_turns_on(Avx(v3), rays, *t_max, stack, leaves),
                    )
                }
                None => self.closest_hits_in_turns_on(Sse, rays, t_max, stack, leaves),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.closest_hits_in_turns_on(super::lanes::Plain, rays, t_max, stack, leaves)
    }

    /// [`BvhView::closest_hits_in_turns`] on the lanes of machine `m`.
    #[inline(always)]
    pub(super) fn closest_hits_in_turns_on<M: Lanes, const N: usize>(
        &self,
        m: M,
        rays: &[PacketRay],
        t_max: [f64; N],
        stack: &mut TraversalStack,
        mut leaves: impl PacketLeaves,
    ) -> [Option<(f64, u32)>; N] {
        const {
            assert!(
                N <= Bits::CAPACITY,
                "a ray a bit of the set of those waiting"
            );
            // The walks under way, and those at a leaf or entering none or one child, are
            // bits of a `u32`: a slot past its width would shift onto another's bit.
            assert!(TURNS <= u32::BITS as usize, "a walk a bit of a u32");
        };
        let mut best = [None; N];
        // The rays waiting to walk in turns, a bit each.
        let mut waiting = Bits::default();
        for (r, ray) in rays.iter().enumerate() {
            // Non-finite rays find nothing, as alone.
            if !(ray.origin.is_finite() && ray.dir.is_finite() && !ray.s.is_nan()) {
                continue;
            }
            if RayLanes::new(m, ray.origin, ray.dir, ray.s).is_some() {
                waiting.insert(r);
            } else {
                // The rare ray the `f32` test cannot take walks alone.
                best[r] = self.closest_hit_alone(m, rays, r, t_max[r], stack, &mut leaves);
            }
        }
        // The walk of ray `r`, the next one taken from `waiting`. Its lanes are made again
        // here rather than kept from the check above for every ray waiting (a few dozen
        // instructions a ray, against `N` rays' lanes held on the stack).
        let walk_of = |r: usize| {
            let ray = &rays[r];
            let lanes = RayLanes::new(m, ray.origin, ray.dir, ray.s).expect("checked above");
            (r, Walk::new(lanes, t_max[r]))
        };
        let placeholder = RayLanes::new(m, DVec3::ZERO, DVec3::ONE, 0.0).expect("a plain ray");
        let mut walks = [(); TURNS].map(|_| (0, Walk::new(placeholder, 0.0)));
        let mut active = 0u32;
        for (slot, walk) in walks.iter_mut().enumerate() {
            let Some(r) = waiting.pop_first() else { break };
            *walk = walk_of(r);
            active |= 1 << slot;
        }
        let stacks = stack.walks();
        // The turns: each walk under way takes one step; a walk that ends hands its slot
        // (and its stack) to the next ray waiting.
        let mut looks = [(0u32, [0f32; LANES]); TURNS];
        while active != 0 {
            // Which walks are at a leaf; then every other walk's node test, one after another
            // with no branch between them (see the module's documentation).
            let mut at_leaf = 0u32;
            let mut bits = active;
            while bits != 0 {
                let slot = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                at_leaf |= u32::from(walks[slot].1.at_leaf()) << slot;
            }
            let mut bits = active & !at_leaf;
            let (mut none, mut one) = (0u32, 0u32);
            while bits != 0 {
                let slot = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                looks[slot] = walks[slot].1.look(self);
                let mask = looks[slot].0;
                none |= u32::from(mask == 0) << slot;
                one |= u32::from(mask.is_power_of_two()) << slot;
            }
            // Then each walk's step with its test, by kind: the walks at a leaf, then those at
            // a node whose ray entered no child, one, and several, so that the branches
            // between the kinds go the same way through a run.
            let nodes = active & !at_leaf;
            for group in [
                active & at_leaf,
                nodes & none,
                nodes & one,
                nodes & !none & !one,
            ] {
                let mut bits = group;
                while bits != 0 {
                    let slot = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let (r, walk) = &mut walks[slot];
                    let mut leaves = OneOf {
                        packet: &mut leaves,
                        r: *r,
                    };
                    let looked = Some(looks[slot]);
                    if !walk.step_with(m, self, &mut stacks[slot], &mut leaves, looked) {
                        best[*r] = walk.best;
                        match waiting.pop_first() {
                            Some(r) => walks[slot] = walk_of(r),
                            None => active &= !(1 << slot),
                        }
                    }
                }
            }
        }
        best
    }
}
