//! Which device takes a frame's rounds of samples: the CPU's threads, tile by tile
//! ([`super::tiles`]), or the GPU ([`crate::gpu`]), which adds its runs' sums to the same film.
//! Everything else of a frame (its budget, adaptive rounds, denoising, figures) is one code
//! path in [`super::frame`].

use std::fmt;

use rayon::prelude::*;

use super::adaptive::Plan;
use super::tiles::{FrameSetup, TileCounts};
use crate::denoise::denoiser::DenoiseError;
use crate::error::Error;
use crate::film::Film;
use crate::gpu::{Gpu, GpuError, GpuFrame, GpuShot};
use crate::scene::{Device, Scene};
use crate::world::StaticGeometry;

/// What a shot keeps from frame to frame on the device that traces it: the CPU's
/// [`StaticGeometry`], or the shot's data uploaded to the GPU.
#[derive(Debug)]
pub enum ShotGeometry {
    Cpu(Box<StaticGeometry>),
    Gpu(Box<GpuShot>),
}

impl ShotGeometry {
    /// For `scene`'s `[render] device`: on the GPU, `gpu` (which must be given then).
    pub fn new(scene: &Scene, gpu: Option<&Gpu>) -> Result<ShotGeometry, Error> {
        match (scene.render.device, gpu) {
            (Device::Cpu, _) => Ok(ShotGeometry::Cpu(Box::new(StaticGeometry::new(scene)))),
            (Device::Gpu, Some(gpu)) => GpuShot::new(gpu, scene)
                .map(|s| ShotGeometry::Gpu(Box::new(s)))
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
            ShotGeometry::Gpu(s) => On::Gpu(s),
        }
    }
}

/// What a shot keeps, borrowed.
#[derive(Clone, Copy)]
pub(super) enum On<'a> {
    Cpu(&'a StaticGeometry),
    Gpu(&'a GpuShot),
}

/// A frame prepared on its device, ready for rounds of samples.
pub(super) enum Rounds<'a> {
    Cpu(Box<FrameSetup<'a>>),
    Gpu(Box<GpuFrame<'a>>),
}

impl Rounds<'_> {
    /// Spheres moving during the frame's exposure.
    pub(super) fn moving(&self) -> usize {
        match self {
            Rounds::Cpu(setup) => setup.world.moving,
            Rounds::Gpu(frame) => frame.moving(),
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
            Rounds::Gpu(frame) => {
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
                    seconds: c.seconds,
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
