//! The history stage (`Carry::Written`, `Carry::Centred`): the frames finished last (and, for
//! a centred window, the frame after, sampled ahead), as another frame's history reads them
//! (`raytrace_denoise::history` combines them).

use super::held::Held;
use super::history_passes;
use raytrace_core::image::{COLOUR, Image};
use raytrace_core::passes::add_pass_channels;
use raytrace_core::renderer::FrameResult;
use raytrace_core::scene::Carry;
use raytrace_denoise::estimate::Blend;
use raytrace_denoise::history;
use raytrace_denoise::reproject::{Along, HISTORY, reproject};

/// Which frames a frame's written frame is combined with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Window {
    /// The [`HISTORY`] frames before it (`Carry::Written`).
    Before,
    /// The frame before it and the frame after it (`Carry::Centred`).
    Centred,
}

impl Window {
    /// The window `carry` combines, if it combines written frames.
    pub(super) fn of(carry: Carry) -> Option<Window> {
        match carry {
            Carry::Written => Some(Window::Before),
            Carry::Centred => Some(Window::Centred),
            Carry::Nothing | Carry::Raw => None,
        }
    }

    /// How many frames before a frame it reads.
    pub(super) fn before(self) -> usize {
        match self {
            Window::Before => HISTORY,
            Window::Centred => 1,
        }
    }

    /// How many frames after a frame it reads.
    pub(super) fn after(self) -> usize {
        match self {
            Window::Before => 0,
            Window::Centred => 1,
        }
    }
}

/// The history stage: the frames around the frame being finished, as its history reads them.
pub(super) struct History {
    window: Window,
    /// The written frames finished last, and the frame sampled ahead.
    frames: Held,
}

impl History {
    /// A stage combining each frame with the frames of `window`.
    pub(super) fn new(window: Window) -> History {
        History {
            window,
            frames: Held::default(),
        }
    }

    /// The window the stage combines.
    pub(super) fn window(&self) -> Window {
        self.window
    }

    /// Whether frame `frame` is held.
    pub(super) fn holds(&self, frame: u32) -> bool {
        self.frames.holds(frame)
    }

    /// The written frame of `result` (its terms, `written`) combined with the frames of the
    /// window that are held (the frame before first, the one before that only after it; the
    /// frame after where it was sampled ahead, [`History::hold_ahead`]); the frame is then held
    /// for the frames after it.
    pub(super) fn combine(&mut self, result: &FrameResult, written: &Image) -> Blend {
        let frame = result.frame;
        let current = temporal_frame(result, written);
        let before = self.frames.before(frame, self.window.before());
        let after = self.frames.after(frame, self.window.after());
        let mut others = reproject(&current, &before, &COLOUR.0, Along::Backward);
        others.extend(reproject(&current, &after, &COLOUR.0, Along::Forward));
        let blend = history::combine(written, &others);
        self.frames.keep(frame, current, frame);
        blend
    }

    /// Holds the written frame of `result` (its terms, `written`), sampled ahead of the frame
    /// before it, for that frame's window; it is finished in its own turn.
    pub(super) fn hold_ahead(&mut self, result: &FrameResult, written: &Image) {
        let frame = result.frame;
        let current = temporal_frame(result, written);
        self.frames.keep(frame, current, frame.saturating_sub(1));
    }
}

/// What another frame's history reads of a finished frame: its written colour (before its
/// own history, [`COLOUR`] of `written`) and its first hits' depth, normal and motion (the
/// film keeps them: [`super::Finishing::passes_read`]).
fn temporal_frame(result: &FrameResult, written: &Image) -> Image {
    let mut frame = written.select(&COLOUR.0);
    add_pass_channels(&mut frame, history_passes(), &result.layout, &result.film);
    frame
}
