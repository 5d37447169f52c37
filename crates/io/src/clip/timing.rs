//! When each frame of a clip is shown: the shot's rate as an exact rational, and frame delays
//! in the units a clip format counts time in.
//!
//! A frame period that a format's unit cannot hold exactly (1/24 s in GIF's hundredths) is
//! rounded so that the error does not build up: frame `i` starts at `round(i / fps)` in the
//! format's units, and its delay is the distance to the next frame's start. Every prefix of
//! the clip then lasts its exact duration within half a unit: at 24 fps a GIF's delays are 4
//! or 5 hundredths (4, 4, 5, 4, 4, 4, ...), 100 for every 24 frames.

/// A frame rate as `frames` per `seconds` (both at least 1): 23.976 fps is 24000 per 1001 s.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rate {
    pub frames: u64,
    pub seconds: u64,
}

impl Rate {
    /// The rate of a shot's `fps`, as the EXR `framesPerSecond` attribute writes it (whole
    /// numbers exact, NTSC rates as n*1000/1001, others as close convergents); `None` for a
    /// rate no such fraction holds.
    pub(crate) fn of_fps(fps: f64) -> Option<Rate> {
        let (frames, seconds) = crate::fps_rational(fps)?;
        Some(Rate {
            frames: u64::try_from(frames).ok().filter(|&n| n > 0)?,
            seconds: seconds.into(),
        })
    }

    /// `24000/1001`, as ffmpeg and ffprobe write a rate.
    pub fn text(self) -> String {
        format!("{}/{}", self.frames, self.seconds)
    }

    /// The duration of `count` frames, in seconds.
    pub fn duration(self, count: u64) -> f64 {
        count as f64 * self.seconds as f64 / self.frames as f64
    }

    /// The start of frame `i` (from 0), in units of `1/unit` s, rounded to nearest (halves
    /// up), exactly: `floor((2 i seconds unit + frames) / (2 frames))` in 128-bit integers.
    fn start(self, i: u64, unit: u64) -> u128 {
        let (n, k) = (self.frames as u128, self.seconds as u128);
        (2 * i as u128 * k * unit as u128 + n) / (2 * n)
    }

    /// The delay of frame `i` (from 0) in units of `1/unit` s: the rounded start of frame
    /// `i + 1` less that of frame `i` (see the module documentation), at most `u16::MAX`.
    pub fn delay(self, i: u64, unit: u64) -> u16 {
        let d = self.start(i + 1, unit) - self.start(i, unit);
        d.min(u16::MAX as u128) as u16
    }

    /// The delay of frame `i` as an APNG frame's `delay_num / delay_den` seconds: the exact
    /// frame period `seconds / frames` whenever both fit 16 bits (every rate up to 65535 fps,
    /// the NTSC rates among them); otherwise milliseconds, rounded as [`Rate::delay`] rounds.
    pub(crate) fn apng_delay(self, i: u64) -> (u16, u16) {
        match (u16::try_from(self.seconds), u16::try_from(self.frames)) {
            (Ok(num), Ok(den)) => (num, den),
            _ => (self.delay(i, 1000), 1000),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ntsc_and_whole_rates_are_exact() {
        let ntsc = Rate::of_fps(23.976).unwrap();
        assert_eq!((ntsc.frames, ntsc.seconds), (24000, 1001));
        assert_eq!(ntsc.text(), "24000/1001");
        assert_eq!(ntsc.apng_delay(7), (1001, 24000));
        assert_eq!(Rate::of_fps(24.0).unwrap().apng_delay(0), (1, 24));
        assert_eq!(Rate::of_fps(0.0), None);
    }

    #[test]
    fn rounded_delays_add_up_to_the_exact_duration() {
        for fps in [24.0, 23.976, 29.97, 30.0, 12.5, 60.0, 7.0, 1.0 / 3.0] {
            let rate = Rate::of_fps(fps).unwrap();
            for count in [1u64, 2, 23, 24, 48, 1001, 24000] {
                let total: u64 = (0..count).map(|i| rate.delay(i, 100) as u64).sum();
                let exact = rate.duration(count) * 100.0;
                assert!((total as f64 - exact).abs() <= 0.5 + 1e-9, "{fps} {count}");
                // Each delay is the period rounded down or up.
                let period = rate.duration(1) * 100.0;
                for i in 0..count.min(100) {
                    let d = rate.delay(i, 100) as f64;
                    assert!(d == period.floor() || d == period.ceil(), "{fps} {i}: {d}");
                }
            }
        }
        let r24 = Rate::of_fps(24.0).unwrap();
        let first: Vec<u16> = (0..6).map(|i| r24.delay(i, 100)).collect();
        assert_eq!(first, [4, 4, 5, 4, 4, 4]);
    }

    #[test]
    fn rates_beyond_16_bits_fall_back_to_rounded_milliseconds() {
        let rate = Rate {
            frames: 100_000,
            seconds: 1,
        };
        let delays: Vec<(u16, u16)> = (0..200).map(|i| rate.apng_delay(i)).collect();
        assert!(delays.iter().all(|&(_, den)| den == 1000));
        let total: u64 = delays.iter().map(|&(n, _)| n as u64).sum();
        assert_eq!(total, 2); // 200 frames at 100,000 fps: 2 ms.
    }
}
