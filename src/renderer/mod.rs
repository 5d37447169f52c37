//! Rendering one frame on the CPU (or on the GPU, [`crate::gpu`]): the frame's world, its camera rays, in parallel over the
//! film's tiles, in one round of the requested samples or, under a time or noise budget, in
//! rounds until the budget is met.
//!
//! - [`frame`]: [`FrameJob`], one frame sampled into its raw film; its figures and result;
//! - [`tiles`]: what is fixed before the first sample, and one round over every tile;
//! - [`budget`]: when to stop, and the uniform rounds' sizes;
//! - [`adaptive`]: which pixels take more samples in an adaptive round;
//! - [`stop`]: when a frame under a noise threshold stops ([`StopRule`]);
//! - [`finish`]: the stages that finish a sampled frame for writing ([`Finishing`]): the
//!   raw and denoised frames blended;
//! - [`device`]: which device takes a frame's rounds (the CPU's tiles or the GPU), and what a
//!   shot keeps on it ([`ShotGeometry`]);
//!
//! This file only declares and re-exports: the children import each other directly.

mod adaptive;
mod budget;
mod device;
mod finish;
mod frame;
mod stop;
mod tiles;

pub use crate::film::TILE;
pub use adaptive::Weights;
pub use budget::{Budget, MIN_SAMPLES_FOR_THRESHOLD, StopReason, next_round};
pub use device::{FrameError, ShotGeometry};
pub use finish::{Denoising, Finishing, MAX_DENOISES, passes_read};
pub use frame::{Denoised, FrameJob, FrameResult, FrameStats};
pub use stop::{RawStop, StopRule, relative_error};
