//! One frame prepared for tracing, whichever device traces it: its world (every animated
//! sphere's motion prepared for the frame's interval, their boxes at the shutter's opening and
//! closing, the hierarchies, [`World::prepare_with`]), its sample times, its camera and its
//! sampler's key. The CPU's tiles trace it directly; the GPU's upload copies it into the
//! device's buffers, deciding nothing of its own.

use crate::camera::View;
use crate::points::FramePoints;
use crate::sampler::{SamplePattern, SamplerKind};
use crate::scene::Scene;
use crate::shutter::{FrameTimes, Interval};
use crate::world::{StaticGeometry, World};

/// Everything about a frame that is fixed before its first sample, on either device.
#[derive(Debug)]
pub struct PreparedFrame<'a> {
    /// The scene it is a frame of (its materials, background, passes' sources).
    pub scene: &'a Scene,
    /// The frame number.
    pub frame: u32,
    /// Its spheres prepared for its interval, in their hierarchies.
    pub world: World<'a>,
    /// Its sample times: its whole exposure, the shutter curve and a rolling shutter's rows.
    pub times: FrameTimes,
    /// Whether the camera moves during the frame's exposure: a view per sample.
    pub camera_moves: bool,
    /// The camera's view at the frame's opening, which every sample uses when the camera
    /// does not move.
    pub fixed_view: View,
    /// Whether a sample draws a time: something (a sphere or the camera) moves during the
    /// frame's exposure, so a still scene renders the same under any shutter.
    pub sample_time: bool,
    /// Whether a sample draws a lens position: the lens has an aperture (which does not
    /// change over time, so any instant's view answers).
    pub has_lens: bool,
    /// The sampler's kind and its key for the scene's seed and this frame, under the
    /// scene's sample pattern ([`SamplePattern::key`]).
    pub sampler: SamplerKind,
    pub key: u64,
}

impl<'a> PreparedFrame<'a> {
    /// Prepares frame `frame` of `scene`, its still spheres from `statics` (built once for
    /// the shot) and `points` (the frame's points of the scene's point caches, traced through
    /// a hierarchy of their own). Runs on the current rayon pool; depends on its arguments alone.
    pub fn new(
        scene: &'a Scene,
        statics: &'a StaticGeometry,
        points: &'a FramePoints,
        frame: u32,
    ) -> PreparedFrame<'a> {
        let times = scene.shot.frame_times(frame);
        let interval = times.interval;
        let world = World::prepare_with(scene, statics, points, interval);
        let camera_moves = scene.camera.moves_in(interval);
        let fixed_view =
            scene
                .camera
                .view_at(interval.open, scene.output.width, scene.output.height);
        let sampler = scene.render.sampler;
        PreparedFrame {
            scene,
            frame,
            sample_time: world.has_motion() || camera_moves,
            has_lens: fixed_view.has_lens(),
            world,
            times,
            camera_moves,
            fixed_view,
            sampler,
            key: SamplePattern::of(scene).key(sampler, scene.render.seed, frame),
        }
    }

    /// The frame's interval: its whole exposure ([`crate::shutter::Shot::interval`]).
    pub fn interval(&self) -> Interval {
        self.times.interval
    }
}
