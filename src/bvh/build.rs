//! Building a hierarchy: a binary tree by the binned surface-area heuristic, in parallel,
//! collapsed into 8-wide nodes.

use glam::DVec3;

use crate::aabb::Aabb;

use super::boxes::{Boxes, ChildBoxes, set_moving};
use super::lanes::LANES;
use super::topology::{COUNT_SHIFT, Links, Topology};

/// Most primitives in a leaf.
const MAX_LEAF: usize = 4;
/// Number of centroid bins per axis for the SAH sweep.
const BINS: usize = 16;
/// Cost of visiting a node relative to intersecting one primitive (pbrt uses 1/8 to 1).
const TRAVERSAL_COST: f64 = 0.5;
/// Deepest level split by the SAH; deeper nodes are halved, so the depth stays below
/// `MAX_SAH_DEPTH + log2(n)`, well inside the traversal stack for any `n` a `u32` indexes.
pub(super) const MAX_SAH_DEPTH: usize = 64;
/// Subtrees with more primitives than this are built on two threads.
const PARALLEL_BUILD: usize = 4096;
// A leaf's count fits the bits of a child slot above `COUNT_SHIFT`.
const _: () = assert!(
    MAX_LEAF < 1 << (32 - COUNT_SHIFT),
    "a leaf's count fits its bits"
);

/// Bytes per primitive a build holds at its peak, about: its working item, and a node of
/// the binary tree (about one per primitive).
pub const BUILD_BYTES_PER_PRIMITIVE: usize =
    std::mem::size_of::<BuildItem>() + std::mem::size_of::<Build>();

/// A node of the binary build tree. It keeps no boxes: the collapse into 8-wide nodes
/// computes them bottom up from the primitives' (as a refit does), so the tree holds 24 bytes
/// a node instead of the 144 of three boxes.
enum Build {
    Leaf {
        first: u32,
        count: u32,
    },
    /// `area`: the surface area of the node's box over the whole shutter, which the collapse
    /// compares to choose the children it opens.
    Inner {
        area: f64,
        children: Box<[Build; 2]>,
    },
}

struct BuildItem {
    /// The box the SAH works with (over the whole shutter).
    bounds: Aabb,
    centroid: DVec3,
    index: u32,
}

/// The boxes of a node: over the whole shutter, at its opening and at its closing.
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

/// The topology and boxes of the hierarchy over primitives whose boxes are `open`, or, with
/// `close`, over moving primitives (as [`Bvh::build_moving`] takes them).
///
/// [`Bvh::build_moving`]: super::hierarchy::Bvh::build_moving
pub(super) fn build_parts(open: &[Aabb], close: Option<&[Aabb]>) -> (Topology, Boxes) {
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
        // The root is always an 8-wide node, even over a single leaf, so traversal starts
        // at node 0. (Its area is never compared: only children are opened.)
        if let Build::Leaf { .. } = tree {
            let lone = std::mem::replace(&mut tree, Build::empty());
            tree = Build::Inner {
                area: 0.0,
                children: Box::new([lone, Build::empty()]),
            };
        }
        let prim = |pos: u32| {
            let i = topology.order[pos as usize] as usize;
            NodeBoxes {
                whole: whole(i),
                open: open[i],
                close: close.map_or(open[i], |c| c[i]),
            }
        };
        let moving = close.is_some();
        let all = collapse(&tree, &prim, moving, &mut topology.links, &mut boxes);
        // Pushed one by one: up to twice the memory needed, kept for the hierarchy's life.
        topology.links.shrink_to_fit();
        boxes.still.shrink_to_fit();
        boxes.moving.shrink_to_fit();
        boxes.bounds = all.whole;
    }
    (topology, boxes)
}

impl Build {
    /// A leaf of no primitives, with empty boxes: no ray enters it.
    fn empty() -> Build {
        Build::Leaf { first: 0, count: 0 }
    }
}

/// Builds the binary tree over `items` (reordered in place so every leaf is a contiguous
/// range); `offset` is the position of `items[0]` in the whole array.
fn build_node(items: &mut [BuildItem], offset: usize, depth: usize) -> Build {
    let leaf = Build::Leaf {
        first: offset as u32,
        count: items.len() as u32,
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
    // The union of the items' boxes is the union of the primitives' boxes below, as the
    // collapse computes it (a union of boxes is exact, in any order).
    Build::Inner {
        area: bounds.surface_area(),
        children: Box::new([l, r]),
    }
}

/// Appends the 8-wide nodes of the binary subtree `t` (an inner node) to `links` and
/// `boxes` in depth-first order, and returns the boxes of `t`: the unions of its primitives'
/// boxes (`prim(pos)` is the boxes of the primitive at position `pos` of the leaf order),
/// computed bottom up. The eight children are found by opening, from the node's two, the inner
/// child with the largest surface area until there are eight (Embree's BVH8 collapse); a node
/// with fewer leaves below it has fewer, its other slots empty.
fn collapse(
    t: &Build,
    prim: &impl Fn(u32) -> NodeBoxes,
    moving: bool,
    links: &mut Vec<Links>,
    boxes: &mut Boxes,
) -> NodeBoxes {
    let Build::Inner { children, .. } = t else {
        unreachable!("collapse starts at inner nodes")
    };
    let mut kids: Vec<&Build> = children.iter().collect();
    while kids.len() < LANES {
        let Some((i, _)) = kids
            .iter()
            .enumerate()
            .filter_map(|(i, c)| match c {
                Build::Inner { area, .. } => Some((i, *area)),
                Build::Leaf { .. } => None,
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
        else {
            break;
        };
        let Build::Inner {
            children: grand, ..
        } = kids.remove(i)
        else {
            unreachable!()
        };
        kids.insert(i, &grand[1]);
        kids.insert(i, &grand[0]);
    }
    let index = links.len();
    links.push(Links { child: [0; LANES] });
    if moving {
        boxes.moving.push([ChildBoxes::EMPTY, ChildBoxes::ZERO]);
    } else {
        boxes.still.push(ChildBoxes::EMPTY);
    }
    let mut all = NodeBoxes::EMPTY;
    for (k, c) in kids.iter().enumerate() {
        let b = match **c {
            Build::Leaf { first, count } => {
                links[index].child[k] = first | count << COUNT_SHIFT;
                (first..first + count).fold(NodeBoxes::EMPTY, |b, p| b.union(&prim(p)))
            }
            Build::Inner { .. } => {
                links[index].child[k] = links.len() as u32;
                collapse(c, prim, moving, links, boxes)
            }
        };
        if moving {
            set_moving(&mut boxes.moving[index], k, &b.open, &b.close);
        } else {
            boxes.still[index].set(k, &b.whole);
        }
        all = all.union(&b);
    }
    all
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
    use crate::bvh::hierarchy::Bvh;
    use crate::rng::Pcg32;

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
        assert_eq!(a.topology(), b.topology());
        assert_eq!(a.boxes(), b.boxes());
    }
}
