//! How a point moves over time: the motion kinds of the scene format, evaluated exactly at any
//! time, and their bounds over an interval.
//!
//! A motion is given for the whole shot ([`Motion`]); before a frame renders it is prepared for
//! the frame's shutter interval ([`Motion::prepare`]), which yields a [`FrameMotion`]: the same
//! path re-expressed relative to the shutter's opening (so late frames keep their digits), or
//! [`FrameMotion::Fixed`] when nothing moves during the interval.

use glam::DVec3;

use crate::aabb::Aabb;
use crate::lerp::{inverse_lerp, lerp3};
use crate::shutter::Interval;

/// A key of a keyframed path: the position at `time`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Key {
    pub time: f64,
    pub position: DVec3,
}

/// A rotation about an axis through a pivot at a constant angular speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    pub pivot: DVec3,
    /// Unit axis; the rotation is counter-clockwise looking down the axis (right-hand rule).
    pub axis: DVec3,
    pub degrees_per_second: f64,
}

/// The motion of a point over the whole shot. `origin` is the position at time 0 for
/// [`Motion::Velocity`] and [`Motion::Orbit`], and the only position for [`Motion::Still`].
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    /// Does not move.
    Still(DVec3),
    /// `origin + velocity * t` at every time `t`.
    Velocity { origin: DVec3, velocity: DVec3 },
    /// Piecewise linear between keys (times strictly increasing, at least one key), held
    /// before the first and after the last.
    Keyframes(Vec<Key>),
    /// On a circle: `origin` rotated about the orbit's axis by `degrees_per_second * t`.
    Orbit { origin: DVec3, orbit: Orbit },
}

/// Rotates `v` about the unit `axis` by `degrees` (Rodrigues' formula). The angle is reduced to
/// [0, 360) in degrees first, which is exact (`rem_euclid` on floats is exact), so large times
/// do not lose the angle's digits to a multiple of pi.
pub(crate) fn rotate(v: DVec3, axis: DVec3, degrees: f64) -> DVec3 {
    let (s, c) = degrees.rem_euclid(360.0).to_radians().sin_cos();
    v * c + axis.cross(v) * s + axis * axis.dot(v) * (1.0 - c)
}

impl Motion {
    /// The position at time `t` (seconds, absolute).
    pub fn at(&self, t: f64) -> DVec3 {
        match self {
            Motion::Still(p) => *p,
            Motion::Velocity { origin, velocity } => *origin + *velocity * t,
            Motion::Keyframes(keys) => keyframe_at(keys, t),
            Motion::Orbit { origin, orbit } => {
                orbit.pivot
                    + rotate(
                        *origin - orbit.pivot,
                        orbit.axis,
                        orbit.degrees_per_second * t,
                    )
            }
        }
    }

    /// Whether the point moves at all during the shot.
    pub fn is_animated(&self) -> bool {
        match self {
            Motion::Still(_) => false,
            Motion::Velocity { velocity, .. } => *velocity != DVec3::ZERO,
            Motion::Keyframes(keys) => keys.windows(2).any(|w| w[0].position != w[1].position),
            Motion::Orbit { origin, orbit } => {
                orbit.degrees_per_second != 0.0 && {
                    let r = *origin - orbit.pivot;
                    r - orbit.axis * orbit.axis.dot(r) != DVec3::ZERO
                }
            }
        }
    }

    /// Prepares the motion for one shutter interval: either a fixed position (nothing moves in
    /// the interval, including any zero-length interval) or a path relative to `interval.open`.
    pub fn prepare(&self, interval: Interval) -> FrameMotion {
        let t0 = interval.open;
        if interval.is_instant() || !self.is_animated() {
            return FrameMotion::Fixed(self.at(t0));
        }
        match self {
            Motion::Still(p) => FrameMotion::Fixed(*p),
            Motion::Velocity { velocity, .. } => FrameMotion::Linear {
                start: self.at(t0),
                velocity: *velocity,
                t0,
            },
            Motion::Keyframes(keys) => prepare_keyframes(keys, interval),
            Motion::Orbit { origin, orbit } => {
                // Decompose origin - pivot into the part along the axis and the radius vector.
                let r = *origin - orbit.pivot;
                let along = orbit.axis * orbit.axis.dot(r);
                let e1 = r - along;
                let e2 = orbit.axis.cross(e1);
                FrameMotion::Circle(CirclePath {
                    center: orbit.pivot + along,
                    e1,
                    e2,
                    degrees0: (orbit.degrees_per_second * t0).rem_euclid(360.0),
                    degrees_per_second: orbit.degrees_per_second,
                    t0,
                })
            }
        }
    }
}

fn keyframe_at(keys: &[Key], t: f64) -> DVec3 {
    let first = keys[0];
    let last = keys[keys.len() - 1];
    if t <= first.time {
        return first.position;
    }
    if t >= last.time {
        return last.position;
    }
    // First key with time > t; it exists and is not the first one.
    let i = keys.partition_point(|k| k.time <= t);
    let (a, b) = (keys[i - 1], keys[i]);
    lerp3(a.position, b.position, inverse_lerp(a.time, b.time, t))
}

fn prepare_keyframes(keys: &[Key], interval: Interval) -> FrameMotion {
    let (t0, t1) = (interval.open, interval.close);
    // Positions at the interval's ends and at every key strictly inside it.
    let mut points = vec![Key {
        time: t0,
        position: keyframe_at(keys, t0),
    }];
    points.extend(keys.iter().filter(|k| k.time > t0 && k.time < t1).copied());
    points.push(Key {
        time: t1,
        position: keyframe_at(keys, t1),
    });
    if points.windows(2).all(|w| w[0].position == w[1].position) {
        return FrameMotion::Fixed(points[0].position);
    }
    if points.len() == 2 {
        // One linear segment over the whole interval (the common case).
        let a = keys.partition_point(|k| k.time <= t0);
        let (ka, kb) = (keys[a - 1], keys[a]);
        let velocity = (kb.position - ka.position) / (kb.time - ka.time);
        return FrameMotion::Linear {
            start: points[0].position,
            velocity,
            t0,
        };
    }
    FrameMotion::Keyframes(points.into_boxed_slice())
}

/// A motion prepared for one shutter interval.
#[derive(Clone, Debug, PartialEq)]
pub enum FrameMotion {
    /// Does not move during the interval.
    Fixed(DVec3),
    /// `start + velocity * (t - t0)`.
    Linear {
        start: DVec3,
        velocity: DVec3,
        t0: f64,
    },
    /// Piecewise linear through the given points (the interval's ends and the keys inside).
    Keyframes(Box<[Key]>),
    /// An arc of a circle.
    Circle(CirclePath),
}

/// `center + cos(a) e1 + sin(a) e2` with `a = degrees0 + degrees_per_second * (t - t0)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CirclePath {
    pub center: DVec3,
    pub e1: DVec3,
    pub e2: DVec3,
    pub degrees0: f64,
    pub degrees_per_second: f64,
    pub t0: f64,
}

impl CirclePath {
    /// The point at time `t`.
    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        let degrees = self.degrees0 + self.degrees_per_second * (t - self.t0);
        circle_point(self.center, self.e1, self.e2, degrees)
    }

    /// The box of the arc swept from `t0` over `duration` seconds.
    pub fn bounds(&self, duration: f64) -> Aabb {
        let sweep = self.degrees_per_second * duration;
        arc_bounds(
            self.center,
            self.e1,
            self.e2,
            self.degrees0,
            self.degrees0 + sweep,
        )
    }
}

impl FrameMotion {
    /// The position at time `t`, which should lie in the interval the motion was prepared for.
    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        match self {
            FrameMotion::Fixed(p) => *p,
            FrameMotion::Linear {
                start,
                velocity,
                t0,
            } => *start + *velocity * (t - t0),
            FrameMotion::Keyframes(points) => keyframe_at(points, t),
            FrameMotion::Circle(c) => c.at(t),
        }
    }

    /// Whether the position changes during the interval.
    pub fn is_moving(&self) -> bool {
        !matches!(self, FrameMotion::Fixed(_))
    }

    /// A box enclosing every position over `interval` (the one it was prepared for), grown by
    /// `radius` in every direction. For a circle this is the box of the whole arc swept.
    pub fn bounds(&self, interval: Interval, radius: f64) -> Aabb {
        let core = match self {
            FrameMotion::Fixed(p) => Aabb::point(*p),
            FrameMotion::Linear { .. } => {
                Aabb::point(self.at(interval.open)).union_point(self.at(interval.close))
            }
            FrameMotion::Keyframes(points) => points
                .iter()
                .fold(Aabb::EMPTY, |b, k| b.union_point(k.position)),
            FrameMotion::Circle(c) => c.bounds(interval.duration()),
        };
        core.grow(radius).pad_for_rounding()
    }
}

/// The point at `degrees` on the circle `center + cos(a) e1 + sin(a) e2`.
#[inline]
fn circle_point(center: DVec3, e1: DVec3, e2: DVec3, degrees: f64) -> DVec3 {
    let (s, c) = degrees.to_radians().sin_cos();
    center + e1 * c + e2 * s
}

/// The box of the arc `center + cos(a) e1 + sin(a) e2` for `a` from `a0` to `a1` degrees
/// (either order): its two end points plus, per axis, the circle's extreme points whose angles
/// fall inside the arc.
fn arc_bounds(center: DVec3, e1: DVec3, e2: DVec3, a0: f64, a1: f64) -> Aabb {
    let (lo, hi) = if a0 <= a1 { (a0, a1) } else { (a1, a0) };
    let point = |deg: f64| circle_point(center, e1, e2, deg);
    let mut b = Aabb::point(point(lo)).union_point(point(hi));
    for axis in 0..3 {
        // Coordinate `axis` is center + e1[axis] cos a + e2[axis] sin a = center + A cos(a - phi).
        let phi = e2[axis].atan2(e1[axis]).to_degrees();
        for extreme in [phi, phi + 180.0] {
            // The first angle >= lo congruent to `extreme` (mod 360).
            let a = lo + (extreme - lo).rem_euclid(360.0);
            if a <= hi {
                b = b.union_point(point(a));
            }
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rng_iter(seed: u64) -> impl FnMut() -> f64 {
        let mut r = crate::rng::Pcg32::new(seed, 7);
        move || r.next_f64()
    }

    fn orbit_motion() -> Motion {
        Motion::Orbit {
            origin: DVec3::new(2.0, 1.0, 0.0),
            orbit: Orbit {
                pivot: DVec3::new(0.0, 1.0, 0.0),
                axis: DVec3::Y,
                degrees_per_second: 90.0,
            },
        }
    }

    #[test]
    fn velocity_is_exact_at_any_time() {
        let m = Motion::Velocity {
            origin: DVec3::new(1.0, 2.0, 3.0),
            velocity: DVec3::new(0.0, 0.5, -1.0),
        };
        assert_eq!(m.at(0.0), DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(m.at(2.0), DVec3::new(1.0, 3.0, 1.0));
        assert_eq!(m.at(-2.0), DVec3::new(1.0, 1.0, 5.0));
    }

    #[test]
    fn keyframes_interpolate_and_hold() {
        let m = Motion::Keyframes(vec![
            Key {
                time: 1.0,
                position: DVec3::ZERO,
            },
            Key {
                time: 3.0,
                position: DVec3::new(2.0, 0.0, 0.0),
            },
            Key {
                time: 4.0,
                position: DVec3::new(2.0, 4.0, 0.0),
            },
        ]);
        assert_eq!(m.at(-5.0), DVec3::ZERO);
        assert_eq!(m.at(1.0), DVec3::ZERO);
        assert_eq!(m.at(2.0), DVec3::new(1.0, 0.0, 0.0));
        assert_eq!(m.at(3.0), DVec3::new(2.0, 0.0, 0.0));
        assert_eq!(m.at(3.5), DVec3::new(2.0, 2.0, 0.0));
        assert_eq!(m.at(100.0), DVec3::new(2.0, 4.0, 0.0));
    }

    #[test]
    fn orbit_stays_on_its_circle() {
        let m = orbit_motion();
        assert!((m.at(1.0) - DVec3::new(0.0, 1.0, -2.0)).length() < 1e-12);
        assert!((m.at(2.0) - DVec3::new(-2.0, 1.0, 0.0)).length() < 1e-12);
        let mut r = rng_iter(1);
        for _ in 0..100 {
            let t = r() * 1e5;
            let p = m.at(t);
            assert!(((p - DVec3::new(0.0, 1.0, 0.0)).length() - 2.0).abs() < 1e-12);
            assert_eq!(p.y, 1.0);
        }
    }

    #[test]
    fn prepared_motion_agrees_with_shot_motion() {
        let motions = [
            Motion::Velocity {
                origin: DVec3::new(1.0, 2.0, 3.0),
                velocity: DVec3::new(0.3, 0.5, -1.0),
            },
            Motion::Keyframes(vec![
                Key {
                    time: 0.0,
                    position: DVec3::ZERO,
                },
                Key {
                    time: 0.5,
                    position: DVec3::new(1.0, 1.0, 0.0),
                },
                Key {
                    time: 0.7,
                    position: DVec3::new(0.0, 3.0, 1.0),
                },
            ]),
            orbit_motion(),
        ];
        let mut r = rng_iter(2);
        for m in &motions {
            for _ in 0..200 {
                let open = r() * 2.0 - 0.5;
                let iv = Interval {
                    open,
                    close: open + r() * 0.8,
                };
                let fm = m.prepare(iv);
                for _ in 0..10 {
                    let t = iv.at(r());
                    assert!((fm.at(t) - m.at(t)).length() < 1e-9, "{m:?} at {t}");
                }
            }
        }
    }

    /// Property: for random intervals, the sphere at random times inside lies in the box.
    #[test]
    fn prepared_bounds_enclose_the_sphere_at_every_time() {
        let motions = [
            Motion::Still(DVec3::new(4.0, -1.0, 2.0)),
            Motion::Velocity {
                origin: DVec3::new(1.0, 2.0, 3.0),
                velocity: DVec3::new(5.0, -0.5, 1.0),
            },
            Motion::Keyframes(vec![
                Key {
                    time: 0.0,
                    position: DVec3::ZERO,
                },
                Key {
                    time: 0.2,
                    position: DVec3::new(1.0, 5.0, 0.0),
                },
                Key {
                    time: 0.4,
                    position: DVec3::new(-3.0, 3.0, 1.0),
                },
            ]),
            orbit_motion(),
            Motion::Orbit {
                origin: DVec3::new(1.0, 2.0, 3.0),
                orbit: Orbit {
                    pivot: DVec3::new(0.5, -1.0, 0.0),
                    axis: DVec3::new(1.0, 2.0, -0.5).normalize(),
                    degrees_per_second: -700.0,
                },
            },
        ];
        let radius = 0.25;
        let mut r = rng_iter(3);
        for m in &motions {
            for _ in 0..300 {
                let open = r() * 4.0 - 1.0;
                let iv = Interval {
                    open,
                    close: open + r() * r(),
                };
                let fm = m.prepare(iv);
                let b = fm.bounds(iv, radius);
                for _ in 0..20 {
                    let c = fm.at(iv.at(r()));
                    let sb = Aabb::point(c).grow(radius);
                    assert!(b.contains(&sb), "{m:?} over {iv:?}: {sb:?} not in {b:?}");
                }
            }
        }
    }

    #[test]
    fn orbit_box_covers_the_arc_not_just_its_ends() {
        // A quarter turn from -45 to +45 degrees about y passes through (2, 1, 0), further out
        // in x than both its end points (sqrt2, 1, -+sqrt2).
        let m = orbit_motion();
        let iv = Interval {
            open: -0.5,
            close: 0.5,
        };
        let b = m.prepare(iv).bounds(iv, 0.0);
        let ends = Aabb::point(m.at(-0.5)).union_point(m.at(0.5));
        let mid = m.at(0.0);
        assert!((b.max.x - 2.0).abs() < 1e-9);
        assert!(!ends.contains(&Aabb::point(mid)));
        assert!(b.contains(&Aabb::point(mid)));
        // Half a turn: the box reaches x = -2 .. 2 but only z in [-2, 0].
        let iv = Interval {
            open: 0.0,
            close: 2.0,
        };
        let b = m.prepare(iv).bounds(iv, 0.0);
        assert!((b.min.x + 2.0).abs() < 1e-9 && (b.max.x - 2.0).abs() < 1e-9);
        assert!((b.min.z + 2.0).abs() < 1e-9 && b.max.z.abs() < 1e-9);
    }

    #[test]
    fn not_moving_in_an_interval_means_fixed() {
        let m = Motion::Keyframes(vec![
            Key {
                time: 0.0,
                position: DVec3::ZERO,
            },
            Key {
                time: 1.0,
                position: DVec3::X,
            },
        ]);
        // Held after the last key.
        assert_eq!(
            m.prepare(Interval {
                open: 2.0,
                close: 3.0
            }),
            FrameMotion::Fixed(DVec3::X)
        );
        assert!(
            m.prepare(Interval {
                open: 0.5,
                close: 0.6
            })
            .is_moving()
        );
        // Zero shutter: fixed, at the instant.
        let v = Motion::Velocity {
            origin: DVec3::ZERO,
            velocity: DVec3::Y,
        };
        assert_eq!(
            v.prepare(Interval::instant(2.0)),
            FrameMotion::Fixed(DVec3::new(0.0, 2.0, 0.0))
        );
        // Zero velocity and a zero-radius orbit never move.
        assert!(
            !Motion::Velocity {
                origin: DVec3::ZERO,
                velocity: DVec3::ZERO
            }
            .is_animated()
        );
        let on_axis = Motion::Orbit {
            origin: DVec3::new(0.0, 5.0, 0.0),
            orbit: Orbit {
                pivot: DVec3::ZERO,
                axis: DVec3::Y,
                degrees_per_second: 30.0,
            },
        };
        assert!(!on_axis.is_animated());
    }
}
