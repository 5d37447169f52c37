//! What a round's dispatches ask of a part of the film, and how large they are: decided from
//! a few numbers per dispatch, never per sample.
//!
//! A part's work entries (one per pixel with samples to take, `remaining` each) are sorted
//! most remaining first. The dispatches go in *windows*: in a window, each entry's pixel takes
//! up to `k` more samples, and the window covers the entries that, had every earlier window
//! taken all it asked, would still have samples to take: a prefix of the sorted entries, cut
//! into dispatches of about the samples the [`Pace`] asks for. An invocation may take fewer
//! than asked (it starts no sample past its loop budget, and a window the device cut is
//! discarded, trace.wgsl): the device keeps each pixel's next sample, so such a pixel is
//! simply behind, and once the windows are over, *catch-up* windows cover every entry until
//! the device's counts say the part is done. A catch-up window that adds nothing means a
//! single sample needs more than the device runs in an invocation.

/// Device seconds a dispatch should take at most: long enough that a dispatch's fixed cost
/// is small, short enough for progress to move and far from the two seconds after which
/// desktop drivers reset a GPU.
pub(super) const BATCH_SECONDS: f64 = 0.1;

/// The share of [`BATCH_SECONDS`] a dispatch is sized for, leaving room for a dispatch to run
/// slower than the last.
const AIM: f64 = 0.7;

/// Samples of the first dispatches, before the device's pace is measured.
const FIRST_SAMPLES: u64 = 1 << 16;

/// How much larger a dispatch may be than the last one measured.
const GROWTH: f64 = 4.0;

/// Samples an invocation takes at most in a window.
const MOST_SAMPLES: u32 = 1 << 16;

/// Samples an invocation takes in a window, at least where its pixel has them: an
/// invocation's fixed cost (reading the frame's header, the pixel's sums, writing them back)
/// is then a small part of its time.
const LEAST_SAMPLES: u64 = 16;

/// Invocations a dispatch holds at most: WebGPU's 65,535 workgroups of
/// [`super::layout::WORKGROUP`].
pub(super) const MOST_INVOCATIONS: u32 = 65_535 * super::layout::WORKGROUP;

/// The device's pace, measured on finished dispatches: what sizes the next ones.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Pace {
    /// Samples a device second, measured on the last dispatch.
    rate: Option<f64>,
    /// The most samples a dispatch held so far.
    largest: u64,
    /// The samples an invocation may take in a window: halved after a window was cut, grown
    /// again as windows finish.
    per_invocation: Option<u32>,
}

impl Pace {
    /// Samples the next dispatch should hold.
    pub(super) fn samples(&self) -> u64 {
        let aim = match self.rate {
            None => FIRST_SAMPLES,
            Some(r) => (r * BATCH_SECONDS * AIM) as u64,
        };
        let most = (self.largest.max(FIRST_SAMPLES) as f64 * GROWTH) as u64;
        aim.clamp(1, most)
    }

    /// A dispatch of `invocations` invocations asked to take up to `k` samples each added
    /// `samples` in `seconds` of device time, and `cut` of its invocations were cut.
    pub(super) fn measured(&mut self, samples: u64, seconds: f64, k: u32, cut: u64) {
        if samples > 0 && seconds > 0.0 {
            self.rate = Some(samples as f64 / seconds);
        }
        self.largest = self.largest.max(samples);
        // A dispatch that added nothing and was not cut (its entries had nothing left) says
        // nothing of the device: growing on it would undo the halving after a cut and keep
        // asking windows the device cuts.
        self.per_invocation = if cut > 0 {
            Some((k / 2).max(1))
        } else if samples > 0 {
            self.per_invocation.map(|p| p.saturating_mul(2))
        } else {
            self.per_invocation
        };
    }

    /// A pace whose invocations take one sample at first (twice as many after each dispatch
    /// that was not cut): other windows than the default's.
    #[cfg(test)]
    pub(super) fn one_sample_at_first() -> Pace {
        Pace {
            per_invocation: Some(1),
            ..Pace::default()
        }
    }

    /// Samples an invocation may take, at most.
    fn per_invocation(&self) -> u32 {
        self.per_invocation
            .unwrap_or(MOST_SAMPLES)
            .min(MOST_SAMPLES)
    }
}

/// One dispatch: `count` entries from `first`, each taking up to `k` samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Dispatch {
    pub(super) first: u32,
    pub(super) count: u32,
    pub(super) k: u32,
    /// The window it belongs to, and whether it is that window's last dispatch.
    pub(super) window: u32,
    pub(super) last: bool,
    /// A catch-up window's.
    pub(super) catch_up: bool,
}

/// The windows of one part's round.
#[derive(Debug)]
pub(super) struct Windows {
    /// Each entry's samples at the round's start, most first.
    remaining: Vec<u32>,
    /// Samples still to be added, by the device's counts.
    left: u64,
    /// Samples every entry would have taken in the windows so far, had none fallen behind.
    taken: u64,
    /// The current window: its entries, its `k`, where its next dispatch starts.
    window: u32,
    active: u32,
    k: u32,
    at: u32,
    catch_up: bool,
    /// Samples added since the current catch-up window began.
    caught: u64,
}

impl Windows {
    /// The windows of a part whose entries, sorted most first, have `remaining` samples each.
    pub(super) fn new(remaining: Vec<u32>) -> Windows {
        debug_assert!(remaining.windows(2).all(|w| w[0] >= w[1]));
        let left = remaining.iter().map(|&r| r as u64).sum();
        Windows {
            remaining,
            left,
            taken: 0,
            window: 0,
            active: 0,
            k: 0,
            at: 0,
            catch_up: false,
            caught: 0,
        }
    }

    /// Samples the part still needs.
    pub(super) fn left(&self) -> u64 {
        self.left
    }

    /// Entries with more than `taken` samples at the start: a prefix.
    fn beyond(&self, taken: u64) -> u32 {
        self.remaining.partition_point(|&r| r as u64 > taken) as u32
    }

    /// The next dispatch, of about `samples` samples, at most `per` a invocation (the pace),
    /// or `None` when every window that can be planned now is out: then either the part is
    /// done ([`left`](Self::left) is 0) or, once the dispatches in flight are back, a
    /// catch-up window starts ([`catch_up`](Self::catch_up)).
    pub(super) fn next(&mut self, samples: u64, pace: &Pace) -> Option<Dispatch> {
        if self.at == self.active {
            // A new window.
            if self.catch_up {
                return None;
            }
            self.active = self.beyond(self.taken);
            self.at = 0;
            if self.active == 0 {
                return None;
            }
            self.window += 1;
            // Each entry of the window takes about an equal share of the dispatch, at least
            // LEAST_SAMPLES, at most what the largest entry has left.
            let most = self.remaining[0] as u64 - self.taken;
            let share = (samples / self.active as u64).max(LEAST_SAMPLES);
            self.k = share.min(most).min(pace.per_invocation() as u64) as u32;
        }
        Some(self.cut(samples))
    }

    /// The next dispatch of the current window.
    fn cut(&mut self, samples: u64) -> Dispatch {
        let fits = (samples / self.k as u64).clamp(1, MOST_INVOCATIONS as u64) as u32;
        let count = fits.min(self.active - self.at);
        let d = Dispatch {
            first: self.at,
            count,
            k: self.k,
            window: self.window,
            last: self.at + count == self.active,
            catch_up: self.catch_up,
        };
        self.at += count;
        if d.last && !self.catch_up {
            self.taken += self.k as u64;
        }
        d
    }

    /// Starts a catch-up window over every entry, each taking up to the pace's share of
    /// samples (at most what the part has left): after the planned windows, when the
    /// device's counts say samples are still missing. `None` when the last catch-up window
    /// asked one sample an invocation and added nothing: a sample needs more than the device
    /// runs in an invocation.
    pub(super) fn catch_up(&mut self, samples: u64, pace: &Pace) -> Option<Dispatch> {
        if self.catch_up && self.caught == 0 && self.k == 1 {
            return None;
        }
        self.catch_up = true;
        self.caught = 0;
        self.active = self.remaining.len() as u32;
        self.at = 0;
        self.window += 1;
        let share = (samples / self.active as u64).max(LEAST_SAMPLES);
        self.k = share.min(self.left).min(pace.per_invocation() as u64) as u32;
        Some(self.cut(samples))
    }

    /// The next dispatch of a catch-up window under way, if it has more.
    pub(super) fn next_catch_up(&mut self, samples: u64) -> Option<Dispatch> {
        (self.catch_up && self.at < self.active).then(|| self.cut(samples))
    }

    /// A dispatch came back having added `samples`.
    pub(super) fn added(&mut self, samples: u64) {
        self.left = self.left.saturating_sub(samples);
        self.caught += samples;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs the windows as the frame does (two dispatches in flight) on a simulated device
    /// whose invocations take at most `limit(e)` samples each (entry `e`) and are cut when
    /// asked more than `cut_above` samples: every entry ends with all its samples, and the
    /// dispatches keep to the pace's size. Returns the dispatches, or `None` when stuck.
    fn simulate(
        remaining: Vec<u32>,
        samples: u64,
        limit: impl Fn(usize) -> u32,
        cut_above: u32,
    ) -> Option<u32> {
        let mut next = vec![0u32; remaining.len()];
        let mut w = Windows::new(remaining.clone());
        let mut pace = Pace::default();
        let mut dispatches = 0;
        let mut in_flight = std::collections::VecDeque::new();
        loop {
            while in_flight.len() < 2 {
                let Some(d) = w.next(samples, &pace).or_else(|| w.next_catch_up(samples)) else {
                    break;
                };
                in_flight.push_back(d);
            }
            let Some(d) = in_flight.pop_front() else {
                if w.left() == 0 {
                    break;
                }
                in_flight.push_back(w.catch_up(samples, &pace)?);
                continue;
            };
            assert!(d.count as u64 * d.k as u64 <= samples.max(d.k as u64));
            let (mut added, mut cut) = (0, 0);
            for e in d.first..d.first + d.count {
                let e = e as usize;
                let n = d.k.min(remaining[e] - next[e]).min(limit(e));
                if n > 0 && d.k > cut_above {
                    cut += 1;
                    continue;
                }
                next[e] += n;
                added += n as u64;
            }
            pace.measured(added, 0.01, d.k, cut);
            w.added(added);
            dispatches += 1;
        }
        assert_eq!(next, remaining);
        Some(dispatches)
    }

    #[test]
    fn every_entry_gets_its_samples_in_dispatches_of_the_paced_size() {
        let all = u32::MAX;
        // A uniform round: 1000 pixels of 64 samples, in dispatches of 4096 samples: each
        // window gives every pixel 16 samples (the least), in four dispatches of 256 pixels.
        assert_eq!(simulate(vec![64; 1000], 4096, |_| all, all), Some(16));
        // An adaptive round: a few pixels with many samples, many with few.
        let mut r: Vec<u32> = (0..3000).map(|i| [16, 32, 64, 1024][i % 4]).collect();
        r.sort_unstable_by(|a, b| b.cmp(a));
        assert!(simulate(r.clone(), 10_000, |_| all, all).is_some());
        // One pixel of 65,536 samples.
        assert_eq!(simulate(vec![65_536], 1 << 20, |_| all, all), Some(1));
        // A device that stops some invocations early: catch-up windows finish them.
        assert!(simulate(r.clone(), 10_000, |e| if e % 7 == 0 { 3 } else { all }, all).is_some());
        // A device that cuts invocations asked more than 5 samples: smaller windows follow.
        assert!(simulate(r, 10_000, |_| all, 5).is_some());
    }

    #[test]
    fn a_sample_the_device_cannot_take_is_found() {
        // Every invocation is cut, even at one sample: the windows halve to one sample an
        // invocation, then say so.
        assert_eq!(simulate(vec![5, 5, 3], 100, |_| u32::MAX, 0), None);
    }

    #[test]
    fn the_pace_grows_by_steps_and_halves_after_a_cut() {
        let mut p = Pace::default();
        assert_eq!(p.samples(), FIRST_SAMPLES);
        // A fast device: each dispatch at most four times the largest so far.
        p.measured(FIRST_SAMPLES, 1e-4, 16, 0);
        assert_eq!(p.samples(), 4 * FIRST_SAMPLES);
        p.measured(4 * FIRST_SAMPLES, 1e-3, 16, 0);
        // 2.6e8 samples a second: 0.07 s of it, within four times the largest.
        assert_eq!(p.samples(), 16 * FIRST_SAMPLES);
        p.measured(16 * FIRST_SAMPLES, 0.1, 16, 0);
        let rate = 16.0 * FIRST_SAMPLES as f64 / 0.1;
        assert_eq!(p.samples(), (rate * BATCH_SECONDS * AIM) as u64);
        assert!(p.samples() as f64 / rate <= BATCH_SECONDS);
        assert_eq!(p.per_invocation(), MOST_SAMPLES);
        p.measured(1000, 0.01, 16, 3);
        assert_eq!(p.per_invocation(), 8);
        // A dispatch whose entries had nothing left: no news.
        p.measured(0, 0.01, 8, 0);
        assert_eq!(p.per_invocation(), 8);
        p.measured(1000, 0.01, 8, 0);
        assert_eq!(p.per_invocation(), 16);
    }
}
