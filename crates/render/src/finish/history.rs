//! The history stage (`Carry::Written`): the frames finished last, as a later frame's history
//! reads them (`raytrace_denoise::history` combines them).

use super::history_passes;
use raytrace_core::image::{COLOUR, Image};
use raytrace_core::passes::add_pass_channels;
use raytrace_core::renderer::FrameResult;
use raytrace_denoise::estimate::Blend;
use raytrace_denoise::history;
use raytrace_denoise::reproject::{HISTORY, reproject};

/// The history stage: the last frames finished, as their history reads them.
#[derive(Default)]
pub(super) struct History {
    /// At most [`HISTORY`] frames, oldest first.
    frames: Vec<(u32, Image)>,
}

impl History {
    pub(super) fn holds(&self, frame: u32) -> bool {
        self.frames.iter().any(|(k, _)| *k == frame)
    }

    /// The written frame of `result` (its terms, `written`) combined with the frames before
    /// it that are held (the frame before first; the one before that only after it); the
    /// frame is then held for the frames after it.
    pub(super) fn combine(&mut self, result: &FrameResult, written: &Image) -> Blend {
        let frame = result.frame;
        let current = temporal_frame(result, written);
        let earlier: Vec<&Image> = (1..=HISTORY as u32)
            .map_while(|back| {
                let k = frame.checked_sub(back)?;
                self.frames.iter().find(|(j, _)| *j == k).map(|(_, f)| f)
            })
            .collect();
        let reprojected = reproject(&current, &earlier, &COLOUR.0);
        let blend = history::combine(written, &reprojected);
        self.frames
            .retain(|(k, _)| *k < frame && frame - *k < HISTORY as u32);
        self.frames.push((frame, current));
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
