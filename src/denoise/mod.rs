//! Denoising frames ([`denoiser`]: Intel Open Image Denoise) and estimating the denoised
//! frame's error, bias included, from the film's two replicates ([`estimate`]).

pub mod denoiser;
pub mod estimate;

#[cfg(test)]
mod estimate_accuracy;
#[cfg(test)]
mod synthetic;
