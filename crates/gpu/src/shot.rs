//! A shot on the GPU ([`GpuShot`]: what its frames share, uploaded once) and one frame of it
//! ([`GpuFrame`]): rounds of samples traced on the GPU into the film on the device
//! ([`super::device_film`]), read back once a round and added to the frame's film.
//!
//! A round takes every pixel to its target: the pixels with samples to take become work
//! entries, part by part of the film, and windows of dispatches ([`super::schedule`]) add
//! their samples, each pixel's in sample order by one invocation at a time, so a pixel's sums
//! depend on its samples alone, never on how they were split into dispatches. Two
//! dispatches are in flight: the next is recorded and submitted while the last runs, and
//! the host's work per dispatch is a few numbers, never a sample's.

use std::collections::VecDeque;
use std::sync::Mutex;
use std::time::Instant;

use super::context::{Gpu, GpuError, classify};
use super::device_film::{DeviceFilm, SLOTS, Submitted, merge};
use super::layout::{MAX_STRIDE, Words};
use super::pages::Pages;
use super::schedule::{Pace, Windows};
use super::support::buffer_bytes;
use super::upload::{FrameWords, ShotWords};
use raytrace_core::error::Error;
use raytrace_core::film::Film;
use raytrace_core::passes::SumLayout;
use raytrace_core::points::FramePoints;
use raytrace_core::prepared::PreparedFrame;
use raytrace_core::renderer::{FrameTracer, RoundCounts, RoundPlan, ShotTracer};
use raytrace_core::scene::Scene;
use raytrace_core::world::StaticGeometry;

/// A shot's data on the GPU: what every frame of it shares, with the still spheres and their
/// hierarchy it was uploaded from (which each frame's preparation starts from).
#[derive(Debug)]
pub struct GpuShot {
    /// The device with the tracer for the shot's words.
    gpu: Gpu,
    statics: StaticGeometry,
    words: ShotWords,
    /// The shot's words, page by page.
    pages: Vec<wgpu::Buffer>,
    /// The device's pace, carried from frame to frame (behind a lock: a shot is shared by
    /// the threads of a run, one frame at a time).
    pace: Mutex<Pace>,
}

impl GpuShot {
    /// Uploads what `scene`'s frames share: its materials, the Sobol tables, and its spheres
    /// that never move, with their hierarchy (built here), over the pages its spheres' words
    /// take, on the tracer for those pages; a frame whose points take more pages gets the
    /// tracer for those ([`GpuShot::upload_frame`]). The tracer compiles on its own thread
    /// while the hierarchy is built and uploaded ([`Gpu::begin`]), and is waited for here,
    /// before any frame's clock starts: a frame's times (its time limit, the host's share)
    /// never count the compilation.
    pub fn new(gpu: &Gpu, scene: &Scene) -> Result<GpuShot, GpuError> {
        let bytes = buffer_bytes(scene, 0);
        gpu.begin(bytes);
        let statics = StaticGeometry::new(scene);
        let words = ShotWords::new(scene, &statics);
        let pages = upload(gpu, gpu.pages().holding(bytes), "shot", &words.words)?;
        Ok(GpuShot {
            gpu: gpu.fitting(bytes)?,
            statics,
            words,
            pages,
            pace: Mutex::new(Pace::default()),
        })
    }

    /// Uploads the frame `prepared` (of the scene this shot was made from), for a film kept
    /// by `layout`.
    pub(crate) fn upload_frame(
        &self,
        prepared: &PreparedFrame,
        layout: &SumLayout,
    ) -> Result<GpuFrame<'_>, GpuError> {
        assert!(
            layout.stride <= MAX_STRIDE as usize,
            "more pass sums than the GPU keeps"
        );
        let words = FrameWords::new(prepared, &self.words, layout);
        // The shot's tracer, or where the frame's points take more pages than it binds, the
        // tracer for those: the shot's words lie in its first pages either way.
        let bytes = 4 * words.words.0.len() as u64;
        let gpu = self
            .gpu
            .fitting(bytes.max(self.gpu.tracer().pages.bytes()))?;
        let pages = upload(&gpu, gpu.tracer().pages, "frame", &words.words)?;
        let scene = prepared.scene;
        let pixels = scene.output.width as usize * scene.output.height as usize;
        let film = DeviceFilm::new(&gpu, [&self.pages, &pages], pixels, layout.stride as u32)?;
        Ok(GpuFrame {
            shot: self,
            gpu,
            _pages: pages,
            film,
            stride: layout.stride,
            max_depth: scene.render.max_depth,
            moving: prepared.world.moving,
        })
    }
}

impl ShotTracer for GpuShot {
    fn statics(&self) -> &StaticGeometry {
        &self.statics
    }

    /// Uploads the frame, its points among its spheres (`prepared`'s world holds them,
    /// prepared for its interval with their hierarchies).
    fn frame<'a>(
        &'a self,
        prepared: PreparedFrame<'a>,
        _points: &'a FramePoints,
        layout: &SumLayout,
    ) -> Result<Box<dyn FrameTracer + 'a>, Error> {
        Ok(Box::new(self.upload_frame(&prepared, layout)?))
    }
}

/// Buffers holding `words` over `pages`, for the shaders to read; more words than the pages
/// hold is an error naming both in MiB (a scene validated against the adapter's pages never
/// gets here, `super::support`).
fn upload(
    gpu: &Gpu,
    pages: Pages,
    label: &str,
    words: &Words,
) -> Result<Vec<wgpu::Buffer>, GpuError> {
    use wgpu::util::DeviceExt;
    let Some(parts) = pages.split(&words.0) else {
        return Err(GpuError::Failed(format!(
            "the {label}'s data take {}, more than the {} this GPU binds ({} bindings of {})",
            mib(4 * words.0.len() as u64),
            mib(pages.bytes()),
            pages.count(),
            mib(4 * pages.page_words() as u64)
        )));
    };
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let buffers = parts
        .into_iter()
        .map(|part| {
            // Whole quads: the shaders read a page as an array of them.
            let mut bytes: Vec<u8> = part.iter().flat_map(|w| w.to_ne_bytes()).collect();
            bytes.resize(bytes.len().next_multiple_of(16), 0);
            gpu.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: &bytes,
                    usage: wgpu::BufferUsages::STORAGE,
                })
        })
        .collect();
    match pollster::block_on(scope.pop()) {
        Some(e) => Err(classify(&e)),
        None => Ok(buffers),
    }
}

/// Bytes in MiB to a tenth (`266.4 MiB`), or in KiB below a MiB (`64.0 KiB`, the sizes
/// of limits forced low).
pub(super) fn mib(bytes: u64) -> String {
    match bytes < 1 << 20 {
        true => format!("{:.1} KiB", bytes as f64 / 1024.0),
        false => format!("{:.1} MiB", bytes as f64 / (1u64 << 20) as f64),
    }
}

/// One frame prepared on the GPU.
pub(crate) struct GpuFrame<'s> {
    shot: &'s GpuShot,
    /// The device with the tracer for the frame's words (the shot's, or one of more pages).
    gpu: Gpu,
    /// The frame's words, page by page, bound in the film's dispatches.
    _pages: Vec<wgpu::Buffer>,
    film: DeviceFilm,
    stride: usize,
    max_depth: u32,
    /// Spheres moving during the frame's exposure.
    moving: usize,
}

impl FrameTracer for GpuFrame<'_> {
    fn moving_spheres(&self) -> usize {
        self.moving
    }

    fn round(
        &mut self,
        film: &mut Film,
        plan: &RoundPlan<'_>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<RoundCounts, Error> {
        use rayon::prelude::*;
        // Each pixel's target, in the film's storage order, decided tile by tile as the
        // CPU's tiles decide them.
        let targets: Vec<u32> = film
            .tiles()
            .par_iter()
            .map(|(rect, pixels)| {
                let mut t = Vec::with_capacity(pixels.len());
                plan.targets(rect, pixels, &mut t);
                t
            })
            .collect::<Vec<_>>()
            .concat();
        Ok(self.take_to(film, &targets, progress)?)
    }

    fn readback_bytes(&self) -> u64 {
        self.film.readback
    }
}

impl GpuFrame<'_> {
    /// Takes every pixel of `film` to its target sample count, `targets` in the film's
    /// storage order (a pixel already there takes none). `progress` is called with the
    /// samples of each finished dispatch.
    pub(crate) fn take_to(
        &mut self,
        film: &mut Film,
        targets: &[u32],
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<RoundCounts, GpuError> {
        let rects = film.tile_rects();
        let (pixels, sums) = film.storage_mut();
        assert_eq!(targets.len(), pixels.len(), "a target for every pixel");
        let mut positions = rects
            .iter()
            .flat_map(|r| (0..r.len()).map(move |i| r.position(i)));
        let mut counts = RoundCounts::default();
        let part = self.film.part();
        let mut entries: Vec<[u32; 4]> = Vec::new();
        for start in (0..pixels.len()).step_by(part) {
            let end = (start + part).min(pixels.len());
            entries.clear();
            for (i, (p, &target)) in pixels[start..end]
                .iter()
                .zip(&targets[start..end])
                .enumerate()
            {
                let (x, y) = positions.next().expect("a position for every pixel");
                if target > p.taken() {
                    entries.push([i as u32, x | y << 16, p.taken(), target]);
                }
            }
            if entries.is_empty() {
                continue;
            }
            // Most samples first (stably: neighbours stay together), so that each window's
            // entries are a prefix.
            entries.sort_by_key(|e| std::cmp::Reverse(e[3] - e[2]));
            counts.busy_seconds += self.film.begin(&self.gpu, end - start, &entries);
            let remaining = entries.iter().map(|e| e[3] - e[2]).collect();
            self.windows(Windows::new(remaining), end - start, &mut counts, progress)?;
            let stride = self.stride;
            let (part_pixels, part_sums, part_targets) = (
                &mut pixels[start..end],
                &mut sums[start * stride..end * stride],
                &targets[start..end],
            );
            let waited = Instant::now();
            counts.non_finite += self.film.read_part(&self.gpu, end - start, |words| {
                counts.busy_seconds += waited.elapsed().as_secs_f64();
                merge(words, part_pixels, part_sums, part_targets, stride)
            })?;
        }
        Ok(counts)
    }

    /// Runs a part's `windows` (of a part of `pixels` pixels) to its end, two dispatches in
    /// flight, each sized by the device's pace.
    fn windows(
        &mut self,
        mut windows: Windows,
        pixels: usize,
        counts: &mut RoundCounts,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<(), GpuError> {
        let gpu = &self.gpu;
        let mut pace = self.shot.pace();
        let mut in_flight: VecDeque<Submitted> = VecDeque::new();
        let mut slot = 0;
        // When the last dispatch came back.
        let mut last = Instant::now();
        loop {
            while in_flight.len() < SLOTS {
                let next = match windows.next(pace.samples(), &pace) {
                    Some(d) => Some(d),
                    None => windows.next_catch_up(pace.samples()),
                };
                let Some(d) = next else { break };
                in_flight.push_back(self.film.submit(gpu, d, pixels, slot));
                slot = (slot + 1) % SLOTS;
            }
            let Some(s) = in_flight.pop_front() else {
                // Nothing planned and nothing in flight: the part is done, or some pixels
                // are behind and a catch-up window starts.
                if windows.left() == 0 {
                    break;
                }
                match windows.catch_up(pace.samples(), &pace) {
                    Some(d) => {
                        in_flight.push_back(self.film.submit(gpu, d, pixels, slot));
                        slot = (slot + 1) % SLOTS;
                        continue;
                    }
                    None => return Err(self.too_long()),
                }
            };
            let (dispatch, submitted, submitting) = (s.dispatch, s.at, s.submitting);
            let waited = Instant::now();
            let c = self.film.wait(gpu, s)?;
            let back = Instant::now();
            counts.busy_seconds += (back - waited + submitting).as_secs_f64();
            // Its device time: from when it was submitted, or the one before it came back,
            // whichever was later; on a device that runs a dispatch within its submission,
            // the submission's time.
            let seconds = (back - submitted.max(last)).max(submitting).as_secs_f64();
            last = back;
            pace.measured(c.samples, seconds, dispatch.k, c.cut);
            windows.added(c.samples);
            counts.samples += c.samples;
            counts.rays += c.rays;
            counts.non_finite += c.non_finite;
            progress(c.samples);
        }
        self.shot.set_pace(pace);
        Ok(())
    }

    /// The error of a sample the device cannot take in one invocation.
    fn too_long(&self) -> GpuError {
        GpuError::Failed(format!(
            "a sample needs more loop iterations than this device runs in one shader \
             invocation (Mesa's software device, lavapipe, ends its loops after 65,535): \
             paths of up to {} bounces (render.max_depth) are too long for it here; render \
             with --device cpu or a lower max_depth",
            self.max_depth
        ))
    }
}

impl GpuShot {
    /// The device's pace the next frame begins with.
    fn pace(&self) -> Pace {
        *self.pace.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Sets the device's pace the next frame begins with.
    pub(super) fn set_pace(&self, pace: Pace) {
        *self.pace.lock().unwrap_or_else(|e| e.into_inner()) = pace;
    }
}

#[cfg(test)]
impl GpuShot {
    /// The shot's words, as uploaded.
    pub(super) fn words(&self) -> &ShotWords {
        &self.words
    }
}

#[cfg(test)]
impl GpuFrame<'_> {
    /// The sampler's numbers of each sample `(x, y, index, uses)` (`uses`: 1 the lens, 2 the
    /// time), as the tracer draws them: pixel, lens, time, then four bounces' (uc, u.0, u.1).
    pub(super) fn numbers(&mut self, samples: &[[u32; 4]]) -> Result<Vec<[f32; 17]>, GpuError> {
        use super::layout::NUMBERS;
        let gpu = &self.gpu;
        let words = self.film.numbers(gpu, samples)?;
        Ok(words
            .chunks_exact(NUMBERS as usize)
            .map(|c| std::array::from_fn(|i| f32::from_bits(c[i])))
            .collect())
    }
}
