//! The world of one frame: every sphere prepared for the frame's shutter interval, in two
//! hierarchies. Spheres that never move in the shot are built into a [`StaticGeometry`] once
//! per sequence; the others are prepared and built per frame, with boxes over that frame's
//! shutter only. A sphere that does not move during a frame is traced as a static sphere.

use glam::DVec3;

use crate::aabb::Aabb;
use crate::bvh::{Bvh, TraversalStack};
use crate::material::{Background, Material};
use crate::motion::FrameMotion;
use crate::ray::Ray;
use crate::scene::Scene;
use crate::shutter::Interval;
use crate::sphere::{SurfacePoint, intersect, surface_point};

/// Marks a [`Prim`] that is fixed during the frame.
const FIXED: u32 = u32::MAX;

/// A sphere as the tracer sees it.
#[derive(Clone, Copy, Debug)]
struct Prim {
    /// The centre, for a sphere fixed during the frame.
    center: DVec3,
    radius: f64,
    material: u32,
    /// Index of the sphere in the scene.
    id: u32,
    /// Index into [`World::motions`], or [`FIXED`].
    motion: u32,
}

impl Prim {
    #[inline]
    fn center_at(&self, motions: &[FrameMotion], t: f64) -> DVec3 {
        if self.motion == FIXED {
            self.center
        } else {
            motions[self.motion as usize].at(t)
        }
    }
}

/// One set of primitives and its hierarchy.
#[derive(Clone, Debug, Default)]
struct Group {
    prims: Vec<Prim>,
    bvh: Bvh,
}

impl Group {
    fn new(prims: Vec<Prim>, boxes: &[Aabb]) -> Group {
        Group {
            bvh: Bvh::build(boxes),
            prims,
        }
    }

    #[inline]
    fn closest(
        &self,
        motions: &[FrameMotion],
        ray: &Ray,
        skip: u32,
        t_max: f64,
        stack: &mut TraversalStack,
    ) -> Option<(f64, Prim)> {
        self.bvh
            .closest_hit(ray.origin, ray.dir, t_max, stack, |i, t_max| {
                let p = &self.prims[i as usize];
                if p.id == skip {
                    return None;
                }
                intersect(p.center_at(motions, ray.time), p.radius, ray, t_max)
            })
            .map(|(t, i)| (t, self.prims[i as usize]))
    }
}

/// The spheres that never move during the shot, with their hierarchy: built once per sequence.
#[derive(Clone, Debug, Default)]
pub struct StaticGeometry {
    group: Group,
}

impl StaticGeometry {
    /// Collects and builds the spheres of `scene` that never move.
    pub fn new(scene: &Scene) -> StaticGeometry {
        let mut prims = Vec::new();
        let mut boxes = Vec::new();
        for (id, s) in scene.spheres.iter().enumerate() {
            if !s.motion.is_animated() {
                let center = s.motion.at(0.0);
                prims.push(Prim {
                    center,
                    radius: s.radius,
                    material: s.material,
                    id: id as u32,
                    motion: FIXED,
                });
                boxes.push(Aabb::point(center).grow(s.radius).pad_for_rounding());
            }
        }
        StaticGeometry {
            group: Group::new(prims, &boxes),
        }
    }

    /// Number of spheres.
    pub fn len(&self) -> usize {
        self.group.prims.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.group.prims.is_empty()
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
    animated: Group,
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
    /// Prepares every animated sphere of `scene` for the shutter `interval`; the static ones
    /// come from `statics`, built once for the sequence.
    pub fn prepare(scene: &'a Scene, statics: &'a StaticGeometry, interval: Interval) -> World<'a> {
        let mut prims = Vec::new();
        let mut boxes = Vec::new();
        let mut motions = Vec::new();
        for (id, s) in scene.spheres.iter().enumerate() {
            if !s.motion.is_animated() {
                continue;
            }
            let prepared = s.prepare(interval);
            let (center, motion) = match prepared.motion {
                FrameMotion::Fixed(c) => (c, FIXED),
                m => {
                    motions.push(m);
                    (DVec3::ZERO, (motions.len() - 1) as u32)
                }
            };
            prims.push(Prim {
                center,
                radius: s.radius,
                material: s.material,
                id: id as u32,
                motion,
            });
            boxes.push(prepared.bounds);
        }
        World {
            statics,
            moving: motions.len(),
            animated: Group::new(prims, &boxes),
            motions,
            materials: &scene.materials,
            background: scene.background,
            interval,
        }
    }

    /// Whether anything moves during the frame's shutter.
    pub fn has_motion(&self) -> bool {
        self.moving > 0
    }

    /// The nearest intersection of `ray` with any sphere except the one with index `skip`
    /// (pass `u32::MAX` to skip none). `stack` is scratch space, reused across calls.
    #[inline]
    pub fn hit(&self, ray: &Ray, skip: u32, stack: &mut TraversalStack) -> Option<Hit> {
        let mut best = self
            .statics
            .group
            .closest(&self.motions, ray, skip, f64::INFINITY, stack);
        let t_max = best.map_or(f64::INFINITY, |b| b.0);
        if let Some(h) = self
            .animated
            .closest(&self.motions, ray, skip, t_max, stack)
        {
            best = Some(h);
        }
        best.map(|(t, p)| {
            let center = p.center_at(&self.motions, ray.time);
            Hit {
                t,
                surface: surface_point(center, p.radius, ray, t),
                material: self.materials[p.material as usize],
                sphere: p.id,
            }
        })
    }
}
