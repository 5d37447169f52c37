//! The denoise stage: a shot's filter, and the stop rule of a denoised frame (the frame
//! written judged, at most [`MAX_DENOISES`] denoises a frame: the module's notes of
//! [`super`]).

use std::time::Instant;

use raytrace_core::error::Error;
use raytrace_core::film::Film;
use raytrace_core::image::Image;
use raytrace_core::renderer::{StopRule, Weights, relative_error};
use raytrace_core::replicates::{REPLICATE_A, REPLICATE_B, Replicates};
use raytrace_core::scene::DenoiseQuality;
use raytrace_denoise::denoiser::{DenoiseError, Denoiser, Filter};
use raytrace_denoise::estimate::{Blend, DenoiseTerms};

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

/// The frame written from a film: its terms (`DenoiseTerms::written`) and their blend, with the
/// samples the film held then, which tell whether it has changed since.
pub(super) struct Written {
    samples: u64,
    pub(super) terms: Image,
    pub(super) blend: Blend,
}

/// What one frame has of its denoising.
#[derive(Default)]
struct FrameState {
    /// The last denoise of the frame's film.
    snapshot: Option<DenoiseTerms>,
    /// The frame written after the last round judged: what finishing writes if no samples
    /// were taken since (the blend is computed once).
    written: Option<Written>,
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

    /// Denoises `replicates` (the film's, [`Film::replicates`]), each replicate alone: the
    /// frame's new snapshot.
    fn denoise(&mut self, replicates: &Image) -> Result<(), Error> {
        let start = Instant::now();
        let da = self.filter.run(replicates, REPLICATE_A)?;
        let db = self.filter.run(replicates, REPLICATE_B)?;
        self.state.snapshot = Some(DenoiseTerms::new(replicates, &da, &db));
        self.state.denoises += 1;
        self.state.seconds += start.elapsed().as_secs_f64();
        Ok(())
    }

    /// The frame written from `film`: the one the last round judged if the film has taken no
    /// sample since, else its last denoise blended with it as it is now, or, if it has none,
    /// a denoise of it.
    pub(super) fn written(&mut self, film: &Film) -> Result<Written, Error> {
        let samples = film.samples_taken();
        if let Some(w) = self.state.written.take_if(|w| w.samples == samples) {
            return Ok(w);
        }
        let replicates = film.replicates();
        if self.state.snapshot.is_none() {
            self.denoise(&replicates)?;
        }
        Ok(self.blend(&replicates, samples))
    }

    /// The last denoise blended with the film's `replicates` now (of `samples` samples).
    fn blend(&mut self, replicates: &Image, samples: u64) -> Written {
        let start = Instant::now();
        let snapshot = self.state.snapshot.as_ref().expect("denoised");
        let terms = snapshot.written(replicates);
        let blend = Blend::from_written(&terms);
        self.state.seconds += start.elapsed().as_secs_f64();
        Written {
            samples,
            terms,
            blend,
        }
    }

    /// Keeps `written` as the frame the last round judged, and its per-pixel errors as the
    /// next round's weights: per sample, as the adaptive rounds weigh pixels. Returns its
    /// estimated relative error.
    fn keep(&mut self, written: Written, replicates: &Image) -> f64 {
        let taken = Replicates::of(replicates).taken();
        let w = written
            .blend
            .pixel_errors
            .iter()
            .zip(taken)
            .map(|(e, &n)| {
                let v = e.max(0.0) * n as f64;
                if v.is_finite() { v } else { f64::MAX }
            })
            .collect();
        self.state.weights = Some(w);
        let error = written.blend.relative_error;
        self.state.written = Some(written);
        error
    }
}

impl StopRule for Denoising<'_> {
    fn begin(&mut self) {
        self.state = FrameState::default();
    }

    fn reached(&mut self, film: &Film, threshold: f64) -> Result<bool, Error> {
        let replicates = film.replicates();
        let taken = Replicates::of(&replicates).taken();
        let total = film.samples_taken();
        let samples = total as f64 / taken.len().max(1) as f64;
        let raw = relative_error(film);
        // The frame the last round judged is stale now: the film has more samples.
        self.state.written = None;
        if self.state.snapshot.is_none() {
            // The frame's first denoise: its gain, measured.
            self.denoise(&replicates)?;
            let written = self.blend(&replicates, total);
            let error = written.blend.relative_error;
            self.state.gain = Some(((error / raw).powi(2), samples));
            return Ok(self.keep(written, &replicates) <= threshold);
        }
        let stale = self.blend(&replicates, total);
        if stale.blend.relative_error <= threshold {
            self.keep(stale, &replicates);
            return Ok(true);
        }
        if self.state.denoises < MAX_DENOISES
            && let Some((gain, at)) = self.state.gain
        {
            let ratio = (gain * (samples / at).powf(RATIO_GROWTH)).min(1.0);
            let predicted = raw * ratio.sqrt();
            if predicted <= threshold {
                self.denoise(&replicates)?;
                let fresh = self.blend(&replicates, total);
                return Ok(self.keep(fresh, &replicates) <= threshold);
            }
        }
        self.keep(stale, &replicates);
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
