//! A bounding volume hierarchy over boxes: built as a binary tree with the surface-area
//! heuristic (binned, as in Wald 2007, "On fast Construction of SAH-based Bounding Volume
//! Hierarchies"), in parallel, then collapsed into a 4-wide tree (as Embree's BVH4) stored as
//! flat arrays of nodes. A node holds its four children's boxes as structure-of-arrays, in
//! `f32` rounded outward (half the memory of `f64`; a box only ever grows, so no hit is lost),
//! so a ray is tested against all four at once with straight-line arithmetic the compiler
//! vectorises, and the children a ray hits are visited nearest first.
//!
//! A hierarchy ([`Bvh`]) is kept in two parts: its [`Topology`] (every node's children and
//! the primitives in leaf order) and its [`Boxes`] (every node's children's boxes). A
//! topology can be refitted to new boxes of the same primitives ([`Topology::refit_moving`]),
//! which gives new [`Boxes`] and leaves the topology as it is, so one topology can serve many
//! sets of boxes at once; a traversal reads a topology with boxes computed for it
//! ([`BvhView`]).
//!
//! Moving primitives get two boxes, one at the shutter's opening and one at its closing; a
//! ray at time `s` (0 at opening, 1 at closing) is tested against their linear interpolation,
//! as in Embree's motion-blur hierarchy (Woop et al. 2017, "STBVH: A Spatial-Temporal BVH for
//! Efficient Multi-Segment Motion Blur", section 3). Since the interpolation of the unions is
//! contained in the union of the interpolations' extremes, a node's two boxes are the unions
//! of its children's.
//!
//! Primitives are identified by their position in [`Topology::order`]: callers store their
//! primitives in that order, so the leaves of the hierarchy read memory front to back.

use glam::DVec3;

use crate::aabb::Aabb;

/// Most primitives in a leaf.
const MAX_LEAF: usize = 4;
/// Number of centroid bins per axis for the SAH sweep.
const BINS: usize = 16;
/// Cost of visiting a node relative to intersecting one primitive (pbrt uses 1/8 to 1).
const TRAVERSAL_COST: f64 = 0.5;
/// Deepest level split by the SAH; deeper nodes are halved, so the depth stays below
/// `MAX_SAH_DEPTH + log2(n)`, well inside the traversal stack for any `n` a `u32` indexes.
const MAX_SAH_DEPTH: usize = 64;
/// Traversal stack size: a 4-wide node pushes at most 3 entries beyond the one it replaces,
/// and the 4-wide tree is no deeper than the binary one.
const STACK: usize = 3 * (MAX_SAH_DEPTH + 40) + 4;
/// Subtrees with more primitives than this are built on two threads.
const PARALLEL_BUILD: usize = 4096;
/// A child slot is one word: a node index, or a leaf's first primitive position with its
/// primitive count in the bits from this one up (a node has count 0). Positions are below
/// 2^28, which a hierarchy of fewer primitives than that guarantees.
const COUNT_SHIFT: u32 = 28;
/// The position bits of a child slot.
const POSITION_MASK: u32 = (1 << COUNT_SHIFT) - 1;
const _: () = assert!(
    MAX_LEAF < 1 << (32 - COUNT_SHIFT),
    "a leaf's count fits its bits"
);

/// Bytes per primitive of a hierarchy, about: its place in the leaf order, and a 4-wide
/// moving node's children and boxes per three primitives (leaves hold one to four).
pub const BYTES_PER_PRIMITIVE: usize =
    4 + (std::mem::size_of::<Links>() + std::mem::size_of::<[Boxes4; 2]>()) / 3;

/// Bytes per primitive a build holds at its peak, about: its working item, and a node of
/// the binary tree (about one per primitive).
pub const BUILD_BYTES_PER_PRIMITIVE: usize =
    std::mem::size_of::<BuildItem>() + std::mem::size_of::<Build>();

/// Scratch space for traversals. Made once per thread of work and reused for every ray:
/// clearing a fresh stack array per ray cost about 8% of a render.
#[derive(Clone, Debug)]
pub struct TraversalStack {
    /// A child slot ([`COUNT_SHIFT`]): a node index, or a leaf's first position and count.
    entry: [u32; STACK],
    /// For a node entry, its children, read from the topology when the entry is pushed.
    links: [Links; STACK],
    /// The ray's entry distance into the entry's box: entries beyond the nearest hit so far
    /// are skipped.
    near: [f32; STACK],
}

impl Default for TraversalStack {
    fn default() -> Self {
        TraversalStack {
            entry: [0; STACK],
            links: [Links::default(); STACK],
            near: [0.0; STACK],
        }
    }
}

/// Four children's boxes, structure-of-arrays: `planes[axis][child]` is the lower side,
/// `planes[3 + axis][child]` the upper side, as `f32` rounded outward ([`f32_below`],
/// [`f32_above`]) so a stored box always contains the `f64` box it stands for. An empty slot
/// has lower sides `+inf` and upper sides `-inf`, which no ray hits. 96 bytes, aligned to 32,
/// so a node's boxes always lie on exactly two cache lines.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(align(32))]
struct Boxes4 {
    planes: [[f32; 4]; 6],
}

impl Boxes4 {
    const EMPTY: Boxes4 = Boxes4 {
        planes: [
            [f32::INFINITY; 4],
            [f32::INFINITY; 4],
            [f32::INFINITY; 4],
            [f32::NEG_INFINITY; 4],
            [f32::NEG_INFINITY; 4],
            [f32::NEG_INFINITY; 4],
        ],
    };

    const ZERO: Boxes4 = Boxes4 {
        planes: [[0.0; 4]; 6],
    };

    /// Sets slot `k` to the smallest `f32` box containing `b`.
    fn set(&mut self, k: usize, b: &Aabb) {
        for a in 0..3 {
            self.planes[a][k] = f32_below(b.min[a]);
            self.planes[3 + a][k] = f32_above(b.max[a]);
        }
    }
}

/// The largest `f32` at or below `x`: `x` itself when it is one, and `-inf` below
/// `-f32::MAX`; `f32::MAX` for a finite `x` above it, `+inf` for `+inf`, NaN for NaN.
fn f32_below(x: f64) -> f32 {
    // `as` rounds to nearest (to an infinity past the range); one step down undoes a rounding up.
    let y = x as f32;
    if f64::from(y) > x { y.next_down() } else { y }
}

/// The smallest `f32` at or above `x` (the mirror of [`f32_below`]).
fn f32_above(x: f64) -> f32 {
    -f32_below(-x)
}

/// The children of a 4-wide node: per slot, a node index or a leaf's first primitive position
/// and count, packed in one word ([`COUNT_SHIFT`]). An empty slot is 0 (node 0 is the root,
/// nobody's child). Sixteen bytes, aligned, so a node's children never straddle a cache line:
/// a traversal reads them apart from the node's boxes, one line more per node.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(align(16))]
struct Links {
    child: [u32; 4],
}

impl Links {
    /// Slot `k`: a node index and count 0, or a leaf's first position and its count.
    #[inline]
    fn slot(&self, k: usize) -> (u32, u32) {
        let w = self.child[k];
        (w & POSITION_MASK, w >> COUNT_SHIFT)
    }
}

/// The structure of a hierarchy over primitives `0..n`, which a refit keeps: the children of
/// every 4-wide node (nodes in depth-first order, the root first) and the primitives in leaf
/// order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Topology {
    links: Vec<Links>,
    /// Primitive indices in leaf order.
    order: Vec<u32>,
}

/// The boxes of the nodes of a [`Topology`], which a refit recomputes: per node, its four
/// children's boxes, and for a moving hierarchy their change over the shutter. Only one of
/// `still` and `moving` has entries.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Boxes {
    /// For a still hierarchy, per node, its children's boxes.
    still: Vec<Boxes4>,
    /// For a moving hierarchy, per node, its children's boxes at the shutter's opening and
    /// their change until its closing (about `close - open`, widened: see [`moving_lower`]),
    /// side by side: a traversal step reads both, with one bounds check.
    moving: Vec<[Boxes4; 2]>,
    /// The box of everything (over the whole shutter, for a moving hierarchy).
    bounds: Aabb,
}

/// A hierarchy over primitives `0..n` given by their boxes: its topology and its boxes.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    topology: Topology,
    boxes: Boxes,
}

/// A topology with boxes computed for it (by its build or by [`Topology::refit_moving`]), as
/// a traversal reads them.
#[derive(Clone, Copy, Debug)]
pub struct BvhView<'a> {
    topology: &'a Topology,
    boxes: &'a Boxes,
}

/// A node of the binary build tree, with its boxes (filled in after the build).
struct Build {
    boxes: NodeBoxes,
    kind: Kind,
}

enum Kind {
    Leaf { first: u32, count: u32 },
    Inner(Box<[Build; 2]>),
}

struct BuildItem {
    /// The box the SAH works with (over the whole shutter).
    bounds: Aabb,
    centroid: DVec3,
    index: u32,
}

/// The boxes of a node of the build tree: over the whole shutter, at its opening and at its
/// closing.
#[derive(Clone, Copy)]
struct NodeBoxes {
    whole: Aabb,
    open: Aabb,
    close: Aabb,
}

impl NodeBoxes {
    const EMPTY: NodeBoxes = NodeBoxes {
        whole: Aabb::EMPTY,
        open: Aabb::EMPTY,
        close: Aabb::EMPTY,
    };

    fn union(&self, o: &NodeBoxes) -> NodeBoxes {
        NodeBoxes {
            whole: self.whole.union(&o.whole),
            open: self.open.union(&o.open),
            close: self.close.union(&o.close),
        }
    }
}

impl Bvh {
    /// Builds the hierarchy over `boxes`; primitive `i` has box `boxes[i]`. At most 2^28
    /// primitives.
    pub fn build(boxes: &[Aabb]) -> Bvh {
        Bvh::build_inner(boxes, None)
    }

    /// Builds a hierarchy over moving primitives: primitive `i` lies at every shutter time
    /// `s` in [0, 1] inside the box interpolated linearly from `open[i]` (at `s = 0`) to
    /// `close[i]` (at `s = 1`). Pad the boxes for the rounding of that interpolation (see
    /// [`Aabb::pad_for_rounding`]).
    pub fn build_moving(open: &[Aabb], close: &[Aabb]) -> Bvh {
        assert_eq!(open.len(), close.len());
        Bvh::build_inner(open, Some(close))
    }

    fn build_inner(open: &[Aabb], close: Option<&[Aabb]>) -> Bvh {
        assert!(
            open.len() <= 1 << COUNT_SHIFT,
            "too many primitives for a hierarchy"
        );
        let whole = |i: usize| close.map_or(open[i], |c| open[i].union(&c[i]));
        let mut items: Vec<BuildItem> = {
            use rayon::prelude::*;
            (0..open.len())
                .into_par_iter()
                .map(|i| {
                    let b = whole(i);
                    BuildItem {
                        bounds: b,
                        centroid: b.centroid(),
                        index: i as u32,
                    }
                })
                .collect()
        };
        let mut topology = Topology::default();
        let mut boxes = Boxes::default();
        if !items.is_empty() {
            let mut tree = build_node(&mut items, 0, 0);
            topology.order = items.iter().map(|it| it.index).collect();
            drop(items);
            let prim = |pos: u32| {
                let i = topology.order[pos as usize] as usize;
                NodeBoxes {
                    whole: whole(i),
                    open: open[i],
                    close: close.map_or(open[i], |c| c[i]),
                }
            };
            annotate(&mut tree, &prim);
            // The root is always a 4-wide node, even over a single leaf, so traversal starts
            // at node 0.
            if let Kind::Leaf { .. } = tree.kind {
                let leaf = Build {
                    boxes: tree.boxes,
                    kind: Kind::Leaf { first: 0, count: 0 },
                };
                let lone = std::mem::replace(&mut tree, leaf);
                tree.kind = Kind::Inner(Box::new([lone, Build::empty()]));
            }
            let moving = close.is_some();
            collapse(&tree, moving, &mut topology.links, &mut boxes);
            boxes.bounds = tree.boxes.whole;
        }
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
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    /// Its boxes.
    pub fn boxes(&self) -> &Boxes {
        &self.boxes
    }

    /// Its topology and boxes, apart.
    pub fn into_parts(self) -> (Topology, Boxes) {
        (self.topology, self.boxes)
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

    /// Number of 4-wide nodes.
    pub fn node_count(&self) -> usize {
        self.topology.node_count()
    }

    /// Bytes held by the hierarchy (topology and boxes).
    pub fn memory_bytes(&self) -> usize {
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
        hit: impl FnMut(u32, f64) -> Option<f64>,
    ) -> Option<(f64, u32)> {
        self.view().closest_hit(origin, dir, s, t_max, stack, hit)
    }
}

impl Topology {
    /// Boxes for moving primitives on this topology (refitting): primitive `i` lies inside
    /// the box interpolated from `open[i]` to `close[i]`, as for [`Bvh::build_moving`]. Every
    /// node's boxes are the unions of its children's, bottom up, so the result is exact for
    /// any boxes; only its quality ([`Boxes::area`]) depends on how far they are from those
    /// the topology was built on. Boxes equal to those of the build give its boxes exactly.
    pub fn refit_moving(&self, open: &[Aabb], close: &[Aabb]) -> Boxes {
        assert!(open.len() == self.order.len() && close.len() == self.order.len());
        let n = self.links.len();
        let mut boxes = Boxes {
            still: Vec::new(),
            moving: vec![[Boxes4::EMPTY, Boxes4::ZERO]; n],
            bounds: Aabb::EMPTY,
        };
        // Nodes are in depth-first order, so every child comes after its parent: in reverse
        // order, a node's children are done before it.
        let mut unions = vec![(Aabb::EMPTY, Aabb::EMPTY); n];
        for i in (0..n).rev() {
            let links = &self.links[i];
            let mut all = (Aabb::EMPTY, Aabb::EMPTY);
            for k in 0..4 {
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
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// Number of 4-wide nodes.
    pub fn node_count(&self) -> usize {
        self.links.len()
    }

    /// Bytes held (children and order).
    pub fn memory_bytes(&self) -> usize {
        self.links.capacity() * std::mem::size_of::<Links>() + self.order.capacity() * 4
    }
}

impl Boxes {
    /// The summed surface areas of every child box of every node, over the whole shutter: the
    /// cost a ray pays to traverse the hierarchy, up to a constant. It grows as refitted
    /// primitives move away from where the topology was built.
    pub fn area(&self) -> f64 {
        let child = |node: &Boxes4, k: usize| {
            let mut b = Aabb::EMPTY;
            for a in 0..3 {
                b.min[a] = f64::from(node.planes[a][k]);
                b.max[a] = f64::from(node.planes[3 + a][k]);
            }
            b
        };
        let mut sum = 0.0;
        for node in &self.still {
            for k in 0..4 {
                let b = child(node, k);
                // Skips an empty slot.
                if b.min.x.is_finite() {
                    sum += b.surface_area();
                }
            }
        }
        for [node, delta] in &self.moving {
            for k in 0..4 {
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
    pub fn memory_bytes(&self) -> usize {
        self.still.capacity() * std::mem::size_of::<Boxes4>()
            + self.moving.capacity() * std::mem::size_of::<[Boxes4; 2]>()
    }
}

impl<'a> BvhView<'a> {
    /// Pairs `topology` with `boxes` computed for it. Panics if they have different numbers
    /// of nodes.
    #[inline]
    pub fn new(topology: &'a Topology, boxes: &'a Boxes) -> BvhView<'a> {
        // One of the two is empty.
        let n = boxes.still.len().max(boxes.moving.len());
        assert!(n == topology.links.len(), "boxes of another topology");
        BvhView { topology, boxes }
    }

    /// Finds the closest primitive hit by the ray `origin + t dir`, `t` in `(0, t_max)`, at
    /// shutter time `s` in [0, 1] (ignored by a still hierarchy). `hit(pos, t_max)` returns
    /// the hit distance in `(0, t_max)` of the primitive at position `pos` of
    /// [`Topology::order`], if any. Returns the distance and position.
    #[inline]
    pub fn closest_hit(
        &self,
        origin: DVec3,
        dir: DVec3,
        s: f64,
        t_max: f64,
        stack: &mut TraversalStack,
        hit: impl FnMut(u32, f64) -> Option<f64>,
    ) -> Option<(f64, u32)> {
        // A ray with a NaN or infinite origin or direction has no meaningful hit, and its
        // slab tests give NaN everywhere (which the tests ignore): it would enter every box.
        // Checked once per ray.
        if self.topology.links.is_empty() || !(origin.is_finite() && dir.is_finite() && !s.is_nan())
        {
            return None;
        }
        match RayLanes::new(origin, dir, s) {
            Some(ray) => self.traverse(stack, t_max, hit, &ray),
            // Rare: an origin beyond 1e30 or a direction with a component below 1e-30 (an
            // axis-parallel ray), whose reciprocal has no `f32`.
            None => {
                let ray = RayF64::new(origin, dir, s);
                self.traverse(stack, t_max, hit, &ray)
            }
        }
    }

    /// The traversal of [`BvhView::closest_hit`], with `test(node, limit)` the slab test of
    /// the children of `node`: a bit per child the ray may enter before `limit` (a bound on
    /// the distance, [`widened_limit`]), and its entry distance (at most the true one).
    #[inline(always)]
    fn traverse(
        &self,
        stack: &mut TraversalStack,
        mut t_max: f64,
        mut hit: impl FnMut(u32, f64) -> Option<f64>,
        ray: &impl SlabTest,
    ) -> Option<(f64, u32)> {
        let links = &self.topology.links[..];
        let mut limit = widened_limit(t_max);
        let mut best = None;
        let mut sp = 0usize;
        let mut current = 0usize;
        let mut node = links[0];
        loop {
            let (mask, near) = ray.test(self.boxes, current, limit, t_max);
            // The child to go to next (a child slot, 0 for none): the nearest child hit. The
            // others are pushed, nearest last, so the nearest of them is popped first.
            let mut next = 0;
            if mask & mask.wrapping_sub(1) == 0 {
                // None or one: nothing to sort or push (the most frequent cases).
                if mask != 0 {
                    next = node.child[mask.trailing_zeros() as usize];
                }
            } else {
                let mut hits = [0usize; 4];
                let mut n = 0;
                for k in 0..4 {
                    if mask & (1 << k) != 0 {
                        let mut j = n;
                        while j > 0 && near[hits[j - 1]] < near[k] {
                            hits[j] = hits[j - 1];
                            j -= 1;
                        }
                        hits[j] = k;
                        n += 1;
                    }
                }
                for &k in &hits[..n - 1] {
                    let w = node.child[k];
                    // A node's children are read now, when it is pushed, not when it is
                    // visited: the load then overlaps the rest of this node's work instead
                    // of delaying the child's, which measured a few percent faster than
                    // reading them at the visit. A leaf reads the root's (always cached)
                    // without a branch.
                    let at = if w >> COUNT_SHIFT == 0 { w as usize } else { 0 };
                    stack.links[sp] = links[at];
                    stack.entry[sp] = w;
                    stack.near[sp] = near[k];
                    sp += 1;
                }
                next = node.child[hits[n - 1]];
            }
            // Its children, if it is a node (a leaf reads the root's).
            let mut next_links = links[if next >> COUNT_SHIFT == 0 {
                next as usize
            } else {
                0
            }];
            // Intersect leaves until an inner node to descend into, popping the stack.
            loop {
                let count = next >> COUNT_SHIFT;
                if count == 0 {
                    // An empty slot (0), entered only through NaN boxes, would read as the
                    // root, and descending into it would push the root again and again until
                    // the stack overflowed. Skipped, every descent is one level down, so the
                    // stack holds at most 3 entries per level of a tree `STACK` is sized for.
                    if next != 0 {
                        current = next as usize;
                        node = next_links;
                        break;
                    }
                } else {
                    let first = next & POSITION_MASK;
                    for pos in first..first + count {
                        if let Some(t) = hit(pos, t_max) {
                            t_max = t;
                            limit = widened_limit(t);
                            best = Some((t, pos));
                        }
                    }
                }
                // Pop the nearest child pushed that may still hold a nearer hit.
                loop {
                    if sp == 0 {
                        return best;
                    }
                    sp -= 1;
                    if stack.near[sp] <= limit {
                        next = stack.entry[sp];
                        next_links = stack.links[sp];
                        break;
                    }
                }
            }
        }
    }
}

/// The relative error of an entry or exit distance computed in `f32` as
/// `(side - origin) * inverse`, with the side and origin `f32` and the inverse the `f32`
/// rounding of the `f64` reciprocal: at most three roundings to `f32` and one to `f64`, so
/// within `(1 + u)^3 (1 + 2^-53) < 1 + 3.01 u` with `u = 2^-24` (pbrt-v4, section 6.8.2),
/// unless the product is subnormal (then off by at most `2^-150`) or overflows (then
/// infinite, beyond every finite `f32` limit).
///
/// An entry distance is scaled by `NEAR_SCALE = 1 - 8u` (rounded, below `1 - 4u` of it):
/// below the exact one. An exit distance is scaled by `FAR_SCALE = 1 + 16u` and `TINY` added
/// (the smallest normal `f32`, for the subnormal case): above the exact one. pbrt-v4's
/// robust slab test widens the exit only (by `1 + 2 gamma(3)`); here both are bounded, since
/// entry distances also prune the stack.
const NEAR_SCALE: f32 = 1.0 - 1.0 / (1 << 21) as f32;
const FAR_SCALE: f32 = 1.0 + 1.0 / (1 << 20) as f32;
const TINY: f32 = f32::MIN_POSITIVE;

/// An `f32` at or above `t * (1 + 16u)` (see [`NEAR_SCALE`]) past any nonnegative `f64`
/// `t`: children entered beyond it are not visited. `+inf` for `t` beyond the `f32` range.
#[inline]
fn widened_limit(t: f64) -> f32 {
    // Rounded up past `t` without a branch: `t (1 + 2^-22)` exceeds `t` by more than its
    // rounding to `f32` (2^-24 of it), and `TINY` covers a subnormal `t`.
    (t * (1.0 + f64::from(2f32.powi(-22)))) as f32 * FAR_SCALE + TINY
}

/// A ray's test against the four children of a node.
trait SlabTest {
    /// The children of `node` (with `boxes`) the ray may enter before the distance `t_max`,
    /// or `limit` (an `f32` at or above it, [`widened_limit`]), as bits, and their entry
    /// distances, at most the true ones.
    fn test(&self, boxes: &Boxes, node: usize, limit: f32, t_max: f64) -> (u32, [f32; 4]);
}

/// A ray as the `f32` slab test reads it: per axis, its reciprocal direction, and its origin
/// rounded to `f32` both ways; whether its direction is negative; the shutter time.
struct RayLanes {
    inv: [lanes::F4; 3],
    /// The origin rounded up, subtracted from lower sides: `lower - origin` comes out at
    /// most the exact difference, so a positive direction's entry distance is not
    /// overestimated, nor a negative one's exit distance underestimated.
    o_up: [lanes::F4; 3],
    /// The origin rounded down, for upper sides (the mirror image).
    o_down: [lanes::F4; 3],
    /// Per axis, whether the direction is negative: the ray enters through the upper side.
    negative: [bool; 3],
    s: lanes::F4,
}

impl RayLanes {
    /// `None` if some origin coordinate exceeds 1e30 in magnitude or some direction
    /// component is below 1e-30 (its reciprocal would be beyond the `f32` range).
    #[inline(always)]
    fn new(origin: DVec3, dir: DVec3, s: f64) -> Option<RayLanes> {
        if !(origin.abs().max_element() <= 1e30 && dir.abs().min_element() >= 1e-30) {
            return None;
        }
        let inv = (DVec3::ONE / dir).as_vec3();
        // `origin -+ m` rounded to the nearest `f32` is below (above) `origin`: `m` exceeds
        // the rounding to `f32` (at most 2^-24 of the magnitude, or 2^-150 below the normal
        // range) and the two `f64` roundings before it. Without the branches of
        // `f32_below`, whose outcome is a coin toss per ray; one `f32` ulp looser.
        let m = origin.abs() * f64::from(2f32.powi(-23)) + f64::from(f32::MIN_POSITIVE);
        let (up, down) = ((origin + m).as_vec3(), (origin - m).as_vec3());
        Some(RayLanes {
            inv: std::array::from_fn(|a| lanes::F4::splat(inv[a])),
            o_up: std::array::from_fn(|a| lanes::F4::splat(up[a])),
            o_down: std::array::from_fn(|a| lanes::F4::splat(down[a])),
            negative: std::array::from_fn(|a| inv[a] < 0.0),
            s: lanes::F4::splat(s as f32),
        })
    }

    /// Along axis `a`, the distances to a box's lower and upper sides, with the rounded
    /// origins they take, as (entry, exit).
    #[inline(always)]
    fn axis(&self, a: usize, lower: lanes::F4, upper: lanes::F4) -> (lanes::F4, lanes::F4) {
        let lower = lower.sub(self.o_up[a]).mul(self.inv[a]);
        let upper = upper.sub(self.o_down[a]).mul(self.inv[a]);
        // A select of values, not of indices: no bounds checks in the loop.
        if self.negative[a] {
            (upper, lower)
        } else {
            (lower, upper)
        }
    }
}

impl SlabTest for RayLanes {
    /// Entry distances at most the exact ones (computed in real arithmetic from the `f64`
    /// origin and direction, against the box a traversal's `f32` evaluation gives).
    #[inline(always)]
    fn test(&self, boxes: &Boxes, node: usize, limit: f32, _: f64) -> (u32, [f32; 4]) {
        use lanes::F4;
        let mut near = F4::splat(0.0);
        let mut far = F4::splat(f32::INFINITY);
        // `max` and `min` keep the running value when the new one is NaN (0 * inf cannot
        // arise with a finite reciprocal, but a NaN side can), which leaves that axis out.
        for a in 0..3 {
            let (lower, upper) = if boxes.moving.is_empty() {
                let planes = &boxes.still[node].planes;
                (F4::load(&planes[a]), F4::load(&planes[3 + a]))
            } else {
                let [planes, d] = &boxes.moving[node];
                let (planes, d) = (&planes.planes, &d.planes);
                // Evaluated in `f32`, as `moving_lower` allows for.
                (
                    F4::load(&planes[a]).add(self.s.mul(F4::load(&d[a]))),
                    F4::load(&planes[3 + a]).add(self.s.mul(F4::load(&d[3 + a]))),
                )
            };
            let (n, f) = self.axis(a, lower, upper);
            near = n.max_keep(near);
            far = f.min_keep(far);
        }
        let near = near.mul(F4::splat(NEAR_SCALE));
        let far = far
            .mul(F4::splat(FAR_SCALE))
            .add(F4::splat(TINY))
            .min_keep(F4::splat(limit));
        (near.le_mask(far), near.to_array())
    }
}

/// A ray as the `f64` slab test reads it, for rays [`RayLanes`] cannot take.
struct RayF64 {
    inv: [f64; 3],
    o: [f64; 3],
    entry: [usize; 3],
    exit: [usize; 3],
    s: f32,
}

impl RayF64 {
    fn new(origin: DVec3, dir: DVec3, s: f64) -> RayF64 {
        let inv = (DVec3::ONE / dir).to_array();
        // Per axis, the index in `Boxes4::planes` of the planes through which the ray enters
        // and leaves boxes: the upper one first for a negative direction. Taken from the
        // reciprocal so that a direction of -0 (reciprocal -inf) counts as negative.
        RayF64 {
            inv,
            o: origin.to_array(),
            entry: std::array::from_fn(|a| if inv[a] < 0.0 { 3 + a } else { a }),
            exit: std::array::from_fn(|a| if inv[a] < 0.0 { a } else { 3 + a }),
            s: s as f32,
        }
    }
}

impl SlabTest for RayF64 {
    /// Tested against `t_max`, with the entry distances rounded down to `f32`.
    #[inline(never)]
    fn test(&self, boxes: &Boxes, node: usize, _: f32, t_max: f64) -> (u32, [f32; 4]) {
        let (o, inv, s32) = (&self.o, &self.inv, self.s);
        let mut near = [0.0f64; 4];
        let mut far = [t_max; 4];
        // `max` and `min` ignore a NaN (0 * inf: a ray in a box's face plane, parallel
        // to it), which leaves that axis out of the interval.
        if boxes.moving.is_empty() {
            let planes = &boxes.still[node].planes;
            for a in 0..3 {
                let (e, x) = (self.entry[a], self.exit[a]);
                for k in 0..4 {
                    near[k] = near[k].max((f64::from(planes[e][k]) - o[a]) * inv[a]);
                    far[k] = far[k].min((f64::from(planes[x][k]) - o[a]) * inv[a]);
                }
            }
        } else {
            let [planes, d] = &boxes.moving[node];
            let (planes, d) = (&planes.planes, &d.planes);
            for a in 0..3 {
                let (e, x) = (self.entry[a], self.exit[a]);
                for k in 0..4 {
                    // In `f32`, which `moving_lower`'s margin allows for.
                    let n = f64::from(planes[e][k] + s32 * d[e][k]);
                    let f = f64::from(planes[x][k] + s32 * d[x][k]);
                    near[k] = near[k].max((n - o[a]) * inv[a]);
                    far[k] = far[k].min((f - o[a]) * inv[a]);
                }
            }
        }
        let mut mask = 0;
        for k in 0..4 {
            mask |= u32::from(near[k] <= far[k]) << k;
        }
        (mask, near.map(f32_below))
    }
}

/// Four `f32` lanes: SSE registers on x86-64 (SSE2 is part of its baseline; `safe_arch`
/// wraps the intrinsics, which the standard library has as unsafe functions), plain arrays
/// elsewhere, with the same results lane by lane.
mod lanes {
    #[cfg(target_arch = "x86_64")]
    use safe_arch::*;

    /// Four `f32`s.
    #[cfg(target_arch = "x86_64")]
    #[derive(Clone, Copy, Debug)]
    pub struct F4(m128);

    #[cfg(target_arch = "x86_64")]
    impl F4 {
        #[inline(always)]
        pub fn splat(x: f32) -> F4 {
            F4(set_splat_m128(x))
        }
        #[inline(always)]
        pub fn load(a: &[f32; 4]) -> F4 {
            F4(load_unaligned_m128(a))
        }
        #[inline(always)]
        pub fn add(self, o: F4) -> F4 {
            F4(add_m128(self.0, o.0))
        }
        #[inline(always)]
        pub fn sub(self, o: F4) -> F4 {
            F4(sub_m128(self.0, o.0))
        }
        #[inline(always)]
        pub fn mul(self, o: F4) -> F4 {
            F4(mul_m128(self.0, o.0))
        }
        /// Per lane, `self` if it is greater than `acc`, else `acc` (so `acc` when `self` is
        /// NaN): SSE's `maxps`.
        #[inline(always)]
        pub fn max_keep(self, acc: F4) -> F4 {
            F4(max_m128(self.0, acc.0))
        }
        /// Per lane, `self` if it is less than `acc`, else `acc` (so `acc` when `self` is
        /// NaN): SSE's `minps`.
        #[inline(always)]
        pub fn min_keep(self, acc: F4) -> F4 {
            F4(min_m128(self.0, acc.0))
        }
        /// Bit `k` set where lane `k` of `self` is at most that of `o` (false for NaN).
        #[inline(always)]
        pub fn le_mask(self, o: F4) -> u32 {
            move_mask_m128(cmp_le_mask_m128(self.0, o.0)) as u32
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            self.0.to_array()
        }
    }

    /// Four `f32`s.
    #[cfg(not(target_arch = "x86_64"))]
    #[derive(Clone, Copy, Debug)]
    pub struct F4([f32; 4]);

    #[cfg(not(target_arch = "x86_64"))]
    impl F4 {
        #[inline(always)]
        pub fn splat(x: f32) -> F4 {
            F4([x; 4])
        }
        #[inline(always)]
        pub fn load(a: &[f32; 4]) -> F4 {
            F4(*a)
        }
        #[inline(always)]
        fn zip(self, o: F4, f: impl Fn(f32, f32) -> f32) -> F4 {
            F4(std::array::from_fn(|k| f(self.0[k], o.0[k])))
        }
        #[inline(always)]
        pub fn add(self, o: F4) -> F4 {
            self.zip(o, |a, b| a + b)
        }
        #[inline(always)]
        pub fn sub(self, o: F4) -> F4 {
            self.zip(o, |a, b| a - b)
        }
        #[inline(always)]
        pub fn mul(self, o: F4) -> F4 {
            self.zip(o, |a, b| a * b)
        }
        /// Per lane, `self` if it is greater than `acc`, else `acc` (so `acc` when `self` is
        /// NaN).
        #[inline(always)]
        pub fn max_keep(self, acc: F4) -> F4 {
            self.zip(acc, |a, b| if a > b { a } else { b })
        }
        /// Per lane, `self` if it is less than `acc`, else `acc` (so `acc` when `self` is NaN).
        #[inline(always)]
        pub fn min_keep(self, acc: F4) -> F4 {
            self.zip(acc, |a, b| if a < b { a } else { b })
        }
        /// Bit `k` set where lane `k` of `self` is at most that of `o` (false for NaN).
        #[inline(always)]
        pub fn le_mask(self, o: F4) -> u32 {
            (0..4).fold(0, |m, k| m | (u32::from(self.0[k] <= o.0[k]) << k))
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            self.0
        }
    }
}

impl Build {
    /// A leaf of no primitives, with empty boxes: no ray enters it.
    fn empty() -> Build {
        Build {
            boxes: NodeBoxes::EMPTY,
            kind: Kind::Leaf { first: 0, count: 0 },
        }
    }
}

/// Builds the binary tree over `items` (reordered in place so every leaf is a contiguous
/// range); `offset` is the position of `items[0]` in the whole array. Boxes are left empty.
fn build_node(items: &mut [BuildItem], offset: usize, depth: usize) -> Build {
    let leaf = Build {
        boxes: NodeBoxes::EMPTY,
        kind: Kind::Leaf {
            first: offset as u32,
            count: items.len() as u32,
        },
    };
    if items.len() <= 1 {
        return leaf;
    }
    let bounds = items.iter().fold(Aabb::EMPTY, |b, it| b.union(&it.bounds));
    // Below MAX_SAH_DEPTH, halving keeps the tree shallow enough for the traversal stack
    // whatever the distribution.
    let sah = if depth < MAX_SAH_DEPTH {
        split(items, &bounds)
    } else {
        None
    };
    let mid = match sah {
        Some(mid) => mid,
        // No useful SAH split (e.g. identical centroids) but too many for a leaf: halve.
        None if items.len() > MAX_LEAF => items.len() / 2,
        None => return leaf,
    };
    let (left, right) = items.split_at_mut(mid);
    let (l, r) = if left.len().min(right.len()) > PARALLEL_BUILD {
        rayon::join(
            || build_node(left, offset, depth + 1),
            || build_node(right, offset + mid, depth + 1),
        )
    } else {
        (
            build_node(left, offset, depth + 1),
            build_node(right, offset + mid, depth + 1),
        )
    };
    Build {
        boxes: NodeBoxes::EMPTY,
        kind: Kind::Inner(Box::new([l, r])),
    }
}

/// Fills in the boxes of every node of `t`, bottom up.
fn annotate(t: &mut Build, prim: &impl Fn(u32) -> NodeBoxes) -> NodeBoxes {
    t.boxes = match &mut t.kind {
        Kind::Leaf { first, count } => {
            (*first..*first + *count).fold(NodeBoxes::EMPTY, |b, p| b.union(&prim(p)))
        }
        Kind::Inner(c) => {
            let [l, r] = &mut **c;
            annotate(l, prim).union(&annotate(r, prim))
        }
    };
    t.boxes
}

/// Appends the 4-wide nodes of the binary subtree `t` (an inner node) to `links` and
/// `boxes` in depth-first order. The four children are found by opening, from the node's two, the child
/// with the largest surface area until there are four (Embree's BVH4 collapse).
fn collapse(t: &Build, moving: bool, links: &mut Vec<Links>, boxes: &mut Boxes) {
    let Kind::Inner(children) = &t.kind else {
        unreachable!("collapse starts at inner nodes")
    };
    let mut kids: Vec<&Build> = children.iter().collect();
    while kids.len() < 4 {
        let Some((i, _)) = kids
            .iter()
            .enumerate()
            .filter(|(_, c)| matches!(c.kind, Kind::Inner(_)))
            .max_by(|a, b| {
                a.1.boxes
                    .whole
                    .surface_area()
                    .total_cmp(&b.1.boxes.whole.surface_area())
            })
        else {
            break;
        };
        let Kind::Inner(grand) = &kids.remove(i).kind else {
            unreachable!()
        };
        kids.insert(i, &grand[1]);
        kids.insert(i, &grand[0]);
    }
    let index = links.len();
    links.push(Links { child: [0; 4] });
    if moving {
        boxes.moving.push([Boxes4::EMPTY, Boxes4::ZERO]);
    } else {
        boxes.still.push(Boxes4::EMPTY);
    }
    for (k, c) in kids.iter().enumerate() {
        links[index].child[k] = match c.kind {
            Kind::Leaf { first, count } => first | count << COUNT_SHIFT,
            Kind::Inner(_) => {
                let at = links.len() as u32;
                collapse(c, moving, links, boxes);
                at
            }
        };
        let b = &c.boxes;
        if moving {
            set_moving(&mut boxes.moving[index], k, &b.open, &b.close);
        } else {
            boxes.still[index].set(k, &b.whole);
        }
    }
}

/// Sets child slot `k` of a moving node's `[boxes, delta]` to a box containing, at every
/// shutter time `s` in [0, 1], the box interpolated from `open` (at `s = 0`) to `close` (at
/// `s = 1`): stored as its sides at the opening and their change until the closing, both
/// `f32`, which a traversal evaluates in `f32` as `side + s * change` ([`moving_lower`]).
fn set_moving(node: &mut [Boxes4; 2], k: usize, open: &Aabb, close: &Aabb) {
    let [boxes, delta] = node;
    for a in 0..3 {
        (boxes.planes[a][k], delta.planes[a][k]) = moving_lower(open.min[a], close.min[a]);
        // An upper side is a lower side of the mirrored box.
        let (o, d) = moving_lower(-open.max[a], -close.max[a]);
        (boxes.planes[3 + a][k], delta.planes[3 + a][k]) = (-o, -d);
    }
}

/// A lower side moving from `open` to `close` during the shutter, as `(o, d)` in `f32` such
/// that `o + s * d` is at most `open + s * (close - open)` (exactly) for every `s` in [0, 1],
/// whether evaluated in `f64` (each `f32` converted exactly) or in `f32` (with `s` rounded to
/// `f32`).
///
/// Why (the reasoning of pbrt-v4's error bounds): let `m = max(|open|, |close|)` and
/// `p = m 2^-18 + 2^-146`. Then `o <= open - p + 2^-53 (m + p)` (rounded down from the `f64`
/// subtraction, off by at most that) and so `o <= open - (1 - 2^-34) p`; likewise `c` for
/// `close`. `d` is `c - o` rounded down but for the `f64` rounding of that difference, at most
/// `2^-52 |c - o| <= 2^-50 (m + p)` above. In exact arithmetic, since the interpolation has
/// non-negative weights, `o + s d <= (1 - s) o + s c + 2^-50 (m + p)`, which is at most
/// `open + s (close - open) - (1 - 2^-34) p + 2^-50 (m + p)`. Evaluating `o + s * d` in `f64` costs two roundings of at
/// most `2^-53 (|s d| + |o + s d|) <= 2^-50 (m + p)`; in `f32`, rounding `s` (by `2^-25`), the
/// product and the sum cost at most `2^-24 (2.5 |d| + |o|) <= 2^-21 (m + p)`, plus `2^-149`
/// for each of two underflows. In all the evaluated side lies below the exact interpolation,
/// as `p >= 2^-18 m` and `2^-146` is more than the underflows. A side that is not finite (an
/// empty slot's `+inf`, a NaN, or one beyond the `f32` range after the margin) is stored as
/// the constant `min(open, close)` rounded down with `d = 0`, below the interpolation at every
/// `s`: an empty slot stays `+inf`, never hit.
fn moving_lower(open: f64, close: f64) -> (f32, f32) {
    let constant = || (f32_below(open.min(close)), 0.0);
    if !(open.is_finite() && close.is_finite()) {
        return constant();
    }
    // 2^-18 and 2^-146, eight times the least positive `f32`.
    let p = open.abs().max(close.abs()) * f64::from(2f32.powi(-18)) + f64::from(f32::from_bits(8));
    let o = f32_below(open - p);
    let c = f32_below(close - p);
    if !(o.is_finite() && c.is_finite()) {
        return constant();
    }
    let d = f32_below(f64::from(c) - f64::from(o));
    if !d.is_finite() {
        return constant();
    }
    (o, d)
}

/// The best SAH split of `items` (reordered in place so the split is at the returned index),
/// or `None` when keeping them in one leaf is cheaper or no split separates them.
fn split(items: &mut [BuildItem], bounds: &Aabb) -> Option<usize> {
    let cb = items
        .iter()
        .fold(Aabb::EMPTY, |b, it| b.union_point(it.centroid));
    let extent = cb.max - cb.min;
    let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, bin boundary)
    for axis in 0..3 {
        // Also skips a NaN extent.
        if extent[axis].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let scale = BINS as f64 / extent[axis];
        let bin_of = |c: DVec3| (((c[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1);
        let mut counts = [0usize; BINS];
        let mut boxes = [Aabb::EMPTY; BINS];
        for it in items.iter() {
            let b = bin_of(it.centroid);
            counts[b] += 1;
            boxes[b] = boxes[b].union(&it.bounds);
        }
        // Sweep from the right to get the area and count of every right part.
        let mut right_area = [0.0; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut n) = (Aabb::EMPTY, 0);
        for i in (1..BINS).rev() {
            acc = acc.union(&boxes[i]);
            n += counts[i];
            right_area[i] = acc.surface_area();
            right_count[i] = n;
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0);
        for i in 1..BINS {
            acc = acc.union(&boxes[i - 1]);
            n += counts[i - 1];
            if n == 0 || right_count[i] == 0 {
                continue;
            }
            let cost = n as f64 * acc.surface_area() + right_count[i] as f64 * right_area[i];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, i));
            }
        }
    }
    let (cost, axis, boundary) = best?;
    let area = bounds.surface_area();
    let split_cost = TRAVERSAL_COST + if area > 0.0 { cost / area } else { 0.0 };
    if items.len() <= MAX_LEAF && split_cost >= items.len() as f64 {
        return None;
    }
    let scale = BINS as f64 / extent[axis];
    let mut mid = 0;
    for i in 0..items.len() {
        let b = (((items[i].centroid[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1);
        if b < boundary {
            items.swap(i, mid);
            mid += 1;
        }
    }
    Some(mid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    fn brute(centers: &[(DVec3, f64)], ray: &crate::ray::Ray) -> Option<(f64, u32)> {
        let mut best: Option<(f64, u32)> = None;
        for (i, (c, r)) in centers.iter().enumerate() {
            if let Some(t) =
                crate::sphere::intersect(*c, *r, ray, best.map_or(f64::INFINITY, |b| b.0))
            {
                best = Some((t, i as u32));
            }
        }
        best
    }

    fn random_rays(r: &mut Pcg32, n: usize) -> Vec<crate::ray::Ray> {
        (0..n)
            .map(|_| {
                let o = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 30.0 - 15.0;
                let mut d = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5;
                // Some axis-parallel rays, whose reciprocal direction has infinities.
                if r.next_f64() < 0.1 {
                    d.x = 0.0;
                }
                if r.next_f64() < 0.1 {
                    d.y = 0.0;
                }
                crate::ray::Ray {
                    origin: o,
                    dir: d.normalize(),
                    time: r.next_f64(),
                }
            })
            .collect()
    }

    #[test]
    fn agrees_with_brute_force() {
        let mut r = Pcg32::new(11, 1);
        let mut stack = TraversalStack::default();
        for &n in &[0usize, 1, 2, 5, 17, 300, 2000, 9000] {
            let centers: Vec<(DVec3, f64)> = (0..n)
                .map(|_| {
                    let c = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 20.0 - 10.0;
                    (c, 0.05 + r.next_f64() * 0.5)
                })
                .collect();
            let boxes: Vec<Aabb> = centers
                .iter()
                .map(|(c, rad)| Aabb::point(*c).grow(*rad))
                .collect();
            let bvh = Bvh::build(&boxes);
            assert_eq!(bvh.len(), n);
            for ray in random_rays(&mut r, 500) {
                let got = bvh.closest_hit(
                    ray.origin,
                    ray.dir,
                    0.0,
                    f64::INFINITY,
                    &mut stack,
                    |p, tmax| {
                        let (c, rad) = centers[bvh.order()[p as usize] as usize];
                        crate::sphere::intersect(c, rad, &ray, tmax)
                    },
                );
                let got = got.map(|(t, p)| (t, bvh.order()[p as usize]));
                assert_eq!(got, brute(&centers, &ray));
            }
        }
    }

    /// Rays with NaN or infinite parts, and boxes with NaN sides, find nothing and never
    /// overflow the traversal stack, in still and moving hierarchies of any size.
    #[test]
    fn non_finite_rays_and_boxes_find_nothing() {
        let mut r = Pcg32::new(13, 5);
        let mut stack = TraversalStack::default();
        let (nan, inf) = (f64::NAN, f64::INFINITY);
        let rays = [
            (DVec3::splat(nan), DVec3::X),
            (DVec3::ZERO, DVec3::splat(nan)),
            (DVec3::new(0.0, nan, 0.0), DVec3::new(0.0, 0.0, 1.0)),
            (DVec3::splat(inf), DVec3::X),
            (DVec3::ZERO, DVec3::splat(inf)),
            (DVec3::ZERO, DVec3::new(-inf, 1.0, 0.0)),
            (DVec3::splat(-inf), DVec3::splat(inf)),
        ];
        for &n in &[1usize, 5, 300, 9000] {
            let boxes: Vec<Aabb> = (0..n)
                .map(|_| {
                    let c = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 20.0 - 10.0;
                    Aabb::point(c).grow(0.5)
                })
                .collect();
            let still = Bvh::build(&boxes);
            let moving = Bvh::build_moving(&boxes, &boxes);
            for bvh in [&still, &moving] {
                for s in [0.0, 0.5, nan] {
                    for &(origin, dir) in &rays {
                        let got = bvh.closest_hit(origin, dir, s, inf, &mut stack, |_, _| {
                            panic!("a non-finite ray reached a primitive")
                        });
                        assert_eq!(got, None);
                    }
                }
            }
            // Boxes with NaN sides (refitted onto the topology) are entered by every ray, since
            // the slab test ignores NaN: the traversal still visits each leaf once, no more.
            let bad = vec![Aabb::point(DVec3::splat(nan)); n];
            let boxes = moving.topology().refit_moving(&bad, &bad);
            let view = BvhView::new(moving.topology(), &boxes);
            for ray in random_rays(&mut r, 20) {
                let mut visits = 0;
                let got = view.closest_hit(ray.origin, ray.dir, 0.5, inf, &mut stack, |_, _| {
                    visits += 1;
                    None
                });
                assert_eq!(got, None);
                assert!(visits <= n, "{visits} visits of {n} primitives");
            }
        }
    }

    /// Spheres moving on straight lines during the shutter: the hierarchy with interpolated
    /// boxes finds exactly what testing every sphere at the ray's time finds.
    #[test]
    fn moving_agrees_with_brute_force() {
        let mut r = Pcg32::new(12, 3);
        let mut stack = TraversalStack::default();
        for &n in &[1usize, 3, 40, 700, 6000] {
            // A third still, the others slow or fast.
            let (spheres, open, close) = moving_spheres(&mut r, n);
            let bvh = Bvh::build_moving(&open, &close);
            for ray in random_rays(&mut r, 400) {
                assert!(moving_hit_is_brute(bvh.view(), &spheres, &ray, &mut stack));
            }
        }
    }

    /// Whether `bvh` over the moving `spheres` finds what testing every sphere at the ray's
    /// time finds (the ray's time is its shutter time `s`).
    fn moving_hit_is_brute(
        bvh: BvhView,
        spheres: &[(DVec3, DVec3, f64)],
        ray: &crate::ray::Ray,
        stack: &mut TraversalStack,
    ) -> bool {
        let s = ray.time;
        let order = bvh.topology.order();
        let at = |i: usize| (spheres[i].0 + spheres[i].1 * s, spheres[i].2);
        let got = bvh.closest_hit(ray.origin, ray.dir, s, f64::INFINITY, stack, |p, tmax| {
            let (c, rad) = at(order[p as usize] as usize);
            crate::sphere::intersect(c, rad, ray, tmax)
        });
        let got = got.map(|(t, p)| (t, order[p as usize]));
        let now: Vec<(DVec3, f64)> = (0..spheres.len()).map(at).collect();
        got == brute(&now, ray)
    }

    /// Spheres `(centre at s = 0, velocity, radius)`, and their boxes at s = 0 and at s = 1.
    type MovingSpheres = (Vec<(DVec3, DVec3, f64)>, Vec<Aabb>, Vec<Aabb>);

    fn moving_spheres(r: &mut Pcg32, n: usize) -> MovingSpheres {
        let spheres: Vec<(DVec3, DVec3, f64)> = (0..n)
            .map(|i| {
                let c = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 20.0 - 10.0;
                let speed = [0.0, 0.5, 8.0][i % 3];
                let v = (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5) * speed;
                (c, v, 0.05 + r.next_f64() * 0.5)
            })
            .collect();
        let open = spheres
            .iter()
            .map(|(c, _, rad)| Aabb::point(*c).grow(*rad).pad_for_rounding())
            .collect();
        let close = spheres
            .iter()
            .map(|(c, v, rad)| Aabb::point(*c + *v).grow(*rad).pad_for_rounding())
            .collect();
        (spheres, open, close)
    }

    #[test]
    fn refitted_hierarchies_agree_with_brute_force() {
        let mut r = Pcg32::new(21, 5);
        let mut stack = TraversalStack::default();
        for &n in &[1usize, 3, 40, 700, 6000] {
            // Built on one set of spheres, refitted to another: the tree is the first's.
            let (_, open0, close0) = moving_spheres(&mut r, n);
            let bvh = Bvh::build_moving(&open0, &close0);
            let topology = bvh.topology();
            // Refitting to the boxes it was built on gives the boxes of the build.
            assert_eq!(topology.refit_moving(&open0, &close0), *bvh.boxes());
            let (spheres, open, close) = moving_spheres(&mut r, n);
            let boxes = topology.refit_moving(&open, &close);
            // Unrelated positions: a much worse tree, but exact.
            if n > 100 {
                assert!(boxes.area() > 2.0 * bvh.area(), "{}", boxes.area());
            }
            // The topology with the new boxes finds every hit; with the boxes of the build
            // (a refit skipped) it misses some.
            let mut stale = 0;
            for ray in random_rays(&mut r, 300) {
                let view = BvhView::new(topology, &boxes);
                assert!(moving_hit_is_brute(view, &spheres, &ray, &mut stack));
                if !moving_hit_is_brute(bvh.view(), &spheres, &ray, &mut stack) {
                    stale += 1;
                }
            }
            if n > 100 {
                assert!(stale > 0, "n {n}");
            }
        }
    }

    #[test]
    fn identical_boxes_still_split_into_small_leaves() {
        let boxes = vec![Aabb::point(DVec3::ONE).grow(1.0); 1000];
        let bvh = Bvh::build(&boxes);
        assert!(
            bvh.topology
                .links
                .iter()
                .all(|n| (0..4).all(|k| n.slot(k).1 as usize <= MAX_LEAF))
        );
        let mut seen: Vec<u32> = bvh.order().to_vec();
        seen.sort();
        assert_eq!(seen, (0..1000).collect::<Vec<u32>>());
    }

    /// `f32_below` and `f32_above` bracket every `f64` by adjacent `f32`s (or by one, when
    /// it is an `f32`), past the `f32` range and down to its subnormals.
    #[test]
    fn f32_rounding_is_outward() {
        let (max, tiny) = (f64::from(f32::MAX), f64::from(f32::from_bits(1)));
        let cases: [(f64, f32, f32); 14] = [
            (1.0, 1.0, 1.0),
            (0.0, 0.0, 0.0),
            (-2.5, -2.5, -2.5),
            (1.0 + f64::EPSILON, 1.0, 1.0f32.next_up()),
            (1.0 - f64::EPSILON / 2.0, 1.0f32.next_down(), 1.0),
            (-(1.0 + f64::EPSILON), -1.0f32.next_up(), -1.0),
            (max, f32::MAX, f32::MAX),
            (3.5e38, f32::MAX, f32::INFINITY),
            (-3.5e38, f32::NEG_INFINITY, -f32::MAX),
            (1e-50, 0.0, f32::from_bits(1)),
            (-1e-50, -f32::from_bits(1), -0.0),
            (1.5 * tiny, f32::from_bits(1), f32::from_bits(2)),
            (f64::INFINITY, f32::INFINITY, f32::INFINITY),
            (f64::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY),
        ];
        for (x, lo, hi) in cases {
            assert_eq!((f32_below(x), f32_above(x)), (lo, hi), "{x:e}");
        }
        assert!(f32_below(f64::NAN).is_nan() && f32_above(f64::NAN).is_nan());
        // Any magnitude, any sign: below <= x <= above, adjacent or equal.
        let mut r = Pcg32::new(31, 7);
        for _ in 0..100_000 {
            let x = (r.next_f64() - 0.5) * 2f64.powi((r.next_f64() * 300.0) as i32 - 160);
            let (lo, hi) = (f32_below(x), f32_above(x));
            assert!(f64::from(lo) <= x && x <= f64::from(hi), "{x:e}");
            assert!(lo == hi || lo.next_up() == hi, "{x:e}");
        }
    }

    /// A moving side's `f32` form, evaluated as a traversal does, stays outside the
    /// interpolation of the `f64` sides at every shutter time, at every scale; an empty slot
    /// stays empty.
    #[test]
    fn moving_sides_are_conservative() {
        assert_eq!(
            moving_lower(f64::INFINITY, f64::INFINITY),
            (f32::INFINITY, 0.0)
        );
        assert_eq!(
            moving_lower(f64::NEG_INFINITY, f64::NEG_INFINITY),
            (f32::NEG_INFINITY, 0.0)
        );
        assert_eq!(
            moving_lower(1.0, f64::NEG_INFINITY),
            (f32::NEG_INFINITY, 0.0)
        );
        // Beyond the `f32` range: a side past it is the constant infinity, a change past it
        // the largest `f32`, less than the change.
        assert_eq!(moving_lower(-3.5e38, 0.0), (f32::NEG_INFINITY, 0.0));
        assert_eq!(moving_lower(-3.4e38, 3.4e38).1, f32::MAX);
        let mut r = Pcg32::new(32, 9);
        for _ in 0..20_000 {
            let scale = 2f64.powi((r.next_f64() * 260.0) as i32 - 140);
            let open = (r.next_f64() - 0.5) * scale;
            // Sometimes far apart, sometimes nearly equal, sometimes equal.
            let close = match r.next_f64() {
                x if x < 0.3 => open,
                x if x < 0.6 => open * (1.0 + (r.next_f64() - 0.5) * 1e-7),
                _ => (r.next_f64() - 0.5) * scale * 2f64.powi((r.next_f64() * 40.0) as i32 - 20),
            };
            for (lo, hi) in [(open, close), (-open, -close)] {
                let (o, d) = moving_lower(lo, hi);
                for s in [
                    0.0,
                    1.0,
                    0.5,
                    r.next_f64(),
                    1.0 - f64::EPSILON / 2.0,
                    1e-300,
                ] {
                    let got = f64::from(o) + s * f64::from(d);
                    // Exact at the ends; elsewhere the `f64` interpolation is within a few
                    // ulps of the exact one, far inside the margin.
                    let exact = if s == 0.0 {
                        lo
                    } else if s == 1.0 {
                        hi
                    } else {
                        lo + s * (hi - lo)
                    };
                    assert!(got <= exact, "{lo:e} {hi:e} at {s}: {got:e}");
                }
            }
        }
    }

    /// Spheres far from the origin (around 1e6) and tiny ones near it (around 1e-6), with rays
    /// grazing them along the faces of their boxes, where rounding the boxes to `f32` the
    /// wrong way would cull hits: the hierarchy finds exactly what testing every sphere does.
    #[test]
    fn grazing_rays_at_far_and_tiny_scales_agree_with_brute_force() {
        let mut r = Pcg32::new(33, 11);
        let mut stack = TraversalStack::default();
        for (offset, scale) in [(1e6, 30.0), (-3e6, 1.0), (0.0, 1e-6), (2e-6, 3e-8)] {
            let n = 400;
            let spheres: Vec<(DVec3, DVec3, f64)> = (0..n)
                .map(|i| {
                    let c = DVec3::splat(offset)
                        + (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5) * scale;
                    let v = if i % 2 == 0 {
                        DVec3::ZERO
                    } else {
                        (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5) * scale * 0.1
                    };
                    (c, v, scale * (0.002 + r.next_f64() * 0.02))
                })
                .collect();
            let boxes_at = |s: f64| -> Vec<Aabb> {
                spheres
                    .iter()
                    .map(|(c, v, rad)| Aabb::point(*c + *v * s).grow(*rad).pad_for_rounding())
                    .collect()
            };
            let still: Vec<(DVec3, f64)> = spheres.iter().map(|(c, _, rad)| (*c, *rad)).collect();
            let still_bvh = Bvh::build(&boxes_at(0.0));
            let moving_bvh = Bvh::build_moving(&boxes_at(0.0), &boxes_at(1.0));
            let mut hits = 0;
            for _ in 0..3000 {
                let (c, v, rad) = spheres[(r.next_f64() * n as f64) as usize];
                let time = if r.next_f64() < 0.5 {
                    0.0
                } else {
                    r.next_f64()
                };
                let moving = r.next_f64() < 0.5;
                let centre = if moving { c + v * time } else { c };
                // The ray touches the sphere where its box's face does (an axis-aligned
                // normal), or elsewhere; it runs along the tangent plane, shifted by a few
                // ulps of the coordinates either way.
                let axis = (r.next_f64() * 3.0) as usize;
                let mut normal = DVec3::ZERO;
                normal[axis] = if r.next_f64() < 0.5 { 1.0 } else { -1.0 };
                if r.next_f64() < 0.3 {
                    normal =
                        (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5).normalize();
                }
                let tangent = normal
                    .cross(DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5)
                    .normalize();
                let shift = (r.next_f64() - 0.5) * 8.0 * f64::EPSILON * (offset.abs() + scale);
                let touch = centre + normal * (rad + shift);
                let ray = crate::ray::Ray {
                    origin: touch - tangent * (scale * (0.01 + r.next_f64())),
                    dir: tangent,
                    time,
                };
                if moving {
                    assert!(moving_hit_is_brute(
                        moving_bvh.view(),
                        &spheres,
                        &ray,
                        &mut stack
                    ));
                } else {
                    let order = still_bvh.order();
                    let got = still_bvh.closest_hit(
                        ray.origin,
                        ray.dir,
                        0.0,
                        f64::INFINITY,
                        &mut stack,
                        |p, tmax| {
                            let (c, rad) = still[order[p as usize] as usize];
                            crate::sphere::intersect(c, rad, &ray, tmax)
                        },
                    );
                    let want = brute(&still, &ray);
                    hits += want.is_some() as usize;
                    assert_eq!(got.map(|(t, p)| (t, order[p as usize])), want);
                }
            }
            // Grazing rays hit about half the time: the test is not vacuous.
            assert!(hits > 100, "{hits} hits at scale {scale}");
        }
    }

    /// The `f32` slab test never misses a child the `f64` one hits, and never puts a child's
    /// entry beyond the `f64` one's: random boxes and rays at scales from 1e-6 to 1e6 and far
    /// from the origin, rays starting on or a few ulps off a face, running along faces, and
    /// nearly axis-parallel (reciprocals up to 1e29); still and moving nodes, any time and
    /// limit.
    #[test]
    fn f32_slab_test_is_conservative() {
        let mut r = Pcg32::new(41, 3);
        let (mut checked, mut hits) = (0u32, 0u32);
        for round in 0..40_000 {
            let offset = [0.0, 1e6, -3e4, 2e-6][round % 4];
            let scale = [1.0, 30.0, 1e-6, 1e-3][(round / 4) % 4];
            let v = |r: &mut Pcg32| {
                (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5) * scale
            };
            let boxes: Vec<Aabb> = (0..4)
                .map(|_| {
                    let c = DVec3::splat(offset) + v(&mut r);
                    Aabb {
                        min: c - v(&mut r).abs(),
                        max: c + v(&mut r).abs(),
                    }
                })
                .collect();
            let moved: Vec<Aabb> = boxes
                .iter()
                .map(|b| Aabb {
                    min: b.min + v(&mut r) * 0.3,
                    max: b.max + v(&mut r) * 0.3,
                })
                .collect();
            let mut still = Boxes4::EMPTY;
            let mut moving = [Boxes4::EMPTY, Boxes4::ZERO];
            // Slot 3 stays empty one time in four.
            for k in 0..4 - usize::from(round % 4 == 1) {
                still.set(k, &boxes[k]);
                set_moving(&mut moving, k, &boxes[k], &moved[k]);
            }
            let nodes = [
                Boxes {
                    still: vec![still],
                    ..Boxes::default()
                },
                Boxes {
                    moving: vec![moving],
                    ..Boxes::default()
                },
            ];
            // A point on a face of a box (as stored), or a few ulps off it, or anywhere.
            let k = (r.next_f64() * 4.0) as usize % 3;
            let axis = (r.next_f64() * 3.0) as usize;
            let mut origin = DVec3::splat(offset) + v(&mut r) * 1.5;
            let side = if r.next_f64() < 0.5 { axis } else { 3 + axis };
            match round % 3 {
                0 => origin[axis] = f64::from(still.planes[side][k]),
                1 => {
                    let p = f64::from(still.planes[side][k]);
                    origin[axis] = p + (r.next_f64() - 0.5) * 8.0 * f64::EPSILON * p.abs();
                }
                _ => {}
            }
            let mut dir = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5;
            // Along a face, or nearly axis-parallel.
            match (round / 3) % 4 {
                0 => dir[axis] = 0.0,
                1 => dir[axis] = 1e-29 * (r.next_f64() - 0.5),
                _ => {}
            }
            let dir = dir.normalize();
            let s = [0.0, 1.0, r.next_f64()][round % 3];
            let t_max = [f64::INFINITY, r.next_f64() * 2.0 * scale][round % 2];
            let Some(lanes) = RayLanes::new(origin, dir, s) else {
                assert!(dir.abs().min_element() < 1e-30);
                continue;
            };
            let exact = RayF64::new(origin, dir, s);
            for boxes in &nodes {
                let limit = widened_limit(t_max);
                let (mask, near) = lanes.test(boxes, 0, limit, t_max);
                let (want, want_near) = exact.test(boxes, 0, limit, t_max);
                // The `f64` entry, as exact: `RayF64` rounds it down to `f32`.
                assert_eq!(mask & want, want, "{origin:?} {dir:?} {s} {t_max}");
                for k in 0..4 {
                    if want & (1 << k) != 0 {
                        assert!(near[k] <= want_near[k], "{origin:?} {dir:?} {k}");
                        assert!(near[k] <= limit);
                    }
                }
                checked += 1;
                hits += want.count_ones();
            }
        }
        // Most rays are taken by the `f32` test, and a fair share of children are hit.
        assert!(checked > 50_000 && hits > 20_000, "{checked} {hits}");
    }

    /// The same boxes give the same hierarchy whatever the number of threads building it.
    #[test]
    fn build_is_deterministic_across_thread_counts() {
        let mut r = Pcg32::new(4, 4);
        let boxes: Vec<Aabb> = (0..40_000)
            .map(|_| {
                let c = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 100.0;
                Aabb::point(c).grow(0.1 + r.next_f64())
            })
            .collect();
        let build = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| Bvh::build(&boxes))
        };
        let (a, b) = (build(1), build(3));
        assert_eq!(a.topology, b.topology);
        assert_eq!(a.boxes, b.boxes);
    }
}
