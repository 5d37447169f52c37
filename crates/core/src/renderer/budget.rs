//! Budgets: when to stop sampling a frame instead of at exactly its requested samples (a time
//! limit, a noise threshold, a largest sample count), why it stopped, and the size of the
//! uniform rounds that come before the adaptive ones.

/// When to stop sampling a frame, instead of at exactly its requested samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Budget {
    /// Stop once this many seconds (preparation included) would be exceeded.
    pub time_limit: Option<f64>,
    /// Stop once the estimated relative error ([`FrameStats::relative_error`](super::FrameStats::relative_error)) is at or below
    /// this.
    pub noise_threshold: Option<f64>,
    /// Never take more samples per pixel than this.
    pub max_samples: Option<u32>,
}

impl Budget {
    /// True when a time limit or noise threshold is set: the frame is rendered in rounds.
    pub fn is_set(&self) -> bool {
        self.time_limit.is_some() || self.noise_threshold.is_some()
    }
}

/// The samples every pixel takes before a budget's rounds become adaptive, and the fewest
/// whose estimate may stop a render at its noise threshold. Below it, a pixel's estimate
/// misses rare bright paths too often.
pub(crate) const MIN_SAMPLES_FOR_THRESHOLD: u32 = 16;

/// Why a frame stopped sampling.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StopReason {
    /// It took exactly the requested samples (no budget).
    #[default]
    Samples,
    /// The estimated error reached the noise threshold.
    NoiseThreshold,
    /// Another round would have passed the time limit.
    TimeLimit,
    /// It reached the budget's largest sample count.
    MaxSamples,
}

impl StopReason {
    /// A short description for summaries.
    pub fn describe(self) -> &'static str {
        match self {
            StopReason::Samples => "requested samples",
            StopReason::NoiseThreshold => "noise threshold reached",
            StopReason::TimeLimit => "time limit",
            StopReason::MaxSamples => "max samples",
        }
    }
}

/// The samples per pixel of the next uniform round, or why to stop.
///
/// Rounds double the samples taken so far (1, 1, 2, 4, ...: totals at powers of two, where
/// Sobol points are best stratified). Under a time limit, a round takes at most half of the time
/// left, at the speed of the previous round: the rounds shrink toward the limit, so a round that
/// runs slower than the one before (a busy machine) still ends before it. The last round is a
/// single sample when 90 percent of the time left fits one.
pub(crate) fn next_round(
    budget: &Budget,
    done: u32,
    elapsed: f64,
    seconds_per_sample: Option<f64>,
) -> Result<u32, StopReason> {
    let cap = budget.max_samples.unwrap_or(u32::MAX);
    if done >= cap {
        return Err(StopReason::MaxSamples);
    }
    let mut size = done.max(1).min(cap - done);
    if let (Some(limit), Some(per_sample)) = (budget.time_limit, seconds_per_sample) {
        let left = limit - elapsed;
        let half = (0.5 * left / per_sample).floor();
        if half >= 1.0 {
            size = size.min(half.min(u32::MAX as f64) as u32);
        } else if 0.9 * left >= per_sample {
            size = 1;
        } else {
            return Err(StopReason::TimeLimit);
        }
    }
    Ok(size)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounds_double_the_samples_taken() {
        let b = Budget {
            noise_threshold: Some(0.01),
            ..Budget::default()
        };
        let mut done = 0;
        let mut totals = vec![];
        for _ in 0..6 {
            done += next_round(&b, done, 0.0, Some(1.0)).unwrap();
            totals.push(done);
        }
        assert_eq!(totals, [1, 2, 4, 8, 16, 32]);
    }

    #[test]
    fn rounds_stop_at_the_largest_sample_count() {
        let b = Budget {
            noise_threshold: Some(0.01),
            max_samples: Some(12),
            ..Budget::default()
        };
        assert_eq!(next_round(&b, 8, 0.0, None), Ok(4));
        assert_eq!(next_round(&b, 12, 0.0, None), Err(StopReason::MaxSamples));
    }

    #[test]
    fn rounds_fit_in_half_the_time_left() {
        let b = Budget {
            time_limit: Some(10.0),
            ..Budget::default()
        };
        // No speed known yet: the first pass is one sample.
        assert_eq!(next_round(&b, 0, 0.5, None), Ok(1));
        // 16 samples taken by 1 s at 0.05 s a sample: 16 more take 0.8 s, under half of 9 s.
        assert_eq!(next_round(&b, 16, 1.0, Some(0.05)), Ok(16));
        // 64 taken by 4 s: half of the 6 s left fits 60.
        assert_eq!(next_round(&b, 64, 4.0, Some(0.05)), Ok(60));
        // By 9.94 s: half of 0.06 s fits no sample, but 90 percent of it fits one.
        assert_eq!(next_round(&b, 200, 9.94, Some(0.05)), Ok(1));
        // By 9.96 s: not even that.
        assert_eq!(
            next_round(&b, 201, 9.96, Some(0.05)),
            Err(StopReason::TimeLimit)
        );
    }
}
