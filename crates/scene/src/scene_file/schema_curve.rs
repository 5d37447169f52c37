//! A shutter curve as the scene file writes it (`[shot] shutter_curve`): a keyword, or points
//! `[s, w]` checked as they are read, so a bad point is reported at its place. Part of the
//! format's schema ([`super::schema`]).

use std::fmt;

use serde::Deserialize;
use serde::de::{self, IgnoredAny, SeqAccess, Visitor};

/// A shutter curve as written: a keyword or points `[s, w]`, checked as they are read so that
/// a bad point is reported at its place (`shot.shutter_curve[2][0]`): `s` from exactly 0 to
/// exactly 1, strictly increasing; `w` finite and >= 0, not all 0; at least 2 points.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum RawCurve {
    Box,
    Triangle,
    Points(Vec<(f64, f64)>),
}

/// What a shutter curve may be, for messages.
const CURVE_EXPECTED: &str = "\"box\", \"triangle\" or an array of [s, w] points";

impl<'de> Deserialize<'de> for RawCurve {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawCurve;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(CURVE_EXPECTED)
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<RawCurve, E> {
                match s {
                    "box" => Ok(RawCurve::Box),
                    "triangle" => Ok(RawCurve::Triangle),
                    _ => Err(E::custom(format_args!(
                        "expected {CURVE_EXPECTED}, found {s:?}"
                    ))),
                }
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<RawCurve, A::Error> {
                let count = seq.size_hint();
                let mut points: Vec<(f64, f64)> = Vec::with_capacity(count.unwrap_or(0));
                loop {
                    let seed = CurvePoint {
                        previous: points.last().map(|p| p.0),
                        last: count.map(|n| n == points.len() + 1),
                    };
                    match seq.next_element_seed(seed)? {
                        Some(p) => points.push(p),
                        None => break,
                    }
                }
                if points.len() < 2 {
                    return Err(de::Error::custom(format_args!(
                        "expected at least 2 points [s, w], found {}",
                        points.len()
                    )));
                }
                let end = points[points.len() - 1].0;
                if end != 1.0 {
                    return Err(de::Error::custom(format_args!(
                        "expected the last point's s to be 1, found {}",
                        raytrace_core::show::show(end)
                    )));
                }
                if points.iter().all(|p| p.1 == 0.0) {
                    return Err(de::Error::custom(
                        "expected a weight w above 0 somewhere (a shutter that opens), found only zeros",
                    ));
                }
                Ok(RawCurve::Points(points))
            }
        }
        d.deserialize_any(V)
    }
}

/// Reads a point of a shutter curve, knowing the previous point's `s` and, when the array's
/// length is known, whether it is the last.
struct CurvePoint {
    previous: Option<f64>,
    last: Option<bool>,
}

impl<'de> de::DeserializeSeed<'de> for CurvePoint {
    type Value = (f64, f64);
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<(f64, f64), D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for CurvePoint {
    type Value = (f64, f64);
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an array of 2 numbers [s, w]")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(f64, f64), A::Error> {
        let wrong =
            |n: usize| de::Error::custom(format_args!("expected 2 numbers [s, w], found {n}"));
        if let Some(n) = seq.size_hint()
            && n != 2
        {
            return Err(wrong(n));
        }
        // s: 0 for the first point; above the previous one, and below 1 unless it is the last.
        let shown = self.previous.map(raytrace_core::show::show);
        let s_expected = match (&shown, self.last) {
            (None, _) => "0 (the first point's s)".to_string(),
            (Some(p), Some(true)) => format!("1 (the last point's s, after {p})"),
            (Some(p), Some(false)) => format!("a number greater than {p} and less than 1"),
            (Some(p), None) => format!("a number greater than {p} and at most 1"),
        };
        let s_ok = move |s: f64| match (self.previous, self.last) {
            (None, _) => s == 0.0,
            (Some(_), Some(true)) => s == 1.0,
            (Some(p), Some(false)) => s > p && s < 1.0,
            (Some(p), None) => s > p && s <= 1.0,
        };
        let s = seq
            .next_element_seed(Checked {
                ok: &s_ok,
                expected: &s_expected,
            })?
            .ok_or_else(|| wrong(0))?;
        let w = seq
            .next_element_seed(Checked {
                ok: &|w: f64| w.is_finite() && w >= 0.0,
                expected: "a finite number >= 0 (the weight w)",
            })?
            .ok_or_else(|| wrong(1))?;
        let mut n = 2;
        while seq.next_element::<IgnoredAny>()?.is_some() {
            n += 1;
        }
        if n != 2 {
            return Err(wrong(n));
        }
        Ok((s, w))
    }
}

/// A number that must pass `ok`; otherwise "expected `expected`, found" the number.
struct Checked<'a> {
    ok: &'a dyn Fn(f64) -> bool,
    expected: &'a str,
}

impl<'de> de::DeserializeSeed<'de> for Checked<'_> {
    type Value = f64;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<f64, D::Error> {
        // Checked inside the number's own visit, so that a refusal is reported at the number.
        d.deserialize_any(self)
    }
}

impl Checked<'_> {
    fn check<E: de::Error>(&self, x: f64) -> Result<f64, E> {
        if (self.ok)(x) {
            Ok(x)
        } else {
            Err(E::invalid_value(de::Unexpected::Float(x), &self.expected))
        }
    }
}

impl Visitor<'_> for Checked<'_> {
    type Value = f64;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a number")
    }
    fn visit_i64<E: de::Error>(self, x: i64) -> Result<f64, E> {
        self.check(x as f64)
    }
    fn visit_u64<E: de::Error>(self, x: u64) -> Result<f64, E> {
        self.check(x as f64)
    }
    fn visit_i128<E: de::Error>(self, x: i128) -> Result<f64, E> {
        self.check(x as f64)
    }
    fn visit_u128<E: de::Error>(self, x: u128) -> Result<f64, E> {
        self.check(x as f64)
    }
    fn visit_f64<E: de::Error>(self, x: f64) -> Result<f64, E> {
        self.check(x)
    }
}
