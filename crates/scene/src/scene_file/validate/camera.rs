//! The camera's checks: a view that never degenerates, at the keys and exactly between them.

use super::*;
use crate::scene_file::schema::RawCameraKey;

impl Validator<'_> {
    /// Checks that `up` can orient a camera: not zero, nor so short that it underflows.
    fn up(&self, up: DVec3) -> Result<(), String> {
        let len = robust_length(up);
        if len == 0.0 {
            return self.err("camera.up must be a non-zero vector");
        }
        if len <= TINY {
            return self.err(format_args!(
                "camera.up {} is too short ({}), at least {TINY:e}",
                fmt_v(up),
                show_approx(len)
            ));
        }
        Ok(())
    }

    /// Checks that a view is not degenerate at one instant (see [`views`](Self::views)).
    fn view(&self, field: &str, from: DVec3, at: DVec3, up: DVec3) -> Result<(), String> {
        self.views(field, (from, at), (from, at), up, None)
    }

    /// Checks that the view is not degenerate at any time while look_from and look_at move
    /// linearly from `a` to `b` (each a pair (look_from, look_at)) between `times`, or at the
    /// one instant of `a` when `times` is `None`: the view direction never vanishes (nor comes
    /// within [`DEGENERATE_VIEW`] of the points' size, nor [`TINY`]) and is never parallel to
    /// `up` (the sine of their angle never [`DEGENERATE_UP`] or less). Both are found exactly per
    /// segment, where the direction is linear in time.
    fn views(
        &self,
        field: &str,
        a: (DVec3, DVec3),
        b: (DVec3, DVec3),
        up: DVec3,
        times: Option<(f64, f64)>,
    ) -> Result<(), String> {
        let (d0, d1) = (a.1 - a.0, b.1 - b.0);
        let scale = [a.0, a.1, b.0, b.1]
            .into_iter()
            .map(robust_length)
            .fold(0.0, f64::max);
        let limit = (DEGENERATE_VIEW * scale).max(TINY);
        let at_time = |s: f64| match times {
            Some((t0, t1)) => format!(" at t = {} s", show_approx(t0 + s * (t1 - t0))),
            None => String::new(),
        };
        let (s, dist) = shortest_on_segment(d0, d1);
        if dist == 0.0 {
            return match times {
                None => self.err(format_args!(
                    "{field}: look_from and look_at must differ, both are {}",
                    fmt_v(a.0)
                )),
                Some(_) => self.err(format_args!(
                    "{field}: look_from meets look_at{}",
                    at_time(s)
                )),
            };
        }
        if dist <= limit {
            return self.err(format_args!(
                "{field}: look_from comes within {} of look_at{}, too close to give a view direction (at most {DEGENERATE_VIEW:e} of their distance from the origin, or {TINY:e})",
                show_approx(dist),
                at_time(s)
            ));
        }
        let (s, sine) = most_parallel_on_segment(up, d0, d1);
        if sine <= DEGENERATE_UP {
            let view = d0.lerp(d1, s);
            let how = if sine == 0.0 {
                "is parallel to".to_string()
            } else {
                format!(
                    "is within {} degrees of",
                    show_approx(sine.asin().to_degrees())
                )
            };
            return self.err(format_args!(
                "{field}: the view direction {} {how} camera.up {}{}",
                fmt_v(view),
                fmt_v(up),
                at_time(s)
            ));
        }
        Ok(())
    }

    /// The camera rig of `c`: its view checked never to degenerate, still, orbiting or
    /// between keyframes.
    pub(super) fn camera(&self, c: &RawCamera) -> Result<CameraRig, String> {
        let from = self.vec(
            "camera.look_from",
            c.look_from.unwrap_or(V3([0.0, 0.0, 0.0])),
        )?;
        let at = self.vec("camera.look_at", c.look_at.unwrap_or(V3([0.0, 0.0, -1.0])))?;
        let up = self.vec("camera.up", c.up.unwrap_or(V3([0.0, 1.0, 0.0])))?;
        let vfov = self.positive("camera.vfov", c.vfov.map_or(90.0, |v| v.0))?;
        if vfov >= 180.0 {
            return self.err(format_args!(
                "camera.vfov must be < 180, got {}",
                show(vfov)
            ));
        }
        let aperture = self.non_negative("camera.aperture", c.aperture.map_or(0.0, |a| a.0))?;
        let focus_distance = c
            .focus_distance
            .map(|f| self.positive("camera.focus_distance", f.0))
            .transpose()?;
        if c.orbit.is_some() && c.keyframes.is_some() {
            return self.err("camera: give at most one of orbit and keyframes");
        }
        self.up(up)?;
        let (look_from, look_at) = if let Some(o) = &c.orbit {
            // An orbit turns look_from about the line through look_at along up: the distance
            // between them and the view's angle to up never change, so the start decides.
            self.view("camera", from, at, up)?;
            let orbit = self.orbit(
                "camera.orbit",
                V3(at.to_array()),
                V3(up.to_array()),
                o.degrees_per_second.0,
            )?;
            (
                Motion::Orbit {
                    origin: from,
                    orbit,
                },
                Motion::Still(at),
            )
        } else if let Some(keys) = &c.keyframes {
            self.camera_keyframes(keys, from, at, up)?
        } else {
            self.view("camera", from, at, up)?;
            (Motion::Still(from), Motion::Still(at))
        };
        Ok(CameraRig {
            look_from,
            look_at,
            up,
            vfov,
            aperture,
            focus_distance,
        })
    }

    /// The motions of look_from and look_at through `keys` (a key without one keeps the one
    /// before, from `from` and `at`): each key's view checked, and the views between keys.
    fn camera_keyframes(
        &self,
        keys: &[RawCameraKey],
        from: DVec3,
        at: DVec3,
        up: DVec3,
    ) -> Result<(Motion, Motion), String> {
        let times = self.keys("camera.keyframes", keys.iter().map(|k| k.time.0))?;
        let (mut f, mut a) = (from, at);
        let (mut fk, mut ak) = (Vec::<Key>::new(), Vec::<Key>::new());
        for (i, (k, time)) in keys.iter().zip(times).enumerate() {
            let field = format!("camera.keyframes[{i}]");
            if let Some(v) = k.look_from {
                f = self.vec(&format!("{field}.look_from"), v)?;
            }
            if let Some(v) = k.look_at {
                a = self.vec(&format!("{field}.look_at"), v)?;
            }
            self.view(&field, f, a, up)?;
            // Between keys both points move linearly; before the first key and after the
            // last they are held, at views just checked.
            if let (Some(pf), Some(pa)) = (fk.last(), ak.last()) {
                self.views(
                    &format!("camera.keyframes[{}..{i}]", i - 1),
                    (pf.position, pa.position),
                    (f, a),
                    up,
                    Some((pf.time, time)),
                )?;
            }
            fk.push(Key { time, position: f });
            ak.push(Key { time, position: a });
        }
        Ok((Motion::Keyframes(fk), Motion::Keyframes(ak)))
    }
}

fn fmt_v(v: DVec3) -> String {
    format!("[{}, {}, {}]", show(v.x), show(v.y), show(v.z))
}
