//! A bounding volume hierarchy over boxes: built as a binary tree with the surface-area
//! heuristic (binned, as in Wald 2007, "On fast Construction of SAH-based Bounding Volume
//! Hierarchies"), in parallel, then collapsed into a 4-wide tree (as Embree's BVH4) stored as
//! one flat array of nodes. A node holds its four children's boxes as structure-of-arrays, so a
//! ray is tested against all four at once with straight-line arithmetic the compiler
//! vectorises, and the children a ray hits are visited nearest first.
//!
//! Moving primitives get two boxes, one at the shutter's opening and one at its closing; a
//! ray at time `s` (0 at opening, 1 at closing) is tested against their linear interpolation,
//! as in Embree's motion-blur hierarchy (Woop et al. 2017, "STBVH: A Spatial-Temporal BVH for
//! Efficient Multi-Segment Motion Blur", section 3). Since the interpolation of the unions is
//! contained in the union of the interpolations' extremes, a node's two boxes are the unions
//! of its children's.
//!
//! Primitives are identified by their position in [`Bvh::order`]: callers store their
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
/// Marks a stack entry that is a leaf (the rest of the entry is its child slot).
const LEAF_BIT: u32 = 1 << 31;

/// Scratch space for traversals. Made once per thread of work and reused for every ray:
/// clearing a fresh stack array per ray cost about 8% of a render.
#[derive(Clone, Debug)]
pub struct TraversalStack {
    /// A node index, or a leaf's `first | LEAF_BIT` with its count in `count`.
    entry: [u32; STACK],
    count: [u8; STACK],
    /// The ray's entry distance into the entry's box: entries beyond the nearest hit so far
    /// are skipped.
    near: [f64; STACK],
}

impl Default for TraversalStack {
    fn default() -> Self {
        TraversalStack {
            entry: [0; STACK],
            count: [0; STACK],
            near: [0.0; STACK],
        }
    }
}

/// Four children's boxes, structure-of-arrays: `planes[axis][child]` is the lower side,
/// `planes[3 + axis][child]` the upper side. An empty slot has lower sides `+inf` and upper
/// sides `-inf`, which no ray hits.
#[derive(Clone, Copy, Debug)]
struct Boxes4 {
    planes: [[f64; 4]; 6],
}

impl Boxes4 {
    const EMPTY: Boxes4 = Boxes4 {
        planes: [
            [f64::INFINITY; 4],
            [f64::INFINITY; 4],
            [f64::INFINITY; 4],
            [f64::NEG_INFINITY; 4],
            [f64::NEG_INFINITY; 4],
            [f64::NEG_INFINITY; 4],
        ],
    };

    const ZERO: Boxes4 = Boxes4 {
        planes: [[0.0; 4]; 6],
    };

    fn set(&mut self, k: usize, b: &Aabb) {
        for a in 0..3 {
            self.planes[a][k] = b.min[a];
            self.planes[3 + a][k] = b.max[a];
        }
    }
}

/// A 4-wide node: per child slot, a box and either a node index (`count == 0`) or a leaf's
/// first primitive position and count.
#[derive(Clone, Copy, Debug)]
struct Node {
    boxes: Boxes4,
    child: [u32; 4],
    count: [u8; 4],
}

/// A hierarchy over primitives `0..n` given by their boxes.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// For a moving hierarchy, per node, the change of its children's boxes from the
    /// shutter's opening to its closing (`close - open`); empty for a still one.
    deltas: Vec<Boxes4>,
    /// Primitive indices in leaf order.
    order: Vec<u32>,
    /// The box of everything (over the whole shutter, for a moving hierarchy).
    bounds: Aabb,
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
    /// Builds the hierarchy over `boxes`; primitive `i` has box `boxes[i]`.
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
        let mut bvh = Bvh {
            bounds: Aabb::EMPTY,
            ..Bvh::default()
        };
        if !items.is_empty() {
            let mut tree = build_node(&mut items, 0, 0);
            bvh.order = items.iter().map(|it| it.index).collect();
            drop(items);
            let prim = |pos: u32| {
                let i = bvh.order[pos as usize] as usize;
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
            collapse(&tree, moving, &mut bvh.nodes, &mut bvh.deltas);
            bvh.bounds = tree.boxes.whole;
        }
        bvh
    }

    /// Moves a moving hierarchy's primitives to new boxes, keeping its tree (refitting):
    /// every node's boxes become the unions of its children's, bottom up. The hierarchy stays
    /// exact for the new boxes; only its quality depends on how far they moved from those it
    /// was built on. Returns [`Bvh::area`] after the refit. Panics on a still hierarchy.
    pub fn refit_moving(&mut self, open: &[Aabb], close: &[Aabb]) -> f64 {
        assert!(
            !self.deltas.is_empty() || self.nodes.is_empty(),
            "refit needs a moving hierarchy"
        );
        assert!(open.len() == self.order.len() && close.len() == self.order.len());
        // Nodes are in depth-first order, so every child comes after its parent: in reverse
        // order, a node's children are done before it.
        let mut unions = vec![(Aabb::EMPTY, Aabb::EMPTY); self.nodes.len()];
        for i in (0..self.nodes.len()).rev() {
            let mut all = (Aabb::EMPTY, Aabb::EMPTY);
            for k in 0..4 {
                let (child, count) = (self.nodes[i].child[k], self.nodes[i].count[k]);
                let (o, c) = if count > 0 {
                    (child..child + count as u32).fold((Aabb::EMPTY, Aabb::EMPTY), |(o, c), pos| {
                        let p = self.order[pos as usize] as usize;
                        (o.union(&open[p]), c.union(&close[p]))
                    })
                } else if child > 0 {
                    unions[child as usize]
                } else {
                    // An empty slot (the root is nobody's child): it stays empty.
                    continue;
                };
                set_moving(&mut self.nodes[i].boxes, &mut self.deltas[i], k, &o, &c);
                all = (all.0.union(&o), all.1.union(&c));
            }
            unions[i] = all;
        }
        if let Some(&(o, c)) = unions.first() {
            self.bounds = o.union(&c);
        }
        self.area()
    }

    /// The summed surface areas of every child box of every node, over the whole shutter: the
    /// cost a ray pays to traverse the hierarchy, up to a constant. It grows as a refitted
    /// hierarchy's primitives move away from where it was built.
    pub fn area(&self) -> f64 {
        let mut sum = 0.0;
        for (i, node) in self.nodes.iter().enumerate() {
            for k in 0..4 {
                let mut b = Aabb::EMPTY;
                let mut e = Aabb::EMPTY;
                for a in 0..3 {
                    b.min[a] = node.boxes.planes[a][k];
                    b.max[a] = node.boxes.planes[3 + a][k];
                }
                if !b.min.x.is_finite() {
                    continue;
                }
                if let Some(d) = self.deltas.get(i) {
                    for a in 0..3 {
                        e.min[a] = b.min[a] + d.planes[a][k];
                        e.max[a] = b.max[a] + d.planes[3 + a][k];
                    }
                    b = b.union(&e);
                }
                sum += b.surface_area();
            }
        }
        sum
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// Whether the hierarchy has no primitives.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// The box of everything in the hierarchy (over the whole shutter, if moving).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The primitives in leaf order: position `p` in the callbacks of
    /// [`Bvh::closest_hit`] is primitive `order()[p]`.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// Number of 4-wide nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes held by the hierarchy (nodes, motion and order).
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.deltas.capacity() * std::mem::size_of::<Boxes4>()
            + self.order.capacity() * 4
    }

    /// Finds the closest primitive hit by the ray `origin + t dir`, `t` in `(0, t_max)`, at
    /// shutter time `s` in [0, 1] (ignored by a still hierarchy). `hit(pos, t_max)` returns
    /// the hit distance in `(0, t_max)` of the primitive at position `pos` of
    /// [`Bvh::order`], if any. Returns the distance and position.
    #[inline]
    pub fn closest_hit(
        &self,
        origin: DVec3,
        dir: DVec3,
        s: f64,
        mut t_max: f64,
        stack: &mut TraversalStack,
        mut hit: impl FnMut(u32, f64) -> Option<f64>,
    ) -> Option<(f64, u32)> {
        if self.nodes.is_empty() {
            return None;
        }
        let moving = !self.deltas.is_empty();
        let inv = (DVec3::ONE / dir).to_array();
        let o = origin.to_array();
        // Per axis, the index in `Boxes4::planes` of the planes through which the ray enters
        // and leaves boxes: the upper one first for a negative direction. Taken from the
        // reciprocal so that a direction of -0 (reciprocal -inf) counts as negative.
        let entry: [usize; 3] = std::array::from_fn(|a| if inv[a] < 0.0 { 3 + a } else { a });
        let exit: [usize; 3] = std::array::from_fn(|a| if inv[a] < 0.0 { a } else { 3 + a });
        let mut best = None;
        let mut sp = 0usize;
        let mut current = 0usize;
        loop {
            // Test the four children of `current` at once.
            let node = &self.nodes[current];
            let planes = &node.boxes.planes;
            let mut near = [0.0f64; 4];
            let mut far = [t_max; 4];
            // `max` and `min` ignore a NaN (0 * inf: a ray in a box's face plane, parallel
            // to it), which leaves that axis out of the interval.
            if moving {
                let d = &self.deltas[current].planes;
                for a in 0..3 {
                    let (e, x) = (entry[a], exit[a]);
                    for k in 0..4 {
                        let n = planes[e][k] + s * d[e][k];
                        let f = planes[x][k] + s * d[x][k];
                        near[k] = near[k].max((n - o[a]) * inv[a]);
                        far[k] = far[k].min((f - o[a]) * inv[a]);
                    }
                }
            } else {
                for a in 0..3 {
                    let (e, x) = (entry[a], exit[a]);
                    for k in 0..4 {
                        near[k] = near[k].max((planes[e][k] - o[a]) * inv[a]);
                        far[k] = far[k].min((planes[x][k] - o[a]) * inv[a]);
                    }
                }
            }
            // The children hit, nearest last, so the nearest is popped first.
            let mut hits = [(0.0f64, 0usize); 4];
            let mut n = 0;
            for k in 0..4 {
                if near[k] <= far[k] {
                    let mut j = n;
                    while j > 0 && hits[j - 1].0 < near[k] {
                        hits[j] = hits[j - 1];
                        j -= 1;
                    }
                    hits[j] = (near[k], k);
                    n += 1;
                }
            }
            for &(d, k) in &hits[..n] {
                let c = node.count[k];
                stack.entry[sp] = if c == 0 {
                    node.child[k]
                } else {
                    node.child[k] | LEAF_BIT
                };
                stack.count[sp] = c;
                stack.near[sp] = d;
                sp += 1;
            }
            // Pop until an inner node to descend into; leaves are intersected on the way.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                if stack.near[sp] > t_max {
                    continue;
                }
                let e = stack.entry[sp];
                if e & LEAF_BIT == 0 {
                    current = e as usize;
                    break;
                }
                let first = e & !LEAF_BIT;
                for pos in first..first + stack.count[sp] as u32 {
                    if let Some(t) = hit(pos, t_max) {
                        t_max = t;
                        best = Some((t, pos));
                    }
                }
            }
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

/// Appends the 4-wide nodes of the binary subtree `t` (an inner node) to `nodes` in
/// depth-first order. The four children are found by opening, from the node's two, the child
/// with the largest surface area until there are four (Embree's BVH4 collapse).
fn collapse(t: &Build, moving: bool, nodes: &mut Vec<Node>, deltas: &mut Vec<Boxes4>) {
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
    let index = nodes.len();
    nodes.push(Node {
        boxes: Boxes4::EMPTY,
        child: [0; 4],
        count: [0; 4],
    });
    if moving {
        deltas.push(Boxes4::ZERO);
    }
    for (k, c) in kids.iter().enumerate() {
        let (child, count) = match c.kind {
            Kind::Leaf { first, count } => (first, count as u8),
            Kind::Inner(_) => {
                let at = nodes.len() as u32;
                collapse(c, moving, nodes, deltas);
                (at, 0)
            }
        };
        nodes[index].child[k] = child;
        nodes[index].count[k] = count;
        let b = &c.boxes;
        if moving {
            set_moving(
                &mut nodes[index].boxes,
                &mut deltas[index],
                k,
                &b.open,
                &b.close,
            );
        } else {
            nodes[index].boxes.set(k, &b.whole);
        }
    }
}

/// Sets child slot `k` of a moving node to the box `open` at the shutter's opening and `close`
/// at its closing (stored as `open` and the change `close - open`).
fn set_moving(boxes: &mut Boxes4, delta: &mut Boxes4, k: usize, open: &Aabb, close: &Aabb) {
    boxes.set(k, open);
    // An empty slot's infinities would give inf - inf = NaN: it does not move.
    let change = |close: f64, open: f64| if open.is_finite() { close - open } else { 0.0 };
    for a in 0..3 {
        delta.planes[a][k] = change(close.min[a], open.min[a]);
        delta.planes[3 + a][k] = change(close.max[a], open.max[a]);
    }
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
                assert_moving_hit_is_brute(&bvh, &spheres, &ray, &mut stack);
            }
        }
    }

    /// Asserts that `bvh` over the moving `spheres` finds what testing every sphere at the
    /// ray's time finds (the ray's time is its shutter time `s`).
    fn assert_moving_hit_is_brute(
        bvh: &Bvh,
        spheres: &[(DVec3, DVec3, f64)],
        ray: &crate::ray::Ray,
        stack: &mut TraversalStack,
    ) {
        let s = ray.time;
        let at = |i: usize| (spheres[i].0 + spheres[i].1 * s, spheres[i].2);
        let got = bvh.closest_hit(ray.origin, ray.dir, s, f64::INFINITY, stack, |p, tmax| {
            let (c, rad) = at(bvh.order()[p as usize] as usize);
            crate::sphere::intersect(c, rad, ray, tmax)
        });
        let got = got.map(|(t, p)| (t, bvh.order()[p as usize]));
        let now: Vec<(DVec3, f64)> = (0..spheres.len()).map(at).collect();
        assert_eq!(got, brute(&now, ray), "n {}", spheres.len());
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
            let mut bvh = Bvh::build_moving(&open0, &close0);
            let built_area = bvh.area();
            // Refitting to the boxes it was built on gives the same hierarchy.
            assert_eq!(bvh.refit_moving(&open0, &close0), built_area);
            let (spheres, open, close) = moving_spheres(&mut r, n);
            let area = bvh.refit_moving(&open, &close);
            // Unrelated positions: a much worse tree, but exact.
            if n > 100 {
                assert!(area > 2.0 * built_area, "{area} {built_area}");
            }
            for ray in random_rays(&mut r, 300) {
                assert_moving_hit_is_brute(&bvh, &spheres, &ray, &mut stack);
            }
        }
    }

    #[test]
    fn identical_boxes_still_split_into_small_leaves() {
        let boxes = vec![Aabb::point(DVec3::ONE).grow(1.0); 1000];
        let bvh = Bvh::build(&boxes);
        assert!(
            bvh.nodes
                .iter()
                .all(|n| n.count.iter().all(|&c| c as usize <= MAX_LEAF))
        );
        let mut seen: Vec<u32> = bvh.order.clone();
        seen.sort();
        assert_eq!(seen, (0..1000).collect::<Vec<u32>>());
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
        assert_eq!(a.order, b.order);
        assert_eq!(a.nodes.len(), b.nodes.len());
        assert!(a.nodes.iter().zip(&b.nodes).all(|(x, y)| {
            x.child == y.child && x.count == y.count && x.boxes.planes == y.boxes.planes
        }));
    }
}
