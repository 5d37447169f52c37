//! The time model: frame number → nominal time → shutter interval.
//!
//! All times are absolute seconds in `f64`. At frame 1,000,000 of a 24 fps shot the time is
//! about 4.2e4 s, where an `f64` still resolves 7e-12 s, so a 1/48 s shutter keeps about 31 bits
//! of resolution for its sample times (an `f32` would keep under 3).

use crate::lerp::lerp;

/// Where the shutter interval sits relative to the frame's nominal time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ShutterPosition {
    /// Opens at the nominal time.
    Start,
    /// Centred on the nominal time.
    #[default]
    Center,
    /// Closes at the nominal time.
    End,
}

impl ShutterPosition {
    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        match self {
            ShutterPosition::Start => "start",
            ShutterPosition::Center => "center",
            ShutterPosition::End => "end",
        }
    }
}

/// A closed time interval `[open, close]`, `open <= close`. Zero length means an instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    pub open: f64,
    pub close: f64,
}

impl Interval {
    /// An interval of zero length at `t`.
    pub fn instant(t: f64) -> Interval {
        Interval { open: t, close: t }
    }

    /// Length of the interval in seconds.
    pub fn duration(&self) -> f64 {
        self.close - self.open
    }

    /// Whether the interval is a single instant.
    pub fn is_instant(&self) -> bool {
        self.close == self.open
    }

    /// The time at fraction `u` in [0, 1) of the interval. Never divides, so a zero-length
    /// interval yields exactly `open` for every `u`.
    #[inline]
    pub fn at(&self, u: f64) -> f64 {
        lerp(self.open, self.close, u)
    }

    /// Whether `t` lies in the closed interval.
    pub fn contains(&self, t: f64) -> bool {
        self.open <= t && t <= self.close
    }
}

/// The timing of a shot: how frame numbers map to times and shutter intervals.
#[derive(Clone, Debug, PartialEq)]
pub struct Shot {
    /// Frames per second, > 0.
    pub fps: f64,
    /// Number of frames, >= 1.
    pub frames: u32,
    /// Number of the first frame.
    pub first_frame: u32,
    /// Time in seconds of the first frame.
    pub start_time: f64,
    /// Seconds the shutter is open per frame, >= 0.
    pub shutter: f64,
    /// Where the shutter interval sits around the nominal time.
    pub position: ShutterPosition,
}

impl Default for Shot {
    fn default() -> Self {
        Shot {
            fps: 24.0,
            frames: 1,
            first_frame: 1,
            start_time: 0.0,
            shutter: shutter_from_angle(180.0, 24.0),
            position: ShutterPosition::Center,
        }
    }
}

/// The shutter duration in seconds of a shutter angle in degrees: `angle / 360 / fps`.
pub fn shutter_from_angle(degrees: f64, fps: f64) -> f64 {
    degrees / 360.0 / fps
}

impl Shot {
    /// The last frame number of the shot.
    pub fn last_frame(&self) -> u32 {
        self.first_frame + (self.frames - 1)
    }

    /// Whether `frame` is one of the shot's frames.
    pub fn contains_frame(&self, frame: u32) -> bool {
        frame >= self.first_frame && frame <= self.last_frame()
    }

    /// The nominal time of `frame`: `start_time + (frame - first_frame) / fps`.
    pub fn frame_time(&self, frame: u32) -> f64 {
        let offset = frame as f64 - self.first_frame as f64;
        self.start_time + offset / self.fps
    }

    /// The shutter interval of `frame`.
    pub fn interval(&self, frame: u32) -> Interval {
        let t = self.frame_time(frame);
        let s = self.shutter;
        match self.position {
            ShutterPosition::Start => Interval {
                open: t,
                close: t + s,
            },
            ShutterPosition::Center => Interval {
                open: t - 0.5 * s,
                close: t + 0.5 * s,
            },
            ShutterPosition::End => Interval {
                open: t - s,
                close: t,
            },
        }
    }

    /// The interval from the first frame's shutter opening to the last frame's closing.
    pub fn whole_interval(&self) -> Interval {
        Interval {
            open: self.interval(self.first_frame).open,
            close: self.interval(self.last_frame()).close,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shot(position: ShutterPosition) -> Shot {
        Shot {
            fps: 24.0,
            frames: 48,
            first_frame: 1,
            start_time: 0.0,
            shutter: 0.02,
            position,
        }
    }

    #[test]
    fn nominal_times_follow_fps_first_frame_and_start_time() {
        let mut s = shot(ShutterPosition::Start);
        assert_eq!(s.frame_time(1), 0.0);
        assert_eq!(s.frame_time(25), 1.0);
        s.first_frame = 101;
        s.start_time = 10.0;
        assert_eq!(s.frame_time(101), 10.0);
        assert_eq!(s.frame_time(149), 12.0);
        assert_eq!(s.last_frame(), 148);
        assert!(s.contains_frame(101) && s.contains_frame(148));
        assert!(!s.contains_frame(100) && !s.contains_frame(149));
    }

    #[test]
    fn three_shutter_positions() {
        let t = 1.0;
        let st = shot(ShutterPosition::Start).interval(25);
        assert_eq!((st.open, st.close), (t, t + 0.02));
        let c = shot(ShutterPosition::Center).interval(25);
        assert_eq!((c.open, c.close), (t - 0.01, t + 0.01));
        let e = shot(ShutterPosition::End).interval(25);
        assert_eq!((e.open, e.close), (t - 0.02, t));
        for i in [st, c, e] {
            assert!((i.duration() - 0.02).abs() < 1e-15);
        }
    }

    #[test]
    fn angle_and_seconds_agree() {
        assert_eq!(shutter_from_angle(180.0, 24.0), 1.0 / 48.0);
        assert_eq!(shutter_from_angle(360.0, 25.0), 1.0 / 25.0);
        assert_eq!(shutter_from_angle(0.0, 24.0), 0.0);
        // Longer than the frame period is allowed.
        assert_eq!(shutter_from_angle(720.0, 10.0), 0.2);
        assert_eq!(Shot::default().shutter, 1.0 / 48.0);
    }

    #[test]
    fn zero_shutter_is_an_instant_and_never_divides() {
        let mut s = shot(ShutterPosition::Center);
        s.shutter = 0.0;
        let i = s.interval(7);
        assert!(i.is_instant());
        for u in [0.0, 0.3, 0.999_999] {
            assert_eq!(i.at(u), s.frame_time(7));
        }
    }

    #[test]
    fn late_frames_keep_their_time_digits() {
        let mut s = shot(ShutterPosition::Start);
        s.shutter = 1.0 / 48.0;
        let i = s.interval(1_000_000);
        let mut times: Vec<f64> = (0..1024).map(|k| i.at(k as f64 / 1024.0)).collect();
        times.dedup();
        assert_eq!(times.len(), 1024, "every stratum keeps a distinct time");
        assert!((i.duration() - 1.0 / 48.0).abs() < 1e-9);
    }

    #[test]
    fn whole_interval_spans_all_frames() {
        let s = shot(ShutterPosition::Center);
        let w = s.whole_interval();
        assert_eq!(w.open, -0.01);
        assert!((w.close - (47.0 / 24.0 + 0.01)).abs() < 1e-12);
    }
}
