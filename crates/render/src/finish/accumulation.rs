//! The accumulation stage (`Carry::Raw`): the raw films of the frames
//! finished last, as a later frame pools them with its own before it is denoised
//! (`raytrace_denoise::accumulate` pools them).

use super::held::Held;
use super::history_passes;
use raytrace_core::passes::add_pass_channels;
use raytrace_core::renderer::FrameResult;
use raytrace_denoise::accumulate::{Accumulated, accumulate, held_frame};
use raytrace_denoise::reproject::HISTORY;

/// The accumulation stage: the last frames' raw films, as a later frame reads them.
#[derive(Default)]
pub(super) struct Accumulation {
    /// The raw films finished last.
    frames: Held,
}

impl Accumulation {
    /// Whether frame `frame` is held.
    pub(super) fn holds(&self, frame: u32) -> bool {
        self.frames.holds(frame)
    }

    /// The raw film of `result` pooled with the frames before it that are held (the frame
    /// before first; the one before that only after it); its raw film is then held for the
    /// frames after it. A frame pools raw films, never pooled ones, so it depends on the
    /// [`HISTORY`] frames before it and no others.
    pub(super) fn pool(&mut self, result: &FrameResult) -> Accumulated {
        let frame = result.frame;
        let mut current = result.film.replicates();
        add_pass_channels(&mut current, history_passes(), &result.layout, &result.film);
        let pooled = accumulate(&current, &self.frames.before(frame, HISTORY));
        self.frames.keep(frame, held_frame(&current), frame);
        pooled
    }
}
