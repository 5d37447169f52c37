//! `raytrace-scene`: scene files read and validated into the core's [`raytrace_core::Scene`]
//! ([`scene_file`]), and the point caches a shot reads frame by frame ([`point_cache`],
//! through the PLY reader [`ply`] and the simulation readers [`sim`]); a fountain simulated
//! and written as a point cache ([`fountain`]).
#![forbid(unsafe_code)]

pub mod fountain;
pub mod ply;
pub mod point_cache;
pub mod scene_file;
mod sim;
