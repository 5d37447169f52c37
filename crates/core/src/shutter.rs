//! The time model: frame number → nominal time → shutter interval, and the time of each
//! camera sample inside it (the shutter curve, the rolling shutter).
//!
//! All times are absolute seconds in `f64`. At frame 1,000,000 of a 24 fps shot the time is
//! about 4.2e4 s, where an `f64` still resolves 7e-12 s, so a 1/48 s shutter keeps about 31 bits
//! of resolution for its sample times (an `f32` would keep under 3).

use crate::lerp::lerp;
use crate::shutter_curve::CurveTable;
pub use crate::shutter_curve::ShutterCurve;

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

/// Which edge of the image a rolling shutter reads first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ReadoutDirection {
    /// The top row opens first.
    #[default]
    TopToBottom,
    /// The bottom row opens first.
    BottomToTop,
}

impl ReadoutDirection {
    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        match self {
            ReadoutDirection::TopToBottom => "top-to-bottom",
            ReadoutDirection::BottomToTop => "bottom-to-top",
        }
    }
}

/// A rolling shutter: every row of the image has its own shutter interval, each row's opening
/// `readout * y / height` later than the first row's (`y` continuous, 0 at the top edge).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollingShutter {
    /// Seconds from the first row's opening to the last row's, >= 0.
    pub readout: f64,
    /// Which row is first.
    pub direction: ReadoutDirection,
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
    /// Where the frame's exposure sits around the nominal time.
    pub position: ShutterPosition,
    /// How open the shutter is across each row's interval.
    pub curve: ShutterCurve,
    /// `None`: a global shutter, every row exposed over the same interval.
    pub rolling: Option<RollingShutter>,
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
            curve: ShutterCurve::Box,
            rolling: None,
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

    /// The seconds from the first row's opening to the last row's closing: the shutter, plus
    /// the readout of a rolling shutter.
    pub fn exposure(&self) -> f64 {
        match self.rolling {
            None => self.shutter,
            Some(r) => self.shutter + r.readout,
        }
    }

    /// The interval of `frame`'s whole exposure, from the first row's opening to the last
    /// row's closing (with a global shutter, the shutter interval), placed around the nominal
    /// time by [`ShutterPosition`]. Every sample time of the frame lies in it.
    pub fn interval(&self, frame: u32) -> Interval {
        let t = self.frame_time(frame);
        let s = self.exposure();
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

    /// How `frame`'s camera samples get their times.
    pub fn frame_times(&self, frame: u32) -> FrameTimes {
        let interval = self.interval(frame);
        FrameTimes {
            interval,
            shutter: self.shutter,
            // A zero shutter ignores the curve: each row is an instant.
            table: if self.shutter > 0.0 {
                self.curve.table()
            } else {
                None
            },
            // A zero readout is a global shutter.
            rolling: self
                .rolling
                .filter(|r| r.readout > 0.0)
                .map(|r| (r.readout, r.direction)),
        }
    }

    /// How a shot that is not a plain global box shutter exposes its frames, as `check` and
    /// `preview` say it: `curve triangle, rolling, readout 0.01 s top-to-bottom, exposure
    /// 0.03 s per frame`; `None` for a global shutter with a box curve (each frame's interval
    /// then says all).
    pub fn exposure_note(&self) -> Option<String> {
        if self.curve == ShutterCurve::Box && self.rolling.is_none() {
            return None;
        }
        let rolling = self.rolling.map_or("global".to_string(), |r| {
            format!("rolling, readout {} s {}", r.readout, r.direction.name())
        });
        Some(format!(
            "curve {}, {rolling}, exposure {} s per frame",
            self.curve.describe(),
            self.exposure()
        ))
    }

    /// The interval from the first frame's shutter opening to the last frame's closing.
    pub fn whole_interval(&self) -> Interval {
        Interval {
            open: self.interval(self.first_frame).open,
            close: self.interval(self.last_frame()).close,
        }
    }
}

/// One frame's sample times: a sample's number for time (in [0, 1)) and its image row give
/// its time, distributed over the row's interval in proportion to the shutter curve.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameTimes {
    /// The frame's whole exposure ([`Shot::interval`]).
    pub interval: Interval,
    /// Seconds each row is open.
    shutter: f64,
    /// The curve's inverse cumulative weight; `None` for a box (or a zero shutter).
    table: Option<CurveTable>,
    /// A rolling shutter's readout and direction.
    rolling: Option<(f64, ReadoutDirection)>,
}

impl FrameTimes {
    /// The time of a sample with time number `u` in [0, 1) at image row `row` in [0, 1]
    /// (the continuous `y` over the height: 0 at the top edge, 1 at the bottom). A box curve
    /// with a global shutter gives exactly `interval.at(u)`. Always inside `interval`.
    #[inline]
    pub fn time(&self, u: f64, row: f64) -> f64 {
        let u = match &self.table {
            None => u,
            Some(t) => t.sample(u),
        };
        match self.rolling {
            None => self.interval.at(u),
            Some((readout, direction)) => {
                let row = match direction {
                    ReadoutDirection::TopToBottom => row,
                    ReadoutDirection::BottomToTop => 1.0 - row,
                };
                let open = self.interval.open + readout * row;
                (open + self.shutter * u).clamp(self.interval.open, self.interval.close)
            }
        }
    }

    /// Whether the time depends on the row (a rolling shutter with a readout).
    #[cfg(test)]
    pub(crate) fn is_rolling(&self) -> bool {
        self.rolling.is_some()
    }

    /// Seconds each row is open.
    pub fn shutter(&self) -> f64 {
        self.shutter
    }

    /// The shutter curve's table, `None` for a box (or a zero shutter).
    pub fn curve(&self) -> Option<&CurveTable> {
        self.table.as_ref()
    }

    /// A rolling shutter's readout (seconds, more than 0) and direction, `None` for a global
    /// shutter.
    pub fn rolling(&self) -> Option<(f64, ReadoutDirection)> {
        self.rolling
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
            ..Shot::default()
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

    fn rolling(shutter: f64, readout: f64, direction: ReadoutDirection) -> Shot {
        Shot {
            shutter,
            rolling: Some(RollingShutter { readout, direction }),
            ..shot(ShutterPosition::Center)
        }
    }

    #[test]
    fn a_rolling_shutter_exposes_shutter_plus_readout_around_the_nominal_time() {
        let s = rolling(0.02, 0.01, ReadoutDirection::TopToBottom);
        let i = s.interval(25);
        assert!((i.open - (1.0 - 0.015)).abs() < 1e-15 && (i.close - 1.015).abs() < 1e-15);
        for (position, open) in [
            (ShutterPosition::Start, 1.0),
            (ShutterPosition::End, 1.0 - 0.03),
        ] {
            let i = Shot {
                position,
                ..s.clone()
            }
            .interval(25);
            assert!((i.open - open).abs() < 1e-15 && (i.duration() - 0.03).abs() < 1e-15);
        }
        // The top row opens with the exposure, the bottom row closes it; the middle row's
        // interval is shifted by half the readout.
        let t = s.frame_times(25);
        assert!(t.is_rolling());
        assert_eq!(t.time(0.0, 0.0), i.open);
        assert!((t.time(1.0, 1.0) - i.close).abs() < 1e-15);
        assert!((t.time(0.0, 0.5) - (i.open + 0.005)).abs() < 1e-15);
        assert!((t.time(0.5, 0.5) - (i.open + 0.005 + 0.01)).abs() < 1e-15);
        // Bottom to top: the bottom row first.
        let b = rolling(0.02, 0.01, ReadoutDirection::BottomToTop).frame_times(25);
        assert_eq!(b.time(0.0, 1.0), i.open);
        assert!((b.time(0.0, 0.0) - (i.open + 0.01)).abs() < 1e-15);
        assert!((b.time(0.0, 0.25) - t.time(0.0, 0.75)).abs() < 1e-15);
    }

    #[test]
    fn a_pure_rolling_shutter_makes_each_row_an_instant() {
        let s = rolling(0.0, 0.04, ReadoutDirection::TopToBottom);
        let i = s.interval(25);
        assert!((i.duration() - 0.04).abs() < 1e-15);
        let t = s.frame_times(25);
        for row in [0.0, 0.3, 1.0] {
            let first = t.time(0.0, row);
            assert!((first - (i.open + 0.04 * row)).abs() < 1e-15);
            for u in [0.2, 0.7, 0.999] {
                assert_eq!(t.time(u, row), first);
            }
        }
    }

    #[test]
    fn a_global_box_shutter_is_the_interval_exactly() {
        let s = shot(ShutterPosition::Center);
        let t = s.frame_times(7);
        assert!(!t.is_rolling());
        let i = s.interval(7);
        for k in 0..1000 {
            let u = k as f64 / 1000.0;
            assert_eq!(t.time(u, 0.3).to_bits(), i.at(u).to_bits());
        }
        // A zero readout is a global shutter; a zero shutter ignores the curve.
        let zero = rolling(0.02, 0.0, ReadoutDirection::TopToBottom);
        assert_eq!(zero.interval(7), i);
        assert_eq!(zero.frame_times(7), t);
        let still = Shot {
            shutter: 0.0,
            curve: ShutterCurve::Triangle,
            ..s
        };
        assert_eq!(still.frame_times(7).time(0.3, 0.5), still.frame_time(7));
    }

    #[test]
    fn curve_times_stay_inside_each_rows_interval() {
        let mut s = rolling(0.02, 0.01, ReadoutDirection::TopToBottom);
        s.curve = ShutterCurve::Triangle;
        let t = s.frame_times(3);
        let i = s.interval(3);
        let mut r = crate::rng::Pcg32::new(4, 4);
        for _ in 0..10_000 {
            let (u, row) = (r.next_f64(), r.next_f64());
            let time = t.time(u, row);
            let open = i.open + 0.01 * row;
            assert!(i.contains(time));
            assert!(time >= open - 1e-15 && time <= open + 0.02 + 1e-15);
        }
        // The triangle's median is the row interval's middle.
        assert!((t.time(0.5, 0.0) - (i.open + 0.01)).abs() < 1e-15);
    }
}
