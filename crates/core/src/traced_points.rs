//! One frame's points as the tracer reads them: a compact record per point (its `f32`
//! position at its set's time, velocity and radius, and its number: 32 bytes), made straight
//! from the columns of [`FramePoints`] and reordered in place into the leaf order of their
//! own hierarchy ([`Topology::build_in_place`]). No object per point, no copy of the records
//! and no array of boxes: the build reads each record's box as it goes, and the hierarchy's
//! boxes are refitted from the records, in leaf order.
//!
//! A record at `dt` seconds after the shutter's opening is the sphere centred at
//! `(P + v lead) + v dt` (`lead`: from its set's time to the opening), computed in `f64`
//! from the `f32` values: exactly the centre [`PointSet::prepare`] gives it, and a
//! `[[sphere]]` with the same centre and velocity gets. Sets are grouped by their time, one
//! hierarchy a group (a frame's sets usually share one time, so one hierarchy in all).
//!
//! [`PointSet::prepare`]: crate::points::PointSet::prepare

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::bvh::{
    Boxes, BuildBox, BvhView, Leaves, PACKET, PacketLeaves, PacketRay, Topology, TraversalStack,
};
use crate::points::FramePoints;
use crate::ray::Ray;
use crate::shutter::Interval;
use crate::sphere::{intersect, pad_for_interpolation};

/// A point as the tracer reads it. Thirty-two bytes, aligned, so a record never straddles a
/// cache line.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(align(32))]
struct Record {
    /// Its position at its set's time.
    p: Vec3,
    radius: f32,
    /// Its velocity; zero for a point that does not move.
    v: Vec3,
    /// Its number as a sphere of the frame (the scene's spheres first).
    id: u32,
}

/// The cost of visiting a node relative to testing one point, for the points' hierarchy: 4,
/// so leaves hold up to four points. Measured on a frame of 1e7 points (docs/performance.md):
/// against 0.5 (spheres' choice, one point a leaf almost everywhere), a third of the nodes
/// (0.7 GB less at the peak), a build a quarter faster, and the same render time: a ray
/// tests more points, which lie together, and fewer nodes, which do not.
const NODE_COST: f64 = 4.0;

/// Bytes per point of the tracer's records.
pub(crate) const RECORD_BYTES: usize = std::mem::size_of::<Record>();

/// Nodes of the points' hierarchy per point, about: 0.075 measured on the fountain's frame
/// of 1.009e7 moving points (755,309 nodes; leaves of up to four points, up to eight children
/// a node, 5.5 on average), taken as 0.08. A closer or looser cloud of points changes it a
/// little.
const NODES_PER_POINT: f64 = 0.08;

/// Bytes per point a frame's [`TracedPoints`] hold at their peak, about: the record, and its
/// share of the hierarchy's compact nodes (their links and boxes). The build itself
/// holds nothing per point but the links it pushes (reordering the records in place).
pub const BYTES_PER_POINT: u64 =
    (RECORD_BYTES as f64 + NODES_PER_POINT * crate::bvh::COMPACT_NODE_BYTES as f64) as u64;

/// The points of the sets that share one time, with their hierarchy.
#[derive(Debug)]
struct Group {
    /// From the sets' time to the shutter's opening, seconds.
    lead: f64,
    /// In the hierarchy's leaf order.
    records: Vec<Record>,
    topology: Topology,
    boxes: Boxes,
}

impl Group {
    /// The group of `records` (points whose sets share a time `lead` seconds before the
    /// shutter opens) with its hierarchy for `interval`, and how many of them move during it.
    fn build(mut records: Vec<Record>, lead: f64, interval: Interval) -> (Group, usize) {
        let duration = interval.close - interval.open;
        let moving = if interval.is_instant() {
            0
        } else {
            records.par_iter().filter(|q| q.v != Vec3::ZERO).count()
        };
        // The build's boxes, in `f32` (they only steer its splits).
        let (lead32, duration32) = (lead as f32, duration as f32);
        let bounds = |q: &Record| {
            let start = q.p + q.v * lead32;
            BuildBox {
                lo: start - q.radius,
                hi: start + q.radius,
                shift: q.v * duration32,
            }
        };
        let topology = Topology::build_in_place(&mut records, bounds, NODE_COST);
        let mut group = Group {
            lead,
            records,
            topology,
            boxes: Boxes::default(),
        };
        group.boxes = if moving == 0 {
            group.topology.refit_still_with(&|pos| {
                let q = &group.records[pos as usize];
                Aabb::point(group.center(q, 0.0))
                    .grow(q.radius.into())
                    .pad_for_rounding()
            })
        } else {
            // As `PreparedPoint::shutter_boxes`: the sphere at the opening and at the
            // closing, padded for the interpolation's rounding.
            group.topology.refit_compact_with(&|pos| {
                let q = &group.records[pos as usize];
                let r = f64::from(q.radius);
                let start = group.center(q, 0.0);
                let open = Aabb::point(start).grow(r);
                let close = Aabb::point(start + q.v.as_dvec3() * duration).grow(r);
                pad_for_interpolation(open, close)
            })
        };
        (group, moving)
    }

    /// The centre of `q` at `dt` seconds after the shutter opened.
    #[inline(always)]
    fn center(&self, q: &Record, dt: f64) -> DVec3 {
        let v = q.v.as_dvec3();
        (q.p.as_dvec3() + v * self.lead) + v * dt
    }

    fn view(&self) -> BvhView<'_> {
        BvhView::new(&self.topology, &self.boxes)
    }
}

/// What a ray hits of the points: the distance, the sphere's centre at the ray's time, its
/// radius and its number.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PointHit {
    pub t: f64,
    pub center: DVec3,
    pub radius: f64,
    pub id: u32,
}

/// A point as a device that copies the frame's points reads it (the GPU's buffers): its
/// centre at the shutter's opening, `(P + v lead)` computed in `f64` as the tracer computes
/// it, its velocity (the centre at `dt` seconds after the opening is `center + velocity dt`),
/// its radius and its number as a sphere of the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracedPoint {
    pub center: DVec3,
    pub velocity: DVec3,
    pub radius: f64,
    pub id: u32,
}

/// The bytes of a frame's points (their records and their hierarchies' nodes) above which
/// rays walk them in turns ([`TracedPoints::walk_in_turns`]): 16 MiB. Measured on the
/// fountain `raytrace generate` writes, at 16 samples on 2 threads (docs/performance.md): with
/// each path walking alone the render took 0.87 of the time in turns at 1e5 points (5 MB),
/// 0.965 at 3e5 (15 MB) and 1.15 to 1.30 at 1e6 (49 MB), on a processor with a 32 MiB
/// last-level cache: the turns hide the misses of points far larger than the cache, and
/// where the points fit in it they only cost. The same bytes either way.
const TURNS_FROM_BYTES: usize = 16 << 20;

/// One frame's points, prepared for its interval, with their hierarchies.
#[derive(Debug, Default)]
pub(crate) struct TracedPoints {
    groups: Vec<Group>,
    /// Points that move during the interval.
    pub moving: usize,
    /// Whether rays walk them in turns ([`TURNS_FROM_BYTES`]).
    turns: bool,
}

impl TracedPoints {
    /// The points of `points` prepared for `interval` (in parallel on the current rayon
    /// pool), point `k` (numbered over every set) numbered `first_id + k`. The same records
    /// and hierarchies on any number of threads.
    pub(crate) fn prepare(points: &FramePoints, first_id: u32, interval: Interval) -> TracedPoints {
        // The sets' first numbers, and their distinct times in the order met.
        let mut firsts = Vec::with_capacity(points.sets.len());
        let mut times: Vec<f64> = Vec::new();
        let mut n = 0;
        for s in &points.sets {
            firsts.push(first_id + n);
            n += s.len() as u32;
            if !times.iter().any(|t| t.to_bits() == s.time.to_bits()) {
                times.push(s.time);
            }
        }
        let mut out = TracedPoints::default();
        for time in times {
            let lead = interval.open - time;
            let members: Vec<usize> = (0..points.sets.len())
                .filter(|&k| points.sets[k].time.to_bits() == time.to_bits())
                .collect();
            let count: usize = members.iter().map(|&k| points.sets[k].len()).sum();
            let mut records = Vec::with_capacity(count);
            for &k in &members {
                let s = &points.sets[k];
                let first = firsts[k];
                records.par_extend((0..s.len()).into_par_iter().map(|i| Record {
                    p: s.centers[i],
                    radius: s.radii.get(i).copied().unwrap_or(s.radius),
                    v: s.velocities.get(i).copied().unwrap_or(Vec3::ZERO),
                    id: first + i as u32,
                }));
            }
            if records.is_empty() {
                continue;
            }
            let (group, moving) = Group::build(records, lead, interval);
            out.moving += moving;
            out.groups.push(group);
        }
        let bytes: usize = out
            .groups
            .iter()
            .map(|g| {
                g.records.len() * RECORD_BYTES
                    + g.topology.node_count() * crate::bvh::COMPACT_NODE_BYTES
            })
            .sum();
        out.turns = bytes > TURNS_FROM_BYTES;
        out
    }

    /// Whether rays walk these points in turns (`BvhView::closest_hits_in_turns`), the
    /// paths of several pixels' samples traced bounce by bounce together: where the points'
    /// records and hierarchies are larger than [`TURNS_FROM_BYTES`]; where they are fewer,
    /// each path goes alone. The same hits either way.
    pub(crate) fn walk_in_turns(&self) -> bool {
        self.turns
    }

    /// Makes rays walk these points in turns, or alone, whatever their size: for tests that
    /// trace both ways.
    #[cfg(test)]
    pub(crate) fn set_walk_in_turns(&mut self, turns: bool) {
        self.turns = turns;
    }

    /// Each group's points (the sets that share a time), in its hierarchy's leaf order (its
    /// leaves' ranges index this order), and that hierarchy.
    pub(crate) fn groups(
        &self,
    ) -> impl Iterator<Item = (impl ExactSizeIterator<Item = TracedPoint> + '_, BvhView<'_>)> + '_
    {
        self.groups.iter().map(|g| {
            let points = g.records.iter().map(move |q| TracedPoint {
                center: g.center(q, 0.0),
                velocity: q.v.as_dvec3(),
                radius: q.radius.into(),
                id: q.id,
            });
            (points, g.view())
        })
    }

    /// Whether there are no points.
    pub(crate) fn is_empty(&self) -> bool {
        self.groups.is_empty()
    }

    /// The nearest point `ray` hits before `t_max`, other than the sphere numbered `skip`;
    /// `dt` is the ray's time after the shutter's opening and `s` that as a fraction of the
    /// shutter.
    #[inline]
    pub(crate) fn closest(
        &self,
        ray: &Ray,
        dt: f64,
        s: f64,
        skip: u32,
        mut t_max: f64,
        stack: &mut TraversalStack,
    ) -> Option<PointHit> {
        let mut best = None;
        for g in &self.groups {
            let found = g.view().closest_hit(
                ray.origin,
                ray.dir,
                s,
                t_max,
                stack,
                RayTest {
                    group: g,
                    ray,
                    dt,
                    skip,
                },
            );
            if let Some((t, pos)) = found {
                t_max = t;
                best = Some(g.hit(t, pos, dt));
            }
        }
        best
    }

    /// [`TracedPoints::closest`] for a packet of rays that skip nothing (camera rays), each
    /// ray `r` at `dt[r]` seconds after the opening, shutter fraction `rays[r].s`, up to
    /// `t_max[r]`: the same hits, traced together.
    #[inline]
    pub(crate) fn closest_packet(
        &self,
        rays: &[Ray],
        lanes: &[PacketRay],
        dt: &[f64; PACKET],
        t_max: [f64; PACKET],
        stack: &mut TraversalStack,
    ) -> [Option<PointHit>; PACKET] {
        let skip = &[u32::MAX; PACKET];
        self.closest_each(rays, dt, skip, t_max, |view, t_max, test| {
            view.closest_hits(lanes, t_max, stack, test)
        })
    }

    /// [`TracedPoints::closest`] for up to `N` rays (at most 256) that need not be coherent
    /// (the bounces of several pixels' samples), ray `r` skipping the sphere numbered
    /// `skip[r]`: the same hits, each ray walking the hierarchy alone, the rays in turns
    /// ([`BvhView::closest_hits_in_turns`]), so one ray's misses in a frame's millions of
    /// records overlap the others' work.
    #[inline]
    pub(crate) fn closest_in_turns<const N: usize>(
        &self,
        rays: &[Ray],
        lanes: &[PacketRay],
        dt: &[f64; N],
        skip: &[u32; N],
        t_max: [f64; N],
        stack: &mut TraversalStack,
    ) -> [Option<PointHit>; N] {
        self.closest_each(rays, dt, skip, t_max, |view, t_max, test| {
            view.closest_hits_in_turns(lanes, t_max, stack, test)
        })
    }

    /// The nearest points of `rays` (ray `r` at `dt[r]` after the opening, skipping the
    /// sphere numbered `skip[r]`, up to `t_max[r]`): each group searched by `search` (a
    /// packet's traversal, or walks in turns) with the group's test, each ray's search
    /// bounded by its nearest hit in the groups before.
    #[inline(always)]
    fn closest_each<const N: usize>(
        &self,
        rays: &[Ray],
        dt: &[f64; N],
        skip: &[u32; N],
        mut t_max: [f64; N],
        mut search: impl FnMut(BvhView<'_>, [f64; N], PacketTest<'_>) -> [Option<(f64, u32)>; N],
    ) -> [Option<PointHit>; N] {
        let mut best = [None; N];
        for g in &self.groups {
            let test = PacketTest {
                group: g,
                rays,
                dt,
                skip,
            };
            let found = search(g.view(), t_max, test);
            for r in 0..rays.len() {
                if let Some((t, pos)) = found[r] {
                    t_max[r] = t;
                    best[r] = Some(g.hit(t, pos, dt[r]));
                }
            }
        }
        best
    }
}

/// A group's points as one ray tests them, the sphere numbered `skip` left out.
struct RayTest<'a> {
    group: &'a Group,
    ray: &'a Ray,
    /// The ray's time after the shutter's opening.
    dt: f64,
    skip: u32,
}

impl Leaves for RayTest<'_> {
    #[inline(always)]
    fn hit(&mut self, pos: u32, t_max: f64) -> Option<f64> {
        let g = self.group;
        let q = &g.records[pos as usize];
        if q.id == self.skip {
            return None;
        }
        intersect(g.center(q, self.dt), q.radius.into(), self.ray, t_max)
    }

    #[inline(always)]
    fn candidates(&mut self, first: u32, count: u32) -> u32 {
        self.group
            .candidates(first, count, self.ray, self.dt, self.skip)
    }

    #[inline(always)]
    fn prefetch(&self, first: u32, count: u32) {
        self.group.prefetch(first, count);
    }
}

/// A group's points as a packet's rays, or walks in turns, test them: ray `r` at `dt[r]`
/// after the opening, the sphere numbered `skip[r]` left out.
struct PacketTest<'a> {
    group: &'a Group,
    rays: &'a [Ray],
    dt: &'a [f64],
    skip: &'a [u32],
}

impl PacketLeaves for PacketTest<'_> {
    #[inline(always)]
    fn hit(&mut self, r: usize, pos: u32, t_max: f64) -> Option<f64> {
        let g = self.group;
        let q = &g.records[pos as usize];
        if q.id == self.skip[r] {
            return None;
        }
        intersect(
            g.center(q, self.dt[r]),
            q.radius.into(),
            &self.rays[r],
            t_max,
        )
    }

    #[inline(always)]
    fn candidates(&mut self, r: usize, first: u32, count: u32) -> u32 {
        self.group
            .candidates(first, count, &self.rays[r], self.dt[r], self.skip[r])
    }

    #[inline(always)]
    fn prefetch(&self, first: u32, count: u32) {
        self.group.prefetch(first, count);
    }
}

impl Group {
    /// Asks for the records at `first..first + count` (a leaf a traversal has entered) to be
    /// loaded into the cache. A frame's records are far larger than the cache, and leaves are
    /// met in no order memory can predict: waiting for a leaf's records when it is tested
    /// took a sixth of a render of ten million points.
    #[inline(always)]
    fn prefetch(&self, first: u32, count: u32) {
        #[cfg(target_arch = "x86_64")]
        for pos in first..first + count {
            if let Some(q) = self.records.get(pos as usize) {
                safe_arch::prefetch_t0(q);
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (first, count);
    }

    /// Of the leaf at `first..first + count`, the points `intersect` may find `ray` (at `dt`)
    /// hitting, a bit each (bit `k` for `first + k`), the point numbered `skip` left out: its
    /// two early outs, which need no `t_max`, made for four points at once in four `f64`
    /// lanes (AVX), lane `k` with the same operations in the same order as `Group::center`
    /// and `intersect` make them for the point at `first + k`, so the same bits and the same
    /// answers (a test checks). A point left out is one `intersect` rejects; the others are
    /// tested by it, one by one. Where the build has no AVX, every point.
    #[inline(always)]
    fn candidates(&self, first: u32, count: u32, ray: &Ray, dt: f64, skip: u32) -> u32 {
        debug_assert!((1..=crate::bvh::MAX_LEAF as u32).contains(&count));
        #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
        {
            use crate::bvh::MAX_LEAF;
            use crate::sphere::EARLY_OUT_SQUARE;
            use safe_arch::*;
            let at = first as usize;
            // A leaf at the records' end may hold fewer than four from its first: its points
            // are all tested (one leaf of the hierarchy at most).
            let Some(q) = self.records.get(at..at + MAX_LEAF) else {
                return crate::bvh::every(count);
            };
            // Four records' halves, then their lanes: `p.x` of the four, `p.y`, ...
            let half = |k: usize, upper: bool| {
                let q = &q[k];
                m128::from_array(if upper {
                    [q.v.x, q.v.y, q.v.z, f32::from_bits(q.id)]
                } else {
                    [q.p.x, q.p.y, q.p.z, q.radius]
                })
            };
            let [mut px, mut py, mut pz, mut r] = [0, 1, 2, 3].map(|k| half(k, false));
            transpose_four_m128(&mut px, &mut py, &mut pz, &mut r);
            let [mut vx, mut vy, mut vz, mut ids] = [0, 1, 2, 3].map(|k| half(k, true));
            transpose_four_m128(&mut vx, &mut vy, &mut vz, &mut ids);
            let wide = convert_to_m256d_from_m128;
            let splat = set_splat_m256d;
            let (lead, dt) = (splat(self.lead), splat(dt));
            let centre = |p: m128, v: m128| {
                let v = wide(v);
                (wide(p) + v * lead) + v * dt
            };
            let (o, d) = (ray.origin, ray.dir);
            let fx = splat(o.x) - centre(px, vx);
            let fy = splat(o.y) - centre(py, vy);
            let fz = splat(o.z) - centre(pz, vz);
            let (dx, dy, dz) = (splat(d.x), splat(d.y), splat(d.z));
            let b = (fx * dx + fy * dy) + fz * dz;
            let ff = (fx * fx + fy * fy) + fz * fz;
            let (lx, ly, lz) = (fx - b * dx, fy - b * dy, fz - b * dz);
            let ll = (lx * lx + ly * ly) + lz * lz;
            let r = wide(r);
            let rr = r * r;
            let rr_up = rr * splat(EARLY_OUT_SQUARE);
            let gt = cmp_op_mask_m256d::<{ cmp_op!(GreaterThanOrdered) }>;
            let checked =
                cmp_op_mask_m256d::<{ cmp_op!(GreaterEqualOrdered) }>(rr, splat(f64::MIN_POSITIVE));
            let misses = checked & ((gt(b, splat(0.0)) & gt(ff, rr_up)) | gt(ll, rr_up));
            let skipped = cmp_eq_mask_i32_m128i(
                cast_to_m128i_from_m128(ids),
                set_splat_i32_m128i(skip as i32),
            );
            let out = move_mask_m256d(misses) | move_mask_m128(cast_to_m128_from_m128i(skipped));
            !(out as u32) & crate::bvh::every(count)
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
        {
            let _ = (ray, dt, skip, first);
            crate::bvh::every(count)
        }
    }

    /// The hit at `t` on the record at `pos`, for a ray at `dt`.
    #[inline(always)]
    fn hit(&self, t: f64, pos: u32, dt: f64) -> PointHit {
        let q = &self.records[pos as usize];
        PointHit {
            t,
            center: self.center(q, dt),
            radius: q.radius.into(),
            id: q.id,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::MAX_LEAF;
    use crate::points::PointSet;
    use crate::rng::Pcg32;
    use crate::sphere::EARLY_OUT_SQUARE;

    /// Three sets: two at one time (one moving, one still with colours and one radius for
    /// all), one at another time, moving; `n` points each.
    fn frame_points(n: usize, seed: u64) -> FramePoints {
        let mut r = Pcg32::new(seed, 3);
        let mut u = || (r.next_f64() * 2.0 - 1.0) as f32;
        let mut set = |time: f64, moving: bool, radii: bool| PointSet {
            material: 0,
            time,
            centers: (0..n).map(|_| Vec3::new(u(), u(), u()) * 10.0).collect(),
            velocities: if moving {
                (0..n).map(|_| Vec3::new(u(), u(), u()) * 40.0).collect()
            } else {
                Vec::new()
            },
            radii: if radii {
                (0..n).map(|_| 0.05 + 0.2 * u().abs()).collect()
            } else {
                Vec::new()
            },
            radius: 0.15,
            colors: Vec::new(),
        };
        FramePoints {
            sets: vec![
                set(0.0, true, true),
                set(0.0, false, false),
                set(0.25, true, true),
            ],
        }
    }

    /// The nearest point along `ray` by testing every one where [`PointSet::prepare`]
    /// places it: its distance and number.
    fn brute(
        points: &FramePoints,
        first: u32,
        interval: Interval,
        ray: &Ray,
    ) -> Option<(f64, u32)> {
        let dt = ray.time - interval.open;
        let mut best: Option<(f64, u32)> = None;
        let mut k = first;
        for s in &points.sets {
            for i in 0..s.len() {
                let q = s.prepare(i, interval);
                let t_max = best.map_or(f64::INFINITY, |b| b.0);
                if let Some(t) = intersect(q.start + q.velocity * dt, q.radius, ray, t_max) {
                    best = Some((t, k));
                }
                k += 1;
            }
        }
        best
    }

    /// A shutter open for 0.02 s, during which the moving sets move, and an instant.
    fn intervals() -> [Interval; 2] {
        [
            Interval {
                open: 0.1,
                close: 0.12,
            },
            Interval::instant(0.3),
        ]
    }

    fn random_ray(r: &mut Pcg32, interval: Interval) -> Ray {
        let mut v = || DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5;
        let origin = v() * 30.0;
        let target = v() * 12.0;
        Ray {
            origin,
            dir: (target - origin).normalize(),
            time: interval.at(r.next_f64()),
        }
    }

    /// Every ray finds, alone, in packets and walking in turns, the point testing every point
    /// finds, at the same distance bit for bit (the same centres, computed the same way), over
    /// moving and still intervals; skipping the point hit, the next one.
    #[test]
    fn finds_what_testing_every_point_finds() {
        let points = frame_points(3000, 5);
        let mut r = Pcg32::new(1, 1);
        for interval in intervals() {
            let traced = TracedPoints::prepare(&points, 7, interval);
            assert_eq!(traced.groups.len(), 2);
            let all_moving = 2 * 3000;
            assert_eq!(
                traced.moving,
                if interval.is_instant() { 0 } else { all_moving }
            );
            let mut stack = TraversalStack::default();
            let duration = interval.close - interval.open;
            let mut hits = 0;
            for _ in 0..300 {
                let rays: Vec<Ray> = (0..PACKET).map(|_| random_ray(&mut r, interval)).collect();
                let mut lanes = [PacketRay {
                    origin: DVec3::ZERO,
                    dir: DVec3::ZERO,
                    s: 0.0,
                }; PACKET];
                let mut dt = [0.0; PACKET];
                for (k, ray) in rays.iter().enumerate() {
                    dt[k] = ray.time - interval.open;
                    let s = if duration > 0.0 {
                        dt[k] / duration
                    } else {
                        0.0
                    };
                    lanes[k] = PacketRay {
                        origin: ray.origin,
                        dir: ray.dir,
                        s,
                    };
                }
                let packet =
                    traced.closest_packet(&rays, &lanes, &dt, [f64::INFINITY; PACKET], &mut stack);
                let wants: Vec<_> = rays
                    .iter()
                    .map(|ray| brute(&points, 7, interval, ray))
                    .collect();
                let in_turns = |skip: &[u32; PACKET], stack: &mut TraversalStack| {
                    traced
                        .closest_in_turns(&rays, &lanes, &dt, skip, [f64::INFINITY; PACKET], stack)
                        .map(|h| h.map(|h| (h.t, h.id)))
                };
                let turns = in_turns(&[u32::MAX; PACKET], &mut stack);
                // Each ray skipping the point it hits (as a ray leaving it does).
                let skip = std::array::from_fn(|k| wants[k].map_or(u32::MAX, |w| w.1));
                let turns_skipping = in_turns(&skip, &mut stack);
                for (k, ray) in rays.iter().enumerate() {
                    let want = wants[k];
                    assert_eq!(turns[k], want, "in turns: {ray:?}");
                    let alone = traced
                        .closest(ray, dt[k], lanes[k].s, u32::MAX, f64::INFINITY, &mut stack)
                        .map(|h| (h.t, h.id));
                    assert_eq!(alone, want, "{ray:?}");
                    assert_eq!(packet[k].map(|h| (h.t, h.id)), want, "{ray:?}");
                    hits += usize::from(want.is_some());
                    // Skipping the point hit finds the next one, as testing every other does.
                    if let Some((_, id)) = want {
                        let next =
                            traced.closest(ray, dt[k], lanes[k].s, id, f64::INFINITY, &mut stack);
                        assert_eq!(turns_skipping[k], next.map(|h| (h.t, h.id)), "{ray:?}");
                        let mut others = points.clone();
                        let (mut set, mut i) = (0, (id - 7) as usize);
                        while i >= others.sets[set].len() {
                            i -= others.sets[set].len();
                            set += 1;
                        }
                        // Moved out of every ray's way, far behind the rays' origins.
                        others.sets[set].centers[i] = Vec3::splat(1e6);
                        let want_next = brute(&others, 7, interval, ray);
                        assert_eq!(next.map(|h| (h.t, h.id)), want_next, "{ray:?}");
                    }
                }
            }
            assert!(hits > 300, "{hits}");
        }
    }

    /// A point far beyond the range compact nodes take (1e35, where their steps would
    /// overflow; the hierarchy keeps `f32` sides then, a choice `bvh`'s tests check) leaves
    /// every point found as testing every point finds it, alone and in turns.
    #[test]
    fn a_point_beyond_the_compact_range_leaves_the_others_found() {
        let mut points = frame_points(400, 6);
        points.sets[0].centers[17] = Vec3::new(1e35, -1e35, 3e34);
        let interval = Interval {
            open: 0.1,
            close: 0.12,
        };
        let traced = TracedPoints::prepare(&points, 0, interval);
        let mut stack = TraversalStack::default();
        let mut r = Pcg32::new(2, 2);
        let mut hits = 0;
        for _ in 0..400 {
            let ray = random_ray(&mut r, interval);
            let dt = ray.time - interval.open;
            let s = dt / (interval.close - interval.open);
            let want = brute(&points, 0, interval, &ray);
            let alone = traced.closest(&ray, dt, s, u32::MAX, f64::INFINITY, &mut stack);
            assert_eq!(alone.map(|h| (h.t, h.id)), want, "{ray:?}");
            let lanes = [PacketRay {
                origin: ray.origin,
                dir: ray.dir,
                s,
            }];
            let turns = traced.closest_in_turns(
                std::slice::from_ref(&ray),
                &lanes,
                &[dt; PACKET],
                &[u32::MAX; PACKET],
                [f64::INFINITY; PACKET],
                &mut stack,
            );
            assert_eq!(turns[0].map(|h| (h.t, h.id)), want, "{ray:?}");
            hits += usize::from(want.is_some());
        }
        assert!(hits > 40, "{hits}");
    }

    /// The same records and hierarchies on one thread and on three.
    #[test]
    fn prepared_alike_on_any_number_of_threads() {
        let points = frame_points(40_000, 8);
        let interval = Interval {
            open: 0.0,
            close: 0.02,
        };
        let prepare = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| TracedPoints::prepare(&points, 0, interval))
        };
        let (a, b) = (prepare(1), prepare(3));
        for (g, h) in a.groups.iter().zip(&b.groups) {
            assert_eq!(g.records, h.records);
            assert_eq!(g.topology, h.topology);
            assert_eq!(g.boxes, h.boxes);
        }
        assert_eq!(a.groups.len(), b.groups.len());
    }

    /// The early outs of `intersect` for the sphere at `c` of radius `r`, written out again
    /// as it writes them: whether it rejects the ray before its roots.
    fn rejected_early(c: DVec3, r: f64, ray: &Ray) -> bool {
        let f = ray.origin - c;
        let b = f.dot(ray.dir);
        let rr = r * r;
        let rr_up = rr * EARLY_OUT_SQUARE;
        let l = f - b * ray.dir;
        rr >= f64::MIN_POSITIVE
            && ((b > 0.0 && f.length_squared() > rr_up) || l.length_squared() > rr_up)
    }

    /// A leaf's candidates, four points in lanes, leave out exactly the points `intersect`'s
    /// early outs reject (so only points it misses at any `t_max`) and the point skipped (a
    /// leaf at the records' end keeps all of its points), and no position past the leaf's
    /// count: for every leaf start of every group, random rays,
    /// and rays aimed past a point's centre at its radius to within a few of its last bits either
    /// way (where the early outs turn), at moving and still intervals.
    #[test]
    fn candidates_leave_out_only_what_intersect_rejects_early() {
        let points = frame_points(300, 9);
        let mut r = Pcg32::new(4, 2);
        let (mut left_out, mut kept) = (0, 0);
        // Whether the build has the lanes (CI's does); without, every point is kept.
        let lanes = cfg!(all(target_arch = "x86_64", target_feature = "avx"));
        for interval in intervals() {
            let traced = TracedPoints::prepare(&points, 7, interval);
            for g in &traced.groups {
                let n = g.records.len();
                for first in 0..n {
                    let count = ((first % MAX_LEAF) + 1).min(n - first) as u32;
                    let mut ray = random_ray(&mut r, interval);
                    let dt = ray.time - interval.open;
                    let q = &g.records[first + (first / 7) % count as usize];
                    if first % 3 == 0 {
                        // From three radii away, past this point's centre at its radius to
                        // within a few ulps (the early outs' margin is four).
                        let (c, radius) = (g.center(q, dt), f64::from(q.radius));
                        let side = ray.dir.cross(DVec3::Y).normalize();
                        let ulps = ((first / 3) % 17) as f64 - 8.0;
                        let past = side * radius * (1.0 + ulps * f64::EPSILON);
                        ray.origin = c + past - ray.dir * 3.0 * radius;
                    }
                    let skip = if first % 5 == 0 { q.id } else { u32::MAX };
                    let bits = g.candidates(first as u32, count, &ray, dt, skip);
                    assert_eq!(bits >> count, 0, "no position past the leaf");
                    for k in 0..count as usize {
                        let p = &g.records[first + k];
                        let (c, radius) = (g.center(p, dt), f64::from(p.radius));
                        let candidate = bits >> k & 1 == 1;
                        if !candidate {
                            assert!(
                                p.id == skip || intersect(c, radius, &ray, f64::INFINITY).is_none(),
                                "a point the ray hits left out"
                            );
                        }
                        // Where the build has lanes, exactly the early outs' answers, but
                        // for a leaf at the records' end, whose points are all kept.
                        if lanes && first + MAX_LEAF <= n {
                            let want = p.id != skip && !rejected_early(c, radius, &ray);
                            assert_eq!(candidate, want, "leaf {first} lane {k}");
                        }
                        if candidate { kept += 1 } else { left_out += 1 }
                    }
                }
            }
        }
        // With the lanes, most of the random rays' points are left out and the grazing ones
        // kept.
        if lanes {
            assert!(
                left_out > 3 * kept && kept > 0,
                "{left_out} left out, {kept} kept"
            );
        } else {
            assert_eq!(left_out, 0);
        }
    }
}
