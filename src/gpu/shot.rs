//! A shot on the GPU ([`GpuShot`]: what its frames share, uploaded once) and one frame of it
//! ([`GpuFrame`]): rounds of samples traced on the GPU and added to the frame's film.
//!
//! A round's samples are cut into *runs*: a pixel's samples from its count so far to its
//! target, cut at every multiple of [`RUN`] of the sample index. One GPU invocation traces a
//! run, summing its samples in order in `f32` (and its odd samples, its non-finite ones, its
//! rays, its pass sums), and the CPU adds each run's sums to its pixel in `f64`, runs in
//! sample order ([`Pixel::add_run`]). Runs are sent in batches of a size fitted to the
//! device's speed, which changes nothing in the result: a run's sums depend only on the run.

use std::time::Instant;

use super::context::{Gpu, GpuError, classify};
use super::dispatch::{Batches, Run};
use super::layout::{MAX_STRIDE, O_NON_FINITE, O_ODD, O_PASSES, O_RAYS, O_SUM, RUN, Words};
use super::upload::{FrameWords, ShotWords};
use crate::film::{Film, Pixel};
use crate::passes::Layout;
use crate::scene::Scene;

/// Bytes of output a batch may hold: its runs' records, and as much again read back.
const BATCH_BYTES: u64 = 64 << 20;

/// The most runs a batch holds.
const MAX_RUNS: u64 = 1 << 20;

/// Pixels listed at once as pending in a round ([`GpuFrame::round`]): 5 MiB of list. The list
/// held every pixel of the frame (20 bytes a pixel), which the memory estimate did not count.
const WINDOW_PIXELS: usize = 1 << 18;

/// Bytes a frame on the GPU holds beyond the CPU's frame, whatever the frame's size: a
/// window's pending pixels, and a batch at its largest: its output (on the device, its
/// staging copy, and the words read back), and its runs (on the device, as listed with their
/// owners, as words, as bytes, and the queue's copy of them). The device's buffers count
/// because a GPU without memory of its own (lavapipe, integrated GPUs) keeps them in the
/// process's; with its own, this errs high.
pub const FIXED_BYTES: u64 = WINDOW_PIXELS as u64 * std::mem::size_of::<Pending>() as u64
    + 3 * BATCH_BYTES
    + MAX_RUNS * (5 * std::mem::size_of::<Run>() as u64 + 4);

/// Bytes a frame on the GPU holds per pixel beyond the CPU's frame: each pixel's target
/// sample count for the round, and its tile's copy while the targets are gathered
/// ([`crate::renderer`]).
pub const BYTES_PER_PIXEL: u64 = 2 * std::mem::size_of::<u32>() as u64;

/// Seconds a batch should take: long enough that a dispatch's fixed cost is small, short
/// enough for progress to move and for drivers that stop long dispatches (two seconds on
/// Windows).
const BATCH_SECONDS: f64 = 0.15;

/// A shot's data on the GPU: what every frame of it shares.
#[derive(Debug)]
pub struct GpuShot {
    gpu: Gpu,
    words: ShotWords,
    buffer: wgpu::Buffer,
}

/// What one round on the GPU did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RoundCounts {
    /// Rays intersected with the scene.
    pub rays: u64,
    /// Samples taken.
    pub samples: u64,
    /// Samples that were not finite (counted as black).
    pub non_finite: u64,
    /// Seconds spent waiting for the GPU.
    pub seconds: f64,
}

impl GpuShot {
    /// Uploads what `scene`'s frames share: its materials, the Sobol tables, and its spheres
    /// that never move with their hierarchy (built here, as the CPU tracer builds its own).
    pub fn new(gpu: &Gpu, scene: &Scene) -> Result<GpuShot, GpuError> {
        let words = ShotWords::new(scene).map_err(GpuError::Failed)?;
        let buffer = upload(gpu, "shot", &words.words)?;
        Ok(GpuShot {
            gpu: gpu.clone(),
            words,
            buffer,
        })
    }

    /// The device.
    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// Prepares frame `frame` of `scene` (the scene this shot was made from) for a film kept
    /// by `layout`: its animated spheres for the frame's interval, their hierarchy, its
    /// camera and shutter, uploaded.
    pub fn frame(
        &self,
        scene: &Scene,
        frame: u32,
        layout: &Layout,
    ) -> Result<GpuFrame<'_>, GpuError> {
        assert!(
            layout.stride <= MAX_STRIDE as usize,
            "more pass sums than the GPU keeps"
        );
        let words = FrameWords::new(scene, &self.words, frame, layout).map_err(GpuError::Failed)?;
        let buffer = upload(&self.gpu, "frame", &words.words)?;
        Ok(GpuFrame {
            shot: self,
            buffer,
            batches: None,
            record: O_PASSES + layout.stride as u32,
            stride: layout.stride,
            moving: words.moving,
            batch: 4096,
        })
    }
}

/// A buffer holding `words`, for the shaders to read.
fn upload(gpu: &Gpu, label: &str, words: &Words) -> Result<wgpu::Buffer, GpuError> {
    use wgpu::util::DeviceExt;
    let limit = gpu.device.limits().max_storage_buffer_binding_size;
    let bytes = words.0.len() as u64 * 4;
    if bytes > limit {
        return Err(GpuError::Failed(format!(
            "the {label}'s data take {} MiB, more than the {} MiB a GPU buffer may hold here",
            bytes >> 20,
            limit >> 20
        )));
    }
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let buffer = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &words.bytes(),
            usage: wgpu::BufferUsages::STORAGE,
        });
    match pollster::block_on(scope.pop()) {
        Some(e) => Err(classify(&e)),
        None => Ok(buffer),
    }
}

/// One frame prepared on the GPU.
pub struct GpuFrame<'s> {
    shot: &'s GpuShot,
    buffer: wgpu::Buffer,
    batches: Option<Batches>,
    /// Words of a run's output record.
    record: u32,
    stride: usize,
    moving: usize,
    /// Runs in the next batch.
    batch: usize,
}

/// A pixel with samples to take in a round.
struct Pending {
    /// Its place in the film's storage.
    index: u32,
    x: u32,
    y: u32,
    /// Its next sample, and the sample it stops before.
    next: u32,
    end: u32,
}

impl GpuFrame<'_> {
    /// Spheres moving during the frame's exposure.
    pub fn moving(&self) -> usize {
        self.moving
    }

    /// Takes every pixel of `film` to its target sample count, `targets` in the film's
    /// storage order (a pixel already there takes none), adding each run's sums to its
    /// pixel. `progress` is called with the samples of each finished batch.
    pub fn round(
        &mut self,
        film: &mut Film,
        targets: &[u32],
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<RoundCounts, GpuError> {
        let rects = film.tile_rects();
        let (pixels, sums) = film.storage_mut();
        assert_eq!(targets.len(), pixels.len(), "a target for every pixel");
        let mut counts = RoundCounts::default();
        // Pixels are taken a window at a time, so that the list of pending pixels is bounded
        // in bytes whatever the frame's size ([`FIXED_BYTES`]).
        let mut pending = Vec::with_capacity(WINDOW_PIXELS);
        let mut index = 0usize;
        for rect in rects {
            for i in 0..rect.len() {
                let (x, y) = rect.position(i);
                let (next, end) = (pixels[index].taken(), targets[index]);
                if end > next {
                    pending.push(Pending {
                        index: index as u32,
                        x,
                        y,
                        next,
                        end,
                    });
                }
                index += 1;
                if pending.len() == WINDOW_PIXELS {
                    self.trace(&mut pending, pixels, sums, &mut counts, progress)?;
                }
            }
        }
        self.trace(&mut pending, pixels, sums, &mut counts, progress)?;
        Ok(counts)
    }

    /// Takes every pixel of `pending` to its end, adding each run's sums to its pixel of
    /// `pixels` and its pass sums in `sums`, and the round's figures to `counts`; leaves
    /// `pending` empty.
    fn trace(
        &mut self,
        pending: &mut Vec<Pending>,
        pixels: &mut [Pixel],
        sums: &mut [f64],
        counts: &mut RoundCounts,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<(), GpuError> {
        let mut runs: Vec<Run> = Vec::new();
        let mut owners: Vec<u32> = Vec::new();
        let mut cursor = 0;
        loop {
            // The next runs: one of each pending pixel in turn, so that neighbouring
            // invocations trace neighbouring pixels; a pixel's runs stay in sample order.
            runs.clear();
            owners.clear();
            let capacity = self.capacity();
            while runs.len() < self.batch.min(capacity) {
                if cursor == pending.len() {
                    pending.retain(|p| p.next < p.end);
                    cursor = 0;
                    if pending.is_empty() {
                        break;
                    }
                }
                let p = &mut pending[cursor];
                let stop = ((p.next as u64 / RUN as u64 + 1) * RUN as u64).min(p.end as u64) as u32;
                runs.push([p.x, p.y, p.next, stop - p.next]);
                owners.push(p.index);
                p.next = stop;
                cursor += 1;
            }
            if runs.is_empty() {
                break;
            }
            let start = Instant::now();
            let shot = self.shot;
            let out = self.batches(runs.len())?.run(&shot.gpu, &runs)?;
            let seconds = start.elapsed().as_secs_f64();
            let mut samples = 0;
            for ((run, &owner), rec) in runs
                .iter()
                .zip(&owners)
                .zip(out.chunks_exact(self.record as usize))
            {
                add(&mut pixels[owner as usize], run[3], rec);
                let at = owner as usize * self.stride;
                for (s, &w) in sums[at..at + self.stride]
                    .iter_mut()
                    .zip(&rec[O_PASSES as usize..])
                {
                    *s += f32::from_bits(w) as f64;
                }
                counts.non_finite += rec[O_NON_FINITE as usize] as u64;
                counts.rays +=
                    rec[O_RAYS as usize] as u64 | (rec[O_RAYS as usize + 1] as u64) << 32;
                samples += run[3] as u64;
            }
            counts.samples += samples;
            counts.seconds += seconds;
            progress(samples);
            // The next batch to take about BATCH_SECONDS at this batch's pace.
            let pace = runs.len() as f64 / seconds.max(1e-6);
            self.batch = (pace * BATCH_SECONDS).clamp(256.0, capacity as f64) as usize;
        }
        pending.clear();
        Ok(())
    }

    /// The runs a batch may hold.
    fn capacity(&self) -> usize {
        (BATCH_BYTES / (self.record as u64 * 4)).min(MAX_RUNS) as usize
    }

    /// Buffers for a batch of `runs` runs: those of the last batch if they are large
    /// enough, else new ones, twice as large as needed (up to the largest batch).
    fn batches(&mut self, runs: usize) -> Result<&Batches, GpuError> {
        if self
            .batches
            .as_ref()
            .is_none_or(|b| (b.capacity() as usize) < runs)
        {
            let capacity = (2 * runs).min(self.capacity()) as u32;
            // The last batch's buffers go before the new ones are made: never both at once.
            self.batches = None;
            self.batches = Some(Batches::new(
                &self.shot.gpu,
                &self.shot.buffer,
                &self.buffer,
                capacity,
                self.record,
            )?);
        }
        Ok(self.batches.as_ref().expect("made above"))
    }
}

#[cfg(test)]
impl GpuFrame<'_> {
    /// The sampler's numbers of each sample `(x, y, index, uses)` (`uses`: 1 the lens, 2 the
    /// time), as the tracer draws them: pixel, lens, time, then four bounces' (uc, u.0, u.1).
    pub(super) fn numbers(&mut self, samples: &[Run]) -> Result<Vec<[f32; 17]>, GpuError> {
        let shot = self.shot;
        let batches = Batches::new(
            &shot.gpu,
            &shot.buffer,
            &self.buffer,
            samples.len() as u32,
            17,
        )?;
        let out = batches.run_with(&shot.gpu, &shot.gpu.numbers, samples)?;
        Ok(out
            .chunks_exact(17)
            .map(|c| std::array::from_fn(|i| f32::from_bits(c[i])))
            .collect())
    }
}

/// Adds a run of `count` samples, summed in the output record `rec`, to `pixel`.
fn add(pixel: &mut Pixel, count: u32, rec: &[u32]) {
    let f = |i: u32| f32::from_bits(rec[i as usize]);
    pixel.add_run(
        [f(O_SUM), f(O_SUM + 1), f(O_SUM + 2)],
        [f(O_ODD), f(O_ODD + 1), f(O_ODD + 2)],
        count,
    );
}
