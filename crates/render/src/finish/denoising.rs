//! The denoise stage: a shot's filter, and the stop rule of a denoised frame (the frame
//! written judged, at most [`MAX_DENOISES`] denoises a frame: the module's notes of
//! [`super`]).

use std::time::Instant;

use raytrace_core::error::Error;
use raytrace_core::film::{Film, Halves};
use raytrace_core::renderer::{StopRule, Weights, relative_error};
use raytrace_core::scene::DenoiseQuality;
use raytrace_denoise::denoiser::{DenoiseError, Denoiser, Filter};
use raytrace_denoise::estimate::{Blend, Snapshot, WrittenPixel};

/// Denoises a frame takes under a noise threshold, at most.
pub(crate) const MAX_DENOISES: u32 = 2;

/// The exponent of the mean samples by which the written frame's error over the raw frame's
/// (as squares) grows between denoises: see the module's notes.
const RATIO_GROWTH: f64 = 1.0 / 3.0;

/// The denoise stage of a shot: its filter, and what the frame being finished has of it.
pub(super) struct Denoising<'d> {
    filter: Filter<'d>,
    quality: DenoiseQuality,
    width: usize,
    state: FrameState,
}

/// What one frame has of its denoising.
#[derive(Default)]
struct FrameState {
    /// The last denoise of the frame's film.
    snapshot: Option<Snapshot>,
    /// The written frame after the last round judged, for the next round's weights: each
    /// pixel's estimated relative variance per sample, row-major.
    weights: Option<Vec<f64>>,
    /// The first denoise's written relative MSE over the raw film's, and its mean samples.
    gain: Option<(f64, f64)>,
    denoises: u32,
    seconds: f64,
}

impl<'d> Denoising<'d> {
    /// Denoising of `width` x `height` frames by `denoiser` at `quality`.
    pub(super) fn new(
        denoiser: &'d Denoiser,
        width: usize,
        height: usize,
        quality: DenoiseQuality,
    ) -> Result<Denoising<'d>, DenoiseError> {
        Ok(Denoising {
            filter: denoiser.filter(width, height, quality)?,
            quality,
            width,
            state: FrameState::default(),
        })
    }

    /// The filter's quality.
    pub(super) fn quality(&self) -> DenoiseQuality {
        self.quality
    }

    /// The seconds the frame's denoising took and its denoises.
    pub(super) fn spent(&self) -> (f64, u32) {
        (self.state.seconds, self.state.denoises)
    }

    /// Denoises `film`'s replicates (`halves`, row-major): the frame's new snapshot.
    fn denoise(&mut self, halves: &[Halves]) -> Result<(), Error> {
        let start = Instant::now();
        let image = |half: fn(&Halves) -> glam::DVec3| -> Vec<f32> {
            halves
                .iter()
                .flat_map(|h| {
                    let c = half(h).as_vec3();
                    if c.is_finite() {
                        c.to_array()
                    } else {
                        [0.0; 3]
                    }
                })
                .collect()
        };
        let da = self.filter.run(&image(Halves::a))?;
        let db = self.filter.run(&image(Halves::b))?;
        self.state.snapshot = Some(Snapshot::new(self.width, halves, &da, &db));
        self.state.denoises += 1;
        self.state.seconds += start.elapsed().as_secs_f64();
        Ok(())
    }

    /// The frame written from `film`: its last denoise blended with it as it is now, or,
    /// if it has none, a denoise of it.
    pub(super) fn written(&mut self, film: &Film) -> Result<Vec<WrittenPixel>, Error> {
        let halves = film.halves();
        if self.state.snapshot.is_none() {
            self.denoise(&halves)?;
        }
        let snapshot = self.state.snapshot.as_ref().expect("denoised");
        Ok(snapshot.written(&halves))
    }

    fn blend(&mut self, halves: &[Halves]) -> Blend {
        let start = Instant::now();
        let snapshot = self.state.snapshot.as_ref().expect("denoised");
        let blend = snapshot.blend(halves);
        self.state.seconds += start.elapsed().as_secs_f64();
        blend
    }

    /// Keeps `blend`'s per-pixel errors as the next round's weights: per sample, as the
    /// adaptive rounds weigh pixels.
    fn keep_weights(&mut self, blend: &Blend, halves: &[Halves]) {
        let w = blend
            .pixel_errors
            .iter()
            .zip(halves)
            .map(|(e, h)| {
                let v = e.max(0.0) * h.taken as f64;
                if v.is_finite() { v } else { f64::MAX }
            })
            .collect();
        self.state.weights = Some(w);
    }
}

impl StopRule for Denoising<'_> {
    fn begin(&mut self) {
        self.state = FrameState::default();
    }

    fn reached(&mut self, film: &Film, threshold: f64) -> Result<bool, Error> {
        let halves = film.halves();
        let samples =
            halves.iter().map(|h| h.taken as f64).sum::<f64>() / halves.len().max(1) as f64;
        let raw = relative_error(film);
        if self.state.snapshot.is_none() {
            // The frame's first denoise: its gain, measured.
            self.denoise(&halves)?;
            let blend = self.blend(&halves);
            self.state.gain = Some(((blend.relative_error / raw).powi(2), samples));
            self.keep_weights(&blend, &halves);
            return Ok(blend.relative_error <= threshold);
        }
        let stale = self.blend(&halves);
        if stale.relative_error <= threshold {
            return Ok(true);
        }
        if self.state.denoises < MAX_DENOISES
            && let Some((gain, at)) = self.state.gain
        {
            let ratio = (gain * (samples / at).powf(RATIO_GROWTH)).min(1.0);
            let predicted = raw * ratio.sqrt();
            if predicted <= threshold {
                self.denoise(&halves)?;
                let fresh = self.blend(&halves);
                self.keep_weights(&fresh, &halves);
                return Ok(fresh.relative_error <= threshold);
            }
        }
        self.keep_weights(&stale, &halves);
        Ok(false)
    }

    fn weights(&self) -> Weights<'_> {
        match &self.state.weights {
            Some(values) => Weights::Map {
                width: self.width as u32,
                values,
            },
            None => Weights::Raw,
        }
    }
}
