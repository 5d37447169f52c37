//! One batch of runs on the GPU: the runs written to the device, one invocation each, and
//! their output records read back. The buffers are a frame's, kept from batch to batch and
//! grown when a batch needs more.

use super::context::{Gpu, GpuError, classify, workgroups};
use super::layout::Words;

/// A run of one pixel's samples: its pixel (x, y), its first sample index and its count.
pub(super) type Run = [u32; 4];

/// The buffers of a frame's batches.
pub(super) struct Batches {
    runs: wgpu::Buffer,
    out: wgpu::Buffer,
    staging: wgpu::Buffer,
    params: wgpu::Buffer,
    bind: wgpu::BindGroup,
    /// Runs the buffers hold.
    capacity: u32,
    /// Words of an output record.
    record: u32,
}

impl Batches {
    /// Buffers for batches of up to `capacity` runs of `record` words of output each, bound
    /// with the shot's and the frame's buffers.
    pub(super) fn new(
        gpu: &Gpu,
        shot: &wgpu::Buffer,
        frame: &wgpu::Buffer,
        capacity: u32,
        record: u32,
    ) -> Result<Batches, GpuError> {
        let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let buffer = |label, size: u64, usage| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        let out_bytes = capacity as u64 * record as u64 * 4;
        let runs = buffer("runs", capacity as u64 * 16, U::STORAGE | U::COPY_DST);
        let out = buffer("out", out_bytes, U::STORAGE | U::COPY_SRC);
        let staging = buffer("staging", out_bytes, U::MAP_READ | U::COPY_DST);
        let params = buffer("params", 16, U::UNIFORM | U::COPY_DST);
        let bind = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tracer"),
            layout: &gpu.layout,
            entries: &[
                entry(0, shot),
                entry(1, frame),
                entry(2, &runs),
                entry(3, &out),
                entry(4, &params),
                entry(5, shot),
                entry(6, frame),
            ],
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(classify(&e));
        }
        Ok(Batches {
            runs,
            out,
            staging,
            params,
            bind,
            capacity,
            record,
        })
    }

    /// Runs the batches take at most.
    pub(super) fn capacity(&self) -> u32 {
        self.capacity
    }

    /// Traces `runs` (at most [`capacity`](Self::capacity)) and returns their output records,
    /// `record` words each, in order.
    pub(super) fn run(&self, gpu: &Gpu, runs: &[Run]) -> Result<Vec<u32>, GpuError> {
        self.run_with(gpu, &gpu.pipeline, runs)
    }

    /// [`run`](Self::run) with another entry point of the shaders, on the same bindings.
    pub(super) fn run_with(
        &self,
        gpu: &Gpu,
        pipeline: &wgpu::ComputePipeline,
        runs: &[Run],
    ) -> Result<Vec<u32>, GpuError> {
        let n = runs.len() as u32;
        assert!(n <= self.capacity, "a batch larger than its buffers");
        if n == 0 {
            return Ok(Vec::new());
        }
        let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let mut words = Words::default();
        runs.iter().flatten().for_each(|&w| words.u(w));
        gpu.queue.write_buffer(&self.runs, 0, &words.bytes());
        let params = Words(vec![n, self.record, 0, 0]);
        gpu.queue.write_buffer(&self.params, 0, &params.bytes());
        let bytes = n as u64 * self.record as u64 * 4;
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("trace"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &self.bind, &[]);
            pass.dispatch_workgroups(workgroups(n), 1, 1);
        }
        encoder.copy_buffer_to_buffer(&self.out, 0, &self.staging, 0, bytes);
        gpu.queue.submit([encoder.finish()]);
        gpu.count_dispatch();
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(classify(&e));
        }
        let slice = self.staging.slice(..bytes);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        let fault = |why: String| gpu.fault().unwrap_or(GpuError::Lost(why));
        // Waits for the copy, then for the mapping's callback, which another thread's poll
        // of the same device may be the one to call.
        let mapped = loop {
            if let Err(e) = gpu.device.poll(wgpu::PollType::wait_indefinitely()) {
                return Err(fault(e.to_string()));
            }
            match rx.recv_timeout(std::time::Duration::from_millis(20)) {
                Ok(r) => break r,
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                    if let Some(e) = gpu.fault() {
                        return Err(e);
                    }
                }
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(fault("the results never came back".to_string()));
                }
            }
        };
        if let Err(e) = mapped {
            return Err(fault(format!("reading the results back: {e}")));
        }
        let out = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| fault(format!("reading the results back: {e}")))?;
            view.chunks_exact(4)
                .map(|b| u32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
                .collect()
        };
        self.staging.unmap();
        if let Some(e) = gpu.fault() {
            return Err(e);
        }
        Ok(out)
    }
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}
