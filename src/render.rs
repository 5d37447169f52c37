//! Rendering one frame: the frame's world, its camera rays, in parallel over tiles.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::film::{Film, PixelAccumulator};
use crate::sampler::{IndependentSampler, Sampler};
use crate::scene::Scene;
use crate::tracer::{TraceStats, radiance};
use crate::world::{StaticGeometry, World};

/// Side of the square tiles the image is split into for parallel work. Small enough that a
/// 400x225 frame has hundreds of tiles, so both cores stay busy to the end of a frame.
pub const TILE: u32 = 16;

/// What to render: a frame of a scene at a size and sample count.
#[derive(Clone, Debug)]
pub struct FrameRequest {
    pub frame: u32,
    pub width: u32,
    pub height: u32,
    pub samples: u32,
    pub max_depth: u32,
    pub seed: u64,
}

impl FrameRequest {
    /// The frame `frame` with the scene's own settings.
    pub fn from_scene(scene: &Scene, frame: u32) -> FrameRequest {
        FrameRequest {
            frame,
            width: scene.output.width,
            height: scene.output.height,
            samples: scene.render.samples,
            max_depth: scene.render.max_depth,
            seed: scene.render.seed,
        }
    }
}

/// Figures of one rendered frame.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    /// Seconds spent preparing the frame's world (motion bounds, hierarchy build).
    pub prepare_seconds: f64,
    /// Seconds spent tracing.
    pub render_seconds: f64,
    /// Rays intersected with the scene.
    pub rays: u64,
    /// Camera samples taken.
    pub samples: u64,
    /// Samples dropped because they were not finite.
    pub dropped: u64,
    /// Spheres moving during the frame's shutter.
    pub moving_spheres: usize,
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    pub film: Film,
    pub stats: FrameStats,
}

/// Renders one frame. `progress` is called with the number of samples of each finished tile;
/// it is called from worker threads. Runs on the current rayon pool.
pub fn render_frame(
    scene: &Scene,
    statics: &StaticGeometry,
    req: &FrameRequest,
    progress: &(dyn Fn(u64) + Sync),
) -> FrameResult {
    let start = Instant::now();
    let interval = scene.shot.interval(req.frame);
    let world = World::prepare(scene, statics, interval);
    let camera_moves = scene.camera.moves_in(interval);
    let fixed_view = scene.camera.view_at(interval.open, req.width, req.height);
    // Sample time only when something moves during the shutter; sample the lens only for a
    // lens with an aperture.
    let sample_time = world.has_motion() || camera_moves;
    // The aperture does not change over time, so the view at any instant answers this.
    let has_lens = fixed_view.has_lens();
    let prepare_seconds = start.elapsed().as_secs_f64();

    let start = Instant::now();
    let tiles_x = req.width.div_ceil(TILE);
    let tiles_y = req.height.div_ceil(TILE);
    let tiles: Vec<(Vec<DVec3>, TraceStats, u64)> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|tile| {
            let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
            let (x1, y1) = ((x0 + TILE).min(req.width), (y0 + TILE).min(req.height));
            let mut sampler = IndependentSampler::new(req.seed, req.frame);
            let mut stats = TraceStats::default();
            let mut dropped = 0u64;
            let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            for y in y0..y1 {
                for x in x0..x1 {
                    let mut acc = PixelAccumulator::default();
                    for s in 0..req.samples {
                        sampler.start_sample(x, y, s);
                        let jitter = sampler.next_2d();
                        let lens = if has_lens {
                            sampler.next_2d()
                        } else {
                            (0.5, 0.5)
                        };
                        let time = if sample_time {
                            interval.at(sampler.next_1d())
                        } else {
                            interval.open
                        };
                        let view = if camera_moves {
                            scene.camera.view_at(time, req.width, req.height)
                        } else {
                            fixed_view
                        };
                        let ray = view.ray(x, y, jitter, lens, time);
                        acc.add(radiance(
                            &world,
                            ray,
                            req.max_depth,
                            &mut sampler,
                            &mut stats,
                        ));
                    }
                    dropped += acc.dropped as u64;
                    out.push(acc.mean());
                }
            }
            progress(out.len() as u64 * req.samples as u64);
            (out, stats, dropped)
        })
        .collect();

    let mut film = Film::new(req.width, req.height);
    let mut stats = FrameStats {
        prepare_seconds,
        samples: req.width as u64 * req.height as u64 * req.samples as u64,
        moving_spheres: world.moving,
        ..FrameStats::default()
    };
    for (tile, (pixels, tstats, dropped)) in tiles.into_iter().enumerate() {
        let tile = tile as u32;
        let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
        let w = (x0 + TILE).min(req.width) - x0;
        for (i, p) in pixels.into_iter().enumerate() {
            film.set(x0 + i as u32 % w, y0 + i as u32 / w, p);
        }
        stats.rays += tstats.rays;
        stats.dropped += dropped;
    }
    stats.render_seconds = start.elapsed().as_secs_f64();
    FrameResult { film, stats }
}
