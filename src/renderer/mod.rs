//! Rendering one frame on the CPU (or on the GPU, [`crate::gpu`]): the frame's world, its camera rays, in parallel over the
//! film's tiles, in one round of the requested samples or, under a time or noise budget, in
//! rounds until the budget is met.
//!
//! - [`frame`]: [`render_frame`], the frame's figures and result;
//! - [`tiles`]: what is fixed before the first sample, and one round over every tile;
//! - [`budget`]: when to stop, and the uniform rounds' sizes;
//! - [`adaptive`]: which pixels take more samples in an adaptive round;
//! - [`denoised`]: a film denoised, and the denoised frame's estimated error;
//! - [`device`]: which device takes a frame's rounds (the CPU's tiles or the GPU), and what a
//!   shot keeps on it ([`ShotGeometry`]);
//! - [`temporal`]: frames denoised with the frames before them.
//!
//! This file only declares and re-exports: the children import each other directly.

mod adaptive;
mod budget;
mod denoised;
mod device;
mod frame;
mod temporal;
mod tiles;

pub use crate::film::TILE;
pub use budget::{Budget, MIN_SAMPLES_FOR_THRESHOLD, StopReason, next_round};
pub use denoised::Denoised;
pub use device::ShotGeometry;
pub use frame::{
    FrameResult, FrameStats, relative_error, render_frame, render_frame_denoised,
    render_frame_with, render_shot_frame, render_shot_frame_with,
};
pub use temporal::TemporalDenoiser;
