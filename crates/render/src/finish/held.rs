//! The frames a shot's later frames read: at most [`HISTORY`] of the frames finished last,
//! each as its stage keeps it (a written frame for history, a raw film for accumulation).

use raytrace_core::image::Image;
use raytrace_denoise::reproject::HISTORY;

/// The frames finished last, as later frames read them.
#[derive(Default)]
pub(super) struct Held {
    /// At most [`HISTORY`] frames, oldest first.
    frames: Vec<(u32, Image)>,
}

impl Held {
    /// Whether frame `frame` is held.
    pub(super) fn holds(&self, frame: u32) -> bool {
        self.frames.iter().any(|(k, _)| *k == frame)
    }

    /// The held frames before `frame`: the frame before first, then the one before that, up to
    /// [`HISTORY`], stopping at the first that is not held.
    pub(super) fn before(&self, frame: u32) -> Vec<&Image> {
        (1..=HISTORY as u32)
            .map_while(|back| {
                let k = frame.checked_sub(back)?;
                self.frames.iter().find(|(j, _)| *j == k).map(|(_, f)| f)
            })
            .collect()
    }

    /// Holds `image` as frame `frame`'s, letting go of the frames no frame after it reads.
    pub(super) fn keep(&mut self, frame: u32, image: Image) {
        self.frames
            .retain(|(k, _)| *k < frame && frame - *k < HISTORY as u32);
        self.frames.push((frame, image));
    }
}
