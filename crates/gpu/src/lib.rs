//! The GPU tracer: the frame's path tracing as WGSL compute shaders run through wgpu (Vulkan,
//! Metal or DirectX 12), with the CPU tracer's integrand, time model and samplers, in `f32`.
//! Everything around it is the CPU's: the validated scene, the frame's preparation
//! ([`raytrace_core::prepared::PreparedFrame`], which the upload only copies), the rounds and the film
//! each round's sums are added to, so frames, passes, budgets and files go through one path.
//!
//! - `context`: the adapter, the device, the compiled shader, the errors ([`Adapter`],
//!   [`Gpu`], [`GpuError`]);
//! - `support`: what the GPU path refuses before rendering ([`unsupported`]);
//! - `layout`: where everything lies in the GPU's buffers, for the CPU and the shaders;
//! - `pages`: the shot's and the frame's words over several bindings ([`Pages`]);
//! - `flatten`: a hierarchy flattened for the GPU, its only reader of one;
//! - `upload`: a shot's and a frame's words, serialised from the CPU's preparation;
//! - `shot`: a shot and its frames on the GPU, rounds of samples into the film ([`GpuShot`]);
//! - `device_film`: the film on the device, its dispatches and what comes back;
//! - `schedule`: a round's windows of dispatches, sized by the device's pace;
//! - `disk_cache`: the tracer's pipeline cache on disk ([`CACHE_VARIABLE`]);
//! - `startup`: how long a GPU took to start (`Startup`);
//! - `quiet`: keeping a driver's stray `XDG_RUNTIME_DIR` line out of the output;
//! - `shaders/`: the WGSL, included in the binary.
//!
//! This file only declares and re-exports: the children import each other directly.
// `deny`, not `forbid`: one function (`disk_cache::created`) allows wgpu's one unsafe call a
// pipeline cache needs, with its reasoning beside it.
#![deny(unsafe_code)]

mod context;
mod device_film;
mod disk_cache;
mod flatten;
mod layout;
mod pages;
mod quiet;
mod schedule;
mod shot;
mod startup;
mod support;
mod upload;

#[cfg(test)]
mod tests;

pub use context::{Adapter, Gpu, GpuError, LOSE_AFTER_VARIABLE, MAX_BINDING_VARIABLE};
pub use disk_cache::CACHE_VARIABLE;
pub use pages::Pages;
pub use shot::GpuShot;
pub use support::{Unsupported, frame_bytes, too_large, unsupported};
