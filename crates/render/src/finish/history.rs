//! The history stage of `--temporal`: the frames finished last, as a later frame's history
//! reads them (`denoise::history` combines them).

use super::history_passes;
use raytrace_core::passes::PassImages;
use raytrace_core::renderer::FrameResult;
use raytrace_denoise::estimate::{Blend, WrittenPixel};
use raytrace_denoise::history;
use raytrace_denoise::reproject::{HISTORY, TemporalFrame, reproject};

/// The history stage: the last frames finished, as their history reads them.
#[derive(Default)]
pub(super) struct History {
    /// At most [`HISTORY`] frames, oldest first.
    frames: Vec<(u32, TemporalFrame)>,
}

impl History {
    pub(super) fn holds(&self, frame: u32) -> bool {
        self.frames.iter().any(|(k, _)| *k == frame)
    }

    /// The written frame of `result` (its `pixels`) combined with the frames before it that
    /// are held (the frame before first; the one before that only after it); the frame is
    /// then held for the frames after it.
    pub(super) fn combine(&mut self, result: &FrameResult, pixels: &[WrittenPixel]) -> Blend {
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
/// [`super::Finishing::passes_read`]).
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
