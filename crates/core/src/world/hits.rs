//! A frame's searches: the nearest hit of one ray ([`World::hit`]), of a packet of camera
//! rays ([`World::hit_packet`]), and of a pixel's bounces walking the points in turns
//! ([`World::hit_in_turns`]). Each searches the still spheres, the animated ones and the
//! points in turn, each search bounded by the nearest hit before it, and makes the hit from
//! the nearest found ([`World::hit_of`]): the same hit whichever search finds it.

use glam::DVec3;

use super::World;
use crate::bvh::{BvhView, PACKET, PacketRay, TraversalStack};
use crate::hit::Hit;
use crate::ray::Ray;
use crate::sphere::{intersect, surface_point};
use crate::traced_points::PointHit;

impl World<'_> {
    /// The nearest intersection of `ray` with any sphere except the one with index `skip`
    /// (pass `u32::MAX` to skip none). `stack` is scratch space, reused across calls.
    #[inline]
    pub fn hit(&self, ray: &Ray, skip: u32, stack: &mut TraversalStack) -> Option<Hit> {
        let still = self.statics.closest(ray, skip, stack);
        let mut t_max = still.map_or(f64::INFINITY, |b| b.0);
        let mut found = None;
        let dt = ray.time - self.interval.open;
        let s = self.shutter_fraction(dt);
        if !self.animated.is_empty() {
            let bvh = BvhView::new(&self.animated_topology, &self.animated_boxes);
            found = bvh.closest_hit(
                ray.origin,
                ray.dir,
                s,
                t_max,
                stack,
                // Inlined into each of the traversal's kernels, as it was into the one before.
                #[inline(always)]
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
            t_max = found.map_or(t_max, |f| f.0);
        }
        let point = if self.points.is_empty() {
            None
        } else {
            self.points.closest(ray, dt, s, skip, t_max, stack)
        };
        self.hit_of(ray, dt, point, found, still)
    }

    /// Whether the paths of several pixels' samples are traced bounce by bounce together,
    /// their rays walking the points in turns ([`World::hit_in_turns`]): where the frame's
    /// points are larger than the cache, as their own room decides
    /// ([`TracedPoints::walk_in_turns`]; on a frame of ten million points the whole process
    /// took 0.82 of the time alone with one packet's paths together, and 0.79 of that with
    /// batches of several pixels'). Spheres walk alone: on `generate --spheres 1000000
    /// --moving 0.5` turns took 1.2 times the render's time.
    ///
    /// [`TracedPoints::walk_in_turns`]: crate::traced_points::TracedPoints::walk_in_turns
    pub(crate) fn takes_turns(&self) -> bool {
        self.points.walk_in_turns()
    }

    /// Makes this frame's paths take turns, or go alone, whatever its points' size: for
    /// tests that trace a frame both ways.
    #[cfg(test)]
    pub(crate) fn set_turns(&mut self, turns: bool) {
        self.points.set_walk_in_turns(turns);
    }

    /// [`World::hit`] of up to `N` rays (at most 256) at once that need not be coherent (the
    /// bounces of several pixels' samples), ray `r` skipping the sphere numbered `skip[r]`:
    /// the same hits. The spheres are searched ray by ray; the points, whose hierarchy is far
    /// larger than the cache, by walks in turns
    /// ([`closest_in_turns`](crate::traced_points::TracedPoints::closest_in_turns)).
    pub(crate) fn hit_in_turns<const N: usize>(
        &self,
        rays: &[Ray],
        skip: &[u32; N],
        stack: &mut TraversalStack,
    ) -> [Option<Hit>; N] {
        let mut still = [None; N];
        let mut found = [None; N];
        let mut t_max = [f64::INFINITY; N];
        let mut dt = [0.0; N];
        let mut lanes = [PacketRay {
            origin: DVec3::ZERO,
            dir: DVec3::ZERO,
            s: 0.0,
        }; N];
        for (r, ray) in rays.iter().enumerate() {
            still[r] = self.statics.closest(ray, skip[r], stack);
            t_max[r] = still[r].map_or(f64::INFINITY, |b: (f64, u32)| b.0);
            dt[r] = ray.time - self.interval.open;
            lanes[r] = PacketRay {
                origin: ray.origin,
                dir: ray.dir,
                s: self.shutter_fraction(dt[r]),
            };
            if !self.animated.is_empty() {
                let bvh = BvhView::new(&self.animated_topology, &self.animated_boxes);
                found[r] = bvh.closest_hit(
                    ray.origin,
                    ray.dir,
                    lanes[r].s,
                    t_max[r],
                    stack,
                    #[inline(always)]
                    |i, t_max| {
                        let p = &self.animated[i as usize];
                        if p.id == skip[r] {
                            return None;
                        }
                        intersect(
                            p.center_at(&self.motions, dt[r], ray.time),
                            p.radius,
                            ray,
                            t_max,
                        )
                    },
                );
                t_max[r] = found[r].map_or(t_max[r], |f: (f64, u32)| f.0);
            }
        }
        let points = if self.points.is_empty() {
            [None; N]
        } else {
            self.points
                .closest_in_turns(rays, &lanes[..rays.len()], &dt, skip, t_max, stack)
        };
        std::array::from_fn(|r| {
            let ray = rays.get(r)?;
            self.hit_of(ray, dt[r], points[r], found[r], still[r])
        })
    }

    /// The ray's time as a fraction of the shutter (`dt` seconds after its opening), for the
    /// interpolated boxes.
    #[inline]
    fn shutter_fraction(&self, dt: f64) -> f64 {
        let duration = self.interval.close - self.interval.open;
        if duration > 0.0 {
            (dt / duration).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The hit of `ray` (at `dt` seconds after the shutter opened), from the nearest point
    /// it hits (`point`), the nearest animated sphere (`found`, a position in their
    /// hierarchy) and the nearest still one (`still`): the point if any, as it was searched
    /// nearer than the spheres, else the animated sphere, searched nearer than the still one.
    #[inline(always)]
    fn hit_of(
        &self,
        ray: &Ray,
        dt: f64,
        point: Option<PointHit>,
        found: Option<(f64, u32)>,
        still: Option<(f64, u32)>,
    ) -> Option<Hit> {
        let (t, center, radius, material, id) = if let Some(h) = point {
            let (material, color) = self.point_look(h.id);
            let mut m = self.materials[material as usize];
            if let Some([r, g, b]) = color {
                m = m.tinted(DVec3::new(r.into(), g.into(), b.into()));
            }
            (h.t, h.center, h.radius, m, h.id)
        } else if let Some((t, i)) = found {
            let p = &self.animated[i as usize];
            let c = p.center_at(&self.motions, dt, ray.time);
            (t, c, p.radius, self.materials[p.material as usize], p.id)
        } else {
            let (t, i) = still?;
            let p = &self.statics.prims[i as usize];
            (
                t,
                p.center,
                p.radius,
                self.materials[p.material as usize],
                p.id,
            )
        };
        Some(Hit {
            t,
            surface: surface_point(center, radius, ray, t),
            material,
            sphere: id,
        })
    }

    /// [`World::hit`] for a packet of up to [`PACKET`] rays that skip no sphere (camera
    /// rays): the same hit for each, traced together ([`BvhView::closest_hits`]).
    pub(crate) fn hit_packet(
        &self,
        rays: &[Ray],
        stack: &mut TraversalStack,
    ) -> [Option<Hit>; PACKET] {
        let mut t_max = [f64::INFINITY; PACKET];
        let mut still = [None; PACKET];
        if !self.statics.is_empty() {
            for (r, ray) in rays.iter().enumerate() {
                still[r] = self.statics.closest(ray, u32::MAX, stack);
                t_max[r] = still[r].map_or(f64::INFINITY, |b: (f64, u32)| b.0);
            }
        }
        let mut found = [None; PACKET];
        let mut dt = [0.0; PACKET];
        let mut packet = [PacketRay {
            origin: DVec3::ZERO,
            dir: DVec3::ZERO,
            s: 0.0,
        }; PACKET];
        for (r, ray) in rays.iter().enumerate() {
            dt[r] = ray.time - self.interval.open;
            packet[r] = PacketRay {
                origin: ray.origin,
                dir: ray.dir,
                s: self.shutter_fraction(dt[r]),
            };
        }
        if !self.animated.is_empty() {
            let bvh = BvhView::new(&self.animated_topology, &self.animated_boxes);
            // One reference to the rays and their times: the traversal keeps the test small.
            let lanes = &(rays, dt);
            found = bvh.closest_hits(
                &packet[..rays.len()],
                t_max,
                stack,
                #[inline(always)]
                move |r: usize, i: u32, t_max: f64| {
                    let p = &self.animated[i as usize];
                    let ray = &lanes.0[r];
                    intersect(
                        p.center_at(&self.motions, lanes.1[r], ray.time),
                        p.radius,
                        ray,
                        t_max,
                    )
                },
            );
            for r in 0..rays.len() {
                t_max[r] = found[r].map_or(t_max[r], |f: (f64, u32)| f.0);
            }
        }
        let points = if self.points.is_empty() {
            [None; PACKET]
        } else {
            self.points
                .closest_packet(rays, &packet[..rays.len()], &dt, t_max, stack)
        };
        std::array::from_fn(|r| {
            let ray = rays.get(r)?;
            self.hit_of(ray, dt[r], points[r], found[r], still[r])
        })
    }
}
