//! The film on the device: a round's per-pixel sums kept in a device buffer across the
//! round's dispatches, read back once at its end and added to the CPU's film.
//!
//! The film's pixels are taken in *parts*, runs of its storage order small enough for one
//! buffer binding (all of a 1920x1080 frame without passes is one part). A part's sums are
//! planes of words ([`super::layout`], `FILM_*`): the colour's sum compensated (a high and a
//! low `f32`, about 48 bits, renormalised after each sample), the odd samples' sum (`f32`, as the CPU's film keeps it), the
//! pass sums compensated. At a part's start they are cleared and its work entries written;
//! dispatches add samples to them; at its end they are copied to a buffer the CPU maps, and
//! each pixel's round is added to its `f64` sums ([`merge`]). A round reads back, per pixel,
//! 36 bytes and 8 per pass sum: less than the film holds.
//!
//! Each dispatch has a slot of parameters and counts (two slots: the next dispatch is
//! recorded and submitted while the last runs), its counts read back when it is done: 32
//! bytes a dispatch.

use std::sync::mpsc;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::context::{Gpu, GpuError, classify, workgroups};
use super::layout::*;
use super::schedule::Dispatch;
use raytrace_core::film::Pixel;

/// Dispatches in flight at most.
pub(super) const SLOTS: usize = 2;

/// Loop iterations after which an invocation starts no other sample (`P_BUDGET`), on a
/// software device: well under the 65,535 after which lavapipe ends every loop of an
/// invocation (its lanes' loops run together, so an invocation's count is below the device's).
const SOFTWARE_BUDGET: u32 = 16_384;

/// The same on a hardware device, which has no such limit: a bound on an invocation's time.
const HARDWARE_BUDGET: u32 = 1 << 24;

/// A frame's film on the device and the buffers of its dispatches.
pub(super) struct DeviceFilm {
    /// Planes of a pixel, and pixels a part holds at most.
    planes: u32,
    part: u32,
    budget: u32,
    sums: wgpu::Buffer,
    staging: wgpu::Buffer,
    work: wgpu::Buffer,
    params: wgpu::Buffer,
    counts: wgpu::Buffer,
    counts_staging: [wgpu::Buffer; SLOTS],
    bind: wgpu::BindGroup,
    /// Bytes read back so far.
    pub(super) readback: u64,
}

/// What a dispatch did, by its counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Counts {
    pub(super) samples: u64,
    pub(super) rays: u64,
    pub(super) non_finite: u64,
    /// Invocations whose window the device cut (discarded).
    pub(super) cut: u64,
}

/// A dispatch submitted: its queue index, its slot, when it was submitted and where its
/// counts' mapping reports.
pub(super) struct Submitted {
    pub(super) dispatch: Dispatch,
    /// How long the submission took: the dispatch's whole run on a device that runs it
    /// within the submission (lavapipe), next to nothing elsewhere.
    pub(super) submitting: std::time::Duration,
    pub(super) at: Instant,
    index: wgpu::SubmissionIndex,
    slot: usize,
    mapped: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

impl DeviceFilm {
    /// The film of a frame of `pixels` pixels with `stride` pass sums each, bound with the
    /// pages of the shot's and the frame's words (`words`, in that order).
    pub(super) fn new(
        gpu: &Gpu,
        words: [&[wgpu::Buffer]; 2],
        pixels: usize,
        stride: u32,
    ) -> Result<DeviceFilm, GpuError> {
        let planes = film_planes(stride);
        // Parts within WebGPU's binding size too, whatever the device binds: the memory
        // estimate ([`film_bytes`]) counts parts of at most that size, and larger parts
        // would only save a read-back now and then.
        let mut limits = gpu.device.limits();
        limits.max_storage_buffer_binding_size = limits
            .max_storage_buffer_binding_size
            .min(wgpu::Limits::default().max_storage_buffer_binding_size);
        let part = part_pixels(pixels as u64, planes, &limits) as u32;
        let budget = if gpu.is_software() {
            SOFTWARE_BUDGET
        } else {
            HARDWARE_BUDGET
        };
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
        let sums_bytes = part as u64 * planes as u64 * 4;
        let sums = buffer("film", sums_bytes, U::STORAGE | U::COPY_SRC | U::COPY_DST);
        let staging = buffer("film read back", sums_bytes, U::MAP_READ | U::COPY_DST);
        let work = buffer("work", part as u64 * 16, U::STORAGE | U::COPY_DST);
        let slots = SLOTS as u64 * SLOT_BYTES;
        let params = buffer("params", slots, U::UNIFORM | U::COPY_DST);
        let counts = buffer("counts", slots, U::STORAGE | U::COPY_SRC | U::COPY_DST);
        let counts_staging = std::array::from_fn(|_| {
            buffer(
                "counts read back",
                4 * COUNTER_WORDS as u64,
                U::MAP_READ | U::COPY_DST,
            )
        });
        // A page the words do not reach is bound to a quad of nothing.
        let unused = buffer("no words", 16, U::STORAGE);
        let mut entries = vec![
            whole(2, &work),
            whole(3, &sums),
            slot(4, &params, PARAMS_WORDS),
            slot(7, &counts, COUNTER_WORDS),
        ];
        for (first, pages) in [SHOT_PAGES, FRAME_PAGES].into_iter().zip(words) {
            for k in 0..gpu.tracer().pages.count() {
                let page = pages.get(k as usize).unwrap_or(&unused);
                entries.push(whole(first + k, page));
            }
        }
        if gpu.tracer().pages.count() == 1 {
            entries.push(whole(FRAME_WORDS, words[1].first().unwrap_or(&unused)));
        }
        let bind = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tracer"),
            layout: &gpu.tracer().layout,
            entries: &entries,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(classify(&e));
        }
        Ok(DeviceFilm {
            planes,
            part,
            budget,
            sums,
            staging,
            work,
            params,
            counts,
            counts_staging,
            bind,
            readback: 0,
        })
    }

    /// Pixels a part holds at most.
    pub(super) fn part(&self) -> usize {
        self.part as usize
    }

    /// Starts a part of `pixels` pixels: its sums cleared, its work `entries` written.
    /// Returns the seconds the submission took (the device's, on a device that runs it
    /// within the submission).
    pub(super) fn begin(&self, gpu: &Gpu, pixels: usize, entries: &[[u32; 4]]) -> f64 {
        let bytes: Vec<u8> = entries
            .iter()
            .flatten()
            .flat_map(|w| w.to_ne_bytes())
            .collect();
        gpu.queue.write_buffer(&self.work, 0, &bytes);
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        if pixels > 0 {
            encoder.clear_buffer(&self.sums, 0, Some(self.part_bytes(pixels)));
        }
        let commands = encoder.finish();
        let start = Instant::now();
        gpu.queue.submit([commands]);
        start.elapsed().as_secs_f64()
    }

    fn part_bytes(&self, pixels: usize) -> u64 {
        pixels as u64 * self.planes as u64 * 4
    }

    /// Records and submits `dispatch` in a part of `pixels` pixels, with slot `slot` (not in
    /// use: its last dispatch is back).
    pub(super) fn submit(
        &self,
        gpu: &Gpu,
        dispatch: Dispatch,
        pixels: usize,
        slot: usize,
    ) -> Submitted {
        let offset = slot as u64 * SLOT_BYTES;
        let mut params = [0u32; PARAMS_WORDS as usize];
        params[P_FIRST as usize] = dispatch.first;
        params[P_ENTRIES as usize] = dispatch.count;
        params[P_SAMPLES as usize] = dispatch.k;
        params[P_PIXELS as usize] = pixels as u32;
        params[P_BUDGET as usize] = self.budget;
        let bytes: Vec<u8> = params.iter().flat_map(|w| w.to_ne_bytes()).collect();
        gpu.queue.write_buffer(&self.params, offset, &bytes);
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        let count_bytes = 4 * COUNTER_WORDS as u64;
        encoder.clear_buffer(&self.counts, offset, Some(count_bytes));
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("trace"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&gpu.tracer().pipeline);
            let dynamic = offset as u32;
            pass.set_bind_group(0, &self.bind, &[dynamic, dynamic]);
            pass.dispatch_workgroups(workgroups(dispatch.count), 1, 1);
        }
        let staging = &self.counts_staging[slot];
        encoder.copy_buffer_to_buffer(&self.counts, offset, staging, 0, count_bytes);
        let commands = encoder.finish();
        let start = Instant::now();
        let index = gpu.queue.submit([commands]);
        let at = Instant::now();
        gpu.count_dispatch();
        let (tx, mapped) = mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        Submitted {
            dispatch,
            submitting: at - start,
            at,
            index,
            slot,
            mapped,
        }
    }

    /// Waits for `s` and reads its counts.
    pub(super) fn wait(&mut self, gpu: &Gpu, s: Submitted) -> Result<Counts, GpuError> {
        let staging = &self.counts_staging[s.slot];
        let words = read(
            gpu,
            staging,
            4 * COUNTER_WORDS as u64,
            &s.index,
            &s.mapped,
            |v| {
                v.chunks_exact(4)
                    .map(|b| u32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
                    .collect::<Vec<u32>>()
            },
        )?;
        self.readback += 4 * COUNTER_WORDS as u64;
        let wide = |k: u32| words[k as usize] as u64 | (words[k as usize + 1] as u64) << 32;
        Ok(Counts {
            samples: wide(C_SAMPLES),
            rays: wide(C_RAYS),
            non_finite: wide(C_NON_FINITE),
            cut: wide(C_CUT),
        })
    }

    /// Reads back the sums of the part of `pixels` pixels under way (its dispatches
    /// submitted) and hands them, planes of `pixels` words, to `take` once the device has
    /// them (the time until then is the host's waiting).
    pub(super) fn read_part<T>(
        &mut self,
        gpu: &Gpu,
        pixels: usize,
        take: impl FnOnce(&[u8]) -> T,
    ) -> Result<T, GpuError> {
        self.read_sums(gpu, self.part_bytes(pixels), take)
    }

    /// Reads back the first `bytes` bytes of the sums' buffer and hands them to `take`.
    fn read_sums<T>(
        &mut self,
        gpu: &Gpu,
        bytes: u64,
        take: impl FnOnce(&[u8]) -> T,
    ) -> Result<T, GpuError> {
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        encoder.copy_buffer_to_buffer(&self.sums, 0, &self.staging, 0, bytes);
        let index = gpu.queue.submit([encoder.finish()]);
        let (tx, mapped) = mpsc::channel();
        self.staging
            .slice(..bytes)
            .map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
        let out = read(gpu, &self.staging, bytes, &index, &mapped, take)?;
        self.readback += bytes;
        Ok(out)
    }
}

#[cfg(test)]
impl DeviceFilm {
    /// The sampler's numbers of each sample `(x, y, index, uses)` (the `numbers` entry
    /// point, trace.wgsl): [`NUMBERS`] words each.
    pub(super) fn numbers(
        &mut self,
        gpu: &Gpu,
        samples: &[[u32; 4]],
    ) -> Result<Vec<u32>, GpuError> {
        let n = samples.len();
        let words = n * NUMBERS as usize;
        assert!(n <= self.part() && words <= self.part() * self.planes as usize);
        let _ = self.begin(gpu, 0, samples);
        let mut params = [0u32; PARAMS_WORDS as usize];
        params[P_ENTRIES as usize] = n as u32;
        let bytes: Vec<u8> = params.iter().flat_map(|w| w.to_ne_bytes()).collect();
        gpu.queue.write_buffer(&self.params, 0, &bytes);
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("numbers"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&gpu.tracer().numbers);
            pass.set_bind_group(0, &self.bind, &[0, 0]);
            pass.dispatch_workgroups(workgroups(n as u32), 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        self.read_sums(gpu, 4 * words as u64, |v| {
            v.chunks_exact(4)
                .map(|b| u32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
                .collect()
        })
    }
}

/// Pixels a part of a film of `pixels` pixels of `planes` planes holds, with a device's
/// `limits`: its sums and its work entries each within one buffer binding.
pub(super) fn part_pixels(pixels: u64, planes: u32, limits: &wgpu::Limits) -> u64 {
    let binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    (binding / (4 * planes as u64))
        .min(binding / 16)
        .min(pixels.max(1))
        .min(u32::MAX as u64)
}

/// Bytes the film on the device and its read-back buffers hold, for a film of `pixels`
/// pixels with `stride` pass sums each: a part's sums, the buffer they are read back
/// through and its work entries (with their copy on the host), the dispatches' slots.
pub(super) fn film_bytes(pixels: u64, stride: u32) -> u64 {
    let planes = film_planes(stride);
    let part = part_pixels(pixels, planes, &wgpu::Limits::default());
    2 * part * planes as u64 * 4
        + 2 * part * 16
        + SLOTS as u64 * (SLOT_BYTES + 4 * COUNTER_WORDS as u64) * 2
}

/// A binding of the whole of `buffer`.
fn whole(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// A binding of a dispatch's slot of `buffer`, `words` long (at the dispatch's offset).
fn slot(binding: u32, buffer: &wgpu::Buffer, words: u32) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer,
            offset: 0,
            size: std::num::NonZeroU64::new(4 * words as u64),
        }),
    }
}

/// Waits for submission `index`, then for the mapping of `buffer`'s first `bytes` (reported
/// on `mapped`), hands them to `take` and unmaps.
fn read<T>(
    gpu: &Gpu,
    buffer: &wgpu::Buffer,
    bytes: u64,
    index: &wgpu::SubmissionIndex,
    mapped: &mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
    take: impl FnOnce(&[u8]) -> T,
) -> Result<T, GpuError> {
    let fault = |why: String| gpu.fault().unwrap_or(GpuError::Lost(why));
    let wait = wgpu::PollType::Wait {
        submission_index: Some(index.clone()),
        timeout: None,
    };
    if let Err(e) = gpu.device.poll(wait) {
        return Err(fault(e.to_string()));
    }
    // The mapping's callback runs in a poll: ours, or another thread's on the same device.
    let result = loop {
        match mapped.recv_timeout(std::time::Duration::from_millis(20)) {
            Ok(r) => break r,
            Err(mpsc::RecvTimeoutError::Timeout) => {
                if let Some(e) = gpu.fault() {
                    return Err(e);
                }
                if let Err(e) = gpu.device.poll(wgpu::PollType::Poll) {
                    return Err(fault(e.to_string()));
                }
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                return Err(fault("the results never came back".to_string()));
            }
        }
    };
    if let Err(e) = result {
        return Err(fault(format!("reading the results back: {e}")));
    }
    let out = {
        let view = buffer
            .get_mapped_range(..bytes)
            .map_err(|e| fault(format!("reading the results back: {e}")))?;
        take(&view)
    };
    buffer.unmap();
    if let Some(e) = gpu.fault() {
        return Err(e);
    }
    Ok(out)
}

/// Pixels a thread merges at a time.
const CHUNK: usize = 4096;

/// Adds a part's round, read back as `words` (its planes, `FILM_*`, of `pixels.len()` words
/// each), to its `pixels` and their pass `sums` (`stride` a pixel): each pixel takes the
/// samples up to its target (`targets`), the colour's sum as its high and low words added
/// in `f64`. A colour sum that is not finite (a driver may fold the shader's own test away)
/// is counted as black, as the CPU's film counts a non-finite sample, and a pass sum that is
/// not finite as 0. Returns the samples counted as black.
pub(super) fn merge(
    words: &[u8],
    pixels: &mut [Pixel],
    sums: &mut [f64],
    targets: &[u32],
    stride: usize,
) -> u64 {
    let n = pixels.len();
    assert_eq!(targets.len(), n);
    assert_eq!(sums.len(), n * stride);
    assert!(words.len() >= 4 * n * film_planes(stride as u32) as usize);
    let plane = |k: u32, i: usize| {
        let at = 4 * (k as usize * n + i);
        f32::from_ne_bytes([words[at], words[at + 1], words[at + 2], words[at + 3]])
    };
    let mut sum_chunks: Vec<&mut [f64]> = match stride {
        0 => (0..n.div_ceil(CHUNK)).map(|_| Default::default()).collect(),
        _ => sums.chunks_mut(CHUNK * stride).collect(),
    };
    pixels
        .par_chunks_mut(CHUNK)
        .zip(sum_chunks.par_iter_mut())
        .enumerate()
        .map(|(c, (pixels, sums))| {
            let mut black = 0;
            for (j, p) in pixels.iter_mut().enumerate() {
                let i = c * CHUNK + j;
                let count = targets[i].saturating_sub(p.taken());
                if count == 0 {
                    continue;
                }
                let wide =
                    |k: u32| plane(FILM_SUM + k, i) as f64 + plane(FILM_SUM_LOW + k, i) as f64;
                let mut sum = DVec3::new(wide(0), wide(1), wide(2));
                let mut odd = [0, 1, 2].map(|k| plane(FILM_ODD + k, i));
                if !(sum.is_finite() && odd.iter().all(|o| o.is_finite())) {
                    (sum, odd) = (DVec3::ZERO, [0.0; 3]);
                    black += count as u64;
                }
                p.add_run(sum, odd, count);
                for (k, s) in sums[j * stride..(j + 1) * stride].iter_mut().enumerate() {
                    let k = k as u32;
                    let v = plane(FILM_PASSES + k, i) as f64
                        + plane(FILM_PASSES + stride as u32 + k, i) as f64;
                    if v.is_finite() {
                        *s += v;
                    }
                }
            }
            black
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Planes of `n` pixels with `stride` pass sums, from each (plane, pixel)'s value.
    fn planes(n: usize, stride: u32, f: impl Fn(u32, usize) -> f32) -> Vec<u8> {
        (0..film_planes(stride))
            .flat_map(|k| (0..n).map(move |i| (k, i)))
            .flat_map(|(k, i)| f(k, i).to_ne_bytes())
            .collect()
    }

    #[test]
    fn a_round_adds_high_and_low_words_and_zeroes_what_is_not_finite() {
        let (n, stride) = (5000, 2);
        // Pixel i: colour high i, low 2^-30 i; odd samples 0.5; passes 1 + k and a low word.
        let words = planes(n, stride, |k, i| match k {
            0..=2 => i as f32,
            3..=5 => i as f32 * 2f32.powi(-30),
            6..=8 => 0.5,
            9 | 10 => 1.0 + (k - 9) as f32,
            _ => 2f32.powi(-30),
        });
        let mut bad = words.clone();
        // Pixel 7's green sum and pixel 9's first pass sum are NaN.
        let at = |k: usize, i: usize| 4 * (k * n + i);
        bad[at(1, 7)..at(1, 7) + 4].copy_from_slice(&f32::NAN.to_ne_bytes());
        bad[at(9, 9)..at(9, 9) + 4].copy_from_slice(&f32::INFINITY.to_ne_bytes());
        let mut pixels = vec![Pixel::default(); n];
        let mut sums = vec![0.0; n * stride as usize];
        // Every pixel to 4 samples but pixel 3, already there (its sums are not added).
        let mut targets = vec![4u32; n];
        targets[3] = 0;
        let black = merge(&bad, &mut pixels, &mut sums, &targets, stride as usize);
        assert_eq!(black, 4);
        for (i, p) in pixels.iter().enumerate() {
            let want = if i == 3 || i == 7 {
                0.0
            } else {
                (i as f64 + i as f64 * 2f64.powi(-30)) / 4.0
            };
            assert_eq!(p.taken(), if i == 3 { 0 } else { 4 }, "{i}");
            assert_eq!(p.mean().x, want, "{i}");
            let low = 2f64.powi(-30);
            let passes = &sums[2 * i..2 * i + 2];
            match i {
                3 => assert_eq!(passes, [0.0, 0.0]),
                9 => assert_eq!(passes, [0.0, 2.0 + low]),
                _ => assert_eq!(passes, [1.0 + low, 2.0 + low], "{i}"),
            }
        }
        // Without passes: the same colour.
        let mut plain = vec![Pixel::default(); n];
        let words = planes(n, 0, |k, i| if k < 3 { i as f32 } else { 0.25 });
        assert_eq!(merge(&words, &mut plain, &mut [], &targets, 0), 0);
        assert_eq!(plain[10].mean().y, (10.0 + 0.25) / 4.0);
    }
}
