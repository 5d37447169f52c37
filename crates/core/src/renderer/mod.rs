//! Sampling one frame on a device (the CPU's tiles here, the GPU's in `raytrace_gpu`, through
//! [`ShotTracer`]): the frame prepared, its camera rays in parallel over the film, in one round
//! of the requested samples or, under a time or noise budget, in rounds until the budget is
//! met.
//!
//! - [`job`]: [`FrameJob`], one frame sampled into its raw film; its figures and result;
//! - [`tiles`]: what is fixed before the first sample, and one round over every tile;
//! - [`budget`]: when to stop, and the uniform rounds' sizes;
//! - [`adaptive`]: which pixels take more samples in an adaptive round;
//! - [`stop`]: when a frame under a noise threshold stops ([`StopRule`]);
//! - [`tracers`]: the seam between the rounds and the device that traces them
//!   ([`ShotTracer`], [`FrameTracer`]), and the CPU's ([`CpuShot`]);
//!
//! This file only declares and re-exports: the children import each other directly.

mod adaptive;
mod budget;
mod job;
mod stop;
mod tiles;
mod tracers;

pub use adaptive::{RoundPlan, Weights};
pub use budget::{Budget, StopReason};
pub use job::{Denoised, FrameJob, FrameResult, FrameStats};
pub use stop::{RawStop, StopRule, relative_error};
pub use tracers::{CpuShot, FrameTracer, RoundCounts, ShotTracer};
