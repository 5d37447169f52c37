//! The hierarchy read one node at a time, whatever its layout in memory: what each child slot
//! holds and its box. For copies of a hierarchy in other layouts (the GPU's, `raytrace_gpu`),
//! which then depend on this file alone and not on how nodes are packed.

use super::boxes::{ChildBoxes, Nodes, set_moving};
use super::lanes::LANES;
use super::traverse::BvhView;

/// What a child slot holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChildKind {
    /// An inner node, by its index (the root is node 0; a child's index is above its parent's).
    Node(u32),
    /// A leaf: `count` primitives from position `first` of [`Topology::order`].
    ///
    /// [`Topology::order`]: super::topology::Topology::order
    Leaf { first: u32, count: u32 },
}

/// One child of a node and its box, in `f32`: at shutter time `s` in [0, 1] the box is
/// `lower + s * lower_change` to `upper + s * upper_change`, each evaluated in `f32`, and it
/// contains the child's primitives at that time (a still hierarchy's changes are 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Child {
    pub kind: ChildKind,
    pub lower: [f32; 3],
    pub upper: [f32; 3],
    pub lower_change: [f32; 3],
    pub upper_change: [f32; 3],
}

impl BvhView<'_> {
    /// Number of nodes (none for a hierarchy without primitives).
    pub fn node_count(&self) -> usize {
        self.topology.links.len()
    }

    /// The children of node `node`, in slot order, empty slots left out. A compact node's
    /// boxes are given as the `f32` sides and changes that contain them ([`moving_lower`]).
    ///
    /// [`moving_lower`]: super::rounding::moving_lower
    pub fn children(&self, node: usize) -> Vec<Child> {
        let links = &self.topology.links[node];
        let side =
            |b: &ChildBoxes, first: usize, k: usize| [0, 1, 2].map(|a| b.planes[first + a][k]);
        (0..LANES)
            .filter_map(|k| {
                let (child, count) = links.slot(k);
                let kind = match (count, child) {
                    (0, 0) => return None,
                    (0, node) => ChildKind::Node(node),
                    (count, first) => ChildKind::Leaf { first, count },
                };
                let (lower, upper, lower_change, upper_change) = match &self.boxes.nodes {
                    Nodes::Still(n) => (
                        side(&n[node], 0, k),
                        side(&n[node], 3, k),
                        [0.0; 3],
                        [0.0; 3],
                    ),
                    Nodes::Moving(n) => {
                        let [b, d] = &n[node];
                        (side(b, 0, k), side(b, 3, k), side(d, 0, k), side(d, 3, k))
                    }
                    Nodes::Compact(_) => {
                        let (open, close) = self.boxes.child(node, k)?;
                        let mut moving = [ChildBoxes::EMPTY, ChildBoxes::ZERO];
                        set_moving(&mut moving, 0, &open, &close);
                        let [b, d] = &moving;
                        (side(b, 0, 0), side(b, 3, 0), side(d, 0, 0), side(d, 3, 0))
                    }
                };
                Some(Child {
                    kind,
                    lower,
                    upper,
                    lower_change,
                    upper_change,
                })
            })
            .collect()
    }
}
