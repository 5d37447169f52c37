//! When a frame under a noise threshold is denoised again: the written error a denoise now
//! would give, predicted from the frame's own earlier denoises, weighed against what a denoise
//! and a round cost, in samples ([`DenoiseSchedule`]).
//!
//! **The prediction.** After a denoise of a film of `n` mean samples a pixel, the written
//! frame (raw and denoised blended, `denoise::estimate`) states its error `e(n)`. Between
//! denoises it is modelled as a power of the samples, `e(n') = e(n) (n' / n)^(-α)`. A
//! smoother's squared error falls as `n^(-2/3)` in two dimensions (Stone, Ann. Statist. 10,
//! 1982), so `α = 1/3` for the denoised frame alone, and the raw frame's `α = 1/2`; the blend
//! lies between. After the frame's first denoise the prior [`ALPHA_PRIOR`] stands; after two,
//! `α` is the slope measured between the last two (clamped to [`ALPHA_RANGE`]), which also
//! takes in what adaptive rounds gain over uniform ones. Measured on the books' scene at
//! 400x225 (`render --denoise --samples N`, stated errors 5.048%, 3.827%, 2.939% and 2.266% at
//! 16, 32, 64 and 128 samples, true 4.949%, 3.756%, 2.879% and 2.231%): `α` 0.40, 0.38 and
//! 0.37 between them, and the slope of one pair predicted the next error within 1.3% and
//! 0.4%; under `--noise-threshold 0.01` a denoise at 16 samples stated 5.05% and one at 1364
//! samples 0.755%, a slope of 0.43.
//!
//! **The choice.** A denoise now meets the threshold `t` with the probability that the
//! prediction's log error allows, `p = Φ((ln t - ln e) / σ)` with [`SIGMA`]. If it does, it
//! saves the next round; so a denoise is worth its cost `c_d` when `p c_r ≥ c_d` (`c_r` the
//! round just taken, which the next one is likely to cost: rounds double the samples of the
//! pixels that need them). And whatever the costs, a frame is denoised as soon as the
//! prediction meets the threshold (`p ≥ 1/2`): waiting would only take more samples than
//! the frame needs.
//!
//! **Costs in samples, not seconds.** Measured seconds would make the frame written depend on
//! how loaded the machine was (a slow denoise on a busy machine is not tried early, and the
//! frame takes other rounds); a frame depends on its seed, frame, pixels and samples alone.
//! So `c_r` is the round's samples and `c_d` the denoise's cost in samples,
//! [`denoise_samples_per_pixel`] times the frame's pixels, per device: the same on any thread
//! count, since the filter and the tracer share the cores.

use raytrace_core::scene::Device;

/// What a denoise of one pixel costs, in the tracer's samples, on the device that traces the
/// frame (`[render] device`).
///
/// - **CPU:** OIDN's CPU filter (both replicates) against the CPU tracer on the same cores,
///   measured at 400x225 on 2 cores with 16 samples (`render --denoise --stats`: the
///   denoising's seconds a pixel over the sampling's seconds a sample): 6.7 and 7.3 on the
///   books' scene, 8.8 and 9.2 on the turntable, 11.5 and 12.2 on `quick` (its samples are
///   cheaper). Taken as 9, their middle: a scene whose samples cost more is denoised a little
///   later than its own costs would have it, one whose samples cost less a little sooner.
/// - **GPU:** not measured on a GPU yet, and the filter runs on the GPU (milliseconds) or on
///   the host's cores (seconds at 1920x1080) by `--denoise-device`: infinite, so such a
///   frame is denoised when the prediction meets the threshold, never earlier.
pub(crate) fn denoise_samples_per_pixel(device: Device) -> f64 {
    match device {
        Device::Cpu => CPU_DENOISE_SAMPLES_PER_PIXEL,
        Device::Gpu => f64::INFINITY,
    }
}

/// [`denoise_samples_per_pixel`] on the CPU.
const CPU_DENOISE_SAMPLES_PER_PIXEL: f64 = 9.0;

/// The prior exponent of the written error's fall with the mean samples, until two denoises
/// measure it: between the denoised frame's `1/3` and the raw frame's `1/2`, as measured on
/// the books' scene (see the module's notes: 0.37 to 0.40 between uniform sample counts, and
/// 0.43 from a denoise at 16 samples to one at 1364 under adaptive rounds). `1/3` alone, the
/// most cautious, left a frame sampling hundreds of samples a pixel past where a denoise
/// would have met its threshold.
pub(crate) const ALPHA_PRIOR: f64 = 0.4;

/// The exponents a measured slope is held to: at most the raw frame's `1/2` (more samples
/// cannot make the blend fall faster than its raw side does once it leans on it), at least a
/// tenth, where a denoiser's bias makes a floor (a slope measured flatter than that is
/// noise in the two estimates more than a trend).
pub(crate) const ALPHA_RANGE: (f64, f64) = (0.1, 0.5);

/// The prediction's standard error in `ln e`: several times the scatter measured on the books'
/// scene (see the module's notes), for the noise of the stated errors themselves (each a mean
/// of noisy per-pixel estimates) and for adaptive rounds that follow the model less closely
/// than uniform ones.
pub(crate) const SIGMA: f64 = 0.1;

/// A denoise of the frame: its mean samples a pixel and the written error it gave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Measured {
    pub(crate) samples: f64,
    pub(crate) error: f64,
}

/// What a frame's denoises so far tell of the next one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct DenoiseSchedule {
    last: Option<Measured>,
    before: Option<Measured>,
}

impl DenoiseSchedule {
    /// Records a denoise that gave `measured`.
    pub(crate) fn denoised(&mut self, measured: Measured) {
        self.before = self.last.replace(measured);
    }

    /// The exponent of the written error's fall: the slope between the last two denoises,
    /// or the prior.
    fn alpha(&self) -> f64 {
        match (self.before, self.last) {
            (Some(b), Some(l)) if l.samples > b.samples && l.error > 0.0 && b.error > 0.0 => {
                let slope = (b.error / l.error).ln() / (l.samples / b.samples).ln();
                if slope.is_finite() {
                    slope.clamp(ALPHA_RANGE.0, ALPHA_RANGE.1)
                } else {
                    ALPHA_PRIOR
                }
            }
            _ => ALPHA_PRIOR,
        }
    }

    /// The written error a denoise of a film of `samples` mean samples would give, or `None`
    /// before the frame's first denoise.
    pub(crate) fn predicted(&self, samples: f64) -> Option<f64> {
        let last = self.last?;
        Some(last.error * (samples / last.samples).powf(-self.alpha()))
    }

    /// Whether to denoise now, under `threshold`, after a round of `round_samples`, where a
    /// denoise costing `denoise_samples` is predicted to give a written error of `predicted`
    /// (see the module's notes).
    pub(crate) fn worth_denoising(
        &self,
        predicted: f64,
        threshold: f64,
        (round_samples, denoise_samples): (f64, f64),
    ) -> bool {
        if predicted.is_nan() || predicted <= threshold {
            return true;
        }
        let p = normal_cdf((threshold.ln() - predicted.ln()) / SIGMA);
        p * round_samples >= denoise_samples
    }
}

/// The standard normal distribution function, by the logistic approximation
/// `1 / (1 + exp(-1.702 x))` (Bowling et al., J. Ind. Eng. Manag. 2(1), 2009: within 0.0095
/// everywhere), which is all a choice between two costs needs; exact at 0 (one half).
fn normal_cdf(x: f64) -> f64 {
    1.0 / (1.0 + (-1.702 * x).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn after(denoises: &[(f64, f64)]) -> DenoiseSchedule {
        let mut s = DenoiseSchedule::default();
        for &(samples, error) in denoises {
            s.denoised(Measured { samples, error });
        }
        s
    }

    #[test]
    fn there_is_no_prediction_before_the_first_denoise() {
        assert_eq!(DenoiseSchedule::default().predicted(16.0), None);
    }

    #[test]
    fn one_denoise_predicts_with_the_prior() {
        let s = after(&[(16.0, 0.05)]);
        let p = s.predicted(16.0 * 32.0).unwrap();
        // 32^(-0.4) = 2^(-2) = 1/4.
        assert!((p - 0.0125).abs() < 1e-12, "{p}");
    }

    #[test]
    fn two_denoises_predict_with_their_slope() {
        // The books' scene's stated errors at 32 and 64 samples (the module's notes): their
        // slope predicts 128 samples' 2.266% within 0.4% (2.257%).
        let s = after(&[(32.0, 0.03827), (64.0, 0.02939)]);
        let p = s.predicted(128.0).unwrap();
        assert!((p / 0.02266 - 1.0).abs() < 0.004, "{p}");
        // A flat pair is held to the range's floor, a steep one to its top.
        let flat = after(&[(32.0, 0.03), (64.0, 0.03)]);
        assert!((flat.predicted(128.0).unwrap() - 0.03 * 2f64.powf(-0.1)).abs() < 1e-12);
        let steep = after(&[(32.0, 0.04), (64.0, 0.01)]);
        assert!((steep.predicted(128.0).unwrap() - 0.01 * 2f64.powf(-0.5)).abs() < 1e-12);
    }

    #[test]
    fn a_prediction_that_meets_the_threshold_is_denoised_whatever_it_costs() {
        let s = after(&[(16.0, 0.05)]);
        // 0.05 at 16 samples predicts 0.0125 at 512 (32^(-0.4) = 1/4), 0.0164 at 256.
        let at = |n| s.predicted(n).unwrap();
        // A round of one sample against a denoise costing a million.
        assert!(s.worth_denoising(at(512.0), 0.0125, (1.0, 1e6)));
        assert!(!s.worth_denoising(at(256.0), 0.0125, (1.0, 1e6)));
        // On a GPU, never before the prediction meets it, however large the round.
        let gpu = denoise_samples_per_pixel(Device::Gpu);
        assert!(s.worth_denoising(at(512.0), 0.0125, (1e12, gpu)));
        assert!(!s.worth_denoising(at(480.0), 0.0125, (1e12, gpu)));
    }

    #[test]
    fn a_cheap_denoise_is_tried_before_the_prediction_meets_the_threshold() {
        // Predicted 5% over the threshold: p = Φ(-0.49) ≈ 0.30 by the approximation.
        let s = after(&[(16.0, 0.05)]);
        // A round of 1e6 samples against a denoise costing 1.5e5: worth it; 4e5: not.
        assert!(s.worth_denoising(0.021, 0.02, (1e6, 1.5e5)));
        assert!(!s.worth_denoising(0.021, 0.02, (1e6, 4e5)));
        // Far from the threshold (twice it) even a round of 1e7 samples is not enough.
        assert!(!s.worth_denoising(0.04, 0.02, (1e7, 1.5e5)));
    }

    #[test]
    fn the_logistic_stays_within_its_stated_bound() {
        // Φ at a few points, from tables: 0.5, 0.8413, 0.9772, 0.1587.
        for (x, phi) in [(0.0, 0.5), (1.0, 0.8413), (2.0, 0.9772), (-1.0, 0.1587)] {
            assert!((normal_cdf(x) - phi).abs() < 0.0095, "{x}");
        }
    }
}
