//! The path tracer: the books' `ray_color`, as a loop.

use glam::DVec3;

use crate::bvh::TraversalStack;
use crate::material::Scatter;
use crate::ray::{Ray, offset_origin};
use crate::sampler::Sampler;
use crate::world::World;

/// Per-thread state of the tracer: counters, and scratch space reused from ray to ray.
#[derive(Clone, Debug, Default)]
pub struct TraceStats {
    /// Rays intersected with the scene.
    pub rays: u64,
    /// The hierarchy traversal's stack.
    pub stack: TraversalStack,
}

/// The radiance arriving along `ray`, following at most `max_depth` bounces; a path that
/// reaches `max_depth` returns black. The scattered rays keep the camera ray's time.
#[inline]
pub fn radiance<S: Sampler>(
    world: &World,
    mut ray: Ray,
    max_depth: u32,
    sampler: &mut S,
    stats: &mut TraceStats,
) -> DVec3 {
    let mut throughput = DVec3::ONE;
    // The sphere the ray just left through its outside, which it cannot hit again.
    let mut skip = u32::MAX;
    for _ in 0..max_depth {
        stats.rays += 1;
        let Some(hit) = world.hit(&ray, skip, &mut stats.stack) else {
            return throughput * world.background.radiance(ray.dir);
        };
        match hit.material.scatter(ray.dir, hit.surface.normal, sampler) {
            Scatter::Absorbed => return DVec3::ZERO,
            Scatter::Continue {
                dir,
                attenuation,
                leaves_outside,
            } => {
                throughput *= attenuation;
                skip = if leaves_outside { hit.sphere } else { u32::MAX };
                let origin =
                    offset_origin(hit.surface.p, hit.surface.p_error, hit.surface.normal, dir);
                ray = Ray {
                    origin,
                    dir,
                    time: ray.time,
                };
            }
        }
    }
    DVec3::ZERO
}
