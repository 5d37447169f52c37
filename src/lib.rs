//! `raytrace`: a renderer of animation sequences of moving spheres, with motion blur and
//! defocus blur, written as EXR or PNG frame sequences.
//!
//! Data flows one way:
//! scene file ([`scene_file`]) → validated [`scene::Scene`] → per-frame [`world::World`]
//! → [`tracer`] → [`film::Film`] → [`output`] file.
#![forbid(unsafe_code)]

pub mod aabb;
pub mod app;
pub mod bvh;
pub mod camera;
pub mod converge;
pub mod error;
pub mod film;
pub mod frames;
pub mod generate;
pub mod lerp;
pub mod material;
pub mod metrics;
pub mod motion;
pub mod output;
pub mod plot;
pub mod ray;
pub mod render;
pub mod rng;
pub mod sampler;
pub mod scene;
pub mod scene_file;
pub mod shutter;
pub mod sphere;
pub mod tracer;
pub mod world;

pub use error::Error;
pub use scene::Scene;
