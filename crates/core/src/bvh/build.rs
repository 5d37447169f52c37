//! Building a hierarchy's topology: the binned surface-area heuristic (Wald 2007) over the
//! primitives' boxes at the shutter's opening and closing, split top down straight into
//! 8-wide nodes (as Embree's BVH8 builder), in parallel, reordering the primitives themselves
//! into leaf order.
//!
//! The build only compares boxes: it reads each primitive's as `f32` ([`BuildBox`]), as the
//! caller computes it on the fly from the primitive (no array of boxes is made), and the
//! hierarchy's own boxes are computed afterwards from the primitives' exact boxes
//! ([`super::refit`]). A split's cost is the surface-area heuristic on linear bounds (Woop et
//! al. 2017, "STBVH", section 4; Embree's `LBBox::expectedApproxHalfArea`): the area a
//! primitive's node presents to a ray at a random shutter time is the mean over the shutter
//! of the area of the box interpolated from its box at the opening to its box at the
//! closing, which for fast, incoherent motion is far smaller than the area of the box over
//! the whole shutter that a still build would compare.

use glam::{Vec3, Vec3A};
use rayon::prelude::*;

use crate::aabb::Aabb;

use super::bins::{Bin, BinMap, PARALLEL_BINS, SAMPLED_BINS, best_split, bins_for};
use super::lanes::LANES;
use super::links::{COUNT_SHIFT, Links};
use super::partition::partition_parallel;

/// Most primitives in a leaf.
pub(crate) const MAX_LEAF: usize = 4;

/// Cost of visiting a node relative to intersecting one primitive, for an index build (pbrt
/// uses 1/8 to 1): spheres' hierarchies split down to one sphere a leaf almost everywhere.
pub(super) const NODE_COST: f64 = 0.5;
/// Deepest level split by the SAH (counted in binary splits); deeper spans are halved, so the
/// depth stays below `MAX_SAH_DEPTH + log2(n)`, well inside the traversal stack for any `n`
/// a `u32` indexes.
pub(super) const MAX_SAH_DEPTH: usize = 64;
/// Nodes over more primitives than this build their children's subtrees in parallel.
const PARALLEL_BUILD: usize = 4096;
// A leaf's count fits the bits of a child slot above `COUNT_SHIFT`.
const _: () = assert!(
    MAX_LEAF < 1 << (32 - COUNT_SHIFT),
    "a leaf's count fits its bits"
);

/// A primitive's box as a build compares it, in `f32`: its box at the shutter's opening
/// (`lo`, `hi`) and the move of that box from the opening to the closing (`shift`; zero for a
/// still primitive). Approximate: it only steers the splits.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BuildBox {
    pub lo: Vec3,
    pub hi: Vec3,
    pub shift: Vec3,
}

impl BuildBox {
    /// The boxes at the opening and the closing as the build takes them: the closing one's
    /// centre only (a primitive's size is taken to be the same at both ends).
    pub(crate) fn new(open: &Aabb, close: &Aabb) -> BuildBox {
        BuildBox {
            lo: open.min.as_vec3(),
            hi: open.max.as_vec3(),
            shift: (close.centroid() - open.centroid()).as_vec3(),
        }
    }

    /// The boxes at the opening and the closing, and the centre at mid-shutter (what the
    /// bins sort by).
    #[inline(always)]
    pub(super) fn parts(&self) -> (Box3, Box3, Vec3A) {
        let (lo, hi, shift) = (
            Vec3A::from(self.lo),
            Vec3A::from(self.hi),
            Vec3A::from(self.shift),
        );
        let open = Box3 { lo, hi };
        let close = Box3 {
            lo: lo + shift,
            hi: hi + shift,
        };
        (open, close, (lo + hi + shift) * 0.5)
    }
}

/// An `f32` box for the build's bookkeeping; empty when `lo > hi`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Box3 {
    pub(super) lo: Vec3A,
    pub(super) hi: Vec3A,
}

impl Box3 {
    pub(super) const EMPTY: Box3 = Box3 {
        lo: Vec3A::splat(f32::INFINITY),
        hi: Vec3A::splat(f32::NEG_INFINITY),
    };

    #[inline(always)]
    pub(super) fn union(self, o: Box3) -> Box3 {
        Box3 {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    #[inline(always)]
    fn with_point(self, p: Vec3A) -> Box3 {
        Box3 {
            lo: self.lo.min(p),
            hi: self.hi.max(p),
        }
    }

    /// Its sides: lower x, y, z, then upper x, y, z.
    #[inline(always)]
    pub(super) fn sides(self) -> [f32; 6] {
        let (lo, hi) = (self.lo.to_array(), self.hi.to_array());
        [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]]
    }
}

/// The mean over the shutter of the half surface area of the box interpolated linearly from
/// `open` to `close` ([`expected_half_areas`] of one box). In `f32`: it only compares splits.
#[inline(always)]
pub(super) fn expected_half_area(open: Box3, close: Box3) -> f32 {
    expected_half_areas(&[open.sides().map(|x| [x]), close.sides().map(|x| [x])])[0]
}

/// [`expected_half_area`] of `N` boxes at once, box `i` in lane `i`: `b[e][k][i]` its side `k`
/// ([`Box3::sides`]) at end `e` (0 the shutter's opening, 1 its closing). With sides `a + s d`
/// (`s` in [0, 1]), the integral of `(a_i + s d_i)(a_j + s d_j)` is
/// `a_i a_j + (a_i d_j + a_j d_i) / 2 + d_i d_j / 3`, summed over the three pairs of axes (`i`,
/// `j = i + 1 mod 3`). For a still box (`close = open`), half its surface area. A side's
/// length is 0 for an empty box or a NaN side. The same operations in the same order as the
/// three-lane vectors' sums the build computed before (a test checks the bits), so the same
/// hierarchies.
#[inline(always)]
pub(super) fn expected_half_areas<const N: usize>(b: &[[[f32; N]; 6]; 2]) -> [f32; N] {
    std::array::from_fn(|i| {
        let side = |e: usize, a: usize| {
            let x = b[e][3 + a][i] - b[e][a][i];
            if x > 0.0 { x } else { 0.0 }
        };
        let a = [side(0, 0), side(0, 1), side(0, 2)];
        let d = [side(1, 0) - a[0], side(1, 1) - a[1], side(1, 2) - a[2]];
        // `u.dot(v.yzx())`, summed `(x + y) + z`
        let dot = |u: [f32; 3], v: [f32; 3]| (u[0] * v[1] + u[1] * v[2]) + u[2] * v[0];
        dot(a, a) + 0.5 * (dot(a, d) + dot(d, a)) + dot(d, d) * (1.0 / 3.0)
    })
}

/// A contiguous run of primitives being built: where it starts in the whole array, how many,
/// the unions of their boxes at the opening and the closing (of a sample's, where it is a
/// half of a span that binned a sample: [`SAMPLED_BINS`]), and of their centroids.
#[derive(Clone, Copy, Debug)]
struct Span {
    start: usize,
    len: usize,
    open: Box3,
    close: Box3,
    centroids: Box3,
    /// Binary splits above it.
    depth: u32,
}

impl Span {
    fn area(&self) -> f32 {
        expected_half_area(self.open, self.close)
    }

    /// The child slot of this span as a leaf.
    fn leaf_slot(&self) -> u32 {
        self.start as u32 | (self.len as u32) << COUNT_SHIFT
    }
}

/// The span of `items` (at `start`, `depth` splits down), measured.
fn measure<P: Sync>(
    items: &[P],
    start: usize,
    depth: u32,
    bounds: &(impl Fn(&P) -> BuildBox + Sync),
) -> Span {
    let one = |items: &[P]| {
        let mut all = (Bin::EMPTY, Box3::EMPTY);
        for p in items {
            let (open, close, c) = bounds(p).parts();
            all.0.add(open, close);
            all.1 = all.1.with_point(c);
        }
        all
    };
    let (all, centroids) = if items.len() <= PARALLEL_BINS {
        one(items)
    } else {
        items.par_chunks(PARALLEL_BINS).map(one).reduce(
            || (Bin::EMPTY, Box3::EMPTY),
            |a, b| (a.0.merge(&b.0), a.1.union(b.1)),
        )
    };
    Span {
        start,
        len: items.len(),
        open: all.open,
        close: all.close,
        centroids,
        depth,
    }
}

/// What a span becomes: a leaf, or a node whose two halves are the given spans. (At most
/// eight live at once, on the stack, while a node is made: boxing the larger variant would
/// allocate for every node to save a few hundred bytes of stack.)
#[derive(Clone, Copy, Debug)]
#[allow(clippy::large_enum_variant)]
enum Kid {
    Leaf(Span),
    Inner(Span, Span, Span),
}

impl Kid {
    fn span(&self) -> &Span {
        match self {
            Kid::Leaf(s) | Kid::Inner(s, _, _) => s,
        }
    }
}

/// Decides whether `span` (its primitives `items`) is a leaf or is split, and if split,
/// reorders `items` so its two halves are contiguous: the best binned SAH split, or halves
/// where the SAH finds none (identical centroids) or the span is too deep, or a leaf where
/// that costs less than any split and holds at most [`MAX_LEAF`] primitives.
fn decide<P: Send + Sync>(
    items: &mut [P],
    span: Span,
    build: &Build<impl Fn(&P) -> BuildBox + Sync>,
) -> Kid {
    debug_assert_eq!(items.len(), span.len);
    let n = span.len;
    let (bounds, node_cost) = (&build.bounds, build.node_cost);
    if build.leaf_without_bins(n) {
        return Kid::Leaf(span);
    }
    let depth = span.depth + 1;
    let halve = |items: &mut [P]| {
        let mid = n / 2;
        let (l, r) = items.split_at(mid);
        Kid::Inner(
            span,
            measure(l, span.start, depth, bounds),
            measure(r, span.start + mid, depth, bounds),
        )
    };
    if span.depth as usize >= MAX_SAH_DEPTH {
        return if n > MAX_LEAF {
            halve(items)
        } else {
            Kid::Leaf(span)
        };
    }
    let map = BinMap::new(span.centroids, bins_for(n, node_cost));
    let best = match map.count {
        8 => best_split::<P, 8>(items, &map, bounds),
        _ => best_split::<P, 16>(items, &map, bounds),
    };
    let Some((cost, axis, boundary, left, right)) = best else {
        return if n > MAX_LEAF {
            halve(items)
        } else {
            Kid::Leaf(span)
        };
    };
    let area = span.area();
    let split_cost = node_cost
        + if area > 0.0 {
            f64::from(cost / area)
        } else {
            0.0
        };
    if n <= MAX_LEAF && split_cost >= n as f64 {
        return Kid::Leaf(span);
    }
    let (mid, lc, rc) = partition_parallel(items, |p| {
        let (_, _, c) = bounds(p).parts();
        (map.below(c, axis, boundary), c)
    });
    debug_assert!(n > SAMPLED_BINS || mid == left.count);
    let part = |b: Bin, start: usize, len: usize, centroids: Box3| Span {
        start,
        len,
        open: b.open,
        close: b.close,
        centroids,
        depth,
    };
    Kid::Inner(
        span,
        part(left, span.start, mid, lc),
        part(right, span.start + mid, n - mid, rc),
    )
}

/// Appends the 8-wide node whose two halves are `a` and `b`, and then its subtree, to
/// `links` in depth-first order (each node's inner children after it, in slot order, each
/// subtree contiguous); `items` are its primitives, the first at position `a.start`. Its
/// children are [`children`]'s; a node with fewer than eight has its other slots empty.
fn node<P: Send + Sync>(
    items: &mut [P],
    a: Span,
    b: Span,
    links: &mut Vec<Links>,
    build: &Build<impl Fn(&P) -> BuildBox + Sync>,
) {
    let total = a.len + b.len;
    let kids = children(items, a, b, build);
    let index = links.len();
    links.push(Links::default());
    for (k, kid) in kids.iter().enumerate() {
        if let Kid::Leaf(s) = kid {
            links[index].child[k] = s.leaf_slot();
        }
    }
    // The inner children's primitives, apart: the kids are contiguous, in order.
    let mut rest = items;
    let mut jobs = Vec::with_capacity(LANES);
    for (k, kid) in kids.iter().enumerate() {
        let (part, tail) = rest.split_at_mut(kid.span().len);
        rest = tail;
        if let Kid::Inner(_, l, r) = *kid {
            jobs.push((k, part, l, r));
        }
    }
    if total <= PARALLEL_BUILD {
        for (k, part, l, r) in jobs {
            links[index].child[k] = links.len() as u32;
            node(part, l, r, links, build);
        }
        return;
    }
    // Each inner child's subtree on its own, numbered from 0, then appended in slot order
    // with its node numbers moved past those before it: the same nodes, in the same order,
    // as built in place.
    let subtrees: Vec<(usize, Vec<Links>)> = jobs
        .into_par_iter()
        .map(|(k, part, l, r)| {
            let mut sub = Vec::new();
            node(part, l, r, &mut sub, build);
            (k, sub)
        })
        .collect();
    for (k, sub) in subtrees {
        let offset = links.len() as u32;
        links[index].child[k] = offset;
        links.extend(sub.into_iter().map(|mut n| {
            for w in &mut n.child {
                // A node (count 0) other than an empty slot.
                if *w >> COUNT_SHIFT == 0 && *w != 0 {
                    *w += offset;
                }
            }
            n
        }));
    }
}

/// The up to eight children of the node whose two halves are `a` and `b` (`items` its
/// primitives, the first at position `a.start`), in position order: from the node's two, an
/// inner child is opened until there are eight. The one opened first is the one with the most
/// halves that will be leaves ([`Build::leaf_without_bins`]), then of these the one with the
/// largest area (Embree's BVH8 rule). A half that is a leaf takes a slot of this node instead
/// of becoming a node of its own: by area alone the bottom of a hierarchy is mostly nodes of
/// two leaves, the halves of spans of five to eight points that a full parent could not open
/// (400,853 of the 1,030,168 nodes over the ten million points of `bench/big_points.toml`;
/// 117,498 of 755,309 this way, the frame's render in 0.97 of the time, docs/performance.md).
fn children<P: Send + Sync>(
    items: &mut [P],
    a: Span,
    b: Span,
    build: &Build<impl Fn(&P) -> BuildBox + Sync>,
) -> Vec<Kid> {
    let base = a.start;
    let mut kids: Vec<Kid> = Vec::with_capacity(LANES);
    for s in [a, b] {
        let part = &mut items[s.start - base..][..s.len];
        kids.push(decide(part, s, build));
    }
    // The halves of `l` and `r` that will be leaves whatever their bins say.
    let leaves = |l: &Span, r: &Span| {
        u8::from(build.leaf_without_bins(l.len)) + u8::from(build.leaf_without_bins(r.len))
    };
    while kids.len() < LANES {
        // Of equal largest, the last in position.
        let Some((i, _, _, _)) = kids
            .iter()
            .enumerate()
            .filter_map(|(i, k)| match k {
                Kid::Inner(s, l, r) => Some((i, leaves(l, r), s.area(), s.start)),
                Kid::Leaf(_) => None,
            })
            .max_by(|x, y| x.1.cmp(&y.1).then(x.2.total_cmp(&y.2)).then(x.3.cmp(&y.3)))
        else {
            break;
        };
        let Kid::Inner(_, l, r) = kids[i] else {
            unreachable!("an inner child was chosen")
        };
        let mut split = |s: Span| decide(&mut items[s.start - base..][..s.len], s, build);
        kids[i] = split(l);
        kids.push(split(r));
    }
    // In position order: each child's primitives after the one's before.
    kids.sort_unstable_by_key(|k| k.span().start);
    kids
}

/// What a build reads of its items and how it weighs a split.
pub(super) struct Build<F> {
    /// An item's box as the build compares it.
    pub(super) bounds: F,
    /// The cost of visiting a node relative to testing one primitive: the higher, the more
    /// primitives a leaf holds (at most [`MAX_LEAF`]) and the fewer nodes.
    pub(super) node_cost: f64,
}

impl<F> Build<F> {
    /// Whether a span of `n` primitives is a leaf before its bins are weighed: one primitive,
    /// or at most [`MAX_LEAF`] where a node's visit costs no less than testing them all (a
    /// split costs at least that).
    fn leaf_without_bins(&self, n: usize) -> bool {
        n <= 1 || (n <= MAX_LEAF && self.node_cost >= n as f64)
    }
}

/// The links of a hierarchy over `items`, which are reordered into leaf order (position `p`
/// of the hierarchy's leaves is `items[p]`). The same hierarchy and order on any number of
/// threads. The root is always an 8-wide node, even over a single leaf, so traversal starts
/// at node 0.
pub(super) fn build_links<P: Send + Sync>(
    items: &mut [P],
    build: &Build<impl Fn(&P) -> BuildBox + Sync>,
) -> Vec<Links> {
    assert!(
        items.len() <= 1 << COUNT_SHIFT,
        "too many primitives for a hierarchy"
    );
    let mut links = Vec::new();
    if items.is_empty() {
        return links;
    }
    let root = measure(items, 0, 0, &build.bounds);
    match decide(items, root, build) {
        Kid::Leaf(s) => links.push(Links {
            child: std::array::from_fn(|k| if k == 0 { s.leaf_slot() } else { 0 }),
        }),
        Kid::Inner(_, a, b) => node(items, a, b, &mut links, build),
    }
    // Pushed one by one: up to twice the memory needed, kept for the hierarchy's life.
    links.shrink_to_fit();
    links
}

/// A primitive of an index build: its box as the build compares it and its index.
#[derive(Clone, Copy, Debug)]
pub(super) struct Indexed {
    pub(super) bounds: BuildBox,
    pub(super) index: u32,
}

/// The links and leaf order of a hierarchy over primitives `0..n`, where `prim(i)` is the box
/// of primitive `i` at the shutter's opening and at its closing (the same box for a still
/// one).
pub(super) fn build_indexed(
    n: usize,
    prim: &(impl Fn(usize) -> (Aabb, Aabb) + Sync),
) -> (Vec<Links>, Vec<u32>) {
    let mut items: Vec<Indexed> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (open, close) = prim(i);
            Indexed::new(&open, &close, i)
        })
        .collect();
    let links = indexed_links(&mut items, NODE_COST);
    let order = items.par_iter().map(|p| p.index).collect();
    (links, order)
}

impl Indexed {
    /// Primitive `index`, its box `open` at the shutter's opening and `close` at its closing.
    fn new(open: &Aabb, close: &Aabb, index: usize) -> Indexed {
        Indexed {
            bounds: BuildBox::new(open, close),
            index: index as u32,
        }
    }
}

/// The links of a hierarchy over `items` at `node_cost`, which reorders them into leaf order.
fn indexed_links(items: &mut [Indexed], node_cost: f64) -> Vec<Links> {
    build_links(
        items,
        &Build {
            bounds: |p: &Indexed| p.bounds,
            node_cost,
        },
    )
}

/// Bytes per primitive an index build holds at its peak, about: its working item and its
/// place in the leaf order.
pub(crate) const BUILD_BYTES_PER_PRIMITIVE: usize = std::mem::size_of::<Indexed>() + 4;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::hierarchy::Bvh;
    use crate::rng::Pcg32;
    use glam::DVec3;

    #[test]
    fn identical_boxes_still_split_into_small_leaves() {
        let boxes = vec![Aabb::point(DVec3::ONE).grow(1.0); 1000];
        let bvh = Bvh::build(&boxes);
        assert!(
            bvh.topology()
                .links
                .iter()
                .all(|n| (0..LANES).all(|k| n.slot(k).1 as usize <= MAX_LEAF))
        );
        let mut seen: Vec<u32> = bvh.order().to_vec();
        seen.sort();
        assert_eq!(seen, (0..1000).collect::<Vec<u32>>());
    }

    /// A node opens first the children whose halves are leaves: a small cluster of six points
    /// beside a large one of 28 (its span's halves three points each, leaves where a node
    /// costs four tests) is held by the root as two leaves, where by area alone the large
    /// cluster's spans, opened first, fill the root and leave the small one a node of two
    /// leaves (this test then fails).
    #[test]
    fn a_node_takes_two_leaves_before_a_larger_child() {
        let point = |x: f64| Aabb::point(DVec3::new(x, 0.0, 0.0)).grow(0.1);
        let (large, small) = (28, 6);
        let mut items: Vec<Indexed> = (0..large + small)
            .map(|i| {
                let b = if i < large {
                    point(i as f64)
                } else {
                    point(1000.0 + 0.01 * (i - large) as f64)
                };
                Indexed::new(&b, &b, i)
            })
            .collect();
        let links = indexed_links(&mut items, 4.0);
        let root_leaves: Vec<u32> = (0..LANES)
            .map(|k| links[0].slot(k))
            .filter(|&(_, count)| count > 0)
            .flat_map(|(first, count)| first..first + count)
            .collect();
        for (pos, item) in items.iter().enumerate() {
            if item.index as usize >= large {
                assert!(
                    root_leaves.contains(&(pos as u32)),
                    "point {} of the small cluster, at position {pos}, in a leaf of the root \
                     {:?}",
                    item.index,
                    links[0]
                );
            }
        }
    }

    /// The same boxes give the same hierarchy whatever the number of threads building it,
    /// still and moving, over enough boxes for the sampled and the parallel binning, the
    /// parallel partition and subtrees.
    #[test]
    fn build_is_deterministic_across_thread_counts() {
        let mut r = Pcg32::new(4, 4);
        let (open, close): (Vec<Aabb>, Vec<Aabb>) = (0..200_000)
            .map(|_| {
                let c = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 100.0;
                let v = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 8.0 - 4.0;
                let b = Aabb::point(c).grow(0.1 + r.next_f64());
                (b, Aabb::point(c + v).grow(b.max.x - c.x))
            })
            .unzip();
        let build = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| (Bvh::build(&open), Bvh::build_moving(&open, &close)))
        };
        let (a, b) = (build(1), build(3));
        assert_eq!(a.0.topology(), b.0.topology());
        assert_eq!(a.0.boxes(), b.0.boxes());
        assert_eq!(a.1.topology(), b.1.topology());
        assert_eq!(a.1.boxes(), b.1.boxes());
    }

    /// The mean area of the interpolated box, against sampling it over the shutter.
    #[test]
    fn expected_area_is_the_mean_over_the_shutter() {
        let open = Box3 {
            lo: Vec3A::new(0.0, 1.0, -2.0),
            hi: Vec3A::new(1.0, 3.0, 0.5),
        };
        let close = Box3 {
            lo: Vec3A::new(4.0, 0.0, -1.0),
            hi: Vec3A::new(9.0, 1.5, 0.0),
        };
        let steps = 100_000;
        let mean = (0..steps)
            .map(|k| {
                let s = (k as f32 + 0.5) / steps as f32;
                let b = Box3 {
                    lo: open.lo + s * (close.lo - open.lo),
                    hi: open.hi + s * (close.hi - open.hi),
                };
                f64::from(expected_half_area(b, b))
            })
            .sum::<f64>()
            / steps as f64;
        let got = f64::from(expected_half_area(open, close));
        assert!((got - mean).abs() < 1e-5 * mean, "{got} {mean}");
        // A still box: half its surface area.
        let still = Aabb {
            min: DVec3::new(0.0, 1.0, -2.0),
            max: DVec3::new(1.0, 3.0, 0.5),
        };
        assert_eq!(
            2.0 * f64::from(expected_half_area(open, open)),
            still.surface_area()
        );
    }

    /// The expected half area as the build computed it before the lanes: three-lane vectors,
    /// their `dot` summing `(x + y) + z`.
    fn with_vectors(open: Box3, close: Box3) -> f32 {
        use glam::Vec3Swizzles;
        let extent = |b: Box3| (b.hi - b.lo).max(Vec3A::ZERO);
        let a = extent(open);
        let d = extent(close) - a;
        let (a2, d2) = (a.yzx(), d.yzx());
        a.dot(a2) + 0.5 * (a.dot(d2) + d.dot(a2)) + d.dot(d2) * (1.0 / 3.0)
    }

    /// The expected areas of the boxes in lanes, and of one box, are the build before's, bit
    /// for bit (its three-lane vectors' sums, written out again here): random boxes, moving and still, empty ones (lane 0 of a sweep, inside out), flat ones and
    /// boxes with a NaN side.
    #[test]
    fn areas_in_lanes_are_the_areas_one_by_one() {
        let mut r = Pcg32::new(12, 5);
        let mut u = || (r.next_f64() * 2.0 - 1.0) as f32;
        for round in 0..500 {
            let mut lanes = [[[0f32; 16]; 6]; 2];
            let mut want = [0f32; 16];
            for (i, want) in want.iter_mut().enumerate() {
                let mut b = || {
                    let lo = Vec3A::new(u(), u(), u()) * 10.0;
                    Box3 {
                        lo,
                        hi: lo + Vec3A::new(u(), u(), u()).abs() * 3.0,
                    }
                };
                let (mut open, mut close) = (b(), b());
                match (round + i) % 6 {
                    0 => (open, close) = (Box3::EMPTY, Box3::EMPTY),
                    1 => close = open,
                    2 => open.hi.y = open.lo.y,
                    3 => close.lo.z = f32::NAN,
                    4 => open.hi.x = open.lo.x - 1.0,
                    _ => {}
                }
                *want = with_vectors(open, close);
                assert_eq!(expected_half_area(open, close).to_bits(), want.to_bits());
                for (e, bx) in [open, close].iter().enumerate() {
                    for (k, x) in bx.sides().into_iter().enumerate() {
                        lanes[e][k][i] = x;
                    }
                }
            }
            let got = expected_half_areas(&lanes);
            assert_eq!(
                got.map(f32::to_bits),
                want.map(f32::to_bits),
                "round {round}"
            );
        }
    }
}
