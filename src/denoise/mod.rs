//! Denoising frames ([`denoiser`]: Intel Open Image Denoise), estimating the denoised
//! frame's error, bias included, from the film's two replicates ([`estimate`]), and carrying
//! a frame's pixels to the frames before it for temporal denoising ([`reproject`]). The
//! library is loaded when a frame is first denoised, from beside the binary ([`library`]).

pub mod denoiser;
pub mod estimate;
pub mod library;
pub mod reproject;

#[cfg(test)]
mod estimate_accuracy;
#[cfg(test)]
mod synthetic;
