//! Finishing a sampled frame for writing: raw film → denoise → history → the frame written. A
//! shot's
//! command assembles the stages its scene asks for once ([`Finishing::new`]) and runs every
//! frame through them ([`Finishing::finish`]); the sampling never branches on them, but asks
//! the pipeline's stop rule ([`Finishing::stop_rule`]) whether the frame that will be written
//! is within a noise threshold.
//!
//! **Denoise** ([`Denoising`]): the film's two replicates are denoised, each alone, by one
//! filter made for the shot; the written frame blends the raw frame and the denoised halves'
//! mean per pixel by their estimated errors, and states its own error
//! (`denoise::estimate`, derived there).
//!
//! **History** ([`History`], `--temporal`): the written frame is combined with the two frames
//! before it, carried to its pixels along the motion vectors, each weighed by its estimated
//! error (`denoise::history`, derived there). A frame reads the frames before it as they were
//! written before their own history, so it depends on those two frames' renders and no
//! others': the command renders them first where its run does not ([`Finishing::needs`]).
//!
//! **Under a noise threshold, at most two denoises a frame.** Once every pixel has its first
//! samples, the frame is denoised; its written error over the raw film's, `ρ`, is the frame's
//! own measured gain. The rounds then sample raw, and after each the written error is
//! predicted from the raw estimate, `ρ` growing as `n^(1/3)` with the mean samples `n` (a
//! smoother's squared error falls as `n^(-2/3)` in two dimensions, Stone, Ann. Statist. 10,
//! 1982, and the raw frame's as `n^(-1)`); when the prediction meets the threshold the frame is
//! denoised again. Every round also re-blends the last denoise with the film as it is now,
//! exactly (the denoised halves are unchanged, the raw side is the film's): the frame stops
//! as soon as that meets the threshold, and after the second denoise only that decides.

use std::time::Instant;

use super::adaptive::Weights;
use super::device::{FrameError, ShotGeometry};
use super::frame::{Denoised, FrameJob, FrameResult, frame_failed};
use super::stop::{RawStop, StopRule, relative_error};
use crate::denoise::denoiser::{DenoiseQuality, Denoiser, Filter};
use crate::denoise::estimate::{Blend, Snapshot, WrittenPixel};
use crate::denoise::history;
use crate::denoise::reproject::{HISTORY, TemporalFrame, reproject};
use crate::error::Error;
use crate::film::{Film, Halves};
use crate::pass::{Pass, PassSet};
use crate::passes::PassImages;
use crate::scene::Scene;

/// Denoises a frame takes under a noise threshold, at most.
pub const MAX_DENOISES: u32 = 2;

/// The exponent of the mean samples by which the written frame's error over the raw frame's
/// (as squares) grows between denoises: see the module's notes.
const RATIO_GROWTH: f64 = 1.0 / 3.0;

/// The passes the finishing stages of `scene` read from the film, written or not: with
/// `--temporal`, the depth, normal and motion that carry a pixel to earlier frames.
pub fn passes_read(scene: &Scene) -> PassSet {
    match scene.output.denoise {
        Some(d) if d.temporal => history_passes(),
        _ => PassSet::EMPTY,
    }
}

/// The passes history reads.
fn history_passes() -> PassSet {
    PassSet::EMPTY
        .with(Pass::Depth)
        .with(Pass::Normal)
        .with(Pass::Motion)
}

/// The stages that finish a shot's frames.
pub struct Finishing<'d> {
    denoising: Option<Denoising<'d>>,
    history: Option<History>,
    first_frame: u32,
    /// The passes the stages read ([`passes_read`]).
    read: PassSet,
    raw: RawStop,
}

impl<'d> Finishing<'d> {
    /// The stages `scene` asks for: denoising when `[output] denoise` is set (with
    /// `denoiser`, which must be given then), history with `--temporal`.
    pub fn new(scene: &Scene, denoiser: Option<&'d Denoiser>) -> Result<Finishing<'d>, Error> {
        let denoising = match (&scene.output.denoise, denoiser) {
            (None, _) => None,
            (Some(settings), Some(d)) => Some(
                Denoising::new(
                    d,
                    scene.output.width as usize,
                    scene.output.height as usize,
                    settings.quality,
                )
                .map_err(|e| Error::Resource(e.to_string()))?,
            ),
            (Some(_), None) => {
                return Err(Error::Resource(
                    "the scene asks for denoising and no denoiser was started".to_string(),
                ));
            }
        };
        let history = scene
            .output
            .denoise
            .filter(|d| d.temporal)
            .map(|_| History::default());
        Ok(Finishing {
            denoising,
            history,
            first_frame: scene.shot.first_frame,
            read: passes_read(scene),
            raw: RawStop,
        })
    }

    /// The rule that stops this shot's frames under a noise threshold: the written frame's.
    pub fn stop_rule(&mut self) -> &mut dyn StopRule {
        match &mut self.denoising {
            Some(d) => d,
            None => &mut self.raw,
        }
    }

    /// `job` sampled on `geometry`, judged under a noise threshold by this pipeline's stop
    /// rule, and finished.
    pub fn render(
        &mut self,
        job: FrameJob<'_>,
        geometry: &ShotGeometry,
    ) -> Result<FrameResult, Error> {
        let raw = job
            .reading(self.passes_read())
            .sample_with(geometry, self.stop_rule())?;
        self.finish(raw)
    }

    /// The passes these stages read from the film, written or not: with history, the depth,
    /// normal and motion that carry a pixel to earlier frames.
    pub fn passes_read(&self) -> PassSet {
        self.read
    }

    /// The frames that must be finished before `frame`, in order, that have not been: with
    /// history, the [`HISTORY`] frames before it (of the shot); none otherwise. A command
    /// renders and finishes them first, without writing them.
    pub fn needs(&self, frame: u32) -> Vec<u32> {
        let Some(history) = &self.history else {
            return Vec::new();
        };
        let from = frame.saturating_sub(HISTORY as u32).max(self.first_frame);
        (from..frame).filter(|k| !history.holds(*k)).collect()
    }

    /// `result`, sampled (with [`stop_rule`](Self::stop_rule) as its stop rule, or none),
    /// finished: denoised and blended, and combined with its earlier frames, as the scene
    /// asks; its figures those of the frame written.
    pub fn finish(&mut self, mut result: FrameResult) -> Result<FrameResult, Error> {
        let Some(d) = &mut self.denoising else {
            return Ok(result);
        };
        let frame = result.frame;
        let start = Instant::now();
        let pixels = d
            .written(&result.film)
            .map_err(|e| frame_failed(frame, e))?;
        let width = result.film.width as usize;
        let blend = match &mut self.history {
            None => Blend::from_written(width, &pixels),
            Some(h) => h.combine(&result, &pixels),
        };
        let st = &mut result.stats;
        // The frame's time holds its finishing, as it holds the denoises its rounds took.
        st.render_seconds += start.elapsed().as_secs_f64();
        st.relative_error = blend.relative_error;
        st.denoise_seconds = d.state.seconds;
        st.denoises = d.state.denoises;
        result.denoised = Some(Denoised {
            rgb: blend.rgb,
            relative_error: blend.relative_error,
            denoised_share: blend.denoised_share,
            history_share: self.history.as_ref().map(|_| blend.history_share),
            quality: d.quality,
        });
        d.begin();
        Ok(result)
    }
}

/// The history stage: the last frames finished, as their history reads them.
#[derive(Default)]
struct History {
    /// At most [`HISTORY`] frames, oldest first.
    frames: Vec<(u32, TemporalFrame)>,
}

impl History {
    fn holds(&self, frame: u32) -> bool {
        self.frames.iter().any(|(k, _)| *k == frame)
    }

    /// The written frame of `result` (its `pixels`) combined with the frames before it that
    /// are held (the frame before first; the one before that only after it); the frame is
    /// then held for the frames after it.
    fn combine(&mut self, result: &FrameResult, pixels: &[WrittenPixel]) -> Blend {
        let frame = result.frame;
        let current = temporal_frame(result, pixels);
        let earlier: Vec<&TemporalFrame> = (1..=HISTORY as u32)
            .map_while(|back| {
                let k = frame.checked_sub(back)?;
                self.frames.iter().find(|(j, _)| *j == k).map(|(_, f)| f)
            })
            .collect();
        let reprojected = reproject(&current, &earlier);
        let blend = history::combine(current.width, pixels, &reprojected);
        self.frames
            .retain(|(k, _)| *k < frame && frame - *k < HISTORY as u32);
        self.frames.push((frame, current));
        blend
    }
}

/// What a later frame's history reads of a finished frame: its written colour (before its
/// own history) and its first hits' depth, normal and backward motion (the film keeps them:
/// [`Finishing::passes_read`]).
fn temporal_frame(result: &FrameResult, pixels: &[WrittenPixel]) -> TemporalFrame {
    let film = &result.film;
    let images = PassImages::of(history_passes(), &result.layout, film);
    let channel = |name: &str| images.channel(name).expect("a kept pass");
    let interleave = |names: &[&str]| -> Vec<f32> {
        let cs: Vec<&[f32]> = names.iter().map(|n| channel(n)).collect();
        (0..cs[0].len())
            .flat_map(|i| cs.iter().map(move |c| c[i]))
            .collect()
    };
    TemporalFrame {
        width: film.width as usize,
        height: film.height as usize,
        colour: pixels.iter().flat_map(|p| p.written.to_array()).collect(),
        depth: channel("Z").to_vec(),
        normal: interleave(&["N.X", "N.Y", "N.Z"]),
        backward: interleave(&["backward.u", "backward.v"]),
    }
}

/// The denoise stage of a shot: its filter, and what the frame being finished has of it.
pub struct Denoising<'d> {
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
    pub fn new(
        denoiser: &'d Denoiser,
        width: usize,
        height: usize,
        quality: DenoiseQuality,
    ) -> Result<Denoising<'d>, crate::denoise::denoiser::DenoiseError> {
        Ok(Denoising {
            filter: denoiser.filter(width, height, quality)?,
            quality,
            width,
            state: FrameState::default(),
        })
    }

    /// Denoises `film`'s replicates (`halves`, row-major): the frame's new snapshot.
    fn denoise(&mut self, halves: &[Halves]) -> Result<(), FrameError> {
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
    fn written(&mut self, film: &Film) -> Result<Vec<WrittenPixel>, FrameError> {
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

    fn reached(&mut self, film: &Film, threshold: f64) -> Result<bool, FrameError> {
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
