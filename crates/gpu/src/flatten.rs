//! A hierarchy built on the CPU, flattened into the GPU's words as one list of its children's
//! entries in depth-first order, each with its box (still, or moving over the shutter), what it
//! holds (a leaf's spheres, or nothing for a node, whose children follow it) and where its
//! subtree ends. A traversal then needs no stack: it walks the list, steps into a node whose
//! box the ray enters and jumps past the subtree of one it misses (a "threaded" hierarchy,
//! as in Smits, "Efficiency Issues for Ray Tracing", 1998). No per-ray array at all suits both
//! GPUs and software devices, which pay dearly for arrays indexed per invocation.
//!
//! A walk's order is fixed, so a node's children are listed nearest to the camera first: camera
//! rays then tend to meet the nearest spheres first, and the nearest hit skips more of the
//! rest (the books' scene renders about a tenth faster on lavapipe than in slot order).
//!
//! This file is the GPU tracer's only reader of a hierarchy, and it reads one through
//! [`BvhView::children`] alone, so a change of the CPU's node layout (its width, its packing)
//! changes nothing here.

use raytrace_core::bvh::{BvhView, Child, ChildKind};

use super::layout::{
    E_COUNT, E_FIRST, E_LOWER, E_LOWER_CHANGE, E_SKIP, E_UPPER, E_UPPER_CHANGE, ENTRY_WORDS, Words,
};

/// Where a flattened hierarchy's entries start and how many there are.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Flat {
    pub(super) entries: u32,
    pub(super) count: u32,
}

/// How much a child's box is grown, relative to its largest coordinate: 2^-16, 128 units in
/// the last place of an `f32`. The GPU places a sphere in `f32` (its centre, its motion at a
/// time computed in `f32`), off by a few units in the last place of its coordinates from
/// the `f64` placement the boxes were made for; the margin keeps it inside its boxes.
const MARGIN: f64 = 1.0 / 65536.0;

/// Appends the hierarchy `view` to `out`, from the next multiple of four words: every child
/// entry of every node, depth first (a node's children right after its entry), each node's
/// children nearest to the camera's position `eye` first (see [`emit`]).
pub(super) fn flatten(view: BvhView<'_>, eye: [f32; 3], out: &mut Words) -> Flat {
    out.align();
    let entries = out.at();
    let mut count = 0;
    if view.node_count() > 0 {
        emit(&view, 0, eye, out, entries, &mut count);
    }
    Flat { entries, count }
}

/// The squared distance from `eye` to the child's box at the shutter's opening.
fn distance2(c: &Child, eye: [f32; 3]) -> f32 {
    (0..3)
        .map(|a| {
            let d = (c.lower[a] - eye[a]).max(0.0).max(eye[a] - c.upper[a]);
            d * d
        })
        .sum()
}

/// Appends the entries of node `node`'s subtree; `count` entries are written so far. A
/// node's children are listed nearest to `eye` first: camera rays then meet near spheres
/// first, and the nearest hit so far lets the walk skip more.
fn emit(
    view: &BvhView<'_>,
    node: usize,
    eye: [f32; 3],
    out: &mut Words,
    entries: u32,
    count: &mut u32,
) {
    let mut children = view.children(node);
    children.sort_by(|a, b| distance2(a, eye).total_cmp(&distance2(b, eye)));
    for child in children {
        let at = *count;
        write_entry(&child, out);
        *count += 1;
        if let ChildKind::Node(j) = child.kind {
            emit(view, j as usize, eye, out, entries, count);
        }
        // Where the walk goes when the ray misses this child: past its subtree.
        out.set(entries + ENTRY_WORDS * at + E_SKIP, *count);
    }
}

fn write_entry(c: &Child, out: &mut Words) {
    let start = out.at();
    let m = (0..3)
        .flat_map(|a| {
            [
                c.lower[a] as f64,
                c.upper[a] as f64,
                c.lower[a] as f64 + c.lower_change[a] as f64,
                c.upper[a] as f64 + c.upper_change[a] as f64,
            ]
        })
        .fold(0.0f64, |m, x| m.max(x.abs()));
    // Plus a tiny absolute margin for boxes at the origin.
    let pad = m * MARGIN + 1e-30;
    let (first, count) = match c.kind {
        ChildKind::Node(_) => (0, 0),
        ChildKind::Leaf { first, count } => (first, count),
    };
    let quad = |out: &mut Words, at: u32, v: [f32; 3], w: u32| {
        debug_assert_eq!(out.at() - start, at);
        v.iter().for_each(|x| out.u(x.to_bits()));
        out.u(w);
    };
    let lower = [0, 1, 2].map(|a| below(c.lower[a] as f64 - pad));
    let upper = [0, 1, 2].map(|a| -below(-(c.upper[a] as f64) - pad));
    // The skip is set once the subtree is written.
    quad(out, E_LOWER, lower, 0);
    debug_assert_eq!(E_SKIP, E_LOWER + 3);
    quad(out, E_UPPER, upper, count);
    debug_assert_eq!(E_COUNT, E_UPPER + 3);
    quad(out, E_LOWER_CHANGE, c.lower_change, first);
    debug_assert_eq!(E_FIRST, E_LOWER_CHANGE + 3);
    quad(out, E_UPPER_CHANGE, c.upper_change, 0);
    debug_assert_eq!(out.at() - start, ENTRY_WORDS);
}

/// The largest `f32` at or below `x`.
fn below(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) > x { y.next_down() } else { y }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use raytrace_core::aabb::Aabb;
    use raytrace_core::bvh::Bvh;
    use raytrace_core::rng::Pcg32;

    /// The flattened hierarchy walked on the CPU as the GPU walks it (into every entry the
    /// point lies in, past every other), at shutter time `s`: the leaves' primitives found,
    /// and the entries visited.
    fn containing(words: &[u32], flat: Flat, p: DVec3, s: f32) -> (Vec<u32>, u32) {
        let f = |i: u32| f32::from_bits(words[i as usize]);
        let (mut found, mut visited) = (vec![], 0);
        let mut e = 0;
        while e < flat.count {
            visited += 1;
            let at = flat.entries + ENTRY_WORDS * e;
            let inside = (0..3).all(|a| {
                let lo = f(at + E_LOWER + a) + s * f(at + E_LOWER_CHANGE + a);
                let hi = f(at + E_UPPER + a) + s * f(at + E_UPPER_CHANGE + a);
                (lo as f64) <= p[a as usize] && p[a as usize] <= hi as f64
            });
            let count = words[(at + E_COUNT) as usize];
            if inside && count == 0 {
                e += 1;
                continue;
            }
            if inside {
                let first = words[(at + E_FIRST) as usize];
                found.extend(first..first + count);
            }
            e = words[(at + E_SKIP) as usize];
        }
        (found, visited)
    }

    #[test]
    fn every_moving_primitive_stays_in_its_flattened_boxes() {
        // Points moving linearly through boxes built over the shutter: at any time, each
        // point's leaf is reached by walking the entries that contain it, and the walk skips
        // most of the hierarchy.
        let mut r = Pcg32::new(5, 9);
        let n = 3000;
        let mut v = || DVec3::new(r.next_f64(), r.next_f64(), r.next_f64());
        let paths: Vec<(DVec3, DVec3)> = (0..n).map(|_| (v() * 100.0, (v() - 0.5) * 5.0)).collect();
        let open: Vec<Aabb> = paths
            .iter()
            .map(|(c, _)| Aabb::point(*c).grow(0.5))
            .collect();
        let close: Vec<Aabb> = paths
            .iter()
            .map(|(c, d)| Aabb::point(*c + *d).grow(0.5))
            .collect();
        let bvh = Bvh::build_moving(&open, &close);
        let mut words = Words::default();
        words.u(7); // the hierarchy need not start at word 0
        let flat = flatten(bvh.view(), [0.0; 3], &mut words);
        assert_eq!(flat.entries, 4);
        // Every child slot of every node, once.
        let slots: usize = (0..bvh.node_count())
            .map(|i| bvh.view().children(i).len())
            .sum();
        assert_eq!(flat.count as usize, slots);
        let mut most = 0;
        for (k, s) in [0.0f32, 0.3, 0.999, 1.0].into_iter().enumerate() {
            for (pos, &prim) in bvh.order().iter().enumerate().skip(k).step_by(7) {
                let (c, d) = paths[prim as usize];
                let p = c + d * s as f64;
                let (found, visited) = containing(&words.0, flat, p, s);
                assert!(found.contains(&(pos as u32)), "primitive {prim} at s {s}");
                most = most.max(visited);
            }
        }
        assert!(most < flat.count / 10, "{most} of {} entries", flat.count);
    }

    #[test]
    fn an_empty_hierarchy_has_no_entries() {
        let bvh = Bvh::build(&[]);
        let mut words = Words::default();
        let flat = flatten(bvh.view(), [0.0; 3], &mut words);
        assert_eq!(flat.count, 0);
        assert!(words.0.is_empty());
    }
}
