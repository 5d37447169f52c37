//! `raytrace-core`: the renderer's core: the time model (shutters, shutter curves, motion),
//! geometry and its hierarchy, the camera, materials, samplers, the validated description of
//! a shot ([`scene::Scene`]), a frame prepared for tracing, the tracer, the film, and the
//! round loop that samples a frame on a device ([`renderer`]).
//!
//! Data flows one way: a validated [`scene::Scene`] → a [`prepared::PreparedFrame`] →
//! rounds of samples ([`renderer::FrameJob`], on a [`renderer::ShotTracer`]) → the raw
//! [`film::Film`]. Reading scene files, finishing frames and writing them are the crates
//! above this one.
#![forbid(unsafe_code)]

pub mod aabb;
mod bits;
pub mod bvh;
pub mod camera;
pub mod colormap;
pub mod error;
pub mod film;
pub mod format;
pub mod hit;
pub mod image;
mod lerp;
pub mod material;
pub mod metrics;
pub mod motion;
pub mod pages;
pub mod pass;
pub mod passes;
pub mod path_pattern;
pub mod points;
pub mod prepared;
pub mod ray;
pub mod renderer;
pub mod replicates;
pub mod rng;
pub mod sampler;
pub mod scene;
pub mod show;
pub mod shutter;
pub mod shutter_curve;
pub mod sphere;
#[cfg(test)]
mod testing;
pub mod traced_points;
pub mod tracer;
mod trig;
pub mod world;

pub use error::Error;
pub use scene::Scene;
