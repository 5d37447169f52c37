//! A ray's nearest intersection with the scene, as the tracer, the passes and the materials
//! see it (pbrt's `SurfaceInteraction`, Psychopath's `SurfaceIntersection`): where, on which
//! sphere, with which material. It lives in a room of its own, below the world that finds it
//! and the passes that read it.

use crate::material::Material;
use crate::sphere::SurfacePoint;

/// A ray's nearest intersection.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// The ray parameter of the hit.
    pub t: f64,
    /// The point, its error bound and its outward normal.
    pub surface: SurfacePoint,
    pub material: Material,
    /// Index of the sphere in the scene.
    pub sphere: u32,
}
