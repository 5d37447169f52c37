//! `raytrace-render`: a shot rendered: the devices a run opens ([`devices`]), the stages that
//! finish a sampled frame ([`finish`]: denoise, history), a finished frame to its file
//! ([`output`]) and the memory a frame will hold ([`memory`]).
#![forbid(unsafe_code)]

pub mod devices;
pub mod finish;
pub mod memory;
pub mod output;
