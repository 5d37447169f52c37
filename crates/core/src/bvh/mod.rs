//! A bounding volume hierarchy over boxes: built top down with the surface-area heuristic
//! (binned, as in Wald 2007, "On fast Construction of SAH-based Bounding Volume
//! Hierarchies"), in parallel, straight into an 8-wide tree (as Embree's BVH8) stored as
//! flat arrays of nodes. A node holds its eight children's boxes as structure-of-arrays, in
//! `f32` rounded outward (half the memory of `f64`; a box only ever grows, so no hit is lost),
//! so a ray is tested against all eight at once (one AVX register where the processor has
//! AVX2, two SSE registers otherwise), and the children a ray hits are visited nearest first.
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
//! primitives in that order, so the leaves of the hierarchy read memory front to back. A
//! caller whose primitives are compact records can have them reordered in place instead
//! ([`Topology::build_in_place`]), with no order and no copy.
//!
//! The files, one concept each, in the order they build on one another:
//! - `rounding`: `f64` sides rounded outward to `f32`, still and moving;
//! - `lanes`: eight `f32` lanes (AVX chosen at run time, SSE, or plain arrays);
//! - `boxes`: [`Boxes`], the nodes' `f32` boxes (eight children a node, still or moving);
//! - `compact`: a moving node's boxes quantised on a grid of its own, a third of the bytes;
//! - `links`: a node's eight children packed one word a slot;
//! - `topology`: [`Topology`], the nodes' children and the leaf order; the refit;
//! - `build`: the binned SAH build, on the primitives' boxes at the shutter's opening and
//!   closing, straight into 8-wide nodes, reordering the primitives into leaf order;
//! - `refit`: the nodes' boxes from the primitives', bottom up (after a build, or a refit);
//! - `slab`: a ray against a node's eight boxes at once, in `f32` lanes or in `f64`;
//! - `stack`: [`TraversalStack`], the fixed stacks of a ray's walk, a packet's traversal and
//!   walks in turns;
//! - `leaves`: [`Leaves`], what a traversal tests in its leaves, and a hint to load a leaf
//!   early;
//! - `walks`: one ray's walk to its nearest hit, a node or a leaf a step; many rays walked
//!   eight at a time in turns, the next ray taking the place of each walk that ends, so that
//!   one ray's loads overlap the others' work (for hierarchies far larger than the cache);
//! - `traverse`: [`BvhView`], the nearest hit of one ray (its walk, step after step);
//! - `packet`: the nearest hits of a packet of rays in one traversal ([`PacketRay`]);
//! - `hierarchy`: [`Bvh`], a built topology with its boxes;
//! - `export`: a node's children and their boxes read one by one ([`Child`]), for copies of a
//!   hierarchy in other layouts.

mod bins;
mod boxes;
mod build;
mod compact;
mod export;
mod hierarchy;
mod lanes;
mod leaves;
mod links;
mod packet;
mod partition;
mod refit;
mod rounding;
mod slab;
mod stack;
mod topology;
mod traverse;
mod walks;

#[cfg(test)]
mod tests;

pub use boxes::Boxes;
pub(crate) use build::BUILD_BYTES_PER_PRIMITIVE;
pub(crate) use build::BuildBox;
pub(crate) use build::MAX_LEAF;
pub use export::{Child, ChildKind};
pub(crate) use hierarchy::BYTES_PER_PRIMITIVE;
pub use hierarchy::Bvh;
pub(crate) use hierarchy::COMPACT_NODE_BYTES;
pub use leaves::Leaves;
pub(crate) use leaves::PacketLeaves;
pub(crate) use leaves::every;
pub(crate) use packet::PacketRay;
pub(crate) use stack::PACKET;
pub(crate) use stack::TURNS_WALKS_BYTES;
pub use stack::TraversalStack;
pub use topology::Topology;
pub use traverse::BvhView;
