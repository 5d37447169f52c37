//! Denoising frames ([`denoiser`]: Intel Open Image Denoise), estimating the denoised
//! frame's error, bias included, from the film's two replicates ([`estimate`]), and carrying
//! a frame's pixels to the frames before it for temporal denoising ([`reproject`]).

pub mod denoiser;
pub mod estimate;
pub mod reproject;

#[cfg(test)]
mod estimate_accuracy;
#[cfg(test)]
mod synthetic;
