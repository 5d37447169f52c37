//! The path tracer: the books' `ray_color`, as a loop.
//!
//! Every bounce takes the same numbers from the sampler, its [`BounceSample`] (pbrt-v4's
//! `uc` and `u`), drawn here and handed to the material, which uses those it needs. So the
//! numbers of bounce k depend only on the sample and k, not on the materials of the bounces
//! before it.

use glam::DVec3;

use crate::bits::Bits;
use crate::bvh::{PACKET, TraversalStack};
use crate::hit::Hit;
use crate::material::Scatter;
use crate::ray::{Ray, offset_origin};
use crate::sampler::{BounceSample, Sampler};
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
///
/// `sampler` is positioned at the ray's sample: each hit takes the sample's next bounce
/// ([`Sampler::next_bounce`]), so the k-th hit of the path gets bounce k's numbers.
///
/// A ray whose origin, direction or time is NaN or infinite (a degenerate camera view, say)
/// is not traced: its radiance is NaN, which the pixel's accumulator drops and counts.
#[inline]
pub fn radiance<S: Sampler>(
    world: &World,
    ray: Ray,
    max_depth: u32,
    sampler: &mut S,
    stats: &mut TraceStats,
) -> DVec3 {
    // With nothing to report and an opaque background, the loop compiles to the plain
    // tracer: the closure and the transparency test are constants once inlined.
    trace(world, ray, None, max_depth, sampler, stats, false, |_| {})
}

/// [`radiance`] of the camera rays of samples `first..first + rays.len()` of pixel (`x`,
/// `y`), at most [`PACKET`]: their first intersections are found together, in one traversal
/// ([`World::hit_packet`]: coherent rays share its order, stack and branches), then each path
/// goes on alone, its sampler positioned at its sample. The same values, bit for bit, as
/// [`radiance`] of each ray in turn.
#[inline]
pub(crate) fn radiance_packet<S: Sampler>(
    world: &World,
    rays: &[Ray],
    at: (u32, u32, u32),
    max_depth: u32,
    sampler: &mut S,
    stats: &mut TraceStats,
) -> [DVec3; PACKET] {
    camera_radiance_packet(world, rays, at, max_depth, sampler, stats, false, |_, _| {})
}

/// The most samples whose paths a frame that takes turns ([`World::takes_turns`]) traces
/// together, bounce by bounce ([`radiance_in_turns`]): thirty-two packets. A bounce's rays
/// then keep the walks under way until the last few are left, where one packet's rays alone
/// left most steps to one or two walks (counted with eight walks in turns, on a frame of ten
/// million points at 16 samples: 51% of the steps were taken with at most two walks under
/// way and 29% by a walk alone; with batches of 64 samples, 5% alone; of 128, 84% of the
/// steps with all eight under way). Batches of 128 rendered that frame in 0.94 of the time
/// of 64, of 256 in 0.94 to 0.96 of the time of 128, of 512 in that of 256, with eight walks
/// (docs/performance.md); a batch's paths hold about 0.2 MB, on the stack (a rayon thread's
/// is 2 MiB).
pub(crate) const STREAM: usize = 32 * PACKET;

/// The most memory a worker thread's batch of paths ([`STREAM`]) holds, in bytes: on its
/// stack, per path its camera hit and next hit (128 bytes each), its ray and next ray (56
/// each), its sampler (at most 288), its throughput and value (24 each), the walks' per-ray
/// arrays below (about 200) and its camera ray in the tile's batch (72), under 1 KiB, taken
/// as 1 KiB; and its walks in turns (`bvh::TURNS_WALKS_BYTES`: their stacks on the heap, their
/// state on the stack, about 200 KiB). A frame whose points are walked in turns touches this
/// much of each thread's memory (`render`'s peak grows by it); the memory estimate counts it
/// per thread.
pub const TURNS_STACK_BYTES: u64 = (STREAM * 1024 + crate::bvh::TURNS_WALKS_BYTES) as u64;

/// A camera ray and the sample it starts: its pixel and its index among the pixel's samples.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SampleRay {
    pub ray: Ray,
    pub pixel: (u32, u32),
    pub index: u32,
}

/// [`radiance_packet`] with the paths' bounces traced together too, for the camera rays of up
/// to `N` samples (at most [`Bits::CAPACITY`], 256): the camera rays' first intersections
/// are found a packet at a time (runs of up to [`PACKET`] consecutive samples of one pixel),
/// then every bounce's rays of the paths still going at once ([`World::hit_in_turns`]: each
/// ray walks alone, the rays in turns, so one ray's cache misses overlap the others' work).
/// Each path takes its own sample's numbers, from its own copy of `sampler`. The same
/// values, bit for bit, as [`radiance`] of each ray in turn.
#[inline]
pub(crate) fn radiance_in_turns<S: Sampler + Clone, const N: usize>(
    world: &World,
    samples: &[SampleRay],
    max_depth: u32,
    sampler: &S,
    stats: &mut TraceStats,
) -> [DVec3; N] {
    camera_radiance_in_turns(world, samples, max_depth, sampler, stats, false, |_, _| {})
}

/// [`radiance_in_turns`] handing each camera ray's first intersection to `first`, in the
/// rays' order, and with `transparent` a camera ray that misses every sphere returning
/// black, as [`camera_radiance_packet`] does: the same values and the same calls.
#[inline]
#[allow(clippy::too_many_arguments)]
pub(crate) fn camera_radiance_in_turns<
    S: Sampler + Clone,
    F: FnMut(usize, Option<&Hit>),
    const N: usize,
>(
    world: &World,
    samples: &[SampleRay],
    max_depth: u32,
    sampler: &S,
    stats: &mut TraceStats,
    transparent: bool,
    mut first: F,
) -> [DVec3; N] {
    const {
        assert!(
            N <= Bits::CAPACITY,
            "a path a bit of the set of those going"
        )
    };
    assert!(
        samples.len() <= N,
        "more samples than the paths have room for"
    );
    // The camera rays' hits, a packet (a pixel's consecutive samples) at a time.
    let mut found = [None; N];
    let mut start = 0;
    while start < samples.len() {
        let SampleRay { pixel, index, .. } = samples[start];
        let mut packet = [samples[start].ray; PACKET];
        let mut n = 1;
        while start + n < samples.len()
            && n < PACKET
            && (samples[start + n].pixel, samples[start + n].index) == (pixel, index + n as u32)
        {
            packet[n] = samples[start + n].ray;
            n += 1;
        }
        let hits = world.hit_packet(&packet[..n], &mut stats.stack);
        found[start..start + n].copy_from_slice(&hits[..n]);
        start += n;
    }
    let mut out = [DVec3::ZERO; N];
    let mut throughput = [DVec3::ONE; N];
    let mut ray = [Ray {
        origin: DVec3::ZERO,
        dir: DVec3::ZERO,
        time: 0.0,
    }; N];
    // The sphere each ray just left through its outside, which it cannot hit again.
    let mut skip = [u32::MAX; N];
    let mut samplers: [S; N] = std::array::from_fn(|_| sampler.clone());
    // The paths still going, a bit each.
    let mut going = Bits::default();
    for (k, sample) in samples.iter().enumerate() {
        let ((x, y), r) = (sample.pixel, sample.ray);
        if k > 0 && samples[k - 1].pixel == (x, y) {
            // The pixel's numbers made for the sample before (its scrambles), kept.
            samplers[k] = samplers[k - 1].clone();
        }
        samplers[k].start_sample(x, y, sample.index);
        ray[k] = r;
        if r.origin.is_finite() && r.dir.is_finite() && r.time.is_finite() {
            going.insert(k);
            first(k, found[k].as_ref());
        } else {
            out[k] = DVec3::NAN;
        }
    }
    for depth in 0..max_depth {
        for k in going.iter() {
            stats.rays += 1;
            let Some(hit) = found[k].take() else {
                if !(transparent && depth == 0) {
                    out[k] = throughput[k] * world.background.radiance(ray[k].dir);
                }
                going.remove(k);
                continue;
            };
            match bounce(
                &hit,
                &ray[k],
                &mut samplers[k],
                &mut throughput[k],
                &mut skip[k],
            ) {
                Some(next) => ray[k] = next,
                None => going.remove(k),
            }
        }
        if going.is_empty() || depth + 1 == max_depth {
            break;
        }
        // The next bounce's rays of the paths still going, side by side.
        let mut path = [0usize; N];
        let mut next = [ray[0]; N];
        let mut next_skip = [u32::MAX; N];
        let mut n = 0;
        for k in going.iter() {
            (path[n], next[n], next_skip[n]) = (k, ray[k], skip[k]);
            n += 1;
        }
        let hits = world.hit_in_turns(&next[..n], &next_skip, &mut stats.stack);
        for (k, hit) in path[..n].iter().zip(hits) {
            found[*k] = hit;
        }
    }
    // A path still going after `max_depth` bounces returns black (`out` is zero).
    out
}

/// [`radiance_packet`] handing each camera ray's first intersection to `first` (with the
/// ray's index in `rays`); with `transparent`, a camera ray that misses every sphere returns
/// black. Otherwise the same values, bit for bit, as [`radiance`] of each ray in turn.
#[inline]
#[allow(clippy::too_many_arguments)]
pub(crate) fn camera_radiance_packet<S: Sampler, F: FnMut(usize, Option<&Hit>)>(
    world: &World,
    rays: &[Ray],
    (x, y, first_sample): (u32, u32, u32),
    max_depth: u32,
    sampler: &mut S,
    stats: &mut TraceStats,
    transparent: bool,
    mut first: F,
) -> [DVec3; PACKET] {
    let hits = world.hit_packet(rays, &mut stats.stack);
    let mut out = [DVec3::ZERO; PACKET];
    for (k, (ray, hit)) in rays.iter().zip(hits).enumerate() {
        sampler.start_sample(x, y, first_sample + k as u32);
        out[k] = trace(
            world,
            *ray,
            Some(hit),
            max_depth,
            sampler,
            stats,
            transparent,
            |h| first(k, h),
        );
    }
    out
}

/// The loop of [`radiance`] and the packets' rays; `camera_hit`, if
/// given, is the ray's first intersection, found already.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn trace<S: Sampler, F: FnOnce(Option<&Hit>)>(
    world: &World,
    mut ray: Ray,
    mut camera_hit: Option<Option<Hit>>,
    max_depth: u32,
    sampler: &mut S,
    stats: &mut TraceStats,
    transparent: bool,
    first: F,
) -> DVec3 {
    if !(ray.origin.is_finite() && ray.dir.is_finite() && ray.time.is_finite()) {
        return DVec3::NAN;
    }
    let mut first = Some(first);
    let mut throughput = DVec3::ONE;
    // The sphere the ray just left through its outside, which it cannot hit again.
    let mut skip = u32::MAX;
    for _ in 0..max_depth {
        stats.rays += 1;
        let found = match camera_hit.take() {
            Some(found) => found,
            None => world.hit(&ray, skip, &mut stats.stack),
        };
        let camera_ray = match first.take() {
            Some(f) => {
                f(found.as_ref());
                true
            }
            None => false,
        };
        let Some(hit) = found else {
            if transparent && camera_ray {
                return DVec3::ZERO;
            }
            return throughput * world.background.radiance(ray.dir);
        };
        match bounce(&hit, &ray, sampler, &mut throughput, &mut skip) {
            Some(next) => ray = next,
            None => return DVec3::ZERO,
        }
    }
    DVec3::ZERO
}

/// A path's bounce at `hit` of `ray`: the sample's next bounce numbers scatter the ray, the
/// path's `throughput` takes the attenuation, and `skip` the sphere the new ray cannot hit
/// again (the one it leaves through its outside). The new ray, or `None` where the path is
/// absorbed.
#[inline(always)]
fn bounce<S: Sampler>(
    hit: &Hit,
    ray: &Ray,
    sampler: &mut S,
    throughput: &mut DVec3,
    skip: &mut u32,
) -> Option<Ray> {
    let sample: BounceSample = sampler.next_bounce();
    match hit.material.scatter(ray.dir, hit.surface.normal, sample) {
        Scatter::Absorbed => None,
        Scatter::Continue {
            dir,
            attenuation,
            leaves_outside,
        } => {
            *throughput *= attenuation;
            *skip = if leaves_outside { hit.sphere } else { u32::MAX };
            Some(scattered(hit, dir, ray.time))
        }
    }
}

/// The ray scattered from `hit` in direction `dir`, offset off the surface.
#[inline]
fn scattered(hit: &Hit, dir: DVec3, time: f64) -> Ray {
    Ray {
        origin: offset_origin(hit.surface.p, hit.surface.p_error, hit.surface.normal, dir),
        dir,
        time,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use crate::sampler::{CameraSample, CameraUse, IndependentSampler, SobolSampler};
    use crate::scene::Scene;
    use crate::world::StaticGeometry;

    /// A sampler that records the bounce numbers it hands out.
    struct Recording<S> {
        inner: S,
        bounces: Vec<BounceSample>,
    }

    impl<S: Sampler> Sampler for Recording<S> {
        fn start_sample(&mut self, x: u32, y: u32, index: u32) {
            self.inner.start_sample(x, y, index);
            self.bounces.clear();
        }
        fn camera(&mut self, uses: CameraUse) -> CameraSample {
            self.inner.camera(uses)
        }
        fn next_bounce(&mut self) -> BounceSample {
            let b = self.inner.next_bounce();
            self.bounces.push(b);
            b
        }
    }

    /// A closed room (the inside of a large diffuse sphere) with a sharp mirror, a fuzzy
    /// metal and a glass sphere in it: no path escapes, so each ray traced hits something.
    fn room() -> Scene {
        use crate::material::{Background, Material};
        use crate::testing::still;
        let grey = glam::DVec3::splat(0.5);
        let silver = glam::DVec3::splat(0.9);
        let mut scene = crate::testing::scene(
            vec![
                still([0.0, 0.0, 0.0], 10.0, 0),
                still([2.0, 0.0, 0.0], 1.5, 1),
                still([-2.0, 0.0, 0.0], 1.5, 2),
                still([0.0, 2.5, 0.0], 1.0, 3),
            ],
            vec![
                Material::Lambertian { albedo: grey },
                Material::Metal {
                    albedo: silver,
                    fuzz: 0.0,
                },
                Material::Dielectric { ior: 1.5 },
                Material::Metal {
                    albedo: silver,
                    fuzz: 0.8,
                },
            ],
        );
        scene.shot.shutter = 0.0;
        scene.background = Background::Uniform(glam::DVec3::ONE);
        scene
    }

    fn bounce_numbers_follow_the_hits(sampler: impl Sampler) {
        let scene = room();
        let statics = StaticGeometry::new(&scene);
        let world = World::prepare(&scene, &statics, scene.shot.interval(1));
        let mut sampler = Recording {
            inner: sampler,
            bounces: vec![],
        };
        let mut r = Pcg32::new(1, 2);
        let mut stats = TraceStats::default();
        let mut longest = 0;
        for i in 0..2000 {
            let dir = crate::material::unit_vector((r.next_f64(), r.next_f64()));
            let ray = Ray {
                origin: DVec3::new(0.0, 0.0, 4.0),
                dir,
                time: 0.0,
            };
            sampler.start_sample(0, 0, i);
            let rays = stats.rays;
            radiance(&world, ray, 12, &mut sampler, &mut stats);
            // One bounce's numbers per hit, whatever the material (a sharp mirror uses none,
            // glass one, a fuzzy metal three)...
            assert_eq!(sampler.bounces.len() as u64, stats.rays - rays);
            longest = longest.max(sampler.bounces.len());
            // ...and bounce k's numbers are the sample's bounce k, whatever came before.
            sampler.inner.start_sample(0, 0, i);
            for b in &sampler.bounces {
                assert_eq!(sampler.inner.next_bounce(), *b);
            }
        }
        assert_eq!(longest, 12);
    }

    #[test]
    fn non_finite_rays_give_nan_and_find_nothing() {
        let scene = room();
        let statics = StaticGeometry::new(&scene);
        let world = World::prepare(&scene, &statics, scene.shot.interval(1));
        let mut stats = TraceStats::default();
        let (nan, inf) = (f64::NAN, f64::INFINITY);
        for (origin, dir, time) in [
            (DVec3::splat(nan), DVec3::Z, 0.0),
            (DVec3::ZERO, DVec3::splat(nan), 0.0),
            (DVec3::new(inf, 0.0, 0.0), DVec3::Z, 0.0),
            (DVec3::ZERO, DVec3::new(0.0, -inf, 0.0), 0.0),
            (DVec3::ZERO, DVec3::Z, nan),
        ] {
            let ray = Ray { origin, dir, time };
            if time.is_finite() {
                assert!(world.hit(&ray, u32::MAX, &mut stats.stack).is_none());
            }
            let mut sampler = IndependentSampler::new(1, 1);
            sampler.start_sample(0, 0, 0);
            assert!(radiance(&world, ray, 8, &mut sampler, &mut stats).is_nan());
        }
        assert_eq!(stats.rays, 0);
    }

    /// The room with a cloud of moving points in it, some coloured, over a shutter.
    fn room_with_points(n: usize) -> (Scene, crate::points::FramePoints) {
        use crate::points::{FramePoints, PointSet};
        let mut scene = room();
        scene.shot.shutter = 0.02;
        let mut r = Pcg32::new(4, 4);
        let mut u = || (r.next_f64() * 2.0 - 1.0) as f32;
        let set = |material, colors: bool, u: &mut dyn FnMut() -> f32| PointSet {
            material,
            time: 0.0,
            centers: (0..n)
                .map(|_| glam::Vec3::new(u(), u(), u()) * 5.0)
                .collect(),
            velocities: (0..n)
                .map(|_| glam::Vec3::new(u(), u(), u()) * 10.0)
                .collect(),
            radii: (0..n).map(|_| 0.02 + 0.1 * u().abs()).collect(),
            radius: 0.1,
            colors: if colors {
                (0..n).map(|_| [u().abs(), u().abs(), u().abs()]).collect()
            } else {
                Vec::new()
            },
        };
        let points = FramePoints {
            sets: vec![set(0, true, &mut u), set(2, false, &mut u)],
        };
        (scene, points)
    }

    /// A whole frame through the tiles is the same whether its paths walk the points in turns
    /// or alone (which the points' size chooses, `World::takes_turns`; forced each way here):
    /// the same means, counts and pass sums, bit for bit, without passes (the tiles' batches)
    /// and with them (a pixel's packet at a time).
    #[test]
    fn a_frame_is_the_same_whether_its_paths_take_turns_or_not() {
        use crate::error::Error;
        use crate::pass::{Pass, PassSet};
        use crate::passes::SumLayout;
        use crate::points::FramePoints;
        use crate::prepared::PreparedFrame;
        use crate::renderer::{CpuShot, FrameJob, FrameTracer, ShotTracer};

        /// The CPU's tracer with the frame's choice of turns made by the test.
        struct Forced {
            cpu: CpuShot,
            turns: bool,
        }
        impl ShotTracer for Forced {
            fn statics(&self) -> &StaticGeometry {
                self.cpu.statics()
            }
            fn frame<'a>(
                &'a self,
                mut prepared: PreparedFrame<'a>,
                points: &'a FramePoints,
                layout: &SumLayout,
            ) -> Result<Box<dyn FrameTracer + 'a>, Error> {
                prepared.world.set_turns(self.turns);
                self.cpu.frame(prepared, points, layout)
            }
        }
        let (mut scene, points) = room_with_points(3000);
        // The room opened (its wall taken away), so that the sky lights the cloud.
        scene.spheres.remove(0);
        scene.camera.look_from = crate::motion::Motion::Still(DVec3::new(0.0, 1.0, 8.0));
        scene.camera.look_at = crate::motion::Motion::Still(DVec3::ZERO);
        (
            scene.output.width,
            scene.output.height,
            scene.render.samples,
        ) = (24, 16, 12);
        let depth_normal = PassSet::EMPTY.with(Pass::Depth).with(Pass::Normal);
        for passes in [PassSet::EMPTY, depth_normal] {
            let mut scene = scene.clone();
            scene.output.passes = passes;
            let frame = scene.shot.first_frame;
            let render = |turns: bool| {
                let shot = Forced {
                    cpu: CpuShot::new(&scene),
                    turns,
                };
                FrameJob::new(&scene, frame)
                    .points(&points)
                    .sample(&shot)
                    .unwrap()
            };
            let (together, alone) = (render(true), render(false));
            let bits = |r: &crate::renderer::FrameResult| {
                r.film
                    .means()
                    .iter()
                    .map(|p| p.to_array().map(f64::to_bits))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&together), bits(&alone), "{passes:?}");
            assert_eq!(together.stats.rays, alone.stats.rays, "{passes:?}");
            assert!(together.stats.rays > 24 * 16 * 12, "the paths bounce");
            assert_eq!(
                together.film.tiles_with_pass_sums(),
                alone.film.tiles_with_pass_sums(),
                "{passes:?}"
            );
        }
    }

    /// Paths traced together, their bounces walking the points in turns, give what each path
    /// gives alone, bit for bit, with each sampler: batches of up to [`STREAM`] rays, the
    /// packets of several pixels, from inside the room through a cloud of moving points or
    /// from outside it, a ray that is not finite among them; with a transparent background
    /// and the camera hits handed out too.
    #[test]
    fn paths_in_turns_give_what_each_gives_alone() {
        fn check(mut sampler: impl Sampler + Clone) {
            let (scene, points) = room_with_points(4000);
            let statics = StaticGeometry::new(&scene);
            let world = World::prepare_with(&scene, &statics, &points, scene.shot.interval(1));
            let mut r = Pcg32::new(7, 1);
            let mut stats = TraceStats::default();
            let (mut together, mut alone, mut misses) = (0, 0, 0);
            // Batches of the packets of several pixels, each of 1 to `PACKET` samples from a
            // pixel's first, as a tile makes them: a pixel's samples may also go on from one
            // packet into the next of the same batch.
            let mut pixel = 0u32;
            for batch in 0..60 {
                let mut samples = Vec::new();
                loop {
                    let n = 1 + pixel as usize % PACKET;
                    let n = if batch % 3 == 0 { PACKET } else { n };
                    if samples.len() + n > STREAM {
                        break;
                    }
                    // Two packets of one pixel now and then: samples 0.. and n...
                    let packets = if pixel.is_multiple_of(5) { 2 } else { 1 };
                    for k in 0..packets * n {
                        // From inside the room, or from outside it (where camera rays may
                        // miss it).
                        let from = if pixel.is_multiple_of(2) { 4.0 } else { 25.0 };
                        let ray = Ray {
                            origin: if pixel % 17 == 3 && k == 0 {
                                DVec3::NAN
                            } else {
                                DVec3::new(0.0, 0.0, from)
                            },
                            dir: crate::material::unit_vector((r.next_f64(), r.next_f64())),
                            time: 0.02 * r.next_f64(),
                        };
                        samples.push(SampleRay {
                            ray,
                            pixel: (pixel, 1),
                            index: k as u32,
                        });
                    }
                    pixel += 1;
                    if samples.len() > STREAM - PACKET {
                        break;
                    }
                }
                samples.truncate(STREAM);
                let before = stats.rays;
                let got: [DVec3; STREAM] =
                    radiance_in_turns(&world, &samples, 12, &sampler, &mut stats);
                together += stats.rays - before;
                for (k, sample) in samples.iter().enumerate() {
                    let (x, y) = sample.pixel;
                    sampler.start_sample(x, y, sample.index);
                    let before = stats.rays;
                    let want = radiance(&world, sample.ray, 12, &mut sampler, &mut stats);
                    alone += stats.rays - before;
                    assert_eq!(
                        got[k].to_array().map(f64::to_bits),
                        want.to_array().map(f64::to_bits),
                        "batch {batch} ray {k}"
                    );
                }
                // With a transparent background and the camera hits handed out: the same
                // values and the same calls as each pixel's packets' paths one by one.
                let mut seen_turns = vec![];
                let turns: [DVec3; STREAM] = camera_radiance_in_turns(
                    &world,
                    &samples,
                    12,
                    &sampler,
                    &mut stats,
                    true,
                    |k, hit| seen_turns.push((k, hit.map(|h| (h.t.to_bits(), h.sphere)))),
                );
                let mut seen_packets = vec![];
                let mut start = 0;
                while start < samples.len() {
                    let SampleRay { pixel, index, .. } = samples[start];
                    let mut end = start + 1;
                    while end < samples.len() && end - start < PACKET && samples[end].pixel == pixel
                    {
                        end += 1;
                    }
                    let rays: Vec<Ray> = samples[start..end].iter().map(|s| s.ray).collect();
                    let packet = camera_radiance_packet(
                        &world,
                        &rays,
                        (pixel.0, pixel.1, index),
                        12,
                        &mut sampler,
                        &mut stats,
                        true,
                        |k, hit| {
                            seen_packets.push((start + k, hit.map(|h| (h.t.to_bits(), h.sphere))))
                        },
                    );
                    for k in start..end {
                        assert_eq!(
                            turns[k].to_array().map(f64::to_bits),
                            packet[k - start].to_array().map(f64::to_bits),
                            "batch {batch} ray {k}, transparent"
                        );
                    }
                    start = end;
                }
                assert_eq!(seen_turns, seen_packets, "batch {batch}");
                misses += seen_turns.iter().filter(|(_, h)| h.is_none()).count();
            }
            assert!(pixel > 300, "{pixel}");
            assert!(misses > 50, "{misses}");
            // The same rays counted, many of them bounces.
            assert_eq!(together, alone);
            assert!(together > 3 * 300 * 4, "{together}");
        }
        check(IndependentSampler::new(3, 1));
        check(SobolSampler::new(3, 1));
    }

    #[test]
    fn every_hit_takes_its_bounces_numbers() {
        bounce_numbers_follow_the_hits(IndependentSampler::new(3, 1));
        bounce_numbers_follow_the_hits(SobolSampler::new(3, 1));
    }
}
