//! The world of one frame: every sphere prepared for the frame's shutter interval, in one or
//! two hierarchies. Spheres that never move in the shot are built into a [`StaticGeometry`]
//! once per sequence; the others are prepared per frame ([`SphereDesc::prepare`]), with boxes
//! at that frame's shutter opening and closing. A sphere that does not move during a frame is
//! traced as a fixed sphere. A frame's interval is its whole exposure ([`Shot::interval`]):
//! under a rolling shutter, from the first row's opening to the last row's closing, so the
//! boxes hold every sphere at every row's times.
//!
//! Where one hierarchy over everything is cheaper, every sphere is treated as animated. In
//! scenes of at most [`MERGE_LIMIT`] spheres its hierarchy is built per frame. In larger
//! scenes where at least [`SHARED_FRACTION`] of the spheres are animated, its topology is
//! built once, on the shot's first frame, and kept in the [`StaticGeometry`], read-only: each
//! [`World`] refits it into boxes of its own, so worlds of any frames can exist at once. A
//! frame whose refitted boxes are too poor ([`REBUILD_AREA`]) gets a hierarchy of its own.
//!
//! The points of a scene's point caches ([`FramePoints`], read for each frame by the files
//! floor) are prepared for the frame's interval straight into the tracer's compact records,
//! with a hierarchy of their own ([`TracedPoints`]): no description and no object per point.
//! A ray is traced against the still spheres, the animated ones and the points in turn, each
//! search bounded by the nearest hit before it. A point's material is its set's, and its
//! colour attribute multiplies the material's albedo where the hit is made
//! ([`Material::tinted`]).
//!
//! [`SphereDesc::prepare`]: crate::sphere::SphereDesc::prepare
//! [`Shot::interval`]: crate::shutter::Shot::interval

use std::borrow::Cow;

use glam::DVec3;
use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::bvh::{Boxes, Bvh, BvhView, Topology, TraversalStack};
use crate::material::{Background, Material};
use crate::motion::{FrameMotion, Motion};
use crate::points::FramePoints;
use crate::ray::Ray;
use crate::scene::Scene;
use crate::shutter::Interval;
use crate::sphere::{PreparedSphere, SphereDesc, intersect};
use crate::traced_points::{TracedPoint, TracedPoints};

mod hits;

/// The points of a frame without any.
static NO_POINTS: FramePoints = FramePoints { sets: Vec::new() };

/// Marks a [`MovingPrim`] whose path is a line (or a point): no entry in [`World::motions`].
const LINEAR: u32 = u32::MAX;

/// Marks, while a world is made, a [`MovingPrim`] whose curved path is not yet in
/// [`World::motions`].
const CURVED: u32 = u32::MAX - 1;

/// Scenes with animated spheres and at most this many spheres in all are built into one
/// hierarchy per frame instead of a static one and a per-frame one.
pub const MERGE_LIMIT: usize = 16384;

/// Larger scenes in which at least this share of the spheres is animated get one hierarchy
/// over every sphere whose topology is built once for the shot and refitted per frame
/// ([`SharedTopology`]): one traversal per ray instead of two, without a build per frame.
/// With fewer animated spheres, the static hierarchy plus a small per-frame one cost less to
/// prepare.
const SHARED_FRACTION: f64 = 0.25;

/// A frame whose boxes refitted to the shared topology have summed areas ([`Boxes::area`])
/// above this factor of those the topology was built with builds a hierarchy of its own.
const REBUILD_AREA: f64 = 2.0;

/// Bytes per sphere of the tracer's copy of it, at most (as an animated sphere, with its
/// index in the scene's list of animated ones).
pub(crate) const PRIM_BYTES: usize = std::mem::size_of::<MovingPrim>() + 4;

/// The bytes the spheres of `scene` hold while a frame of it renders, at most: per sphere,
/// the scene's description of it, the shot's static geometry, one frame's prepared sphere
/// with its boxes at the shutter's opening and closing, a hierarchy build's working arrays
/// (a copy of each box with its centroid: the build takes the union, then the per-leaf boxes)
/// and the hierarchy; keyframed paths hold their keys in the description and again in each
/// frame's path. It errs high for scenes whose spheres are mostly still.
pub fn bytes_for(scene: &Scene) -> u64 {
    use std::mem::size_of;
    let per_sphere = size_of::<SphereDesc>()
        + size_of::<PreparedSphere>()
        + 2 * size_of::<Aabb>()
        + PRIM_BYTES
        + crate::bvh::BUILD_BYTES_PER_PRIMITIVE
        + crate::bvh::BYTES_PER_PRIMITIVE;
    let keys: usize = scene
        .spheres
        .iter()
        .map(|s| match &s.motion {
            Motion::Keyframes(k) => k.len(),
            _ => 0,
        })
        .sum();
    (scene.spheres.len() * per_sphere + keys * 2 * size_of::<crate::motion::Key>()) as u64
}

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

/// Whether `scene` is traced through one hierarchy over every sphere, each prepared per frame
/// as an animated one: it has animated spheres (or point caches, whose points are animated
/// spheres of every frame) and at most [`MERGE_LIMIT`] spheres in all, or at least
/// [`SHARED_FRACTION`] of them animated. The one rule for which spheres a frame prepares, for
/// the world and for what the GPU's buffers hold.
pub fn one_hierarchy(scene: &Scene) -> bool {
    let n = scene.spheres.len();
    let animated = scene
        .spheres
        .iter()
        .filter(|s| s.motion.is_animated())
        .count();
    // A scene's points have a hierarchy of their own, per frame.
    animated > 0 && (n <= MERGE_LIMIT || animated as f64 >= SHARED_FRACTION * n as f64)
}

/// A sphere as a frame's world traces it, for a device that copies the world (the GPU's
/// buffers): its centre at the frame's opening and its velocity (the centre at time `t` is
/// `center + velocity * (t - open)`), or its curved path prepared for the frame.
#[derive(Clone, Copy, Debug)]
pub struct TracedSphere<'w> {
    pub center: DVec3,
    pub velocity: DVec3,
    pub radius: f64,
    pub material: u32,
    /// Its index in the scene.
    pub id: u32,
    /// Its curved path (a circle, several keyframe segments), if it has one.
    pub path: Option<&'w FrameMotion>,
}

/// What is built once per sequence: the spheres that never move during the shot, with their
/// hierarchy, and, for a large scene with many animated spheres, the topology of a hierarchy
/// over every sphere that each frame refits. Read-only once built.
#[derive(Debug, Default)]
pub struct StaticGeometry {
    /// In the hierarchy's leaf order.
    prims: Vec<StillPrim>,
    bvh: Bvh,
    /// Indices of the scene's animated spheres, prepared per frame.
    animated: Vec<u32>,
    /// For a large scene with many animated spheres: the topology of one hierarchy over all
    /// of them (then `animated` holds every sphere and `prims` none), refitted per frame.
    shared: Option<SharedTopology>,
}

/// The topology of a hierarchy over the animated spheres, built on their boxes in the shot's
/// first frame.
#[derive(Clone, Debug)]
struct SharedTopology {
    topology: Topology,
    /// [`Boxes::area`] of the boxes it was built with.
    area: f64,
}

impl StaticGeometry {
    /// Collects the spheres of `scene` that never move and builds their hierarchy (in
    /// parallel on the current rayon pool).
    pub fn new(scene: &Scene) -> StaticGeometry {
        let n = scene.spheres.len();
        let merged = one_hierarchy(scene);
        let (still, animated): (Vec<u32>, Vec<u32>) = if merged {
            // One hierarchy over everything, one traversal per ray: rebuilt per frame for a
            // few thousand spheres (well under a millisecond), refitted for more.
            (Vec::new(), (0..n as u32).collect())
        } else {
            (0..n as u32).partition(|&i| !scene.spheres[i as usize].motion.is_animated())
        };
        let shared = (merged && n > MERGE_LIMIT).then(|| {
            let first = scene.shot.interval(scene.shot.first_frame);
            let prepared = prepare_spheres(scene, &animated, first);
            let (topology, boxes) = build_animated(&prepared, first);
            SharedTopology {
                topology,
                area: boxes.area(),
            }
        });
        let boxes: Vec<Aabb> = still
            .par_iter()
            .map(|&i| scene.spheres[i as usize].still_box())
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

    /// The spheres that never move, in their hierarchy's leaf order (its leaves' ranges index
    /// this order), and that hierarchy.
    pub fn still_spheres(
        &self,
    ) -> (
        impl ExactSizeIterator<Item = TracedSphere<'_>> + '_,
        BvhView<'_>,
    ) {
        let spheres = self.prims.iter().map(|p| TracedSphere {
            center: p.center,
            velocity: DVec3::ZERO,
            radius: p.radius,
            material: p.material,
            id: p.id,
            path: None,
        });
        (spheres, self.bvh.view())
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    #[inline]
    fn closest(&self, ray: &Ray, skip: u32, stack: &mut TraversalStack) -> Option<(f64, u32)> {
        self.bvh.closest_hit(
            ray.origin,
            ray.dir,
            0.0,
            f64::INFINITY,
            stack,
            #[inline(always)]
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

/// Everything the tracer needs for one frame. It owns everything that depends on the frame
/// and only reads the [`StaticGeometry`].
#[derive(Debug)]
pub struct World<'a> {
    statics: &'a StaticGeometry,
    /// The animated spheres, in the order of their hierarchy's leaves.
    animated: Vec<MovingPrim>,
    /// The topology of their hierarchy: the shared one, or one built for this frame.
    animated_topology: Cow<'a, Topology>,
    /// The boxes of that topology for this frame.
    animated_boxes: Boxes,
    /// The curved paths of this frame (circles, several keyframe segments).
    motions: Vec<FrameMotion>,
    /// The frame's points as the tracer reads them, with their hierarchy.
    points: TracedPoints,
    /// The frame's points as read: their sets' materials and colours.
    frame_points: &'a FramePoints,
    /// The number of the first point as a sphere of the frame (after the scene's spheres).
    first_point: u32,
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
    /// sequence. The result depends only on its arguments, never on other worlds. A scene
    /// with point caches is prepared with its frame's points by [`World::prepare_with`].
    pub fn prepare(scene: &'a Scene, statics: &'a StaticGeometry, interval: Interval) -> World<'a> {
        World::prepare_with(scene, statics, &NO_POINTS, interval)
    }

    /// [`World::prepare`], with `points` (the frame's points of the scene's caches). Point
    /// `k` (numbered over every set) is sphere `spheres.len() + k` in hits and in what the
    /// tracer skips.
    pub(crate) fn prepare_with(
        scene: &'a Scene,
        statics: &'a StaticGeometry,
        points: &'a FramePoints,
        interval: Interval,
    ) -> World<'a> {
        let prepared = prepare_spheres(scene, &statics.animated, interval);
        let first_point = scene.spheres.len() as u32;
        let (animated_topology, animated_boxes) = animated_hierarchy(statics, &prepared, interval);
        let (animated, motions) =
            tracer_copies(scene, statics, &prepared, animated_topology.order());
        drop(prepared);
        let points_traced = TracedPoints::prepare(points, first_point, interval);
        let moving = animated
            .par_iter()
            .filter(|p| p.general != LINEAR || p.velocity != DVec3::ZERO)
            .count()
            + points_traced.moving;
        World {
            statics,
            animated,
            animated_topology,
            animated_boxes,
            motions,
            points: points_traced,
            frame_points: points,
            first_point,
            materials: &scene.materials,
            background: scene.background,
            interval,
            moving,
        }
    }

    /// Whether anything moves during the frame's shutter.
    pub(crate) fn has_motion(&self) -> bool {
        self.moving > 0
    }

    /// What the shot's spheres that never move are held in.
    pub fn statics(&self) -> &StaticGeometry {
        self.statics
    }

    /// The frame's animated spheres, prepared for its interval, in their hierarchy's leaf
    /// order (its leaves' ranges index this order), and that hierarchy.
    pub fn animated_spheres(
        &self,
    ) -> (
        impl ExactSizeIterator<Item = TracedSphere<'_>> + '_,
        BvhView<'_>,
    ) {
        let spheres = self.animated.iter().map(|p| TracedSphere {
            center: p.center,
            velocity: p.velocity,
            radius: p.radius,
            material: p.material,
            id: p.id,
            path: (p.general != LINEAR).then(|| &self.motions[p.general as usize]),
        });
        (
            spheres,
            BvhView::new(&self.animated_topology, &self.animated_boxes),
        )
    }

    /// The frame's points, prepared for its interval: each group's (the sets that share a
    /// time) in its hierarchy's leaf order, and that hierarchy.
    pub fn point_groups(
        &self,
    ) -> impl Iterator<Item = (impl ExactSizeIterator<Item = TracedPoint> + '_, BvhView<'_>)> + '_
    {
        self.points.groups()
    }

    /// The look of the point numbered `id` (a sphere number of the frame's points): its
    /// set's material, and its colour, which multiplies the material's albedo
    /// ([`Material::tinted`]), where its set has colours.
    #[inline]
    pub fn point_look(&self, id: u32) -> (u32, Option<[f32; 3]>) {
        let (set, i) = self
            .frame_points
            .locate((id - self.first_point) as usize)
            .expect("a point of the frame");
        (set.material, set.colors.get(i).copied())
    }
}

/// The spheres `ids` of `scene` prepared for the shutter `interval` (in parallel on the
/// current rayon pool).
/// The hierarchy of the frame's animated spheres (`prepared`, in `statics.animated`'s order)
/// and its boxes: the shot's shared topology refitted, or the frame's own.
fn animated_hierarchy<'a>(
    statics: &'a StaticGeometry,
    prepared: &[PreparedSphere],
    interval: Interval,
) -> (Cow<'a, Topology>, Boxes) {
    let own = || {
        let (topology, boxes) = build_animated(prepared, interval);
        (Cow::Owned(topology), boxes)
    };
    let Some(shared) = &statics.shared else {
        return own();
    };
    let boxes = shared.topology.refit_moving_with(&|pos| {
        prepared[shared.topology.order()[pos as usize] as usize].shutter_boxes(interval)
    });
    // Refitted boxes that have moved far from those the topology was built on overlap a lot
    // and make a slow traversal: then the frame builds its own hierarchy. Both give the same
    // nearest hits; the choice depends only on this frame's boxes and the shot's first frame,
    // so a frame is traced the same way whichever frames were prepared before or alongside it.
    if boxes.area() > REBUILD_AREA * shared.area {
        own()
    } else {
        (Cow::Borrowed(&shared.topology), boxes)
    }
}

/// The tracer's copies of the animated spheres in the hierarchy's leaf `order` (in parallel),
/// and the curved paths they index (in order, each curved path its index in the list).
fn tracer_copies(
    scene: &Scene,
    statics: &StaticGeometry,
    prepared: &[PreparedSphere],
    order: &[u32],
) -> (Vec<MovingPrim>, Vec<FrameMotion>) {
    let mut animated: Vec<MovingPrim> = order
        .par_iter()
        .map(|&k| {
            let k = k as usize;
            let id = statics.animated[k];
            let s = &prepared[k];
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
                _ => prim.general = CURVED,
            }
            prim
        })
        .collect();
    let mut motions = Vec::new();
    for (prim, &k) in animated.iter_mut().zip(order) {
        if prim.general == CURVED {
            prim.general = motions.len() as u32;
            motions.push(prepared[k as usize].motion.clone());
        }
    }
    (animated, motions)
}

fn prepare_spheres(scene: &Scene, ids: &[u32], interval: Interval) -> Vec<PreparedSphere> {
    ids.par_iter()
        .map(|&id| scene.spheres[id as usize].prepare(interval))
        .collect()
}

/// The topology and boxes of a hierarchy over the animated spheres `prepared` (for the
/// shutter `interval`), built on their boxes at its opening and closing
/// ([`PreparedSphere::shutter_boxes`]), computed as the build and the refit read them: no
/// arrays of boxes.
fn build_animated(prepared: &[PreparedSphere], interval: Interval) -> (Topology, Boxes) {
    let topology = Topology::build(prepared.len(), &|i| prepared[i].shutter_boxes(interval));
    let boxes = topology.refit_moving_with(&|pos| {
        prepared[topology.order()[pos as usize] as usize].shutter_boxes(interval)
    });
    (topology, boxes)
}

/// The nearest sphere along `ray` at its time and its distance, found by testing every sphere
/// of `scene` where its motion puts it: no hierarchy, no boxes. The reference the hierarchies
/// are tested against (here and in tests/integration/shutter.rs).
pub fn nearest_by_testing_every_sphere(scene: &Scene, ray: &Ray) -> Option<(f64, u32)> {
    let mut best: Option<(f64, u32)> = None;
    for (i, s) in scene.spheres.iter().enumerate() {
        let t_max = best.map_or(f64::INFINITY, |b| b.0);
        if let Some(t) = intersect(s.motion.at(ray.time), s.radius, ray, t_max) {
            best = Some((t, i as u32));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use crate::testing::{CUBE, random};

    /// A generated scene of `n` spheres, a share `moving` of them animated.
    fn generated(n: u64, moving: f64, seed: u64, frames: u32) -> Scene {
        random(n, moving, seed, frames)
    }

    /// A ray from in or around the generated cube, in a random direction, at a random time of
    /// `interval`.
    fn random_ray(r: &mut Pcg32, interval: Interval) -> Ray {
        let mut v = || DVec3::new(r.next_f64(), r.next_f64(), r.next_f64());
        let origin = (v() - 0.5) * 1.2 * CUBE;
        let dir = (v() - 0.5).normalize();
        Ray {
            origin,
            dir,
            time: interval.at(r.next_f64()),
        }
    }

    /// Whether `world` finds the sphere testing every one finds, at the same distance up to
    /// the rounding of the two ways of placing a moving centre (relative 1e-9). Returns
    /// `None` if it does not, else whether there is a hit.
    fn agrees(world: &World, scene: &Scene, ray: &Ray, stack: &mut TraversalStack) -> Option<bool> {
        let got = world.hit(ray, u32::MAX, stack).map(|h| (h.t, h.sphere));
        match (got, nearest_by_testing_every_sphere(scene, ray)) {
            (Some((t, i)), Some((u, j))) => (i == j && (t - u).abs() <= 1e-9 * u).then_some(true),
            (None, None) => Some(false),
            _ => None,
        }
    }

    /// Asserts that `world` agrees with brute force on 400 random rays, most of which hit.
    fn assert_agrees(world: &World, scene: &Scene, r: &mut Pcg32) {
        let mut stack = TraversalStack::default();
        let mut hits = 0;
        for _ in 0..400 {
            let ray = random_ray(r, world.interval);
            match agrees(world, scene, &ray, &mut stack) {
                Some(hit) => hits += hit as u32,
                None => panic!("{ray:?}: {:?}", world.hit(&ray, u32::MAX, &mut stack)),
            }
        }
        assert!(hits > 100, "{hits}");
    }

    impl World<'_> {
        /// Whether the world's hierarchy is the shared topology refitted.
        fn shares_topology(&self) -> bool {
            matches!(self.animated_topology, Cow::Borrowed(_))
        }
    }

    #[test]
    fn every_layout_finds_the_nearest_sphere() {
        let mut r = Pcg32::new(8, 8);
        // Per frame, one hierarchy built per frame; one topology built once and refitted; a
        // static hierarchy and a per-frame one.
        for (n, moving, shared) in [
            (2000, 0.5, false),
            (20_000, 0.5, true),
            (20_000, 0.1, false),
        ] {
            let scene = generated(n, moving, 3, 40);
            let statics = StaticGeometry::new(&scene);
            assert_eq!(statics.shared.is_some(), shared, "{n} {moving}");
            // The first frame (whose boxes the topology was built on), a later one refitted,
            // and the last, whose refitted boxes are too poor: it builds its own hierarchy.
            let (first, last) = (scene.shot.first_frame, scene.shot.last_frame());
            for (frame, refitted) in [(first, shared), (first + 2, shared), (last, false)] {
                let world = World::prepare(&scene, &statics, scene.shot.interval(frame));
                assert_eq!(world.shares_topology(), refitted, "{n} {moving} {frame}");
                assert_agrees(&world, &scene, &mut r);
            }
        }
    }

    /// A world of a later frame with the boxes of the first (its refit skipped) misses
    /// spheres that have moved: the brute-force comparisons above would catch it.
    #[test]
    fn a_skipped_refit_is_caught() {
        let scene = generated(20_000, 0.5, 4, 10);
        let statics = StaticGeometry::new(&scene);
        let first = World::prepare(&scene, &statics, scene.shot.interval(1));
        let later = World::prepare(&scene, &statics, scene.shot.interval(3));
        assert!(first.shares_topology() && later.shares_topology());
        assert_ne!(first.animated_boxes, later.animated_boxes);
        let stale = World {
            animated_boxes: first.animated_boxes.clone(),
            ..later
        };
        let mut r = Pcg32::new(6, 6);
        let mut stack = TraversalStack::default();
        let wrong = (0..400)
            .filter(|_| {
                let ray = random_ray(&mut r, stale.interval);
                agrees(&stale, &scene, &ray, &mut stack).is_none()
            })
            .count();
        assert!(wrong > 0);
    }

    #[test]
    fn worlds_of_several_frames_at_once() {
        // Two frames refitting the shared topology into their own boxes and one building its
        // own hierarchy, all alive together: each finds the nearest sphere of its frame.
        let scene = generated(20_000, 0.5, 4, 10);
        let statics = StaticGeometry::new(&scene);
        let worlds: Vec<World> = [2, 4, 10]
            .iter()
            .map(|&f| World::prepare(&scene, &statics, scene.shot.interval(f)))
            .collect();
        let shares: Vec<bool> = worlds.iter().map(World::shares_topology).collect();
        assert_eq!(shares, [true, true, false]);
        assert_ne!(worlds[0].animated_boxes, worlds[1].animated_boxes);
        let mut r = Pcg32::new(2, 2);
        for world in &worlds {
            assert_agrees(world, &scene, &mut r);
        }
    }

    #[test]
    fn a_frame_is_the_same_alone_or_after_others() {
        let scene = generated(20_000, 0.5, 5, 10);
        let interval = scene.shot.interval(3);
        let alone_statics = StaticGeometry::new(&scene);
        let alone = World::prepare(&scene, &alone_statics, interval);
        let statics = StaticGeometry::new(&scene);
        let before = World::prepare(&scene, &statics, scene.shot.interval(1));
        drop(before);
        let _alive = World::prepare(&scene, &statics, scene.shot.interval(2));
        let after = World::prepare(&scene, &statics, interval);
        assert!(alone.shares_topology() && after.shares_topology());
        assert_eq!(alone.animated_boxes, after.animated_boxes);
        let mut r = Pcg32::new(3, 1);
        let mut stack = TraversalStack::default();
        for _ in 0..400 {
            let ray = random_ray(&mut r, interval);
            let hit = |w: &World, stack: &mut TraversalStack| {
                w.hit(&ray, u32::MAX, stack).map(|h| {
                    (
                        h.t.to_bits(),
                        h.sphere,
                        h.surface.p.to_array().map(f64::to_bits),
                    )
                })
            };
            assert_eq!(hit(&alone, &mut stack), hit(&after, &mut stack));
        }
    }
}
