//! The frames a shot's later frames read: the frames finished last (and, for a centred window,
//! the frame sampled ahead), each as its stage keeps it (a written frame for history, a raw
//! film for accumulation).

use raytrace_core::image::Image;
use raytrace_denoise::reproject::HISTORY;

/// The frames finished last, as other frames read them.
#[derive(Default)]
pub(super) struct Held {
    /// At most [`HISTORY`] + 1 frames.
    frames: Vec<(u32, Image)>,
}

impl Held {
    /// Whether frame `frame` is held.
    pub(super) fn holds(&self, frame: u32) -> bool {
        self.frames.iter().any(|(k, _)| *k == frame)
    }

    /// Up to `count` held frames before `frame`: the frame before first, then the one before
    /// that, stopping at the first that is not held.
    pub(super) fn before(&self, frame: u32, count: usize) -> Vec<&Image> {
        (1..=count as u32)
            .map_while(|back| self.at(frame.checked_sub(back)?))
            .collect()
    }

    /// Up to `count` held frames after `frame`: the frame after first, stopping at the first
    /// that is not held.
    pub(super) fn after(&self, frame: u32, count: usize) -> Vec<&Image> {
        (1..=count as u32)
            .map_while(|ahead| self.at(frame.checked_add(ahead)?))
            .collect()
    }

    fn at(&self, frame: u32) -> Option<&Image> {
        self.frames
            .iter()
            .find(|(k, _)| *k == frame)
            .map(|(_, f)| f)
    }

    /// Holds `image` as frame `frame`'s (in place of any held before), for the frames read
    /// around frame `around` (the frame being finished), letting go of those further from it
    /// than [`HISTORY`] - 1 frames: no frame from `around` on reads them.
    pub(super) fn keep(&mut self, frame: u32, image: Image, around: u32) {
        self.frames
            .retain(|(k, _)| *k != frame && k.abs_diff(around) < HISTORY as u32);
        self.frames.push((frame, image));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-pixel image holding `v`, to tell frames apart.
    fn image(v: f32) -> Image {
        let mut i = Image::new(1, 1);
        i.set(
            "R",
            raytrace_core::image::Precision::Float,
            raytrace_core::image::Values::Float(vec![v]),
        );
        i
    }

    fn values(frames: Vec<&Image>) -> Vec<f32> {
        frames.iter().map(|f| f.floats("R").unwrap()[0]).collect()
    }

    #[test]
    fn history_holds_the_frames_before_and_lets_go_of_older_ones() {
        let mut held = Held::default();
        for frame in 1..=4 {
            held.keep(frame, image(frame as f32), frame);
        }
        assert_eq!(values(held.before(5, HISTORY)), [4.0, 3.0]);
        assert!(!held.holds(2));
        // A gap ends the frames before: frame 7 reads nothing of 4.
        assert!(held.before(7, HISTORY).is_empty());
    }

    #[test]
    fn a_centred_window_holds_the_frame_before_and_the_frame_sampled_ahead() {
        let mut held = Held::default();
        // In a run's order: frame 2 ahead of 1, 1 finished, 3 ahead of 2, 2 finished, ...
        held.keep(2, image(-2.0), 1);
        held.keep(1, image(1.0), 1);
        for frame in 2..=5 {
            held.keep(frame + 1, image(-(frame as f32 + 1.0)), frame);
            assert_eq!(values(held.before(frame, 1)), [frame as f32 - 1.0]);
            assert_eq!(values(held.after(frame, 1)), [-(frame as f32 + 1.0)]);
            // The frame finished replaces its held copy from ahead.
            held.keep(frame, image(frame as f32), frame);
            assert_eq!(held.frames.len(), 3, "frame {frame}");
        }
        assert_eq!(values(held.before(6, 1)), [5.0]);
        assert_eq!(values(held.after(5, 1)), [-6.0]);
    }
}
