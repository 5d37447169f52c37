//! Denoising frames ([`denoiser`]: Intel Open Image Denoise, on the device [`device`] opens), the written frame blended from
//! the raw and denoised frames with its error estimated from the film's two replicates
//! ([`estimate`]), and the history route's combination of a frame with its earlier frames
//! ([`reproject`] carries them to its pixels, [`history`] weighs them). The library is loaded
//! when a frame is first denoised, from beside the binary ([`library`]).
#![forbid(unsafe_code)]

pub mod accumulate;
pub mod change;
pub mod denoiser;
pub mod device;
pub mod estimate;
pub mod history;
pub mod library;
pub mod reproject;

#[cfg(test)]
mod change_accuracy;
#[cfg(test)]
mod estimate_accuracy;
#[cfg(test)]
mod synthetic;
