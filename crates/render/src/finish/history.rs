//! The history stage (`Carry::Written`): the frames finished last, as a later frame's history
//! reads them (`raytrace_denoise::history` combines them).

use super::held::Held;
use super::history_passes;
use raytrace_core::image::{COLOUR, Image};
use raytrace_core::passes::add_pass_channels;
use raytrace_core::renderer::FrameResult;
use raytrace_denoise::estimate::Blend;
use raytrace_denoise::history;
use raytrace_denoise::reproject::reproject;

/// The history stage: the last frames finished, as their history reads them.
#[derive(Default)]
pub(super) struct History {
    /// The written frames finished last.
    frames: Held,
}

impl History {
    /// Whether frame `frame` is held.
    pub(super) fn holds(&self, frame: u32) -> bool {
        self.frames.holds(frame)
    }

    /// The written frame of `result` (its terms, `written`) combined with the frames before
    /// it that are held (the frame before first; the one before that only after it); the
    /// frame is then held for the frames after it.
    pub(super) fn combine(&mut self, result: &FrameResult, written: &Image) -> Blend {
        let frame = result.frame;
        let current = temporal_frame(result, written);
        let reprojected = reproject(&current, &self.frames.before(frame), &COLOUR.0);
        let blend = history::combine(written, &reprojected);
        self.frames.keep(frame, current);
        blend
    }
}

/// What a later frame's history reads of a finished frame: its written colour (before its
/// own history, [`COLOUR`] of `written`) and its first hits' depth, normal and motion (the
/// film keeps them: [`super::Finishing::passes_read`]).
fn temporal_frame(result: &FrameResult, written: &Image) -> Image {
    let mut frame = written.select(&COLOUR.0);
    add_pass_channels(&mut frame, history_passes(), &result.layout, &result.film);
    frame
}
