//! A bounding volume hierarchy over boxes, built with the surface-area heuristic (binned, as in
//! Wald 2007, "On fast Construction of SAH-based Bounding Volume Hierarchies") and stored as a
//! flat array of nodes in depth-first order: a node's left child follows it directly.

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
/// Traversal stack size: at most one entry per level.
const STACK: usize = MAX_SAH_DEPTH + 40;

/// Scratch space for traversals. Made once per thread of work and reused for every ray:
/// clearing a fresh stack array per ray cost about 8% of a render.
#[derive(Clone, Debug)]
pub struct TraversalStack([u32; STACK]);

impl Default for TraversalStack {
    fn default() -> Self {
        TraversalStack([0; STACK])
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    /// Leaf: index of the first primitive in `Bvh::order`; interior: index of the right child.
    index: u32,
    /// Number of primitives for a leaf, 0 for an interior node.
    count: u16,
    /// Split axis of an interior node, used to visit the nearer child first.
    axis: u8,
}

/// A hierarchy over primitives `0..n` given by their boxes.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Primitive indices in leaf order.
    order: Vec<u32>,
}

struct BuildItem {
    bounds: Aabb,
    centroid: DVec3,
    index: u32,
}

impl Bvh {
    /// Builds the hierarchy over `boxes`; primitive `i` has box `boxes[i]`.
    pub fn build(boxes: &[Aabb]) -> Bvh {
        let mut items: Vec<BuildItem> = boxes
            .iter()
            .enumerate()
            .map(|(i, b)| BuildItem {
                bounds: *b,
                centroid: b.centroid(),
                index: i as u32,
            })
            .collect();
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(2 * boxes.len() / MAX_LEAF + 1),
            order: Vec::new(),
        };
        if !items.is_empty() {
            bvh.build_node(&mut items, 0, 0);
        }
        bvh.order = items.iter().map(|it| it.index).collect();
        bvh
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// Whether the hierarchy has no primitives.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// The box of everything in the hierarchy.
    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds)
    }

    fn build_node(&mut self, items: &mut [BuildItem], offset: usize, depth: usize) {
        let bounds = items.iter().fold(Aabb::EMPTY, |b, it| b.union(&it.bounds));
        let node_index = self.nodes.len();
        self.nodes.push(Node {
            bounds,
            index: offset as u32,
            count: items.len() as u16,
            axis: 0,
        });
        if items.len() <= 1 {
            return;
        }
        // Below MAX_SAH_DEPTH, halving keeps the tree shallow enough for the traversal stack
        // whatever the distribution.
        let sah = if depth < MAX_SAH_DEPTH {
            split(items, &bounds)
        } else {
            None
        };
        let Some((axis, mid)) = sah else {
            if items.len() <= MAX_LEAF {
                return;
            }
            // No useful SAH split (e.g. identical centroids) but too many for a leaf: halve.
            self.build_children(node_index, items, offset, 0, items.len() / 2, depth);
            return;
        };
        self.build_children(node_index, items, offset, axis, mid, depth);
    }

    fn build_children(
        &mut self,
        node: usize,
        items: &mut [BuildItem],
        offset: usize,
        axis: usize,
        mid: usize,
        depth: usize,
    ) {
        self.nodes[node].count = 0;
        self.nodes[node].axis = axis as u8;
        let (left, right) = items.split_at_mut(mid);
        self.build_node(left, offset, depth + 1);
        self.nodes[node].index = self.nodes.len() as u32;
        self.build_node(right, offset + mid, depth + 1);
    }

    /// Finds the closest primitive hit. `hit(prim, t_max)` returns the primitive's hit
    /// distance in `(0, t_max)`, if any. Returns the distance and primitive index.
    #[inline]
    pub fn closest_hit(
        &self,
        origin: DVec3,
        dir: DVec3,
        mut t_max: f64,
        stack: &mut TraversalStack,
        mut hit: impl FnMut(u32, f64) -> Option<f64>,
    ) -> Option<(f64, u32)> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv_dir = DVec3::ONE / dir;
        let negative = [dir.x < 0.0, dir.y < 0.0, dir.z < 0.0];
        let mut best = None;
        let stack = &mut stack.0;
        let mut sp = 0usize;
        let mut current = 0usize;
        loop {
            let node = &self.nodes[current];
            if node.bounds.hit(origin, inv_dir, 0.0, t_max) {
                if node.count > 0 {
                    let first = node.index as usize;
                    for &prim in &self.order[first..first + node.count as usize] {
                        if let Some(t) = hit(prim, t_max) {
                            t_max = t;
                            best = Some((t, prim));
                        }
                    }
                } else {
                    // Visit the child on the ray's side of the split first.
                    let (near, far) = if negative[node.axis as usize] {
                        (node.index as usize, current + 1)
                    } else {
                        (current + 1, node.index as usize)
                    };
                    stack[sp] = far as u32;
                    sp += 1;
                    current = near;
                    continue;
                }
            }
            if sp == 0 {
                return best;
            }
            sp -= 1;
            current = stack[sp] as usize;
        }
    }
}

/// The best SAH split of `items` (reordered in place so the split is at the returned index),
/// or `None` when keeping them in one leaf is cheaper or no split separates them.
fn split(items: &mut [BuildItem], bounds: &Aabb) -> Option<(usize, usize)> {
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
    Some((axis, mid))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    fn brute(boxes: &[Aabb], centers: &[(DVec3, f64)], o: DVec3, d: DVec3) -> Option<(f64, u32)> {
        let _ = boxes;
        let ray = crate::ray::Ray {
            origin: o,
            dir: d,
            time: 0.0,
        };
        let mut best: Option<(f64, u32)> = None;
        for (i, (c, r)) in centers.iter().enumerate() {
            if let Some(t) =
                crate::sphere::intersect(*c, *r, &ray, best.map_or(f64::INFINITY, |b| b.0))
            {
                best = Some((t, i as u32));
            }
        }
        best
    }

    #[test]
    fn agrees_with_brute_force() {
        let mut r = Pcg32::new(11, 1);
        let mut stack = TraversalStack::default();
        for &n in &[0usize, 1, 2, 5, 17, 300, 2000] {
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
            for _ in 0..500 {
                let o = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 30.0 - 15.0;
                let d = (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5).normalize();
                let ray = crate::ray::Ray {
                    origin: o,
                    dir: d,
                    time: 0.0,
                };
                let got = bvh.closest_hit(o, d, f64::INFINITY, &mut stack, |p, tmax| {
                    let (c, rad) = centers[p as usize];
                    crate::sphere::intersect(c, rad, &ray, tmax)
                });
                assert_eq!(got, brute(&boxes, &centers, o, d));
            }
        }
    }

    #[test]
    fn identical_boxes_still_split_into_small_leaves() {
        let boxes = vec![Aabb::point(DVec3::ONE).grow(1.0); 1000];
        let bvh = Bvh::build(&boxes);
        assert!(bvh.nodes.iter().all(|n| n.count as usize <= MAX_LEAF));
        let mut seen: Vec<u32> = bvh.order.clone();
        seen.sort();
        assert_eq!(seen, (0..1000).collect::<Vec<u32>>());
    }
}
