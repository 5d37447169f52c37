//! The world of one frame: every sphere prepared for the frame's shutter interval, in one or
//! two hierarchies. Spheres that never move in the shot are built into a [`StaticGeometry`]
//! once per sequence; the others are prepared per frame ([`SphereDesc::prepare`]), with boxes
//! at that frame's shutter opening and closing, and built into a hierarchy per frame. A sphere
//! that does not move during a frame is traced as a fixed sphere.
//!
//! Where one hierarchy over everything is cheaper, every sphere is treated as animated: in
//! scenes of at most [`MERGE_LIMIT`] spheres it is built per frame; in larger scenes where at
//! least [`SHARED_FRACTION`] of the spheres are animated it is built once, on the shot's first
//! frame, and refitted to each frame's boxes, unless it has degraded too far
//! ([`REBUILD_AREA`]), when the frame gets a hierarchy of its own.
//!
//! [`SphereDesc::prepare`]: crate::sphere::SphereDesc::prepare

use std::sync::{Mutex, MutexGuard, TryLockError};

use glam::DVec3;
use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::bvh::{Bvh, TraversalStack};
use crate::material::{Background, Material};
use crate::motion::FrameMotion;
use crate::ray::Ray;
use crate::scene::Scene;
use crate::shutter::Interval;
use crate::sphere::{PreparedSphere, SurfacePoint, intersect, surface_point};

/// Marks a [`MovingPrim`] whose path is a line (or a point): no entry in [`World::motions`].
const LINEAR: u32 = u32::MAX;

/// Scenes with animated spheres and at most this many spheres in all are built into one
/// hierarchy per frame instead of a static one and a per-frame one.
const MERGE_LIMIT: usize = 16384;

/// Larger scenes in which at least this share of the spheres is animated get one hierarchy
/// over every sphere, built once for the shot and refitted per frame ([`Shared`]): one
/// traversal per ray instead of two, without a build per frame. With fewer animated spheres,
/// the static hierarchy plus a small per-frame one cost less to prepare.
const SHARED_FRACTION: f64 = 0.25;

/// A refitted hierarchy whose summed box areas ([`Bvh::area`]) grew past this factor of
/// those it was built with is replaced by a hierarchy built for the frame.
const REBUILD_AREA: f64 = 2.0;

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

/// What is built once per sequence: the spheres that never move during the shot, with their
/// hierarchy, and, for a large scene with many animated spheres, the hierarchy over every
/// sphere that each frame refits.
#[derive(Debug, Default)]
pub struct StaticGeometry {
    /// In the hierarchy's leaf order.
    prims: Vec<StillPrim>,
    bvh: Bvh,
    /// Indices of the scene's animated spheres, prepared per frame.
    animated: Vec<u32>,
    /// For a large scene with many animated spheres: one hierarchy over all of them (then
    /// `animated` holds every sphere and `prims` none), to be refitted per frame.
    shared: Option<Mutex<Shared>>,
}

/// The hierarchy of a frame's animated spheres: its own, or the shared one refitted to it (and
/// locked while the frame renders).
#[derive(Debug)]
enum FrameBvh<'a> {
    Own(Bvh),
    Shared(MutexGuard<'a, Shared>),
}

impl FrameBvh<'_> {
    #[inline]
    fn get(&self) -> &Bvh {
        match self {
            FrameBvh::Own(b) => b,
            FrameBvh::Shared(s) => &s.bvh,
        }
    }
}

/// A hierarchy over the animated spheres built once, on their boxes in the shot's first
/// frame, to be refitted to each frame's boxes.
#[derive(Clone, Debug)]
struct Shared {
    bvh: Bvh,
    /// Its [`Bvh::area`] as built.
    area: f64,
}

impl StaticGeometry {
    /// Collects the spheres of `scene` that never move and builds their hierarchy (in
    /// parallel on the current rayon pool).
    pub fn new(scene: &Scene) -> StaticGeometry {
        let n = scene.spheres.len();
        let animated_count = scene
            .spheres
            .iter()
            .filter(|s| s.motion.is_animated())
            .count();
        let one_hierarchy = animated_count > 0
            && (n <= MERGE_LIMIT || animated_count as f64 >= SHARED_FRACTION * n as f64);
        let (still, animated): (Vec<u32>, Vec<u32>) = if one_hierarchy {
            // One hierarchy over everything, one traversal per ray: rebuilt per frame for a
            // few thousand spheres (well under a millisecond), refitted for more.
            (Vec::new(), (0..n as u32).collect())
        } else {
            (0..n as u32).partition(|&i| !scene.spheres[i as usize].motion.is_animated())
        };
        let shared = (one_hierarchy && n > MERGE_LIMIT).then(|| {
            let first = scene.shot.interval(scene.shot.first_frame);
            let prepared = prepare_spheres(scene, &animated, first);
            let (open, close) = shutter_boxes(&prepared, first);
            let bvh = Bvh::build_moving(&open, &close);
            Mutex::new(Shared {
                area: bvh.area(),
                bvh,
            })
        });
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
            shared,
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
            + self.shared.as_ref().map_or(0, |s| {
                s.lock()
                    .unwrap_or_else(|poisoned| poisoned.into_inner())
                    .bvh
                    .memory_bytes()
            })
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
    animated_bvh: FrameBvh<'a>,
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
        let prepared = prepare_spheres(scene, &statics.animated, interval);
        let (open, close) = shutter_boxes(&prepared, interval);
        let own = || FrameBvh::Own(Bvh::build_moving(&open, &close));
        // Frames are prepared one at a time, and this one keeps the shared hierarchy locked
        // while it renders. Were another world holding it, this one builds its own (the same
        // hits, never a deadlock). A lock poisoned by a panic is refitted like any other.
        let shared = statics.shared.as_ref().and_then(|m| match m.try_lock() {
            Ok(guard) => Some(guard),
            Err(TryLockError::Poisoned(poisoned)) => Some(poisoned.into_inner()),
            Err(TryLockError::WouldBlock) => None,
        });
        let animated_bvh = match shared {
            Some(mut shared) => {
                // Refitted boxes that have moved far from those the tree was built on make a
                // slow tree: then build this frame's own.
                let built = shared.area;
                if shared.bvh.refit_moving(&open, &close) > REBUILD_AREA * built {
                    own()
                } else {
                    FrameBvh::Shared(shared)
                }
            }
            None => own(),
        };
        drop((open, close));
        let mut motions = Vec::new();
        let mut moving = 0;
        let mut animated = Vec::with_capacity(prepared.len());
        for &k in animated_bvh.get().order() {
            let id = statics.animated[k as usize];
            let s = &prepared[k as usize];
            let mut prim = MovingPrim {
                center: DVec3::ZERO,
                velocity: DVec3::ZERO,
                radius: s.radius,
                material: scene.spheres[id as usize].material,
                id,
                general: LINEAR,
            };
            match &s.motion {
                FrameMotion::Fixed(c) => prim.center = *c,
                FrameMotion::Linear {
                    start, velocity, ..
                } => {
                    prim.center = *start;
                    prim.velocity = *velocity;
                }
                curved => {
                    prim.general = motions.len() as u32;
                    motions.push(curved.clone());
                }
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
            + self.animated_bvh.get().memory_bytes()
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
            found = self.animated_bvh.get().closest_hit(
                ray.origin,
                ray.dir,
                s,
                t_max,
                stack,
                |i, t_max| {
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
                },
            );
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

/// The spheres `ids` of `scene` prepared for the shutter `interval` (in parallel on the
/// current rayon pool).
fn prepare_spheres(scene: &Scene, ids: &[u32], interval: Interval) -> Vec<PreparedSphere> {
    ids.par_iter()
        .map(|&id| scene.spheres[id as usize].prepare(interval))
        .collect()
}

/// The boxes of `prepared` at the shutter's opening and at its closing
/// ([`PreparedSphere::shutter_boxes`]). One pass each, rather than one array of pairs and two
/// copies: at a million spheres the difference is a few hundred megabytes at the peak.
fn shutter_boxes(prepared: &[PreparedSphere], interval: Interval) -> (Vec<Aabb>, Vec<Aabb>) {
    let boxes = |at_close: bool| -> Vec<Aabb> {
        prepared
            .par_iter()
            .map(|p| {
                let (open, close) = p.shutter_boxes(interval);
                if at_close { close } else { open }
            })
            .collect()
    };
    (boxes(false), boxes(true))
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::generate::{CUBE, GenerateOptions, scene_text};
    use crate::rng::Pcg32;

    /// The nearest sphere along `ray`, by testing every one.
    fn brute(scene: &Scene, ray: &Ray) -> Option<(f64, u32)> {
        let mut best: Option<(f64, u32)> = None;
        for (i, s) in scene.spheres.iter().enumerate() {
            let t_max = best.map_or(f64::INFINITY, |b| b.0);
            if let Some(t) = intersect(s.motion.at(ray.time), s.radius, ray, t_max) {
                best = Some((t, i as u32));
            }
        }
        best
    }

    #[test]
    fn every_layout_finds_the_nearest_sphere() {
        let mut r = Pcg32::new(8, 8);
        let mut stack = TraversalStack::default();
        // Per frame, one hierarchy built per frame; one built once and refitted; a static
        // hierarchy and a per-frame one.
        for (n, moving, shared) in [
            (2000, 0.5, false),
            (20_000, 0.5, true),
            (20_000, 0.1, false),
        ] {
            let text = scene_text(&GenerateOptions {
                spheres: n,
                moving,
                seed: 3,
                frames: 40,
            });
            let scene = Scene::parse(&text, Path::new("g.toml")).unwrap();
            let statics = StaticGeometry::new(&scene);
            assert_eq!(statics.shared.is_some(), shared, "{n} {moving}");
            // The first frame (the refitted hierarchy's own) and a later one.
            for frame in [scene.shot.first_frame, scene.shot.last_frame()] {
                let interval = scene.shot.interval(frame);
                let world = World::prepare(&scene, &statics, interval);
                let mut hits = 0;
                for _ in 0..400 {
                    let mut v = || DVec3::new(r.next_f64(), r.next_f64(), r.next_f64());
                    let origin = (v() - 0.5) * 1.2 * CUBE;
                    let dir = (v() - 0.5).normalize();
                    let ray = Ray {
                        origin,
                        dir,
                        time: interval.at(r.next_f64()),
                    };
                    let got = world
                        .hit(&ray, u32::MAX, &mut stack)
                        .map(|h| (h.t, h.sphere));
                    let want = brute(&scene, &ray);
                    // The same sphere at the same distance, up to the rounding of the two
                    // ways of placing a moving centre.
                    match (got, want) {
                        (Some((t, i)), Some((u, j))) => {
                            assert!(i == j && (t - u).abs() <= 1e-9 * u, "{got:?} {want:?}");
                            hits += 1;
                        }
                        _ => assert_eq!(got, want),
                    }
                }
                assert!(hits > 100, "{hits}");
            }
        }
    }

    #[test]
    fn two_worlds_of_one_shared_hierarchy_at_once() {
        // The first world holds the shared hierarchy; the second builds its own, and both
        // find the nearest sphere.
        let text = scene_text(&GenerateOptions {
            spheres: 20_000,
            moving: 0.5,
            seed: 4,
            frames: 10,
        });
        let scene = Scene::parse(&text, Path::new("g.toml")).unwrap();
        let statics = StaticGeometry::new(&scene);
        let (a, b) = (scene.shot.interval(1), scene.shot.interval(10));
        let first = World::prepare(&scene, &statics, a);
        let second = World::prepare(&scene, &statics, b);
        assert!(matches!(first.animated_bvh, FrameBvh::Shared(_)));
        assert!(matches!(second.animated_bvh, FrameBvh::Own(_)));
        let mut stack = TraversalStack::default();
        let mut r = Pcg32::new(2, 2);
        for (world, interval) in [(&first, a), (&second, b)] {
            for _ in 0..100 {
                let mut v = || DVec3::new(r.next_f64(), r.next_f64(), r.next_f64());
                let ray = Ray {
                    origin: (v() - 0.5) * CUBE,
                    dir: (v() - 0.5).normalize(),
                    time: interval.at(r.next_f64()),
                };
                let got = world.hit(&ray, u32::MAX, &mut stack).map(|h| h.sphere);
                assert_eq!(got, brute(&scene, &ray).map(|h| h.1));
            }
        }
    }
}
