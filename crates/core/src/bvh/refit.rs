//! A topology's boxes computed from its primitives' boxes: every node's children's boxes are
//! the unions of the boxes below them, bottom up, in parallel over the subtrees. What a build
//! ends with and a refit to new boxes does, exact for any boxes.

use rayon::prelude::*;

use crate::aabb::Aabb;

use super::boxes::{ChildBoxes, set_moving};
use super::compact::CompactNode;
use super::lanes::LANES;
use super::links::Links;

/// Subtrees of more nodes than this have their children's subtrees refitted in parallel.
const PARALLEL_REFIT: usize = 512;

/// A node's children's boxes as a hierarchy stores them: still, moving over the shutter, or
/// moving and compact.
pub(super) trait NodeBoxes: Copy + Send + Sync {
    /// Every slot empty: no ray enters it.
    const EMPTY: Self;
    /// The node whose slot `k` holds `children[k]`: the boxes at the shutter's opening and
    /// at its closing, rounded outward (`None`: an empty slot). `links` are its children, which
    /// a compact node keeps beside its boxes.
    fn new(children: &[Option<(Aabb, Aabb)>; LANES], links: &Links) -> Self;
}

/// A node of a layout that stores each slot on its own: empty, then `set(node, k, open,
/// close)` for every child.
#[inline]
fn slot_by_slot<T: NodeBoxes>(
    children: &[Option<(Aabb, Aabb)>; LANES],
    set: impl Fn(&mut T, usize, &Aabb, &Aabb),
) -> T {
    let mut node = T::EMPTY;
    for (k, c) in children.iter().enumerate() {
        if let Some((open, close)) = c {
            set(&mut node, k, open, close);
        }
    }
    node
}

impl NodeBoxes for ChildBoxes {
    const EMPTY: Self = ChildBoxes::EMPTY;

    /// A still node holds the union (for a still primitive, `open` and `close` are one box).
    #[inline]
    fn new(children: &[Option<(Aabb, Aabb)>; LANES], _: &Links) -> Self {
        slot_by_slot(children, |node: &mut Self, k, open, close| {
            node.set(k, &open.union(close))
        })
    }
}

impl NodeBoxes for [ChildBoxes; 2] {
    const EMPTY: Self = [ChildBoxes::EMPTY, ChildBoxes::ZERO];

    #[inline]
    fn new(children: &[Option<(Aabb, Aabb)>; LANES], _: &Links) -> Self {
        slot_by_slot(children, set_moving)
    }
}

impl NodeBoxes for CompactNode {
    const EMPTY: Self = CompactNode::EMPTY;

    #[inline]
    fn new(children: &[Option<(Aabb, Aabb)>; LANES], links: &Links) -> Self {
        CompactNode::new(children, links)
    }
}

/// The boxes of every node of `links` (depth first, each node's inner children after it and
/// each subtree contiguous, as a build lays them out), with `prim(pos)` the boxes of the
/// primitive at leaf position `pos` at the shutter's opening and closing; and the unions of
/// every primitive's boxes at the opening and at the closing.
pub(super) fn refit<T: NodeBoxes>(
    links: &[Links],
    prim: &(impl Fn(u32) -> (Aabb, Aabb) + Sync),
) -> (Vec<T>, (Aabb, Aabb)) {
    let mut nodes = crate::pages::filled(links.len(), T::EMPTY);
    let all = if links.is_empty() {
        (Aabb::EMPTY, Aabb::EMPTY)
    } else {
        subtree(links, 0, &mut nodes, prim)
    };
    (nodes, all)
}

/// Refits node `first` and its subtree, whose boxes are `nodes` (`nodes[0]` the node's own);
/// returns the unions of its boxes.
fn subtree<T: NodeBoxes>(
    links: &[Links],
    first: usize,
    nodes: &mut [T],
    prim: &(impl Fn(u32) -> (Aabb, Aabb) + Sync),
) -> (Aabb, Aabb) {
    let node = links[first];
    let mut child = [(Aabb::EMPTY, Aabb::EMPTY); LANES];
    // The inner children, by node number: each one's subtree runs up to the next one's. On
    // the stack: most nodes have none (a frame of points makes a million nodes).
    let mut inner = [(0u32, 0usize); LANES];
    let mut inners = 0;
    for (k, c) in child.iter_mut().enumerate() {
        let (at, count) = node.slot(k);
        if count > 0 {
            *c = (at..at + count).fold((Aabb::EMPTY, Aabb::EMPTY), |(o, c), pos| {
                let (po, pc) = prim(pos);
                (o.union(&po), c.union(&pc))
            });
        } else if at > 0 {
            inner[inners] = (at, k);
            inners += 1;
        }
    }
    let inner = &mut inner[..inners];
    inner.sort_unstable();
    let (head, mut rest) = nodes.split_first_mut().expect("a node's boxes");
    let end = first + 1 + rest.len();
    let mut jobs: [(usize, usize, &mut [T]); LANES] = Default::default();
    for (j, &(at, k)) in inner.iter().enumerate() {
        let next = inner.get(j + 1).map_or(end, |n| n.0 as usize);
        let at = at as usize;
        // A build lays the subtrees out one after another, right after their node.
        let skipped = at - (end - rest.len());
        assert!(
            skipped == 0 && next > at,
            "a topology not laid out depth first"
        );
        let (part, tail) = std::mem::take(&mut rest).split_at_mut(next - at);
        rest = tail;
        jobs[j] = (k, at, part);
    }
    let jobs = &mut jobs[..inners];
    if jobs.iter().map(|j| j.2.len()).sum::<usize>() > PARALLEL_REFIT {
        let done: Vec<(usize, (Aabb, Aabb))> = jobs
            .par_iter_mut()
            .map(|(k, at, part)| (*k, subtree(links, *at, std::mem::take(part), prim)))
            .collect();
        for (k, b) in done {
            child[k] = b;
        }
    } else {
        for (k, at, part) in jobs.iter_mut() {
            child[*k] = subtree(links, *at, std::mem::take(part), prim);
        }
    }
    let mut all = (Aabb::EMPTY, Aabb::EMPTY);
    let mut slots = [None; LANES];
    for (k, (o, c)) in child.iter().enumerate() {
        let (at, count) = node.slot(k);
        if count == 0 && at == 0 {
            // An empty slot (the root is nobody's child): it stays empty.
            continue;
        }
        slots[k] = Some((*o, *c));
        all = (all.0.union(o), all.1.union(c));
    }
    *head = T::new(&slots, &node);
    all
}
