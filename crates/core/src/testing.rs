//! Scenes for the core's own tests, made in code: scene files are read a crate above this one
//! (`raytrace-scene`), so a test here builds the validated description directly, with the
//! defaults a scene file's validation gives.

use std::path::PathBuf;

use glam::DVec3;

use crate::camera::CameraRig;
use crate::format::Format;
use crate::material::{Background, Material};
use crate::motion::Motion;
use crate::pass::PassSet;
use crate::path_pattern::FramePattern;
use crate::rng::{Pcg32, hash_words};
use crate::sampler::SamplerKind;
use crate::scene::{Device, OutputSettings, RenderSettings, Scene};
use crate::shutter::Shot;
use crate::sphere::SphereDesc;

/// A scene of `spheres` (their materials `materials`) with a scene file's defaults: one frame
/// at 24 fps, a 180-degree shutter, 400x225 pixels, 16 samples, paths of 50 bounces, the sky,
/// a camera at the origin looking down -z.
pub(crate) fn scene(spheres: Vec<SphereDesc>, materials: Vec<Material>) -> Scene {
    Scene {
        source: PathBuf::from("test.toml"),
        shot: Shot::default(),
        output: OutputSettings {
            path: FramePattern::new("renders/test_####.png").expect("a pattern"),
            format: Format::Png,
            width: 400,
            height: 225,
            clip: None,
            passes: PassSet::EMPTY,
            denoise: None,
        },
        render: RenderSettings {
            samples: 16,
            max_depth: 50,
            seed: 0,
            sampler: SamplerKind::default(),
            device: Device::Cpu,
        },
        camera: CameraRig {
            look_from: Motion::Still(DVec3::ZERO),
            look_at: Motion::Still(DVec3::new(0.0, 0.0, -1.0)),
            up: DVec3::Y,
            vfov: 90.0,
            aperture: 0.0,
            focus_distance: None,
        },
        background: Background::Sky,
        transparent: false,
        materials,
        spheres,
        points: Vec::new(),
    }
}

/// A still sphere of material `material`.
pub(crate) fn still(center: [f64; 3], radius: f64, material: u32) -> SphereDesc {
    SphereDesc {
        motion: Motion::Still(DVec3::from_array(center)),
        radius,
        material,
    }
}

/// Side of the cube [`random`]'s spheres fill.
pub(crate) const CUBE: f64 = 100.0;

/// `n` random spheres in a cube of side [`CUBE`], a share `moving` of them moving, over a shot
/// of `frames` frames: the scenes `raytrace generate` writes (the same draws from the same
/// streams, its radii and speeds), made in code.
pub(crate) fn random(n: u64, moving: f64, seed: u64, frames: u32) -> Scene {
    const FPS: f64 = 24.0;
    let typical = 0.35 * CUBE / (n.max(1) as f64).cbrt();
    let spheres = (0..n)
        .map(|i| {
            let mut r = Pcg32::new(hash_words(&[seed, i]), 7);
            let mut u = || r.next_f64();
            let c = DVec3::new(u() - 0.5, u() - 0.5, u() - 0.5) * CUBE;
            let radius = typical * (0.5 + u());
            let material = ((u() * 16.0) as u32).min(15);
            let motion = if u() < moving {
                let z = 1.0 - 2.0 * u();
                let (s, co) = (std::f64::consts::TAU * u()).sin_cos();
                let rho = (1.0 - z * z).max(0.0).sqrt();
                let speed = typical * 2.0 * FPS * u();
                Motion::Velocity {
                    origin: c,
                    velocity: DVec3::new(rho * co, rho * s, z) * speed,
                }
            } else {
                Motion::Still(c)
            };
            SphereDesc {
                motion,
                radius,
                material,
            }
        })
        .collect();
    let materials = (0..16)
        .map(|i| match i {
            0..=11 => Material::Lambertian {
                albedo: DVec3::splat(0.5),
            },
            12..=14 => Material::Metal {
                albedo: DVec3::splat(0.8),
                fuzz: 0.2,
            },
            _ => Material::Dielectric { ior: 1.5 },
        })
        .collect();
    let mut scene = scene(spheres, materials);
    scene.shot = Shot {
        frames,
        ..Shot::default()
    };
    scene.camera.look_from = Motion::Still(DVec3::new(90.0, 60.0, 240.0));
    scene.camera.look_at = Motion::Still(DVec3::ZERO);
    scene.camera.vfov = 32.0;
    scene
}
