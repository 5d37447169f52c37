//! The tiles of a frame on the CPU: the prepared frame with its passes' context
//! ([`CpuFrame`]), and one round of samples over every tile of the film, in parallel.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::adaptive::RoundPlan;
use super::tracers::{FrameTracer, RoundCounts};
use crate::bvh::PACKET;
use crate::camera::View;
use crate::error::Error;
use crate::film::{Film, FilmTile, Pixel, TileRect};
use crate::hit::Hit;
use crate::passes::PassContext;
use crate::prepared::PreparedFrame;
use crate::ray::Ray;
use crate::sampler::{IndependentSampler, Sampler, SamplerKind, SobolSampler};
use crate::scene::Scene;
use crate::tracer::{
    STREAM, SampleRay, TraceStats, camera_radiance_in_turns, camera_radiance_packet, radiance,
    radiance_in_turns, radiance_packet,
};
use crate::world::World;

/// The settings of one frame, copied from the scene's (`[output]` size, `[render]` samples
/// and depth) so the per-sample loop reads them from one small struct; the sampler's are the
/// prepared frame's.
#[derive(Clone, Debug)]
pub(super) struct FrameRequest {
    pub(super) width: u32,
    pub(super) height: u32,
    /// Samples per pixel (without a budget: exactly these).
    pub(super) samples: u32,
    pub(super) max_depth: u32,
}

impl FrameRequest {
    /// The scene's settings.
    pub(super) fn from_scene(scene: &Scene) -> FrameRequest {
        FrameRequest {
            width: scene.output.width,
            height: scene.output.height,
            samples: scene.render.samples,
            max_depth: scene.render.max_depth,
        }
    }
}

/// A frame on the CPU: everything fixed before its first sample, the prepared frame and the
/// passes' context when the scene asks for passes.
pub(super) struct CpuFrame<'a> {
    pub(super) prepared: PreparedFrame<'a>,
    pub(super) req: FrameRequest,
    pub(super) passes: Option<PassContext<'a>>,
}

impl CpuFrame<'_> {
    /// Takes `tile`'s samples of this round (`plan`); returns the rays traced, the samples taken
    /// and those that were not finite.
    ///
    /// The camera rays of a packet are made in this loop, not in a function of their own:
    /// split out (commit 1969e91), the same frames rendered about 1% slower (held-out books'
    /// scene, 400x225, 100 spp, 2 cores, user time of 11 runs each).
    fn sample_tile<S: Sampler + Clone>(
        &self,
        sampler: &mut S,
        tile: &mut FilmTile,
        plan: &RoundPlan,
    ) -> RoundCounts {
        let req = &self.req;
        let prepared = &self.prepared;
        let interval = prepared.interval();
        let uses = crate::sampler::CameraUse {
            lens: prepared.has_lens,
            time: prepared.sample_time,
        };
        // Frames with passes or a transparent background take each camera ray's first hit
        // from the tracer, in a function of its own (`observed_packet`), so that this loop
        // is compiled for frames without them as it would be without passes at all.
        let observed = self.passes.is_some() || prepared.scene.transparent;
        let tracing = if observed {
            Tracing::Observed
        } else if prepared.world.takes_turns() {
            Tracing::InTurns
        } else {
            Tracing::Packets
        };
        let stride = self.passes.as_ref().map_or(0, |p| p.layout.stride);
        let mut targets = Vec::with_capacity(tile.pixels.len());
        plan.targets(&tile.rect, tile.pixels, &mut targets);
        let mut stats = TraceStats::default();
        let mut counts = RoundCounts::default();
        let mut sums = tile.pass_sums.chunks_mut(stride.max(1));
        // Where the world takes turns, the camera rays of up to `STREAM` samples (whole
        // packets, of one or more pixels) are traced together (`Batch`).
        let mut batch = Batch::new();
        for (i, &target) in targets.iter().enumerate() {
            let (x, y) = tile.rect.position(i);
            let taken = tile.pixels[i].taken();
            counts.samples += target.saturating_sub(taken) as u64;
            let sums = if stride > 0 { sums.next() } else { None };
            let sums = sums.unwrap_or_default();
            let mut s = taken;
            while s < target {
                // A pixel's camera rays go in packets of up to `PACKET` samples: coherent
                // rays, one traversal (`radiance_packet`, the same values as one by one). In
                // a frame with points, whose hierarchy dwarfs the cache, the packets' paths
                // go on together, bounce by bounce (`radiance_in_turns`).
                let n = (target - s).min(PACKET as u32);
                let mut rays = [Ray {
                    origin: DVec3::ZERO,
                    dir: DVec3::ZERO,
                    time: 0.0,
                }; PACKET];
                let mut views = [prepared.fixed_view; PACKET];
                for (k, (ray, view)) in rays.iter_mut().zip(&mut views).enumerate().take(n as usize)
                {
                    let s = s + k as u32;
                    sampler.start_sample(x, y, s);
                    // The pixel position, and the lens position and the time (one joint
                    // sample) where used; the bounces' numbers do not depend on which are.
                    let camera = sampler.camera(uses);
                    let time = if prepared.sample_time {
                        // The row of a rolling shutter: the sample's continuous y over the
                        // height (0 at the top edge), as the camera places it.
                        let row = (y as f64 + camera.pixel.1) / req.height as f64;
                        prepared.times.time(camera.time, row)
                    } else {
                        interval.open
                    };
                    if prepared.camera_moves {
                        *view = prepared.scene.camera.view_at(time, req.width, req.height);
                    }
                    *ray = view.ray(x, y, camera.pixel, camera.lens, time);
                }
                let rays = &rays[..n as usize];
                let (world, depth, at) = (&prepared.world, req.max_depth, (x, y, s));
                let v = match tracing {
                    Tracing::InTurns => {
                        if !batch.fits(rays.len()) {
                            let pixels = (&tile.rect, &mut *tile.pixels);
                            batch.trace(world, depth, sampler, &mut stats, pixels, &mut counts);
                        }
                        batch.push(rays, at);
                        s += n;
                        continue;
                    }
                    Tracing::Observed => {
                        self.observed_packet(rays, &views, at, sampler, &mut stats, sums)
                    }
                    Tracing::Packets if n == 1 => {
                        let mut v = [DVec3::ZERO; PACKET];
                        v[0] = radiance(world, rays[0], depth, sampler, &mut stats);
                        v
                    }
                    Tracing::Packets => {
                        radiance_packet(world, rays, at, depth, sampler, &mut stats)
                    }
                };
                for v in &v[..n as usize] {
                    if !tile.pixels[i].add(*v) {
                        counts.non_finite += 1;
                    }
                }
                s += n;
            }
        }
        batch.trace(
            &prepared.world,
            req.max_depth,
            sampler,
            &mut stats,
            (&tile.rect, tile.pixels),
            &mut counts,
        );
        counts.rays = stats.rays;
        counts
    }

    /// The camera samples `first..first + rays.len()` of pixel (`x`, `y`) of a frame with
    /// passes or a transparent background: their radiance, and their passes into the
    /// pixel's sums `sums` (each ray seen through its view in `views`).
    #[inline(never)]
    fn observed_packet<S: Sampler + Clone>(
        &self,
        rays: &[Ray],
        views: &[View; PACKET],
        at: (u32, u32, u32),
        sampler: &mut S,
        stats: &mut TraceStats,
        sums: &mut [f64],
    ) -> [DVec3; PACKET] {
        let (world, depth) = (&self.prepared.world, self.req.max_depth);
        let transparent = self.prepared.scene.transparent;
        let first = |k: usize, hit: Option<&Hit>| {
            if let Some(passes) = &self.passes {
                passes.record(sums, &rays[k], &views[k], hit);
            }
        };
        if world.takes_turns() {
            let (x, y, index) = at;
            let samples: [_; PACKET] = std::array::from_fn(|k| SampleRay {
                ray: rays.get(k).copied().unwrap_or(rays[0]),
                pixel: (x, y),
                index: index + k as u32,
            });
            let samples = &samples[..rays.len()];
            camera_radiance_in_turns(world, samples, depth, sampler, stats, transparent, first)
        } else {
            camera_radiance_packet(world, rays, at, depth, sampler, stats, transparent, first)
        }
    }
}

impl FrameTracer for CpuFrame<'_> {
    fn moving_spheres(&self) -> usize {
        self.prepared.world.moving
    }

    /// Takes the samples of one round (`plan`) in every tile of `film`, in parallel.
    fn round(
        &mut self,
        film: &mut Film,
        plan: &RoundPlan<'_>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<RoundCounts, Error> {
        let mut tiles = film.tiles_mut();
        let counts = tiles
            .par_iter_mut()
            // One tile at a time: rayon otherwise hands out runs of tiles, and a run of
            // costly ones left a core idle for up to a tenth of a short frame.
            .with_max_len(1)
            .map(|tile| {
                let start = Instant::now();
                let key = self.prepared.key;
                let mut counts = match self.prepared.sampler {
                    SamplerKind::Independent => {
                        self.sample_tile(&mut IndependentSampler::from_key(key), tile, plan)
                    }
                    SamplerKind::Sobol => {
                        self.sample_tile(&mut SobolSampler::from_key(key), tile, plan)
                    }
                };
                progress(counts.samples);
                counts.busy_seconds = start.elapsed().as_secs_f64();
                counts
            })
            .reduce(RoundCounts::default, RoundCounts::plus);
        Ok(counts)
    }
}

/// How a tile's samples are traced, settled once a tile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Tracing {
    /// Camera rays in packets, each path then alone ([`radiance_packet`]).
    Packets,
    /// Each camera ray's first hit handed to the passes or the transparent background
    /// ([`camera_radiance_packet`], or [`camera_radiance_in_turns`] where the world takes
    /// turns).
    Observed,
    /// Camera rays in packets, gathered in batches of up to [`STREAM`] samples (`Batch`)
    /// whose paths bounce by bounce together, their rays walking the hierarchies in turns
    /// ([`radiance_in_turns`]).
    InTurns,
}

/// The camera rays of up to [`STREAM`] samples of a tile, whole packets of one or more
/// pixels, waiting to be traced together ([`radiance_in_turns`]).
struct Batch {
    samples: [SampleRay; STREAM],
    len: usize,
}

impl Batch {
    fn new() -> Batch {
        let ray = Ray {
            origin: DVec3::ZERO,
            dir: DVec3::ZERO,
            time: 0.0,
        };
        Batch {
            samples: [SampleRay {
                ray,
                pixel: (0, 0),
                index: 0,
            }; STREAM],
            len: 0,
        }
    }

    /// Whether `n` more rays fit.
    fn fits(&self, n: usize) -> bool {
        self.len + n <= STREAM
    }

    /// Adds the camera rays of samples `first..` of pixel (`x`, `y`).
    fn push(&mut self, rays: &[Ray], (x, y, first): (u32, u32, u32)) {
        for (k, &ray) in rays.iter().enumerate() {
            self.samples[self.len + k] = SampleRay {
                ray,
                pixel: (x, y),
                index: first + k as u32,
            };
        }
        self.len += rays.len();
    }

    /// Traces the rays waiting and adds their radiance to their pixels of the tile (its
    /// rectangle and pixels), each pixel's samples in order (a packet's samples are
    /// consecutive, and packets were added in order); empties the batch.
    fn trace<S: Sampler + Clone>(
        &mut self,
        world: &World,
        depth: u32,
        sampler: &S,
        stats: &mut TraceStats,
        (rect, pixels): (&TileRect, &mut [Pixel]),
        counts: &mut RoundCounts,
    ) {
        let n = self.len;
        if n == 0 {
            return;
        }
        let v: [DVec3; STREAM] =
            radiance_in_turns(world, &self.samples[..n], depth, sampler, stats);
        for (v, sample) in v[..n].iter().zip(&self.samples[..n]) {
            let (x, y) = sample.pixel;
            if !pixels[rect.index(x, y)].add(*v) {
                counts.non_finite += 1;
            }
        }
        self.len = 0;
    }
}
