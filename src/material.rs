//! Materials and the background: the integrand of "Ray Tracing in One Weekend", exactly.
//! (Scattering code comes with the tracer; this file holds the types.)

use glam::DVec3;

/// A surface material. A closed set, so an enum: no dynamic dispatch in the hot loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// Diffuse: scatters to `normal + random_unit_vector()`, attenuated by `albedo`.
    Lambertian { albedo: DVec3 },
    /// Mirror: reflects the unit incoming direction, plus `fuzz` times a random point in the
    /// unit sphere; rays that end below the surface are absorbed.
    Metal { albedo: DVec3, fuzz: f64 },
    /// Glass: Schlick reflectance, total internal reflection, attenuation 1.
    Dielectric { ior: f64 },
}

/// What a ray that leaves the scene sees.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Background {
    /// The sky gradient of the books: white at the horizon to (0.5, 0.7, 1.0) straight up.
    #[default]
    Sky,
    /// A uniform environment of this radiance.
    Uniform(DVec3),
}
