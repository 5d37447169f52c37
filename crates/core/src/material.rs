//! Materials and the background: the integrand of "Ray Tracing in One Weekend", exactly.
//!
//! [`Material::scatter`] is the books' scattering of each material. It draws no numbers of
//! its own: the tracer hands it a bounce's numbers ([`BounceSample`], the same three for
//! every material), and each material uses those it needs: a Lambertian `u` for its
//! direction, a fuzzy metal `u` and `uc` for its point in the unit ball (a sharp mirror
//! none), glass `uc` to choose between reflection and refraction.

use glam::DVec3;

use crate::sampler::BounceSample;

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

/// What a material does with a ray that hits it.
#[derive(Clone, Copy, Debug)]
pub enum Scatter {
    /// The path ends (a metal ray scattered below the surface).
    Absorbed,
    /// The path continues in unit direction `dir` with its throughput multiplied by
    /// `attenuation`. `leaves_outside` is true when the new ray leaves the outside of an
    /// opaque sphere: it cannot hit that (convex) sphere again.
    Continue {
        dir: DVec3,
        attenuation: DVec3,
        leaves_outside: bool,
    },
}

/// A uniformly distributed unit vector from two numbers in [0, 1) (the distribution of the
/// books' `random_unit_vector()`, drawn by inversion instead of rejection).
#[inline]
pub(crate) fn unit_vector((a, b): (f64, f64)) -> DVec3 {
    let z = 1.0 - 2.0 * a;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = crate::trig::sin_cos_turns(b);
    DVec3::new(r * c, r * s, z)
}

/// A uniformly distributed point in the unit ball from three numbers in [0, 1) (the
/// distribution of the books' `random_in_unit_sphere()`).
#[inline]
pub(crate) fn in_unit_ball(dir: (f64, f64), radius: f64) -> DVec3 {
    unit_vector(dir) * radius.cbrt()
}

/// Mirror reflection of `v` about the normal `n`.
#[inline]
pub fn reflect(v: DVec3, n: DVec3) -> DVec3 {
    v - 2.0 * v.dot(n) * n
}

/// Snell refraction of the unit vector `uv` through the surface with unit normal `n` (on the
/// side `uv` comes from) with `eta_ratio = eta_in / eta_out` (the books' `refract`).
#[inline]
pub fn refract(uv: DVec3, n: DVec3, eta_ratio: f64, cos_theta: f64) -> DVec3 {
    let perp = eta_ratio * (uv + cos_theta * n);
    let parallel = -((1.0 - perp.length_squared()).abs()).sqrt() * n;
    perp + parallel
}

/// Schlick's approximation of Fresnel reflectance.
#[inline]
pub fn schlick(cosine: f64, eta_ratio: f64) -> f64 {
    let r0 = (1.0 - eta_ratio) / (1.0 + eta_ratio);
    let r0 = r0 * r0;
    r0 + (1.0 - r0) * (1.0 - cosine).powi(5)
}

impl Material {
    /// The material with its albedo replaced by `albedo` (glass, which has none, unchanged).
    pub fn with_albedo(self, albedo: DVec3) -> Material {
        match self {
            Material::Lambertian { .. } => Material::Lambertian { albedo },
            Material::Metal { fuzz, .. } => Material::Metal { albedo, fuzz },
            glass @ Material::Dielectric { .. } => glass,
        }
    }

    /// The material with its albedo multiplied by `color` (a point's colour attribute);
    /// glass, which has no albedo, is unchanged.
    #[inline]
    pub(crate) fn tinted(self, color: DVec3) -> Material {
        match self {
            Material::Lambertian { albedo } => Material::Lambertian {
                albedo: albedo * color,
            },
            Material::Metal { albedo, fuzz } => Material::Metal {
                albedo: albedo * color,
                fuzz,
            },
            glass @ Material::Dielectric { .. } => glass,
        }
    }

    /// Scatters a ray arriving in unit direction `dir_in` at a point with unit outward normal
    /// `outward`, with the bounce's numbers `sample`.
    /// This is the integrand of "Ray Tracing in One Weekend" exactly: the scattered
    /// directions have the books' distributions.
    #[inline]
    pub fn scatter(&self, dir_in: DVec3, outward: DVec3, sample: BounceSample) -> Scatter {
        let front_face = dir_in.dot(outward) < 0.0;
        let n = if front_face { outward } else { -outward };
        match *self {
            Material::Lambertian { albedo } => {
                let mut dir = n + unit_vector(sample.u);
                // The books' near_zero(): every component below 1e-8.
                if dir.abs().max_element() < 1e-8 {
                    dir = n;
                }
                Scatter::Continue {
                    dir: dir.normalize(),
                    attenuation: albedo,
                    leaves_outside: front_face,
                }
            }
            Material::Metal { albedo, fuzz } => {
                let mut dir = reflect(dir_in, n);
                if fuzz > 0.0 {
                    dir += fuzz * in_unit_ball(sample.u, sample.uc);
                }
                // Absorbed when scattered below the surface (and when it has no length).
                if dir.dot(n) <= 0.0 {
                    return Scatter::Absorbed;
                }
                Scatter::Continue {
                    dir: dir.normalize(),
                    attenuation: albedo,
                    leaves_outside: front_face,
                }
            }
            Material::Dielectric { ior } => {
                let ratio = if front_face { 1.0 / ior } else { ior };
                let cos_theta = (-dir_in).dot(n).min(1.0);
                let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
                let cannot_refract = ratio * sin_theta > 1.0;
                // Reflects with probability Schlick's reflectance (the books' comparison
                // with a uniform number).
                let dir = if cannot_refract || schlick(cos_theta, ratio) > sample.uc {
                    reflect(dir_in, n)
                } else {
                    refract(dir_in, n, ratio, cos_theta)
                };
                Scatter::Continue {
                    dir: dir.normalize(),
                    attenuation: DVec3::ONE,
                    leaves_outside: false,
                }
            }
        }
    }
}

impl Background {
    /// The radiance seen along unit direction `dir`.
    #[inline]
    pub fn radiance(&self, dir: DVec3) -> DVec3 {
        match *self {
            Background::Sky => {
                let a = 0.5 * (dir.y + 1.0);
                (1.0 - a) * DVec3::ONE + a * DVec3::new(0.5, 0.7, 1.0)
            }
            Background::Uniform(c) => c,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// Fixed bounce numbers.
    fn fixed(uc: f64, u: (f64, f64)) -> BounceSample {
        BounceSample { uc, u }
    }

    #[test]
    fn unit_vectors_are_unit_and_uniform() {
        let mut r = Pcg32::new(3, 3);
        let n = 200_000;
        let mut mean = DVec3::ZERO;
        let mut upper = 0;
        for _ in 0..n {
            let v = unit_vector((r.next_f64(), r.next_f64()));
            assert!((v.length() - 1.0).abs() < 1e-12);
            mean += v;
            upper += (v.y > 0.5) as u32;
        }
        assert!((mean / n as f64).length() < 0.01);
        // The cap y > 0.5 holds a quarter of the sphere's area (Archimedes).
        assert!((upper as f64 / n as f64 - 0.25).abs() < 0.005);
    }

    #[test]
    fn ball_points_fill_the_ball_uniformly() {
        let mut r = Pcg32::new(4, 4);
        let n = 200_000;
        let inner = (0..n)
            .filter(|_| {
                let p = in_unit_ball((r.next_f64(), r.next_f64()), r.next_f64());
                assert!(p.length() < 1.0 + 1e-12);
                p.length() < 0.5
            })
            .count();
        assert!((inner as f64 / n as f64 - 0.125).abs() < 0.004);
    }

    #[test]
    fn schlick_limits() {
        assert!((schlick(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-12);
        assert!((schlick(0.0, 1.0 / 1.5) - 1.0).abs() < 1e-12);
        assert_eq!(schlick(1.0, 1.0), 0.0);
        assert!((schlick(0.7, 1.0) - 0.3f64.powi(5)).abs() < 1e-15);
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = DVec3::Y;
        let uv = DVec3::new(0.6, -0.8, 0.0);
        let cos = -uv.dot(n);
        let t = refract(uv, n, 1.0 / 1.5, cos);
        let sin_in = 0.6;
        let sin_out = t.x / t.length();
        assert!((sin_in / 1.5 - sin_out).abs() < 1e-12);
        assert!((t.length() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn total_internal_reflection_reflects_always() {
        let glass = Material::Dielectric { ior: 1.5 };
        // From inside (the outward normal points the same way as the ray), at a grazing angle.
        let dir = DVec3::new(0.9, 0.1, 0.0).normalize();
        match glass.scatter(dir, DVec3::Y, fixed(0.999, (0.5, 0.5))) {
            Scatter::Continue {
                dir: d,
                attenuation,
                ..
            } => {
                assert!((d - reflect(dir, -DVec3::Y)).length() < 1e-12);
                assert_eq!(attenuation, DVec3::ONE);
            }
            Scatter::Absorbed => panic!("glass never absorbs"),
        }
    }

    #[test]
    fn metal_below_surface_is_absorbed_and_mirror_is_exact() {
        let m = Material::Metal {
            albedo: DVec3::splat(0.5),
            fuzz: 1.0,
        };
        let dir = DVec3::new(1.0, -1e-3, 0.0).normalize();
        // A fuzz point straight down (z = 0, azimuth 270 degrees) pushes the reflection below
        // the surface.
        let down = fixed(0.999, (0.5, 0.75));
        assert!(matches!(m.scatter(dir, DVec3::Y, down), Scatter::Absorbed));
        let mirror = Material::Metal {
            albedo: DVec3::splat(0.5),
            fuzz: 0.0,
        };
        match mirror.scatter(DVec3::new(1.0, -1.0, 0.0).normalize(), DVec3::Y, down) {
            Scatter::Continue {
                dir,
                leaves_outside,
                ..
            } => {
                assert!((dir - DVec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-15);
                assert!(leaves_outside);
            }
            Scatter::Absorbed => panic!(),
        }
    }

    /// The direction of a scatter that continues.
    fn direction(s: Scatter) -> DVec3 {
        match s {
            Scatter::Continue { dir, .. } => dir,
            Scatter::Absorbed => panic!("absorbed"),
        }
    }

    #[test]
    fn each_material_uses_only_its_numbers() {
        let dir = DVec3::new(0.3, -1.0, 0.2).normalize();
        let scatter = |m: Material, uc, u| m.scatter(dir, DVec3::Y, fixed(uc, u));
        let diffuse = Material::Lambertian { albedo: DVec3::ONE };
        let a = direction(scatter(diffuse, 0.1, (0.3, 0.6)));
        assert_eq!(direction(scatter(diffuse, 0.9, (0.3, 0.6))), a);
        assert_ne!(direction(scatter(diffuse, 0.1, (0.4, 0.6))), a);
        let glass = Material::Dielectric { ior: 1.5 };
        let a = direction(scatter(glass, 0.5, (0.3, 0.6)));
        assert_eq!(direction(scatter(glass, 0.5, (0.9, 0.1))), a);
        let mirror = Material::Metal {
            albedo: DVec3::ONE,
            fuzz: 0.0,
        };
        let a = direction(scatter(mirror, 0.5, (0.3, 0.6)));
        assert_eq!(direction(scatter(mirror, 0.1, (0.9, 0.1))), a);
        let fuzzy = Material::Metal {
            albedo: DVec3::ONE,
            fuzz: 0.3,
        };
        let a = direction(scatter(fuzzy, 0.5, (0.3, 0.6)));
        assert_ne!(direction(scatter(fuzzy, 0.9, (0.3, 0.6))), a);
        assert_ne!(direction(scatter(fuzzy, 0.5, (0.4, 0.6))), a);
    }

    #[test]
    fn glass_reflects_with_the_probability_of_its_reflectance() {
        // Straight in from outside, Schlick's reflectance is 0.04: `uc` below it reflects
        // (straight back), above it refracts (straight through).
        let glass = Material::Dielectric { ior: 1.5 };
        let down = -DVec3::Y;
        let reflected = direction(glass.scatter(down, DVec3::Y, fixed(0.039, (0.5, 0.5))));
        assert!((reflected - DVec3::Y).length() < 1e-12);
        let refracted = direction(glass.scatter(down, DVec3::Y, fixed(0.041, (0.5, 0.5))));
        assert!((refracted - down).length() < 1e-12);
    }

    #[test]
    fn lambertian_directions_follow_the_cosine() {
        // normal + a uniform unit vector is distributed as cos(theta) / pi about the normal:
        // mean cosine 2/3, and a quarter of the directions within 30 degrees of the normal
        // (sin^2 30 = 1/4 of the cosine-weighted hemisphere).
        let diffuse = Material::Lambertian { albedo: DVec3::ONE };
        let mut r = Pcg32::new(5, 5);
        let n = 200_000;
        let (mut sum, mut near) = (0.0, 0);
        for _ in 0..n {
            let u = (r.next_f64(), r.next_f64());
            let d = direction(diffuse.scatter(-DVec3::Y, DVec3::Y, fixed(r.next_f64(), u)));
            sum += d.y;
            near += (d.y > 30f64.to_radians().cos()) as u32;
        }
        assert!((sum / n as f64 - 2.0 / 3.0).abs() < 0.003);
        assert!((near as f64 / n as f64 - 0.25).abs() < 0.005);
    }

    #[test]
    fn sky_gradient() {
        assert_eq!(
            Background::Sky.radiance(DVec3::Y),
            DVec3::new(0.5, 0.7, 1.0)
        );
        assert_eq!(Background::Sky.radiance(-DVec3::Y), DVec3::ONE);
    }
}
