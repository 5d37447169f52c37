//! When a frame under a noise threshold has sampled enough, and where the next round's samples
//! go: one interface, [`StopRule`], that the round loop (`job`) asks after every round once
//! every pixel has its first samples. [`RawStop`] judges the raw film by its own estimate; the
//! denoised implementation (`finish::Denoising`) judges the frame that will be written, the
//! raw and denoised frames blended.

use super::adaptive::Weights;
use crate::error::Error;
use crate::film::Film;

/// What decides whether a frame under a noise threshold stops, and weighs its pixels for the
/// next adaptive round.
pub trait StopRule {
    /// A new frame begins: forget the last one.
    fn begin(&mut self);

    /// Whether the frame, as `film` holds it after a round of `round_samples` samples, is
    /// within `threshold` (a relative error). The round's samples are what the next round is
    /// likely to cost, which a rule with work of its own to do (a denoise) weighs against it:
    /// in samples, never in seconds, so that the frame written depends on its samples alone,
    /// not on how loaded the machine was.
    fn reached(&mut self, film: &Film, threshold: f64, round_samples: u64) -> Result<bool, Error>;

    /// Each pixel's weight in the next adaptive round (its estimated relative variance per
    /// sample).
    fn weights(&self) -> Weights<'_>;
}

/// The raw film's own estimate: the frame written is the raw frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct RawStop;

impl StopRule for RawStop {
    fn begin(&mut self) {}

    fn reached(&mut self, film: &Film, threshold: f64, _: u64) -> Result<bool, Error> {
        Ok(relative_error(film) <= threshold)
    }

    fn weights(&self) -> Weights<'_> {
        Weights::Raw
    }
}

/// The relative error estimated from the film's pixels
/// ([`FrameStats::relative_error`](super::FrameStats::relative_error) of a raw frame): the
/// square root of the mean of their [`film::relative_variances`](crate::film::relative_variances),
/// summed in storage order.
pub fn relative_error(film: &Film) -> f64 {
    let sum: f64 = film
        .tiles()
        .iter()
        .flat_map(|(rect, pixels)| crate::film::relative_variances(rect, pixels))
        .sum();
    (sum / film.all_pixels().len().max(1) as f64).sqrt()
}
