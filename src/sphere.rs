//! Spheres: their description in a scene and their intersection with rays.

use crate::motion::Motion;

/// A sphere as the scene describes it, for the whole shot.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereDesc {
    /// The path of the centre.
    pub motion: Motion,
    /// Radius, > 0.
    pub radius: f64,
    /// Index into [`crate::scene::Scene::materials`].
    pub material: u32,
}
