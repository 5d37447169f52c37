//! The one place the preview calls the renderer: a frame of a scene at the scene's own size
//! and samples (the worker makes the scene at the size and sample count it wants, through the
//! validator), its point caches read for the frame, on the device the shot's geometry was
//! is on, denoised when the scene says so. The same call `render` makes, so a frame's
//! pixels are those `render --frames N` writes at the same size and samples.

use raytrace_core::error::Error;
use raytrace_core::renderer::{FrameJob, FrameResult, ShotTracer};
use raytrace_core::scene::Scene;
use raytrace_render::devices::Devices;
use raytrace_scene::point_cache;

/// Renders `frame` of `scene` with exactly its samples in every pixel on `tracer`'s device,
/// finished as `render` finishes it (denoised when the scene asks, by `devices`' denoiser).
pub(crate) fn render_frame(
    scene: &Scene,
    devices: &Devices,
    tracer: &dyn ShotTracer,
    frame: u32,
) -> Result<FrameResult, Error> {
    let points = point_cache::read_frame(scene, frame)?;
    let job = FrameJob::new(scene, frame).points(&points);
    devices.finishing(scene)?.render(job, tracer)
}
