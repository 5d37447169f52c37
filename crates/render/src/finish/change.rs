//! The clip's stated flicker (`--temporal`'s frames, written alone): each written frame's
//! change terms, held for the frame after it, which states the change of its error from them
//! (`raytrace_denoise::change`, derived there).

use raytrace_denoise::change::{ChangeTerms, mean_change};

/// The last written frame's change terms.
#[derive(Default)]
pub(super) struct Change {
    last: Option<(u32, ChangeTerms)>,
}

impl Change {
    /// The estimated change of the error from frame `frame - 1` to `frame`, whose change terms
    /// are `terms`, where the frame before is held; `frame` is held then for the frame after
    /// it.
    pub(super) fn next(&mut self, frame: u32, terms: ChangeTerms) -> Option<f64> {
        let change = match &self.last {
            Some((k, before)) if k.checked_add(1) == Some(frame) => {
                Some(mean_change(before, &terms))
            }
            _ => None,
        };
        self.last = Some((frame, terms));
        change
    }
}
