//! Finishing a sampled frame for writing: raw film → denoise → history → the frame written. A
//! shot's command assembles the stages its scene asks for once ([`Finishing::new`]) and runs
//! every frame through them ([`Finishing::finish`]); the sampling never branches on them, but asks
//! the pipeline's stop rule ([`Finishing::stop_rule`]) whether the frame that will be written
//! is within a noise threshold.
//!
//! **Denoise** (`Denoising`): the film's two replicates are denoised, each alone, by one
//! filter made for the shot; the written frame blends the raw frame and the denoised halves'
//! mean per pixel by their estimated errors, and states its own error
//! (`denoise::estimate`, derived there).
//!
//! **History** (`History`, measured by `converge --flicker`, set by no option): the written frame is combined with the two frames
//! before it, carried to its pixels along the motion vectors, each weighed by its estimated
//! error (`denoise::history`, derived there). A frame reads the frames before it as they were
//! written before their own history, so it depends on those two frames' renders and no
//! others': the command renders them first where its run does not ([`Finishing::needs`]).
//! A **centred window** (`Carry::Centred`, measured by `converge --flicker`, set by no option)
//! combines it with the frame before it and the frame after it instead; the frame after is
//! sampled and denoised ahead ([`Finishing::ahead`], [`Finishing::render_ahead`]) and finished
//! again in its own turn, the same samples.
//!
//! **The clip's stated flicker** (`Change`, `--temporal`'s frames, written alone):
//! each written frame states the change of its error from the frame before it, where this
//! pipeline finished that frame just before (`denoise::change`, derived there), from the two
//! frames' replicates and denoised replicates; the frames written are unchanged.
//!
//! **Accumulation** (`Accumulation`, measured by `converge --flicker`, set by no option): before
//! the denoise, the frame's raw replicates are pooled with the two frames' before it, carried
//! along the motion vectors, where they agree with the frame's own within their noise
//! (`denoise::accumulate`, derived there). A frame pools the raw films of those two frames
//! only, which the command renders first where its run does not ([`Finishing::needs`]). The
//! stop rule under a noise threshold judges the frame's own film.
//!
//! **Under a noise threshold, a denoise when it pays.** Once every pixel has its first
//! samples, the frame is denoised and its written error measured. After every later round the
//! last denoise is re-blended with the film as it is now, exactly and without the filter (the
//! denoised halves are unchanged, the raw side is the film's): the frame stops as soon as
//! that meets the threshold. Otherwise the written error a denoise now would give is
//! predicted from the frame's own earlier denoises, and the frame is denoised again when the
//! prediction meets the threshold, or sooner when a denoise costs less than the round it may
//! save (`when`, derived there). The rounds' samples go where the written frame's estimated
//! error is largest ([`StopRule::weights`]).

mod accumulation;
mod change;
mod denoising;
mod held;
mod history;
mod when;

use std::time::Instant;

use accumulation::Accumulation;
use change::Change;
use denoising::Denoising;
use history::{History, Window};
use raytrace_core::error::Error;
use raytrace_core::image::Image;
use raytrace_core::pass::{Pass, PassSet};
use raytrace_core::renderer::{
    Denoised, FrameJob, FrameResult, RawStop, ShotTracer, StopReason, StopRule,
};
use raytrace_core::scene::{Carry, DenoiseSettings, Scene};
use raytrace_denoise::change::ChangeTerms;
use raytrace_denoise::denoiser::{Denoiser, Filter, oidn_scratch};
use raytrace_denoise::estimate;
use raytrace_denoise::reproject::{self, HISTORY};

/// The passes the finishing stages of `scene` read from the film, written or not: with
/// history, the depth, normal and motion that carry a pixel to earlier frames.
pub fn passes_read(scene: &Scene) -> PassSet {
    match scene.output.denoise {
        Some(d) if d.carry != Carry::Nothing => history_passes(),
        _ => PassSet::EMPTY,
    }
}

/// The bytes the stages that finish a frame of `scene` hold at their peak, beyond the sampled
/// frame. With denoising: OIDN's scratch memory, which the shot's filter keeps
/// ([`oidn_scratch`]); the film's replicates (10 channels), the snapshot and each pixel's
/// weight for the adaptive rounds; and the largest of a denoise (a run's images,
/// [`Filter::run_bytes`], the two denoised replicates and the snapshot they replace), a
/// blend ([`estimate::blending_bytes`]) and, with history, the frame written
/// ([`estimate::written_bytes`]) with the frames held and the frame's own
/// ([`reproject::frame_bytes`]), their reprojection and the combination's working memory
/// ([`raytrace_denoise::history::bytes_for`]); with `--temporal`, the frame before's change
/// terms ([`ChangeTerms::bytes_for`]). Nothing for a raw frame.
pub fn bytes_for(scene: &Scene) -> u64 {
    let Some(settings) = scene.output.denoise else {
        return 0;
    };
    let pixels = scene.output.width as u64 * scene.output.height as u64;
    let snapshot = estimate::terms_bytes(pixels);
    let denoise = Filter::run_bytes(pixels) + Image::bytes_for(pixels, 2 * 3) + snapshot;
    let blend = estimate::blending_bytes(pixels);
    let history = match Window::of(settings.carry).is_some() {
        true => {
            estimate::written_bytes(pixels)
                + (HISTORY as u64 + 1) * reproject::frame_bytes(pixels)
                + reproject::reprojected_bytes(pixels)
                + raytrace_denoise::history::bytes_for(pixels)
        }
        false => 0,
    };
    let accumulation = match settings.carry == Carry::Raw {
        true => raytrace_denoise::accumulate::bytes_for(pixels),
        false => 0,
    };
    // The frame before's change terms, held while the frame is sampled and denoised; the
    // frame's own are made after its denoise has let go of more (its denoised halves).
    let change = match states_flicker(&settings) {
        true => ChangeTerms::bytes_for(pixels),
        false => 0,
    };
    oidn_scratch(
        scene.output.width.into(),
        scene.output.height.into(),
        settings.quality,
    ) + Image::bytes_for(pixels, 10)
        + snapshot
        + pixels * 8
        + denoise.max(blend).max(history)
        + accumulation
        + change
}

/// Whether frames finished with `settings` state the change of their error from the frame
/// before (`Change`): `--temporal`'s, which asks for a steady clip, written alone. A plain
/// `--denoise` run does not hold the frame before's terms for it (92 bytes a pixel, 182 MiB
/// at 1920x1080); history and accumulation write frames the estimate does not cover.
fn states_flicker(settings: &DenoiseSettings) -> bool {
    settings.temporal && settings.carry == Carry::Nothing
}

/// The passes history reads.
pub(crate) fn history_passes() -> PassSet {
    PassSet::EMPTY
        .with(Pass::Depth)
        .with(Pass::Normal)
        .with(Pass::Motion)
}

/// The stages that finish a shot's frames.
pub struct Finishing<'d> {
    denoising: Option<Denoising<'d>>,
    history: Option<History>,
    accumulation: Option<Accumulation>,
    /// The clip's stated flicker, for `--temporal`'s frames.
    change: Option<Change>,
    first_frame: u32,
    last_frame: u32,
    /// The passes the stages read ([`passes_read`]).
    read: PassSet,
    raw: RawStop,
}

impl<'d> Finishing<'d> {
    /// The stages `scene` asks for: denoising by `denoiser` when `[output] denoise` is set
    /// (`Devices::finishing` gives the run's denoiser then), history when its denoise
    /// settings ask for it (`DenoiseSettings::carry`).
    pub fn new(scene: &Scene, denoiser: Option<&'d Denoiser>) -> Result<Finishing<'d>, Error> {
        let denoising = match (&scene.output.denoise, denoiser) {
            (Some(settings), Some(d)) => Some(Denoising::new(
                d,
                (scene.output.width as usize, scene.output.height as usize),
                settings.quality,
                scene.render.device,
            )?),
            _ => None,
        };
        let history = scene
            .output
            .denoise
            .and_then(|d| Window::of(d.carry))
            .map(History::new);
        let accumulation = scene
            .output
            .denoise
            .filter(|d| d.carry == Carry::Raw)
            .map(|_| Accumulation::default());
        let change = scene
            .output
            .denoise
            .filter(states_flicker)
            .map(|_| Change::default());
        Ok(Finishing {
            denoising,
            history,
            accumulation,
            change,
            first_frame: scene.shot.first_frame,
            last_frame: scene.shot.last_frame(),
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

    /// `job` sampled on `tracer`'s device, judged under a noise threshold by this pipeline's
    /// stop rule, and finished.
    pub fn render(
        &mut self,
        job: FrameJob<'_>,
        tracer: &dyn ShotTracer,
    ) -> Result<FrameResult, Error> {
        let raw = job
            .reading(self.passes_read())
            .sample_with(tracer, self.stop_rule())?;
        self.finish(raw)
    }

    /// The passes these stages read from the film, written or not: with history, the depth,
    /// normal and motion that carry a pixel to earlier frames.
    pub fn passes_read(&self) -> PassSet {
        self.read
    }

    /// The frames that must be finished before `frame`, in order, that have not been: with
    /// history or accumulation, the frames before it (of the shot) that it reads, [`HISTORY`]
    /// or, for a centred window, one; none otherwise. A command renders and finishes them
    /// first, without writing them.
    pub fn needs(&self, frame: u32) -> Vec<u32> {
        let back = match (&self.history, &self.accumulation) {
            (Some(h), _) => h.window().before(),
            (None, Some(_)) => HISTORY,
            (None, None) => 0,
        };
        let from = frame.saturating_sub(back as u32).max(self.first_frame);
        let held = |k: u32| match (&self.history, &self.accumulation) {
            (Some(h), _) => h.holds(k),
            (None, Some(a)) => a.holds(k),
            (None, None) => true,
        };
        (from..frame).filter(|k| !held(*k)).collect()
    }

    /// The frame that must be sampled before `frame` is finished, and is not held: with a
    /// centred window, the frame after it, where the shot has one; none otherwise. A command
    /// renders it with [`Finishing::render_ahead`] before it samples `frame`.
    pub fn ahead(&self, frame: u32) -> Option<u32> {
        let h = self.history.as_ref()?;
        let next = frame.checked_add(h.window().after() as u32)?;
        (next > frame && next <= self.last_frame && !h.holds(next)).then_some(next)
    }

    /// `job` (the frame [`Finishing::ahead`] names) sampled as [`Finishing::render`] samples
    /// it and denoised, its written frame held for the window of the frame before it; it is
    /// not finished.
    pub fn render_ahead(
        &mut self,
        job: FrameJob<'_>,
        tracer: &dyn ShotTracer,
    ) -> Result<(), Error> {
        let raw = job
            .reading(self.passes_read())
            .sample_with(tracer, self.stop_rule())?;
        let (Some(d), Some(h)) = (&mut self.denoising, &mut self.history) else {
            return Ok(());
        };
        let written = written_frame(d, &raw).map_err(|e| e.in_frame(raw.frame))?;
        h.hold_ahead(&raw, &written.terms);
        // What the frame's denoising spent is counted in its own turn.
        d.begin();
        Ok(())
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
        let (written, pooled_share) = match (&mut self.accumulation, result.stats.stop) {
            (Some(a), _) => {
                let pooled = a.pool(&result);
                (
                    d.written_pooled(&pooled.replicates),
                    Some(pooled.history_share),
                )
            }
            (None, _) => (written_frame(d, &result), None),
        };
        let written = written.map_err(|e| e.in_frame(frame))?;
        let change = self
            .change
            .as_mut()
            .and_then(|c| c.next(frame, d.change_terms(&result.film, &written.terms)));
        let (blend, history_share) = match &mut self.history {
            None => (written.blend, pooled_share),
            Some(h) => {
                let blend = h.combine(&result, &written.terms);
                let share = blend.history_share;
                (blend, Some(share))
            }
        };
        let st = &mut result.stats;
        // The frame's time holds its finishing, as it holds the denoises its rounds took.
        st.render_seconds += start.elapsed().as_secs_f64();
        st.relative_error = blend.relative_error;
        (st.denoise_seconds, st.denoises) = d.spent();
        // The written colour in place of the film's; the passes stay.
        for channel in blend.image.into_channels() {
            result.image.set_channel(channel);
        }
        result.denoised = Some(Denoised {
            relative_error: blend.relative_error,
            denoised_share: blend.denoised_share,
            history_share,
            quality: d.quality(),
            change,
        });
        d.begin();
        Ok(result)
    }
}

/// The written frame of `result`'s film by `d`: under a time limit the last denoise's, which
/// the frame stopped on (`Denoising::written_within_time`).
fn written_frame(d: &mut Denoising, result: &FrameResult) -> Result<denoising::Written, Error> {
    match result.stats.stop {
        StopReason::TimeLimit => d.written_within_time(&result.film),
        _ => d.written(&result.film),
    }
}
