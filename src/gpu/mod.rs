//! The GPU tracer: the frame's path tracing as WGSL compute shaders run through wgpu (Vulkan,
//! Metal or DirectX 12), with the CPU tracer's integrand, time model and samplers, in `f32`.
//! Everything around it is the CPU's: the validated scene, the per-frame preparation (motions
//! prepared for the frame's interval, hierarchies built by [`crate::bvh`]), and the film the
//! runs' sums are added to, so frames, passes, budgets and files go through one path.
//!
//! - [`context`]: the device, the compiled shader, the errors ([`Gpu`], [`GpuError`]);
//! - [`support`]: what the GPU path refuses before rendering ([`unsupported`]);
//! - [`layout`]: where everything lies in the GPU's buffers, for the CPU and the shaders;
//! - [`flatten`]: a hierarchy flattened for the GPU, its only reader of one;
//! - [`upload`]: a shot's and a frame's words;
//! - [`shot`]: a shot and its frames on the GPU, rounds of samples into the film ([`GpuShot`]);
//! - [`dispatch`]: one batch of runs on the device and back;
//! - [`quiet`]: keeping a driver's stray `XDG_RUNTIME_DIR` line out of the output;
//! - `shaders/`: the WGSL, included in the binary.
//!
//! This file only declares and re-exports: the children import each other directly.

mod context;
mod dispatch;
mod flatten;
mod layout;
mod quiet;
mod shot;
mod support;
mod upload;

#[cfg(test)]
mod tests;

pub use context::{DRIVER_BYTES, Gpu, GpuError, LOSE_AFTER_VARIABLE};
pub use shot::{BYTES_PER_PIXEL, FIXED_BYTES, GpuFrame, GpuShot, RoundCounts};
pub use support::{
    CAMERA_FRACTION, MAX_BUFFER_BYTES, MAX_COORDINATE, MAX_SWEEP_DEGREES, MIN_PIXEL_ANGLE,
    MIN_RADIUS, MIN_RADIUS_FRACTION, Unsupported, unsupported,
};
