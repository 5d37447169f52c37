//! The world of one frame: every sphere prepared for the frame's shutter interval, in two
//! hierarchies. Spheres that never move in the shot are built into a [`StaticGeometry`] once
//! per sequence; the others are prepared and built per frame, with boxes over that frame's
//! shutter only. A sphere that does not move during a frame is traced as a static sphere.

use glam::DVec3;
use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::bvh::{Bvh, TraversalStack};
use crate::material::{Background, Material};
use crate::motion::FrameMotion;
use crate::ray::Ray;
use crate::scene::Scene;
use crate::shutter::Interval;
use crate::sphere::{SurfacePoint, intersect, surface_point};

/// Marks a [`MovingPrim`] whose path is a line (or a point): no entry in [`World::motions`].
const LINEAR: u32 = u32::MAX;

/// Scenes with animated spheres and at most this many spheres in all are built into one
/// hierarchy per frame instead of a static one and a per-frame one.
const MERGE_LIMIT: usize = 16384;

/// A sphere that never moves, as the tracer sees it.
#[derive(Clone, Copy, Debug)]
struct StillPrim {
    center: DVec3,
    radius: f64,
    material: u32,
    /// Index of the sphere in the scene.
    id: u32,
}

/// An animated sphere prepared for one frame. Its centre at time `t` is
/// `center + velocity * (t - open)` (exactly [`FrameMotion::at`] for a linear motion, and
/// `center` for a sphere that does not move in this frame), or, for a curved path,
/// `World::motions[general].at(t)`.
#[derive(Clone, Copy, Debug)]
struct MovingPrim {
    center: DVec3,
    velocity: DVec3,
    radius: f64,
    material: u32,
    /// Index of the sphere in the scene.
    id: u32,
    /// Index into [`World::motions`], or [`LINEAR`].
    general: u32,
}

impl MovingPrim {
    /// The centre at `dt` seconds after the shutter opened (absolute time `t`).
    #[inline]
    fn center_at(&self, motions: &[FrameMotion], dt: f64, t: f64) -> DVec3 {
        if self.general == LINEAR {
            self.center + self.velocity * dt
        } else {
            motions[self.general as usize].at(t)
        }
    }
}

/// The spheres that never move during the shot, with their hierarchy: built once per sequence.
#[derive(Clone, Debug, Default)]
pub struct StaticGeometry {
    /// In the hierarchy's leaf order.
    prims: Vec<StillPrim>,
    bvh: Bvh,
    /// Indices of the scene's animated spheres, prepared per frame.
    animated: Vec<u32>,
}

impl StaticGeometry {
    /// Collects the spheres of `scene` that never move and builds their hierarchy (in
    /// parallel on the current rayon pool).
    pub fn new(scene: &Scene) -> StaticGeometry {
        let n = scene.spheres.len();
        let any_animated = scene.spheres.iter().any(|s| s.motion.is_animated());
        let (still, animated): (Vec<u32>, Vec<u32>) = if any_animated && n <= MERGE_LIMIT {
            // One hierarchy per frame over everything: rebuilding a few thousand boxes costs
            // well under a millisecond, and one traversal per ray is cheaper than two.
            (Vec::new(), (0..n as u32).collect())
        } else {
            (0..n as u32).partition(|&i| !scene.spheres[i as usize].motion.is_animated())
        };
        let boxes: Vec<Aabb> = still
            .par_iter()
            .map(|&i| {
                let s = &scene.spheres[i as usize];
                Aabb::point(s.motion.at(0.0))
                    .grow(s.radius)
                    .pad_for_rounding()
            })
            .collect();
        let bvh = Bvh::build(&boxes);
        drop(boxes);
        let prims = bvh
            .order()
            .par_iter()
            .map(|&k| {
                let id = still[k as usize];
                let s = &scene.spheres[id as usize];
                StillPrim {
                    center: s.motion.at(0.0),
                    radius: s.radius,
                    material: s.material,
                    id,
                }
            })
            .collect();
        StaticGeometry {
            prims,
            bvh,
            animated,
        }
    }

    /// Number of spheres.
    pub fn len(&self) -> usize {
        self.prims.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// Bytes held (spheres and hierarchy).
    pub fn memory_bytes(&self) -> usize {
        self.prims.capacity() * std::mem::size_of::<StillPrim>()
            + self.bvh.memory_bytes()
            + self.animated.capacity() * 4
    }

    #[inline]
    fn closest(&self, ray: &Ray, skip: u32, stack: &mut TraversalStack) -> Option<(f64, u32)> {
        self.bvh.closest_hit(
            ray.origin,
            ray.dir,
            0.0,
            f64::INFINITY,
            stack,
            |i, t_max| {
                let p = &self.prims[i as usize];
                if p.id == skip {
                    return None;
                }
                intersect(p.center, p.radius, ray, t_max)
            },
        )
    }
}

/// A ray's nearest intersection.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f64,
    pub surface: SurfacePoint,
    pub material: Material,
    /// Index of the sphere in the scene.
    pub sphere: u32,
}

/// Everything the tracer needs for one frame.
#[derive(Debug)]
pub struct World<'a> {
    statics: &'a StaticGeometry,
    /// The animated spheres, in the order of their hierarchy's leaves.
    animated: Vec<MovingPrim>,
    animated_bvh: Bvh,
    /// The curved paths of this frame (circles, several keyframe segments).
    motions: Vec<FrameMotion>,
    materials: &'a [Material],
    /// What rays that leave the scene see.
    pub background: Background,
    /// The shutter interval the world was prepared for.
    pub interval: Interval,
    /// Number of spheres that move during this frame's shutter.
    pub moving: usize,
}

impl<'a> World<'a> {
    /// Prepares every animated sphere of `scene` for the shutter `interval` (in parallel on
    /// the current rayon pool); the static ones come from `statics`, built once for the
    /// sequence.
    pub fn prepare(scene: &'a Scene, statics: &'a StaticGeometry, interval: Interval) -> World<'a> {
        let duration = interval.close - interval.open;
        // Per animated sphere: the prim (with a curved path's motion), and its boxes at the
        // shutter's opening and closing.
        let prepared: Vec<(MovingPrim, Option<FrameMotion>, Aabb, Aabb)> = statics
            .animated
            .par_iter()
            .map(|&id| {
                let s = &scene.spheres[id as usize];
                let motion = s.motion.prepare(interval);
                let mut prim = MovingPrim {
                    center: DVec3::ZERO,
                    velocity: DVec3::ZERO,
                    radius: s.radius,
                    material: s.material,
                    id,
                    general: LINEAR,
                };
                let (open, close, general) = match motion {
                    FrameMotion::Fixed(c) => {
                        prim.center = c;
                        let b = Aabb::point(c).grow(s.radius);
                        (b, b, None)
                    }
                    FrameMotion::Linear {
                        start, velocity, ..
                    } => {
                        prim.center = start;
                        prim.velocity = velocity;
                        // The end exactly as `center_at` computes it at the closing.
                        let end = start + velocity * duration;
                        (
                            Aabb::point(start).grow(s.radius),
                            Aabb::point(end).grow(s.radius),
                            None,
                        )
                    }
                    m => {
                        // A curved path: the box over the whole shutter at both ends.
                        let b = m.bounds(interval, s.radius);
                        (b, b, Some(m))
                    }
                };
                let (open, close) = pad_for_interpolation(open, close);
                (prim, general, open, close)
            })
            .collect();
        let open: Vec<Aabb> = prepared.iter().map(|p| p.2).collect();
        let close: Vec<Aabb> = prepared.iter().map(|p| p.3).collect();
        let animated_bvh = Bvh::build_moving(&open, &close);
        drop((open, close));
        let mut motions = Vec::new();
        let mut moving = 0;
        let mut animated = Vec::with_capacity(prepared.len());
        for &k in animated_bvh.order() {
            let (mut prim, general, _, _) = prepared[k as usize].clone();
            if let Some(m) = general {
                prim.general = motions.len() as u32;
                motions.push(m);
            }
            if prim.general != LINEAR || prim.velocity != DVec3::ZERO {
                moving += 1;
            }
            animated.push(prim);
        }
        World {
            statics,
            animated,
            animated_bvh,
            motions,
            materials: &scene.materials,
            background: scene.background,
            interval,
            moving,
        }
    }

    /// Whether anything moves during the frame's shutter.
    pub fn has_motion(&self) -> bool {
        self.moving > 0
    }

    /// Bytes held by this frame's animated spheres and their hierarchy.
    pub fn memory_bytes(&self) -> usize {
        self.animated.capacity() * std::mem::size_of::<MovingPrim>()
            + self.animated_bvh.memory_bytes()
            + self.motions.capacity() * std::mem::size_of::<FrameMotion>()
    }

    /// The nearest intersection of `ray` with any sphere except the one with index `skip`
    /// (pass `u32::MAX` to skip none). `stack` is scratch space, reused across calls.
    #[inline]
    pub fn hit(&self, ray: &Ray, skip: u32, stack: &mut TraversalStack) -> Option<Hit> {
        let still = self.statics.closest(ray, skip, stack);
        let t_max = still.map_or(f64::INFINITY, |b| b.0);
        let mut found = None;
        let dt = ray.time - self.interval.open;
        if !self.animated.is_empty() {
            // The ray's time as a fraction of the shutter, for the interpolated boxes.
            let duration = self.interval.close - self.interval.open;
            let s = if duration > 0.0 {
                (dt / duration).clamp(0.0, 1.0)
            } else {
                0.0
            };
            found =
                self.animated_bvh
                    .closest_hit(ray.origin, ray.dir, s, t_max, stack, |i, t_max| {
                        let p = &self.animated[i as usize];
                        if p.id == skip {
                            return None;
                        }
                        intersect(
                            p.center_at(&self.motions, dt, ray.time),
                            p.radius,
                            ray,
                            t_max,
                        )
                    });
        }
        let (t, center, radius, material, id) = if let Some((t, i)) = found {
            let p = &self.animated[i as usize];
            let c = p.center_at(&self.motions, dt, ray.time);
            (t, c, p.radius, p.material, p.id)
        } else {
            let (t, i) = still?;
            let p = &self.statics.prims[i as usize];
            (t, p.center, p.radius, p.material, p.id)
        };
        Some(Hit {
            t,
            surface: surface_point(center, radius, ray, t),
            material: self.materials[material as usize],
            sphere: id,
        })
    }
}

/// Grows the boxes a sphere has at the shutter's opening and closing so that their linear
/// interpolation at any time, as the traversal rounds it, still contains the sphere as
/// `center_at` rounds it: by 64 units in the last place of their largest coordinate, which is
/// several times the few roundings of either computation (`lo + s (hi - lo)`, `c + v dt`).
fn pad_for_interpolation(open: Aabb, close: Aabb) -> (Aabb, Aabb) {
    let m = open
        .min
        .abs()
        .max(open.max.abs())
        .max(close.min.abs())
        .max(close.max.abs())
        .max_element();
    let pad = m * 64.0 * f64::EPSILON;
    (open.grow(pad), close.grow(pad))
}
