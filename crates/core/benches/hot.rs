//! Benchmarks of the hot parts of a render: ray-sphere intersection, hierarchy build and
//! traversal (still and moving), and a small render of the books' motion-blur scene.
//!
//! ```text
//! cargo bench -p raytrace-core --bench hot
//! ```

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use raytrace_core::aabb::Aabb;
use raytrace_core::bvh::{Bvh, TraversalStack};
use raytrace_core::ray::Ray;
use raytrace_core::renderer::{CpuShot, FrameJob};
use raytrace_core::rng::Pcg32;
use raytrace_core::sampler::SamplerKind;
use raytrace_core::scene::Scene;
use raytrace_core::sphere::intersect;
use raytrace_scene::scene_file::Overrides;
use raytrace_scene::scene_file::SceneFile;

/// `n` random spheres in a cube of side 20 (radius 0.05 to 0.55) and their velocities.
fn spheres(n: usize) -> Vec<(DVec3, DVec3, f64)> {
    let mut r = Pcg32::new(1, 2);
    (0..n)
        .map(|_| {
            let c = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 20.0 - 10.0;
            let v = DVec3::new(0.0, r.next_f64() * 0.5, 0.0);
            (c, v, 0.05 + r.next_f64() * 0.5)
        })
        .collect()
}

/// Rays from outside the cube towards random points inside it, at random shutter times.
fn rays(n: usize) -> Vec<Ray> {
    let mut r = Pcg32::new(3, 4);
    (0..n)
        .map(|_| {
            let o = DVec3::new(r.next_f64() - 0.5, r.next_f64() - 0.5, 1.0) * 30.0;
            let target = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 20.0 - 10.0;
            Ray {
                origin: o,
                dir: (target - o).normalize(),
                time: r.next_f64(),
            }
        })
        .collect()
}

fn ray_sphere(c: &mut Criterion) {
    let rays = rays(1024);
    let center = DVec3::new(0.0, 0.0, 0.0);
    c.bench_function("intersect 1024 rays x 1 sphere", |b| {
        b.iter(|| {
            let mut hits = 0;
            for ray in &rays {
                if intersect(black_box(center), black_box(3.0), ray, f64::INFINITY).is_some() {
                    hits += 1;
                }
            }
            hits
        })
    });
}

fn hierarchy(c: &mut Criterion) {
    let s = spheres(10_000);
    let still: Vec<Aabb> = s.iter().map(|(c, _, r)| Aabb::point(*c).grow(*r)).collect();
    let close: Vec<Aabb> = s
        .iter()
        .map(|(c, v, r)| Aabb::point(*c + *v).grow(*r))
        .collect();
    c.bench_function("build 10k boxes", |b| {
        b.iter(|| Bvh::build(black_box(&still)))
    });
    c.bench_function("build 10k moving boxes", |b| {
        b.iter(|| Bvh::build_moving(black_box(&still), black_box(&close)))
    });
    let rays = rays(1024);
    for (name, bvh, moving) in [
        ("traverse 10k still: 1024 rays", Bvh::build(&still), false),
        (
            "traverse 10k moving: 1024 rays",
            Bvh::build_moving(&still, &close),
            true,
        ),
    ] {
        let mut stack = TraversalStack::default();
        let order = bvh.order().to_vec();
        let prims: Vec<(DVec3, DVec3, f64)> = order.iter().map(|&i| s[i as usize]).collect();
        c.bench_function(name, |b| {
            b.iter(|| {
                let mut hits = 0;
                for ray in &rays {
                    let t = if moving { ray.time } else { 0.0 };
                    let hit = bvh.closest_hit(
                        ray.origin,
                        ray.dir,
                        t,
                        f64::INFINITY,
                        &mut stack,
                        |p, t_max| {
                            let (c, v, r) = prims[p as usize];
                            intersect(c + v * t, r, ray, t_max)
                        },
                    );
                    hits += hit.is_some() as u32;
                }
                hits
            })
        });
    }
}

fn small_render(c: &mut Criterion) {
    // The workspace's scenes, two folders above this crate.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/bouncing_spheres.toml");
    for sampler in SamplerKind::ALL {
        let overrides = Overrides {
            width: Some(64),
            height: Some(36),
            samples: Some(4),
            seed: Some(1),
            sampler: Some(sampler),
            ..Overrides::default()
        };
        let scene = Scene::load_with(&path, &overrides).expect("scene");
        let statics = CpuShot::new(&scene);
        let frame = scene.shot.first_frame;
        let name = format!("render bouncing_spheres 64x36 4 spp {sampler}");
        c.bench_function(&name, |b| {
            b.iter(|| FrameJob::new(&scene, frame).sample(&statics).unwrap())
        });
    }
}

criterion_group!(benches, ray_sphere, hierarchy, small_render);
criterion_main!(benches);
