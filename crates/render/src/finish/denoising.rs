//! The denoise stage: a shot's filter, and the stop rule of a denoised frame (the frame
//! written judged; denoised again when [`DenoiseSchedule`] says a denoise pays: the module's
//! notes of [`super`]).

use std::time::Instant;

use raytrace_core::error::Error;
use raytrace_core::film::Film;
use raytrace_core::image::Image;
use raytrace_core::renderer::{StopRule, Weights};
use raytrace_core::replicates::{REPLICATE_A, REPLICATE_B, Replicates};
use raytrace_core::scene::{DenoiseQuality, Device};
use raytrace_denoise::change::ChangeTerms;
use raytrace_denoise::denoiser::{DenoiseError, Denoiser, Filter};
use raytrace_denoise::estimate::{self, Blend, DenoiseTerms};

use super::when::{DenoiseSchedule, Measured, denoise_samples_per_pixel};

/// The denoise stage of a shot: its filter, and what the frame being finished has of it.
pub(super) struct Denoising<'d> {
    filter: Filter<'d>,
    quality: DenoiseQuality,
    width: usize,
    /// What a denoise of a pixel costs in the tracer's samples (`when`).
    denoise_samples_per_pixel: f64,
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
    /// What the frame's denoises so far tell of the next.
    schedule: DenoiseSchedule,
    /// The film's samples at the last denoise.
    denoised_at: Option<u64>,
    denoises: u32,
    seconds: f64,
}

impl<'d> Denoising<'d> {
    /// Denoising of `width` x `height` frames by `denoiser` at `quality`, for frames traced
    /// on `device`.
    pub(super) fn new(
        denoiser: &'d Denoiser,
        (width, height): (usize, usize),
        quality: DenoiseQuality,
        device: Device,
    ) -> Result<Denoising<'d>, DenoiseError> {
        Ok(Denoising {
            filter: denoiser.filter(width, height, quality)?,
            quality,
            width,
            denoise_samples_per_pixel: denoise_samples_per_pixel(device),
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
    /// frame's new snapshot. `samples` is the film's count.
    fn denoise(&mut self, replicates: &Image, samples: u64) -> Result<(), Error> {
        let start = Instant::now();
        let da = self.filter.run(replicates, REPLICATE_A)?;
        let db = self.filter.run(replicates, REPLICATE_B)?;
        self.state.snapshot = Some(DenoiseTerms::new(replicates, &da, &db));
        self.state.denoised_at = Some(samples);
        self.state.denoises += 1;
        self.state.seconds += start.elapsed().as_secs_f64();
        Ok(())
    }

    /// The frame written from `film`: a denoise of all its samples, blended with it. The
    /// frame the last round judged where it is that (a frame stopped at its noise
    /// threshold), else a denoise now (a frame that took its samples, or stopped at its
    /// largest sample count after a round that did not denoise).
    pub(super) fn written(&mut self, film: &Film) -> Result<Written, Error> {
        let samples = film.samples_taken();
        if self.state.denoised_at == Some(samples)
            && let Some(w) = self.state.written.take_if(|w| w.samples == samples)
        {
            return Ok(w);
        }
        let replicates = film.replicates();
        self.denoise(&replicates, samples)?;
        Ok(self.blend(&replicates, samples))
    }

    /// The frame written from `replicates` (a film's replicates pooled with its earlier
    /// frames', `raytrace_denoise::accumulate`): a denoise of them, blended with them.
    pub(super) fn written_pooled(&mut self, replicates: &Image) -> Result<Written, Error> {
        let samples = Replicates::of(replicates)
            .taken()
            .iter()
            .map(|&n| n as u64)
            .sum();
        self.denoise(replicates, samples)?;
        Ok(self.blend(replicates, samples))
    }

    /// The frame written from `film` without another denoise where it has one: the one the
    /// last round judged if the film has taken no sample since, else its last denoise
    /// blended with the film as it is now. For a frame stopped at its time limit, which a
    /// denoise after it would overrun (a second or two at 1920x1080 on the CPU).
    pub(super) fn written_within_time(&mut self, film: &Film) -> Result<Written, Error> {
        if self.state.snapshot.is_none() {
            return self.written(film);
        }
        let samples = film.samples_taken();
        if let Some(w) = self.state.written.take_if(|w| w.samples == samples) {
            return Ok(w);
        }
        Ok(self.blend(&film.replicates(), samples))
    }

    /// The change terms (`raytrace_denoise::change`) of the frame written from `film` whose
    /// written terms are `written`: from the last denoise and the film as it is now.
    pub(super) fn change_terms(&self, film: &Film, written: &Image) -> ChangeTerms {
        let snapshot = self.state.snapshot.as_ref().expect("denoised");
        ChangeTerms::new(snapshot, &film.replicates(), written)
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

    /// Keeps `written` as the frame the last round judged, and what more samples would remove
    /// of its pixels' errors ([`estimate::sample_weights`]) as the next round's weights: per
    /// sample, as the adaptive rounds weigh pixels. Returns its estimated relative error.
    ///
    /// The weights are scaled so that their mean over the frame, divided by the samples, is
    /// the written frame's relative MSE: the rounds' plan (`renderer::adaptive`) reads the
    /// weights as a frame's error that its samples bring down as `1 / n`, and aims the sample
    /// counts at the threshold from them. What more samples remove decides where they go; the
    /// written frame's whole error, not the removable part alone, how many: with the
    /// removable part alone the plan would see the frame already within its threshold while
    /// the written frame is not, and its rounds would shrink to nothing.
    fn keep(&mut self, written: Written, replicates: &Image) -> f64 {
        let taken = Replicates::of(replicates).taken();
        let gains = estimate::sample_weights(&written.terms);
        let error = written.blend.relative_error;
        let finite = gains.iter().filter(|g| g.is_finite() && **g < f64::MAX);
        let mean = finite.clone().sum::<f64>() / finite.count().max(1) as f64;
        let scale = match error * error / mean {
            s if s.is_finite() && s > 0.0 => s,
            _ => 1.0,
        };
        let w = gains
            .iter()
            .zip(taken)
            .map(|(g, &n)| {
                let v = g.max(0.0) * scale * n as f64;
                if v.is_finite() { v } else { f64::MAX }
            })
            .collect();
        self.state.weights = Some(w);
        self.state.written = Some(written);
        error
    }
}

impl StopRule for Denoising<'_> {
    fn begin(&mut self) {
        self.state = FrameState::default();
    }

    /// Stops on a fresh denoise that meets `threshold`. After each round the last denoise is
    /// blended with the film as it is now (the next round's weights); a denoise now is
    /// predicted to do at least as well as that blend and as [`DenoiseSchedule`]'s model, and
    /// is taken when the schedule says it pays (always the frame's first). A frame never stops
    /// on a stale denoise: a blend of one snapshot, judged round after round, would stop when
    /// that snapshot's noisy estimate happens to be low (measured on the books' scene: stated
    /// 1.89%, true 2.32%), and a fresh denoise of all the samples is the better frame anyway.
    fn reached(&mut self, film: &Film, threshold: f64, round_samples: u64) -> Result<bool, Error> {
        let replicates = film.replicates();
        let total = film.samples_taken();
        let samples = total as f64 / (film.width as f64 * film.height as f64).max(1.0);
        // The frame the last round judged is stale now: the film has more samples.
        self.state.written = None;
        if self.state.snapshot.is_some() {
            let stale = self.blend(&replicates, total);
            let schedule = &self.state.schedule;
            let predicted = schedule
                .predicted(samples)
                .map_or(stale.blend.relative_error, |p| {
                    p.min(stale.blend.relative_error)
                });
            let pixels = film.width as f64 * film.height as f64;
            let costs = (
                round_samples as f64,
                pixels * self.denoise_samples_per_pixel,
            );
            if !schedule.worth_denoising(predicted, threshold, costs) {
                self.keep(stale, &replicates);
                return Ok(false);
            }
        }
        self.denoise(&replicates, total)?;
        let fresh = self.blend(&replicates, total);
        let error = fresh.blend.relative_error;
        self.state.schedule.denoised(Measured { samples, error });
        Ok(self.keep(fresh, &replicates) <= threshold)
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
