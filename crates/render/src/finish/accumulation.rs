//! The accumulation stage (`Carry::Raw`): the raw films of the frames
//! finished last, as a later frame pools them with its own before it is denoised
//! (`raytrace_denoise::accumulate` pools them).

use super::history_passes;
use raytrace_core::image::Image;
use raytrace_core::passes::add_pass_channels;
use raytrace_core::renderer::FrameResult;
use raytrace_denoise::accumulate::{Accumulated, accumulate, held_frame};
use raytrace_denoise::reproject::HISTORY;

/// The accumulation stage: the last frames' raw films, as a later frame reads them.
#[derive(Default)]
pub(super) struct Accumulation {
    /// At most [`HISTORY`] frames, oldest first.
    frames: Vec<(u32, Image)>,
}

impl Accumulation {
    pub(super) fn holds(&self, frame: u32) -> bool {
        self.frames.iter().any(|(k, _)| *k == frame)
    }

    /// The raw film of `result` pooled with the frames before it that are held (the frame
    /// before first; the one before that only after it); its raw film is then held for the
    /// frames after it. A frame pools raw films, never pooled ones, so it depends on the
    /// [`HISTORY`] frames before it and no others.
    pub(super) fn pool(&mut self, result: &FrameResult) -> Accumulated {
        let frame = result.frame;
        let mut current = result.film.replicates();
        add_pass_channels(&mut current, history_passes(), &result.layout, &result.film);
        let earlier: Vec<&Image> = (1..=HISTORY as u32)
            .map_while(|back| {
                let k = frame.checked_sub(back)?;
                self.frames.iter().find(|(j, _)| *j == k).map(|(_, f)| f)
            })
            .collect();
        let pooled = accumulate(&current, &earlier);
        self.frames
            .retain(|(k, _)| *k < frame && frame - *k < HISTORY as u32);
        let mut held = held_frame(&current);
        add_pass_channels(&mut held, history_passes(), &result.layout, &result.film);
        self.frames.push((frame, held));
        pooled
    }
}
