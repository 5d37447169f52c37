//! Shutter curves: how open the shutter is across its interval, and sample times drawn in
//! proportion to it.
//!
//! A curve is a piecewise-linear weight `w(s)` over the position `s` in [0, 1] of the shutter
//! interval. Its cumulative integral is piecewise quadratic; [`CurveTable::sample`] inverts it,
//! so a uniform number `u` becomes a position distributed as `w` (each sample still counts
//! once, and none lands where `w` is 0). The map is monotone and continuous, so a stratified
//! `u` (Sobol points) gives stratified positions.

use std::borrow::Cow;

/// How open the shutter is across its interval.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum ShutterCurve {
    /// Fully open at once, fully closed at once: times uniform over the interval.
    #[default]
    Box,
    /// `[[0, 0], [0.5, 1], [1, 0]]`: opens and closes linearly.
    Triangle,
    /// Points `(s, w)`, `s` from exactly 0 to exactly 1 and strictly increasing, `w >= 0`,
    /// finite and not all 0 (the scene validator checks this).
    Points(Vec<(f64, f64)>),
}

/// The points of [`ShutterCurve::Triangle`].
const TRIANGLE: [(f64, f64); 3] = [(0.0, 0.0), (0.5, 1.0), (1.0, 0.0)];

impl ShutterCurve {
    /// The curve's points (a box is `[[0, 1], [1, 1]]`).
    pub fn points(&self) -> Cow<'_, [(f64, f64)]> {
        match self {
            ShutterCurve::Box => Cow::Borrowed(&[(0.0, 1.0), (1.0, 1.0)]),
            ShutterCurve::Triangle => Cow::Borrowed(&TRIANGLE),
            ShutterCurve::Points(p) => Cow::Borrowed(p),
        }
    }

    /// How the scene file writes it: `box`, `triangle`, or the points
    /// (`[[0, 0], [0.2, 1], [0.8, 1], [1, 0]]`).
    pub fn describe(&self) -> String {
        match self {
            ShutterCurve::Box => "box".into(),
            ShutterCurve::Triangle => "triangle".into(),
            ShutterCurve::Points(p) => {
                // Shortest form, scientific when very small or large (never hundreds of digits).
                let show = |x: f64| {
                    let debug = format!("{x:?}");
                    if debug.contains('e') {
                        debug
                    } else {
                        format!("{x}")
                    }
                };
                let points: Vec<String> = p
                    .iter()
                    .map(|&(s, w)| format!("[{}, {}]", show(s), show(w)))
                    .collect();
                format!("[{}]", points.join(", "))
            }
        }
    }

    /// The table that samples the curve, or `None` when its weight is constant (a box, also
    /// when written as points): then the position is the uniform number itself, exactly.
    pub fn table(&self) -> Option<CurveTable> {
        let points = self.points();
        let first = points.first()?.1;
        if points.iter().all(|p| p.1 == first) {
            return None;
        }
        CurveTable::new(&points)
    }
}

/// A piecewise-linear curve prepared for sampling: its knots and the cumulative area at each.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveTable {
    s: Vec<f64>,
    w: Vec<f64>,
    /// `cdf[i]`: the area under the curve from 0 to `s[i]`, over the whole area (so the
    /// first is 0 and the last 1).
    cdf: Vec<f64>,
}

impl CurveTable {
    /// The table of `points` (as [`ShutterCurve::Points`] requires), or `None` for fewer than
    /// two points or no area.
    pub fn new(points: &[(f64, f64)]) -> Option<CurveTable> {
        if points.len() < 2 {
            return None;
        }
        let mut cdf = Vec::with_capacity(points.len());
        let mut area = 0.0;
        cdf.push(0.0);
        for pair in points.windows(2) {
            let ((s0, w0), (s1, w1)) = (pair[0], pair[1]);
            area += 0.5 * (s1 - s0) * (w0 + w1);
            cdf.push(area);
        }
        if !(area > 0.0 && area.is_finite()) {
            return None;
        }
        for c in &mut cdf {
            *c /= area;
        }
        // Exactly 1 at the end, whatever the rounding of the sum.
        *cdf.last_mut().expect("at least two knots") = 1.0;
        Some(CurveTable {
            s: points.iter().map(|p| p.0).collect(),
            w: points.iter().map(|p| p.1 / area).collect(),
            cdf,
        })
    }

    /// The knots: position `s`, normalised weight `w` and cumulative area up to `s`, in
    /// order; for a tracer that samples the curve elsewhere (the GPU's).
    pub fn knots(&self) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
        (0..self.s.len()).map(|i| (self.s[i], self.w[i], self.cdf[i]))
    }

    /// The normalised weight (probability density) at position `s` in [0, 1].
    pub fn density(&self, s: f64) -> f64 {
        let i = self.segment_at(s);
        let (s0, s1) = (self.s[i], self.s[i + 1]);
        let x = ((s - s0) / (s1 - s0)).clamp(0.0, 1.0);
        (1.0 - x) * self.w[i] + x * self.w[i + 1]
    }

    /// The fraction of the whole area below position `s` in [0, 1].
    #[cfg(test)]
    pub(crate) fn cdf(&self, s: f64) -> f64 {
        let i = self.segment_at(s);
        let (s0, s1) = (self.s[i], self.s[i + 1]);
        let h = s1 - s0;
        let x = ((s - s0) / h).clamp(0.0, 1.0);
        let (a, b) = (self.w[i], self.w[i + 1]);
        (self.cdf[i] + h * x * (a + 0.5 * (b - a) * x)).min(1.0)
    }

    /// The segment `i` (from knot `i` to `i + 1`) holding position `s`.
    fn segment_at(&self, s: f64) -> usize {
        let n = self.s.len();
        self.s.partition_point(|&k| k <= s).clamp(1, n - 1) - 1
    }

    /// The position whose [`cdf`](CurveTable::cdf) is `u` in [0, 1): the inverse of the
    /// piecewise-quadratic CDF. Monotone in `u`; 0 maps to where the curve's area starts.
    #[inline]
    pub fn sample(&self, u: f64) -> f64 {
        let n = self.cdf.len();
        // The last knot whose cumulative area is at most u: segments of no area (where the
        // shutter is closed) are stepped over, as their end has the same area as their start.
        let mut i = self.cdf.partition_point(|&c| c <= u).clamp(1, n - 1) - 1;
        // u at (or rounded past) the total: the last segment with area.
        while i > 0 && self.cdf[i + 1] == self.cdf[i] {
            i -= 1;
        }
        let (a, b) = (self.w[i], self.w[i + 1]);
        let (c0, c1) = (self.cdf[i], self.cdf[i + 1]);
        // The fraction of this segment's area below the point sought.
        let f = ((u - c0) / (c1 - c0)).clamp(0.0, 1.0);
        // Within the segment the weight is linear, a at x = 0 to b at x = 1, and the area
        // below x is a x + (b - a) x^2 / 2 = f (a + b) / 2. Of this quadratic's roots the one
        // in [0, 1] is x = f (a + b) / (a + sqrt((1 - f) a^2 + f b^2)): the textbook
        // (-a + sqrt(...)) / (b - a) multiplied through by its conjugate, which subtracts
        // nothing (a, b >= 0) and so keeps its digits as b - a goes to 0, where it becomes
        // x = f, with no division by b - a (pbrt-v4's `SampleLinear`; Numerical Recipes,
        // section 5.6). At a = 0 it is x = sqrt(f).
        let den = a + ((1.0 - f) * a * a + f * b * b).sqrt();
        let x = if den > 0.0 {
            (f * (a + b) / den).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (s0, s1) = (self.s[i], self.s[i + 1]);
        (s0 + (s1 - s0) * x).clamp(s0, s1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::{CameraUse, IndependentSampler, Sampler, SobolSampler};

    fn trapezoid() -> ShutterCurve {
        ShutterCurve::Points(vec![(0.0, 0.0), (0.2, 1.0), (0.8, 1.0), (1.0, 0.0)])
    }

    /// Curves of every kind: rising, falling, with closed stretches (w = 0 over a segment),
    /// a step (a flat segment after a jump), steep and nearly flat slopes.
    fn curves() -> Vec<ShutterCurve> {
        vec![
            ShutterCurve::Triangle,
            trapezoid(),
            ShutterCurve::Points(vec![(0.0, 0.0), (1.0, 1.0)]),
            ShutterCurve::Points(vec![(0.0, 3.0), (1.0, 0.0)]),
            ShutterCurve::Points(vec![
                (0.0, 0.0),
                (0.3, 0.0),
                (0.4, 2.0),
                (0.6, 2.0),
                (0.7, 0.0),
                (1.0, 0.0),
            ]),
            ShutterCurve::Points(vec![
                (0.0, 1.0),
                (0.5, 1.0 + 1e-13),
                (0.75, 5.0),
                (1.0, 5.0),
            ]),
            ShutterCurve::Points(vec![(0.0, 1e-9), (0.001, 1e3), (1.0, 1e-9)]),
        ]
    }

    #[test]
    fn a_box_is_the_identity_bit_for_bit() {
        assert_eq!(ShutterCurve::Box.table(), None);
        // Constant weights written as points are a box too.
        assert_eq!(
            ShutterCurve::Points(vec![(0.0, 2.0), (0.4, 2.0), (1.0, 2.0)]).table(),
            None
        );
        // And a table of a constant curve (were one built) is the identity to rounding: the
        // root formula is exactly x = f there.
        let t = CurveTable::new(&[(0.0, 1.0), (1.0, 1.0)]).unwrap();
        for k in 0..1000 {
            let u = k as f64 / 1000.0;
            assert_eq!(t.sample(u), u);
        }
    }

    #[test]
    fn the_inverse_inverts_the_cdf() {
        for curve in curves() {
            let t = curve.table().unwrap();
            for k in 0..=10_000 {
                let u = k as f64 / 10_000.0 * (1.0 - f64::EPSILON);
                let s = t.sample(u);
                assert!((0.0..=1.0).contains(&s), "{curve:?} {u} {s}");
                let back = t.cdf(s);
                assert!(
                    (back - u).abs() < 1e-9,
                    "{curve:?}: cdf({s}) = {back}, u = {u}"
                );
            }
        }
    }

    #[test]
    fn the_inverse_is_monotone_with_exact_ends() {
        for curve in curves() {
            let t = curve.table().unwrap();
            let mut last = -1.0;
            for k in 0..=100_000 {
                let u = k as f64 / 100_000.0 * (1.0 - f64::EPSILON);
                let s = t.sample(u);
                assert!(s >= last, "{curve:?} at {u}: {s} < {last}");
                last = s;
            }
            assert_eq!(t.cdf(0.0), 0.0);
            assert_eq!(t.cdf(1.0), 1.0);
        }
        // The ends: u = 0 is where the area starts; u just below 1 where it ends.
        let t = ShutterCurve::Triangle.table().unwrap();
        assert_eq!(t.sample(0.0), 0.0);
        assert!(1.0 - t.sample(1.0 - f64::EPSILON / 2.0) < 1e-7);
        assert_eq!(t.sample(0.5), 0.5);
        // Closed at the start over [0, 0.3] and at the end over [0.7, 1]: no sample there.
        let closed = &curves()[4];
        let t = closed.table().unwrap();
        assert_eq!(t.sample(0.0), 0.3);
        for k in 0..1000 {
            let s = t.sample(k as f64 / 1000.0);
            assert!((0.3..=0.7).contains(&s), "{s}");
        }
    }

    #[test]
    fn triangle_quantiles_are_analytic() {
        // For the triangle, CDF(s) = 2 s^2 below 0.5: the inverse is sqrt(u / 2).
        let t = ShutterCurve::Triangle.table().unwrap();
        for u in [0.01, 0.125, 0.3, 0.49] {
            assert!((t.sample(u) - (u / 2.0).sqrt()).abs() < 1e-15, "{u}");
            assert!(
                (t.sample(1.0 - u) - (1.0 - (u / 2.0).sqrt())).abs() < 1e-15,
                "{u}"
            );
        }
        assert!((t.density(0.25) - 1.0).abs() < 1e-15);
        assert!((t.density(0.5) - 2.0).abs() < 1e-15);
    }

    /// Pearson's chi-square of `positions` in `bins` equal bins against the curve's
    /// probabilities, and its degrees of freedom.
    fn chi_square(t: &CurveTable, positions: &[f64], bins: usize) -> (f64, usize) {
        let mut counts = vec![0.0; bins];
        for &s in positions {
            counts[((s * bins as f64) as usize).min(bins - 1)] += 1.0;
        }
        let n = positions.len() as f64;
        let mut chi = 0.0;
        let mut dof = 0;
        for (b, &c) in counts.iter().enumerate() {
            let p = t.cdf((b + 1) as f64 / bins as f64) - t.cdf(b as f64 / bins as f64);
            if p == 0.0 {
                // A sample where the shutter is closed: no distribution of the curve's.
                if c > 0.0 {
                    chi = f64::INFINITY;
                }
                continue;
            }
            chi += (c - n * p).powi(2) / (n * p);
            dof += 1;
        }
        (chi, dof - 1)
    }

    #[test]
    fn sampled_times_follow_the_curve_for_both_samplers() {
        // The times a frame's samples draw (the sampler's time number through the frame's
        // `FrameTimes`, as the renderer maps it), over the pixels and samples of a small frame,
        // as positions in each sample's row's interval, in 32 bins against the curve's weight
        // (bins where it is closed must stay empty); with a global shutter and with a rolling
        // one. The chi-square of a correct distribution with k degrees of freedom (mean k,
        // deviation sqrt(2k)) stays below k + 6 sqrt(2k) but with probability under 1e-5
        // (k = 31: 78); uniform (box) times fail it by thousands.
        use crate::shutter::{ReadoutDirection, RollingShutter, Shot};
        let uses = CameraUse {
            lens: false,
            time: true,
        };
        let bins = 32;
        let (shutter, readout, height) = (0.02, 0.01, 16);
        for curve in [ShutterCurve::Triangle, trapezoid(), curves()[4].clone()] {
            let t = curve.table().unwrap();
            let mut uniform = vec![];
            let mut draw = |s: &mut dyn Sampler, rolling: bool| {
                let shot = Shot {
                    shutter,
                    curve: curve.clone(),
                    rolling: rolling.then_some(RollingShutter {
                        readout,
                        direction: ReadoutDirection::BottomToTop,
                    }),
                    ..Shot::default()
                };
                let times = shot.frame_times(5);
                let open = times.interval.open;
                let mut positions = vec![];
                for y in 0..height {
                    for x in 0..16 {
                        for i in 0..64 {
                            s.start_sample(x, y, i);
                            let c = s.camera(uses);
                            let row = (y as f64 + c.pixel.1) / height as f64;
                            let time = times.time(c.time, row);
                            let row_open = if rolling {
                                open + readout * (1.0 - row)
                            } else {
                                open
                            };
                            uniform.push(c.time);
                            positions.push(((time - row_open) / shutter).clamp(0.0, 1.0));
                        }
                    }
                }
                positions
            };
            let mut sets = vec![];
            for rolling in [false, true] {
                let name = if rolling { "rolling" } else { "global" };
                sets.push((
                    name,
                    "independent",
                    draw(&mut IndependentSampler::new(3, 7), rolling),
                ));
                sets.push((name, "sobol", draw(&mut SobolSampler::new(3, 7), rolling)));
            }
            for (shutter, sampler, positions) in sets {
                let (chi, dof) = chi_square(&t, &positions, bins);
                assert!(dof >= 10, "{dof}");
                let bound = dof as f64 + 6.0 * (2.0 * dof as f64).sqrt();
                assert!(
                    chi < bound,
                    "{shutter} {sampler} {curve:?}: chi-square {chi} ({dof} dof)"
                );
            }
            // Teeth: the unmapped numbers do not follow the curve.
            let (chi, _) = chi_square(&t, &uniform, bins);
            assert!(chi > 1000.0, "{curve:?}: {chi}");
        }
    }

    #[test]
    fn sobol_times_stay_stratified_after_the_mapping() {
        // 256 samples of one pixel's replicate: one in each of 256 equal-probability strata of
        // the curve.
        let uses = CameraUse {
            lens: false,
            time: true,
        };
        let t = trapezoid().table().unwrap();
        let mut s = SobolSampler::new(1, 1);
        let mut strata = vec![0; 256];
        for i in 0..256 {
            s.start_sample(4, 5, crate::sampler::REPLICATES * i);
            let pos = t.sample(s.camera(uses).time);
            strata[((t.cdf(pos) * 256.0) as usize).min(255)] += 1;
        }
        assert!(strata.iter().all(|&c| c == 1), "{strata:?}");
    }

    #[test]
    fn names_and_points() {
        assert_eq!(ShutterCurve::default(), ShutterCurve::Box);
        assert_eq!(ShutterCurve::Triangle.points().as_ref(), &TRIANGLE);
        assert_eq!(
            trapezoid().describe(),
            "[[0, 0], [0.2, 1], [0.8, 1], [1, 0]]"
        );
        assert_eq!(ShutterCurve::Triangle.describe(), "triangle");
        assert_eq!(
            ShutterCurve::Points(vec![(0.0, 1e-300), (1e-300, 1e300), (1.0, 0.0)]).describe(),
            "[[0, 1e-300], [1e-300, 1e300], [1, 0]]"
        );
        assert!(CurveTable::new(&[(0.0, 0.0), (1.0, 0.0)]).is_none());
    }
}
