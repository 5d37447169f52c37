//! `raytrace`: a renderer of animation sequences of moving spheres, with motion blur and
//! defocus blur, written as EXR or PNG frame sequences.
//!
//! Data flows one way:
//! scene file ([`scene`]: schema → validation) → validated [`scene::Scene`] → per-frame
//! [`world::World`] → [`tracer`] → [`film::Film`] → [`io`] file.
//!
//! The rendering core is flat, one concept per module; around it, [`scene`] reads scene
//! files, [`io`] writes and reads files, [`analysis`] measures images, and [`cli`] is the
//! command line.
#![forbid(unsafe_code)]

pub mod aabb;
pub mod analysis;
pub mod bvh;
pub mod camera;
pub mod cli;
mod clip;
pub mod colormap;
pub mod denoise;
pub mod devices;
pub mod error;
pub mod film;
pub mod finish;
pub mod format;
pub mod fountain;
pub mod gpu;
pub mod hit;
pub mod io;
mod lerp;
pub mod material;
pub mod memory;
pub mod metrics;
pub mod motion;
pub mod output;
pub mod pass;
pub mod passes;
pub mod path_pattern;
pub mod ply;
pub mod point_cache;
pub mod points;
pub mod prepared;
mod preview;
pub mod ray;
pub mod renderer;
pub mod replicates;
pub mod rng;
pub mod sampler;
pub mod scene;
pub mod scene_file;
pub mod show;
pub mod shutter;
pub mod shutter_curve;
pub mod sim;
pub mod sphere;
pub mod traced_points;
pub mod tracer;
pub mod trig;
pub mod world;

pub use error::Error;
pub use scene::Scene;
