//! The seam between a frame's rounds of samples and the device that traces them. The round
//! loop ([`super::job`]) asks a [`ShotTracer`] to make each prepared frame ready
//! ([`ShotTracer::frame`]) and the [`FrameTracer`] it returns to take each round's samples into
//! the film; the budget, the adaptive rounds, the stop rule and the film are the same code
//! whatever the device. The CPU's tracer is [`CpuShot`] (its tiles, [`super::tiles`]); the
//! GPU's implements the same two traits in the GPU's room. Which one a shot gets is decided
//! once, where a run's devices are opened.

use crate::error::Error;
use crate::film::Film;
use crate::passes::{PassContext, SumLayout};
use crate::points::FramePoints;
use crate::prepared::PreparedFrame;
use crate::scene::Scene;
use crate::world::StaticGeometry;

use super::adaptive::RoundPlan;
use super::tiles::{CpuFrame, FrameRequest};

/// A shot on the device that traces its frames: what the shot keeps there from frame to frame
/// (the spheres that never move, with their hierarchy, built once), and each of its frames
/// made ready for rounds of samples.
pub trait ShotTracer: Send + Sync {
    /// The shot's spheres that never move, with their hierarchy: what every frame's
    /// preparation starts from.
    fn statics(&self) -> &StaticGeometry;

    /// The frame `prepared` (its points `points` among its spheres) ready on the device, for
    /// a film that keeps the pass sums `layout` says.
    fn frame<'a>(
        &'a self,
        prepared: PreparedFrame<'a>,
        points: &'a FramePoints,
        layout: &SumLayout,
    ) -> Result<Box<dyn FrameTracer + 'a>, Error>;
}

/// One frame ready on its device: rounds of samples into its film.
pub trait FrameTracer {
    /// Spheres moving during the frame's exposure.
    fn moving_spheres(&self) -> usize;

    /// Takes the samples of one round (`plan`) in every pixel of `film`. A device that fails
    /// (lost, out of memory) is an error, and the film is then not the frame's.
    fn round(
        &mut self,
        film: &mut Film,
        plan: &RoundPlan<'_>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<RoundCounts, Error>;

    /// Bytes read back from the device so far (0 where the film is the device's own memory).
    fn readback_bytes(&self) -> u64 {
        0
    }
}

/// What one round did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RoundCounts {
    /// Rays intersected with the scene.
    pub rays: u64,
    /// Samples taken.
    pub samples: u64,
    /// Samples that were not finite (counted as black).
    pub non_finite: u64,
    /// Seconds the device was busy: on the CPU, the tiles' seconds summed over the threads;
    /// on the GPU, the seconds the host waited for it.
    pub busy_seconds: f64,
}

impl RoundCounts {
    /// The counts of two parts of a round together.
    pub fn plus(self, o: RoundCounts) -> RoundCounts {
        RoundCounts {
            rays: self.rays + o.rays,
            samples: self.samples + o.samples,
            non_finite: self.non_finite + o.non_finite,
            busy_seconds: self.busy_seconds + o.busy_seconds,
        }
    }
}

/// A shot on the CPU: its still spheres and their hierarchy, built once; its frames are
/// traced by the current rayon pool's threads, tile by tile.
#[derive(Debug)]
pub struct CpuShot {
    statics: StaticGeometry,
}

impl CpuShot {
    /// `scene`'s shot on the CPU, whatever device the scene names.
    pub fn new(scene: &Scene) -> CpuShot {
        CpuShot {
            statics: StaticGeometry::new(scene),
        }
    }
}

impl ShotTracer for CpuShot {
    fn statics(&self) -> &StaticGeometry {
        &self.statics
    }

    fn frame<'a>(
        &'a self,
        prepared: PreparedFrame<'a>,
        points: &'a FramePoints,
        layout: &SumLayout,
    ) -> Result<Box<dyn FrameTracer + 'a>, Error> {
        let scene = prepared.scene;
        let req = FrameRequest::from_scene(scene);
        let passes = (layout.stride > 0).then(|| {
            PassContext::new(
                *layout,
                &scene.spheres,
                scene.background,
                &scene.camera,
                scene.shot.fps,
                req.width,
                req.height,
            )
            .with_points(points)
        });
        Ok(Box::new(CpuFrame {
            prepared,
            req,
            passes,
        }))
    }
}
