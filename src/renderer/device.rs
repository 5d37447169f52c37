//! Which device takes a frame's rounds of samples: the CPU's threads, tile by tile
//! ([`super::tiles`]), or the GPU ([`crate::gpu`]), which adds each round's sums to the same
//! film. Both take the same [`PreparedFrame`]; everything else of a frame (its budget,
//! adaptive rounds, denoising, figures) is one code path in [`super::frame`].

use std::fmt;

use rayon::prelude::*;

use super::adaptive::Plan;
use super::tiles::{FrameRequest, FrameSetup, TileCounts};
use crate::denoise::denoiser::DenoiseError;
use crate::error::Error;
use crate::film::Film;
use crate::gpu::{Gpu, GpuError, GpuFrame, GpuShot};
use crate::passes::{Layout, PassContext};
use crate::points::FramePoints;
use crate::prepared::PreparedFrame;
use crate::scene::{Device, Scene};
use crate::world::StaticGeometry;

/// What a shot keeps from frame to frame: its [`StaticGeometry`] (the spheres that never
/// move, with their hierarchy), and on the GPU the shot's data uploaded from it.
#[derive(Debug)]
pub enum ShotGeometry {
    Cpu(Box<StaticGeometry>),
    Gpu(Box<StaticGeometry>, Box<GpuShot>),
}

impl ShotGeometry {
    /// For `scene`'s `[render] device`: on the GPU, `gpu` (which must be given then).
    pub fn new(scene: &Scene, gpu: Option<&Gpu>) -> Result<ShotGeometry, Error> {
        let statics = Box::new(StaticGeometry::new(scene));
        match (scene.render.device, gpu) {
            (Device::Cpu, _) => Ok(ShotGeometry::Cpu(statics)),
            (Device::Gpu, Some(gpu)) => GpuShot::new(gpu, scene, &statics)
                .map(|s| ShotGeometry::Gpu(statics, Box::new(s)))
                .map_err(|e| Error::Resource(e.to_string())),
            (Device::Gpu, None) => Err(Error::Resource(
                "the scene asks for the GPU and no GPU was opened".to_string(),
            )),
        }
    }

    /// The CPU's: `scene`'s static geometry, whatever device the scene names.
    pub fn cpu(scene: &Scene) -> ShotGeometry {
        ShotGeometry::Cpu(Box::new(StaticGeometry::new(scene)))
    }

    /// The device's state, borrowed.
    pub(super) fn on(&self) -> On<'_> {
        match self {
            ShotGeometry::Cpu(s) => On::Cpu(s),
            ShotGeometry::Gpu(s, g) => On::Gpu(s, g),
        }
    }
}

/// What a shot keeps, borrowed.
#[derive(Clone, Copy)]
pub(super) enum On<'a> {
    Cpu(&'a StaticGeometry),
    Gpu(&'a StaticGeometry, &'a GpuShot),
}

impl<'a> On<'a> {
    /// The shot's still spheres.
    pub(super) fn statics(self) -> &'a StaticGeometry {
        match self {
            On::Cpu(s) | On::Gpu(s, _) => s,
        }
    }
}

/// A frame prepared on its device, ready for rounds of samples.
pub(super) enum Rounds<'a> {
    Cpu(Box<FrameSetup<'a>>),
    Gpu(Box<GpuFrame<'a>>, usize),
}

impl<'a> Rounds<'a> {
    /// The frame `prepared` (with `points`, the frame's points, among its spheres) made ready
    /// on `on`'s device, for a film kept by `layout`: on the CPU with its passes' context,
    /// on the GPU uploaded. The GPU renders no point caches.
    pub(super) fn new(
        on: On<'a>,
        prepared: PreparedFrame<'a>,
        points: &'a FramePoints,
        req: &'a FrameRequest,
        layout: &Layout,
    ) -> Result<Rounds<'a>, GpuError> {
        match on {
            On::Cpu(_) => {
                let scene = prepared.scene;
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
                Ok(Rounds::Cpu(Box::new(FrameSetup {
                    prepared,
                    req,
                    passes,
                })))
            }
            // Unreachable from a validated scene: one with `[[points]]` is refused for the GPU.
            On::Gpu(..) if !points.is_empty() => Err(GpuError::Failed(
                "the GPU renders no point caches".to_string(),
            )),
            On::Gpu(_, shot) => {
                let frame = shot.frame(&prepared, layout)?;
                Ok(Rounds::Gpu(Box::new(frame), prepared.world.moving))
            }
        }
    }

    /// Spheres moving during the frame's exposure.
    pub(super) fn moving(&self) -> usize {
        match self {
            Rounds::Cpu(setup) => setup.prepared.world.moving,
            Rounds::Gpu(_, moving) => *moving,
        }
    }

    /// Bytes read back from the device so far (0 on the CPU).
    pub(super) fn readback_bytes(&self) -> u64 {
        match self {
            Rounds::Cpu(_) => 0,
            Rounds::Gpu(frame, _) => frame.readback_bytes(),
        }
    }

    /// Takes the samples of one round (`plan`) in every pixel of `film`.
    pub(super) fn round(
        &mut self,
        film: &mut Film,
        plan: &Plan<'_>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<TileCounts, GpuError> {
        match self {
            Rounds::Cpu(setup) => Ok(setup.round(film, plan, progress)),
            Rounds::Gpu(frame, _) => {
                // Each pixel's target, in the film's storage order, decided tile by tile as
                // the CPU's tiles decide them.
                let targets: Vec<u32> = film
                    .tiles()
                    .par_iter()
                    .map(|(rect, pixels)| {
                        let mut t = Vec::with_capacity(pixels.len());
                        plan.targets(rect, pixels, &mut t);
                        t
                    })
                    .collect::<Vec<_>>()
                    .concat();
                let c = frame.round(film, &targets, progress)?;
                Ok(TileCounts {
                    rays: c.rays,
                    samples: c.samples,
                    non_finite: c.non_finite,
                    seconds: c.wait_seconds,
                })
            }
        }
    }
}

/// Why a frame could not be rendered.
#[derive(Debug)]
pub enum FrameError {
    Denoise(DenoiseError),
    Gpu(GpuError),
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::Denoise(e) => write!(f, "{e}"),
            FrameError::Gpu(e) => write!(f, "{e}"),
        }
    }
}

impl From<DenoiseError> for FrameError {
    fn from(e: DenoiseError) -> Self {
        FrameError::Denoise(e)
    }
}

impl From<GpuError> for FrameError {
    fn from(e: GpuError) -> Self {
        FrameError::Gpu(e)
    }
}
