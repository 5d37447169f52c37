//! The stability suite: scenes whose expected values are known exactly, swept over scales,
//! distances, speeds, frame numbers and extreme settings, plus the validation of bad numbers.
//! `docs/stability.md` lists every case with the largest error measured (printed here with
//! `eprintln!`; run with `--nocapture` to see them) and the tolerance.
//!
//! The furnaces rest on one fact: in a uniform background of radiance 1, with one convex
//! sphere, every path returns a value known in advance:
//! - lambertian of albedo `a`, or a mirror of albedo `a` and fuzz 0: a camera ray that hits the
//!   sphere scatters once and escapes (it cannot hit a convex sphere again from its outside):
//!   `a`; a camera ray that misses: 1. Two rays either way, so the frame's ray count is known.
//! - glass: attenuation 1 at every bounce, so 1, unless the path is cut at `max_depth` (0).
//! - a mirror of fuzz 1: `a`, or 0 when the fuzzed direction points below the surface, with
//!   a probability known in closed form.
//!
//! So where the sphere covers a pixel's whole footprint the pixel is exact (zero variance);
//! where coverage is partial each pixel is a mean of `N` samples from two known values and
//! must be one of the `N + 1` possible means; where the answer is random (fuzz 1, contact
//! shadows) the count of samples of each value is binomial with a probability computed here
//! independently, and is tested against exact binomial tails.

use crate::common;

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use common::{f, scene, v};
use glam::DVec3;
use rayon::prelude::*;
use raytrace_core::camera::View;
use raytrace_core::material::schlick;
use raytrace_core::ray::Ray;
use raytrace_core::renderer::{Budget, CpuShot, FrameJob, FrameResult};
use raytrace_core::sampler::{CameraUse, IndependentSampler, Sampler};
use raytrace_core::scene::Scene;
use raytrace_core::sphere::{intersect, surface_point};
use raytrace_core::tracer::{TraceStats, radiance};
use raytrace_core::world::{StaticGeometry, World};
use raytrace_scene::scene_file::SceneFile;

/// Albedo of the lambertian spheres (a different value per channel).
const MATTE: [f64; 3] = [0.7, 0.5, 0.3];
/// Albedo of the mirror spheres.
const STEEL: [f64; 3] = [0.9, 0.6, 0.3];
/// Tolerance of the zero-variance answers. The acceptance criterion is 1e-4; what is left
/// is the rounding of the sum of at most a few thousand samples.
const EXACT: f64 = 1e-12;
/// A binomial count whose tail probability is below this is a failure.
const TAIL: f64 = 1e-9;
/// Largest |z| accepted for sums of many independent samples with known mean and variance.
const Z_MAX: f64 = 6.0;
/// Depth for glass: every cut path costs a whole sample, so keep it out of reach.
const GLASS_DEPTH: u32 = 128;

// ------------------------------------------------------------------------------------------
// Rendering and statistics helpers

/// Which tracer renders: the CPU's (`f64`), or the GPU's (`f32`, `--device gpu`).
#[derive(Clone, Copy)]
enum Tracer {
    Cpu,
    Gpu(&'static raytrace_gpu::Gpu),
}

impl Tracer {
    /// Tolerance of the zero-variance answers: the rounding of the sums of a few thousand
    /// samples in `f64` on the CPU; on the GPU, of `f32` samples (an albedo of 0.7 is
    /// 0.69999999 there) summed in `f32` runs of 16.
    fn exact(self) -> f64 {
        match self {
            Tracer::Cpu => EXACT,
            Tracer::Gpu(_) => EXACT_GPU,
        }
    }
}

/// [`EXACT`] on the GPU.
const EXACT_GPU: f64 = 1e-6;

/// Renders `frame` with the scene's own settings; asserts that no sample was dropped.
fn render_checked(scene: &Scene, frame: u32, what: &str) -> FrameResult {
    render_checked_on(scene, frame, what, Tracer::Cpu)
}

/// [`render_checked`] by `tracer`.
fn render_checked_on(scene: &Scene, frame: u32, what: &str, tracer: Tracer) -> FrameResult {
    let result = match tracer {
        Tracer::Cpu => {
            let statics = CpuShot::new(scene);
            FrameJob::new(scene, frame).sample(&statics).unwrap()
        }
        Tracer::Gpu(gpu) => common::render_gpu_frame(gpu, scene, frame, &Budget::default()),
    };
    assert_eq!(
        result.stats.non_finite, 0,
        "{what}: {} non-finite samples",
        result.stats.non_finite
    );
    result
}

/// The frame's camera at the shutter's opening (the furnace cameras do not move).
fn view_of(scene: &Scene, frame: u32) -> View {
    let open = scene.shot.interval(frame).open;
    scene
        .camera
        .view_at(open, scene.output.width, scene.output.height)
}

/// A pixel that is the mean of `n` samples, each `lo` or `hi` (per channel): the number of
/// `hi` samples and how far the pixel is from the exact mean with that count. Panics if no
/// count in 0..=n explains the pixel.
fn two_valued(p: DVec3, lo: DVec3, hi: DVec3, n: u32, what: &str) -> (u32, f64) {
    two_valued_within(p, lo, hi, n, what, EXACT)
}

/// [`two_valued`] to within `tolerance`.
fn two_valued_within(
    p: DVec3,
    lo: DVec3,
    hi: DVec3,
    n: u32,
    what: &str,
    tolerance: f64,
) -> (u32, f64) {
    let d = hi - lo;
    let axis = if d.x.abs() >= d.y.abs() && d.x.abs() >= d.z.abs() {
        0
    } else if d.y.abs() >= d.z.abs() {
        1
    } else {
        2
    };
    let k = ((p[axis] - lo[axis]) * n as f64 / d[axis]).round();
    assert!(
        (0.0..=n as f64).contains(&k),
        "{what}: pixel {p} is not a mean of {lo} and {hi}"
    );
    let exact = (k * hi + (n as f64 - k) * lo) / n as f64;
    let err = (p - exact).abs().max_element();
    assert!(
        err <= tolerance,
        "{what}: pixel {p} is {err:e} from the nearest possible mean {exact} ({k} of {n} samples {hi}): a path returned another value"
    );
    (k as u32, err)
}

/// Natural logarithms of 0! ..= n!.
fn ln_factorials(n: u32) -> Vec<f64> {
    let mut out = vec![0.0; n as usize + 1];
    for i in 1..=n as usize {
        out[i] = out[i - 1] + (i as f64).ln();
    }
    out
}

/// P(X = i) for X ~ Binomial(n, p).
fn binomial_pmf(lf: &[f64], n: u32, i: u32, p: f64) -> f64 {
    if p <= 0.0 {
        return if i == 0 { 1.0 } else { 0.0 };
    }
    if p >= 1.0 {
        return if i == n { 1.0 } else { 0.0 };
    }
    let (n_, i_) = (n as usize, i as usize);
    (lf[n_] - lf[i_] - lf[n_ - i_] + i as f64 * p.ln() + (n - i) as f64 * (1.0 - p).ln()).exp()
}

/// The smaller of P(X >= k | p = hi) and P(X <= k | p = lo) for X ~ Binomial(n, p): how
/// surprising `k` successes are when the success probability is only known to lie in
/// [lo, hi].
fn binomial_surprise(n: u32, k: u32, lo: f64, hi: f64) -> f64 {
    let lf = ln_factorials(n);
    let upper: f64 = (k..=n).map(|i| binomial_pmf(&lf, n, i, hi.min(1.0))).sum();
    let lower: f64 = (0..=k).map(|i| binomial_pmf(&lf, n, i, lo.max(0.0))).sum();
    upper.min(lower).min(1.0)
}

/// A per-sample probability over one pixel's footprint, from the function `prob(jx, jy)`
/// of the position in the pixel: (lowest, highest, mean, every point valid). The extremes
/// come from a 12x12 grid over the pixel grown by a quarter pixel on every side, widened by
/// the largest step between neighbouring grid points, so they bound the value over the whole
/// footprint; the mean comes from an 8x8 midpoint grid inside the pixel.
fn footprint(prob: impl Fn(f64, f64) -> Option<f64>) -> (f64, f64, f64, bool) {
    const G: usize = 12;
    let mut grid = [[0.0f64; G]; G];
    let mut clean = true;
    for (i, row) in grid.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            let jx = -0.25 + 1.5 * i as f64 / (G - 1) as f64;
            let jy = -0.25 + 1.5 * j as f64 / (G - 1) as f64;
            match prob(jx, jy) {
                Some(p) => *cell = p,
                None => {
                    clean = false;
                    *cell = 0.0;
                }
            }
        }
    }
    let mut step: f64 = 0.0;
    for i in 0..G {
        for j in 0..G {
            if i + 1 < G {
                step = step.max((grid[i + 1][j] - grid[i][j]).abs());
            }
            if j + 1 < G {
                step = step.max((grid[i][j + 1] - grid[i][j]).abs());
            }
        }
    }
    let lo = grid.iter().flatten().copied().fold(f64::INFINITY, f64::min) - step;
    let hi = grid
        .iter()
        .flatten()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max)
        + step;
    let mut mean = 0.0;
    for i in 0..8 {
        for j in 0..8 {
            mean += prob((i as f64 + 0.5) / 8.0, (j as f64 + 0.5) / 8.0).unwrap_or(0.0);
        }
    }
    (lo.max(0.0), hi.min(1.0), mean / 64.0, clean)
}

/// The largest value of a slice.
fn max_of(xs: impl IntoIterator<Item = f64>) -> f64 {
    xs.into_iter().fold(0.0, f64::max)
}

// ------------------------------------------------------------------------------------------
// Furnaces

#[derive(Clone, Copy, Debug, PartialEq)]
enum Surface {
    Lambertian,
    /// Metal, fuzz 0.
    Mirror,
    /// Metal, fuzz 1.
    FuzzyMirror,
    /// Dielectric of this index of refraction.
    Glass(f64),
}

impl Surface {
    fn toml(self) -> String {
        match self {
            Surface::Lambertian => format!(
                "{{ type = \"lambertian\", albedo = {} }}",
                v(DVec3::from_array(MATTE))
            ),
            Surface::Mirror => format!(
                "{{ type = \"metal\", albedo = {}, fuzz = 0.0 }}",
                v(DVec3::from_array(STEEL))
            ),
            Surface::FuzzyMirror => format!(
                "{{ type = \"metal\", albedo = {}, fuzz = 1.0 }}",
                v(DVec3::from_array(STEEL))
            ),
            Surface::Glass(ior) => format!("{{ type = \"dielectric\", ior = {} }}", f(ior)),
        }
    }

    /// What a path that hits the sphere returns (the opaque surfaces).
    fn albedo(self) -> DVec3 {
        match self {
            Surface::Lambertian => DVec3::from_array(MATTE),
            Surface::Mirror | Surface::FuzzyMirror => DVec3::from_array(STEEL),
            Surface::Glass(_) => DVec3::ONE,
        }
    }
}

/// Where the camera looks.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Aim {
    /// At the centre, with the frame inside the silhouette: every pixel fully covered.
    Centre,
    /// At a point of the silhouette, with a field of view of `zoom` times the sphere's
    /// angular radius: the limb crosses the frame, and the rays near it graze the sphere.
    Limb { zoom: f64 },
}

/// One furnace: a sphere alone in a uniform background of radiance 1.
#[derive(Clone, Copy, Debug)]
struct Furnace {
    surface: Surface,
    radius: f64,
    /// Distance of the centre from the origin at the frame's nominal time.
    distance: f64,
    /// Distance of the camera from the centre, in radii.
    camera: f64,
    /// Radii travelled per shutter interval (0: still). With a zero shutter, the sphere
    /// moves at this many radii per 1/48 s.
    speed: f64,
    frame: u32,
    fps: f64,
    shutter_angle: f64,
    aim: Aim,
    size: u32,
    samples: u32,
}

impl Furnace {
    fn new(surface: Surface, radius: f64, distance: f64, camera: f64) -> Furnace {
        Furnace {
            surface,
            radius,
            distance,
            camera,
            speed: 0.0,
            frame: 1,
            fps: 24.0,
            shutter_angle: 180.0,
            aim: Aim::Centre,
            size: 16,
            samples: 8,
        }
    }

    /// Whether every pixel's footprint lies inside the sphere's silhouette at every sample
    /// time.
    fn fully_covered(&self) -> bool {
        self.aim == Aim::Centre && (self.speed == 0.0 || self.shutter_angle == 0.0)
    }

    fn max_depth(&self) -> u32 {
        match self.surface {
            Surface::Glass(_) => GLASS_DEPTH,
            _ => 8,
        }
    }

    /// The scene, and the sphere's centre at the frame's nominal time.
    fn scene(&self) -> (String, DVec3) {
        let r = self.radius;
        // Directions chosen off the axes: centre from the origin, camera from the centre.
        let centre = DVec3::new(1.0, -0.6, 0.35).normalize() * self.distance;
        let toward_camera = DVec3::new(0.36, 0.48, 0.8).normalize();
        // Perpendicular to the line of sight: the direction of motion and of the aimed limb.
        let across = toward_camera.cross(DVec3::Y).normalize();
        let from = centre + toward_camera * (self.camera * r);
        let dist = (from - centre).length();
        let beta = (r / dist).asin();
        let (look_at, vfov) = match self.aim {
            Aim::Centre => {
                // The frame's corners at 0.9 of the angular radius: tan(corner) =
                // sqrt(2) tan(vfov / 2) for a square frame.
                let half = ((0.9 * beta).tan() / 2f64.sqrt()).atan();
                (centre, (2.0 * half).to_degrees())
            }
            Aim::Limb { zoom } => {
                // The point where a ray from the camera touches the sphere: at angle beta
                // from the line of sight, with sin(beta) = r / dist.
                let tangent = centre + r * (toward_camera * beta.sin() + across * beta.cos());
                (tangent, (zoom * beta).to_degrees())
            }
        };
        let time = (self.frame as f64 - 1.0) / self.fps;
        let shutter = self.shutter_angle / 360.0 / self.fps;
        let per_shutter = if shutter > 0.0 { shutter } else { 1.0 / 48.0 };
        let velocity = across * (self.speed * r / per_shutter);
        let motion = if self.speed > 0.0 {
            format!(
                "center = {}\nvelocity = {}",
                v(centre - velocity * time),
                v(velocity)
            )
        } else {
            format!("center = {}", v(centre))
        };
        let text = format!(
            r#"
[shot]
fps = {fps}
frames = {frame}
shutter_angle = {angle}
[output]
width = {size}
height = {size}
[render]
samples = {samples}
max_depth = {depth}
[camera]
look_from = {from}
look_at = {at}
vfov = {vfov}
[background]
color = [1.0, 1.0, 1.0]
[[sphere]]
{motion}
radius = {r}
material = {material}
"#,
            fps = f(self.fps),
            frame = self.frame,
            angle = f(self.shutter_angle),
            size = self.size,
            samples = self.samples,
            depth = self.max_depth(),
            from = v(from),
            at = v(look_at),
            vfov = f(vfov),
            r = f(r),
            material = self.surface.toml(),
        );
        (text, centre)
    }
}

/// The figures of one furnace render.
#[derive(Clone, Copy, Debug, Default)]
struct Figures {
    /// Largest |pixel - exact| over fully covered pixels.
    exact: f64,
    /// Largest distance of a pixel from the nearest possible mean of its two path values.
    two_valued: f64,
    /// |z| of the frame's ray count against its expectation (glass).
    z: f64,
    /// Smallest binomial tail probability of a pixel's count (fuzz 1).
    tail: f64,
    /// Pixels partly covered (0 < hits < samples).
    partial: u32,
    /// Glass samples cut at max_depth.
    lost: u64,
}

impl Figures {
    fn worst(a: Figures, b: Figures) -> Figures {
        Figures {
            exact: a.exact.max(b.exact),
            two_valued: a.two_valued.max(b.two_valued),
            z: a.z.max(b.z),
            tail: a.tail.min(b.tail),
            partial: a.partial + b.partial,
            lost: a.lost + b.lost,
        }
    }

    fn none() -> Figures {
        Figures {
            tail: 1.0,
            ..Figures::default()
        }
    }
}

/// Renders one furnace and checks every pixel against its exact value; returns the figures.
fn check_furnace(c: &Furnace) -> Figures {
    check_furnace_on(c, Tracer::Cpu)
}

/// [`check_furnace`] by `tracer`.
fn check_furnace_on(c: &Furnace, tracer: Tracer) -> Figures {
    let (text, centre) = c.scene();
    let sc = scene(&text);
    let what = format!("{c:?}");
    let result = render_checked_on(&sc, c.frame, &what, tracer);
    let exact = tracer.exact();
    let two_valued = |p: DVec3, lo: DVec3, hi: DVec3, n: u32, what: &str| {
        two_valued_within(p, lo, hi, n, what, exact)
    };
    let film = &result.film;
    let n = c.samples;
    let mut fig = Figures::none();
    match c.surface {
        Surface::Glass(ior) if !c.fully_covered() => {
            // Every path returns 1, or 0 when cut at max_depth: the count of lost samples is
            // binomial with the cut probability of each camera ray (0 for a miss).
            let depth = c.max_depth();
            let (view, t) = (view_of(&sc, c.frame), sc.shot.interval(c.frame).open);
            let anywhere = glass_cut_max(ior, depth);
            for y in 0..film.height {
                for x in 0..film.width {
                    let (k, err) = two_valued(film.get(x, y), DVec3::ZERO, DVec3::ONE, n, &what);
                    fig.two_valued = fig.two_valued.max(err);
                    let lost = n - k;
                    fig.lost += lost as u64;
                    let (lo, hi) = if c.speed == 0.0 {
                        let (lo, hi, _, _) = footprint(|jx, jy| {
                            let ray = view.ray(x, y, (jx, jy), (0.5, 0.5), t);
                            Some(match intersect(centre, c.radius, &ray, f64::INFINITY) {
                                Some(hit) => {
                                    let sp = surface_point(centre, c.radius, &ray, hit);
                                    glass_cut(-ray.dir.dot(sp.normal), ior, depth)
                                }
                                None => 0.0,
                            })
                        });
                        (lo, hi)
                    } else {
                        (0.0, anywhere)
                    };
                    let tail = binomial_surprise(n, lost, lo, hi);
                    assert!(
                        tail >= TAIL,
                        "{what}: pixel ({x}, {y}) lost {lost} of {n} samples, cut probability in [{lo:e}, {hi:e}] (tail {tail:e})"
                    );
                    fig.tail = fig.tail.min(tail);
                }
            }
        }
        Surface::Glass(ior) => {
            // Every path returns 1 unless cut at max_depth; the cut probability is bounded
            // below and is far below anything a frame could show.
            fig.exact = max_of(
                film.means()
                    .iter()
                    .map(|p| (*p - DVec3::ONE).abs().max_element()),
            );
            assert!(
                fig.exact <= exact,
                "{what}: a glass pixel is {:e} from 1",
                fig.exact
            );
            {
                assert!(cut_bound(c, ior) * result.stats.samples as f64 <= 1e-9);
                fig.z = glass_ray_count_z(c, &sc, ior, centre, result.stats.rays);
                assert!(fig.z <= Z_MAX, "{what}: ray count off by {} sigma", fig.z);
            }
        }
        Surface::Lambertian | Surface::Mirror => {
            let a = c.surface.albedo();
            if c.fully_covered() {
                fig.exact = max_of(film.means().iter().map(|p| (*p - a).abs().max_element()));
                assert!(
                    fig.exact <= exact,
                    "{what}: a pixel is {:e} from the albedo",
                    fig.exact
                );
                // One ray to the sphere and one to the background per sample: no other hit.
                assert_eq!(result.stats.rays, 2 * result.stats.samples, "{what}");
            } else {
                // Each sample is a (hit) or 1 (missed): the pixel is one of n + 1 means, and
                // each hit costs exactly one more ray than a miss.
                let mut hits = 0u64;
                for p in film.means() {
                    let (k, err) = two_valued(p, DVec3::ONE, a, n, &what);
                    fig.two_valued = fig.two_valued.max(err);
                    hits += k as u64;
                    fig.partial += (k > 0 && k < n) as u32;
                }
                assert_eq!(result.stats.rays, result.stats.samples + hits, "{what}");
            }
        }
        Surface::FuzzyMirror => {
            assert!(c.fully_covered());
            let a = c.surface.albedo();
            let view = view_of(&sc, c.frame);
            let t = sc.shot.interval(c.frame).open;
            for y in 0..film.height {
                for x in 0..film.width {
                    let (k, err) = two_valued(film.get(x, y), DVec3::ZERO, a, n, &what);
                    fig.two_valued = fig.two_valued.max(err);
                    let (lo, hi, _, clean) = footprint(|jx, jy| {
                        let ray = view.ray(x, y, (jx, jy), (0.5, 0.5), t);
                        let hit = intersect(centre, c.radius, &ray, f64::INFINITY)?;
                        let sp = surface_point(centre, c.radius, &ray, hit);
                        Some(fuzz1_escape(-ray.dir.dot(sp.normal)))
                    });
                    assert!(clean, "{what}: pixel ({x}, {y}) not fully covered");
                    let tail = binomial_surprise(n, k, lo, hi);
                    assert!(
                        tail >= TAIL,
                        "{what}: pixel ({x}, {y}) kept {k} of {n} samples, escape probability in [{lo}, {hi}] (tail {tail:e})"
                    );
                    fig.tail = fig.tail.min(tail);
                }
            }
        }
    }
    fig
}

/// Probability that a mirror of fuzz 1 keeps a ray arriving at incidence cosine `cos`: the
/// reflection (normal component `cos`) plus a uniform point of the unit ball stays above the
/// surface unless the point lies in the cap `b.n <= -cos`, of height h = 1 - cos and volume
/// fraction h^2 (3 - h) / 4.
fn fuzz1_escape(cos: f64) -> f64 {
    let h = 1.0 - cos.clamp(0.0, 1.0);
    1.0 - h * h * (3.0 - h) / 4.0
}

/// Largest sine of incidence of the camera rays of a centred furnace: a ray at angle g from
/// the centre has impact parameter d sin g, so sin(incidence) = sin g / sin(beta) <=
/// sin(corner) / sin(beta), with the corner at 0.9 beta.
fn max_sin_incidence(c: &Furnace) -> f64 {
    let beta = (1.0 / c.camera).asin();
    (0.9 * beta).sin() / beta.sin()
}

/// Upper bound of the probability that a glass path of a centred furnace is cut at
/// `max_depth`. Inside a sphere every chord meets the surface at the same angle, the
/// refraction angle t (sin t = sin i / ior < 1/ior: no total internal reflection), so the
/// path stays inside with probability R = schlick(cos t) at each internal hit; it is cut only
/// after max_depth - 2 internal reflections in a row. R grows with t, so R(t_max) bounds it.
fn cut_bound(c: &Furnace, ior: f64) -> f64 {
    let s = max_sin_incidence(c) / ior;
    let r_in = schlick((1.0 - s * s).sqrt(), ior);
    r_in.powi(c.max_depth() as i32 - 2)
}

/// Probability that a glass path whose camera ray meets the sphere at incidence cosine
/// `cos_i` is cut at `max_depth`: it must refract in (1 - R_out), then reflect internally
/// max_depth - 2 times in a row (R_in each, every chord meeting the surface at the same
/// angle). With the books' Schlick approximation R -> 1 at grazing incidence even for
/// ior 1, so this is not negligible near the silhouette of a glass of low index.
fn glass_cut(cos_i: f64, ior: f64, max_depth: u32) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t = (1.0 - cos_i * cos_i).sqrt() / ior;
    let r_out = schlick(cos_i, 1.0 / ior);
    let r_in = schlick((1.0 - sin_t * sin_t).sqrt(), ior);
    (1.0 - r_out) * r_in.powi(max_depth as i32 - 2)
}

/// The largest cut probability over every incidence (a fine scan, widened by a tenth).
fn glass_cut_max(ior: f64, max_depth: u32) -> f64 {
    let m = (0..=100_000)
        .map(|i| glass_cut(i as f64 / 100_000.0, ior, max_depth))
        .fold(0.0, f64::max);
    1.1 * m
}

/// First and second moments of the number of rays of a glass path whose camera ray meets
/// the sphere at incidence cosine `cos_i`: 2 rays when it reflects off the outside
/// (probability R_out), else 1 + K + 1 with K internal rays, K geometric with parameter
/// 1 - R_in.
fn glass_ray_moments(cos_i: f64, ior: f64) -> (f64, f64) {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t = (1.0 - cos_i * cos_i).sqrt() / ior;
    let r_out = schlick(cos_i, 1.0 / ior);
    let r_in = schlick((1.0 - sin_t * sin_t).sqrt(), ior);
    let mu = 1.0 / (1.0 - r_in);
    let k2 = (1.0 + r_in) / ((1.0 - r_in) * (1.0 - r_in));
    let e1 = 2.0 + (1.0 - r_out) * mu;
    let e2 = 4.0 * r_out + (1.0 - r_out) * (4.0 + 4.0 * mu + k2);
    (e1, e2)
}

/// |z| of the frame's ray count of a centred glass furnace against the count expected from
/// Schlick's reflectance at each camera ray's incidence (averaged over every pixel's
/// footprint). Self-intersections or lost rays inside the glass would change the count.
fn glass_ray_count_z(c: &Furnace, sc: &Scene, ior: f64, centre: DVec3, rays: u64) -> f64 {
    let view = view_of(sc, c.frame);
    let t = sc.shot.interval(c.frame).open;
    let (mut mean, mut var) = (0.0, 0.0);
    for y in 0..c.size {
        for x in 0..c.size {
            let (mut e1, mut e2) = (0.0, 0.0);
            for i in 0..4 {
                for j in 0..4 {
                    let jit = ((i as f64 + 0.5) / 4.0, (j as f64 + 0.5) / 4.0);
                    let ray = view.ray(x, y, jit, (0.5, 0.5), t);
                    let hit = intersect(centre, c.radius, &ray, f64::INFINITY)
                        .expect("a centred furnace's camera rays all hit");
                    let sp = surface_point(centre, c.radius, &ray, hit);
                    let (a, b) = glass_ray_moments(-ray.dir.dot(sp.normal), ior);
                    e1 += a / 16.0;
                    e2 += b / 16.0;
                }
            }
            mean += c.samples as f64 * e1;
            var += c.samples as f64 * (e2 - e1 * e1);
        }
    }
    ((rays as f64 - mean) / var.sqrt()).abs()
}

/// Runs every furnace in parallel and reports the worst figures under `name`.
fn sweep(name: &str, cases: &[Furnace]) -> Figures {
    let start = Instant::now();
    let fig = cases
        .par_iter()
        .map(check_furnace)
        .reduce(Figures::none, Figures::worst);
    eprintln!(
        "[stability] {name}: {} cases, max |pixel - exact| {:.3e}, max two-valued residual {:.3e}, max |z| {:.2}, min binomial tail {:.3e}, partly covered pixels {}, glass samples cut at max_depth {}, {:.2} s",
        cases.len(),
        fig.exact,
        fig.two_valued,
        fig.z,
        fig.tail,
        fig.partial,
        fig.lost,
        start.elapsed().as_secs_f64()
    );
    fig
}

const RADII: [f64; 6] = [1e-4, 1e-2, 1.0, 1e2, 1e4, 1e6];
const DISTANCES: [f64; 4] = [0.0, 1.0, 1e3, 1e6];
const CAMERAS: [f64; 3] = [2.0, 100.0, 1e4];
const OPAQUE_AND_GLASS: [Surface; 3] = [Surface::Lambertian, Surface::Mirror, Surface::Glass(1.5)];

/// Every combination of the given radii, centre distances and camera distances.
fn grid(surfaces: &[Surface], radii: &[f64], distances: &[f64], cameras: &[f64]) -> Vec<Furnace> {
    let mut out = Vec::new();
    for &s in surfaces {
        for &r in radii {
            for &d in distances {
                for &k in cameras {
                    out.push(Furnace::new(s, r, d, k));
                }
            }
        }
    }
    out
}

#[test]
fn furnace_still_spheres_at_every_scale_read_exactly() {
    let mut cases = Vec::new();
    for base in grid(&OPAQUE_AND_GLASS, &RADII, &DISTANCES, &CAMERAS) {
        for frame in [1, 1_000_000] {
            cases.push(Furnace { frame, ..base });
        }
    }
    let fig = sweep("furnace, still, radius x centre x camera x frame", &cases);
    assert!(fig.exact <= EXACT);
}

/// Beyond the sweep: cameras 1e8 and 1e10 radii away (a sphere of radius 1e-4 at 1e6 seen
/// from near the origin). The textbook discriminant b^2 - c loses every digit once the
/// distance exceeds 1/sqrt(eps) = 6.7e7 radii; the form of Ray Tracing Gems keeps them.
#[test]
fn furnace_small_spheres_seen_from_afar_read_exactly() {
    let cases = grid(&OPAQUE_AND_GLASS, &[1e-4, 1e-2], &[1e6], &[1e8, 1e10]);
    let fig = sweep("furnace, still, camera 1e8 and 1e10 radii away", &cases);
    assert!(fig.exact <= EXACT);
}

#[test]
fn furnace_moving_spheres_read_between_albedo_and_one() {
    let mut cases = Vec::new();
    for base in grid(
        &OPAQUE_AND_GLASS,
        &[1e-4, 1.0, 1e6],
        &[0.0, 1e6],
        &[2.0, 1e4],
    ) {
        for speed in [0.5, 1000.0] {
            for frame in [1, 1000, 1_000_000] {
                cases.push(Furnace {
                    speed,
                    frame,
                    size: 32,
                    samples: 16,
                    ..base
                });
            }
        }
    }
    let fig = sweep("furnace, moving, 0.5 and 1000 radii per shutter", &cases);
    assert!(
        fig.partial > 0,
        "the motion must make coverage partial somewhere"
    );
}

#[test]
fn furnace_zero_shutter_freezes_fast_spheres_exactly() {
    let mut cases = Vec::new();
    for base in grid(
        &OPAQUE_AND_GLASS,
        &[1e-4, 1.0, 1e6],
        &[0.0, 1e6],
        &[2.0, 1e4],
    ) {
        for frame in [1, 1_000_000] {
            cases.push(Furnace {
                speed: 1000.0,
                shutter_angle: 0.0,
                frame,
                ..base
            });
        }
    }
    sweep("furnace, shutter 0, 1000 radii per 1/48 s", &cases);
}

#[test]
fn furnace_extreme_frame_rates_and_long_shutters() {
    let mut cases = Vec::new();
    for base in grid(&OPAQUE_AND_GLASS, &[1e-4, 1e6], &[1e6], &[2.0, 1e4]) {
        for fps in [0.001, 10000.0] {
            for frame in [1, 1_000_000] {
                // A still sphere, then moving with shutters of half, two and five frame periods.
                cases.push(Furnace { fps, frame, ..base });
                for angle in [180.0, 720.0, 1800.0] {
                    for speed in [0.5, 1000.0] {
                        cases.push(Furnace {
                            fps,
                            frame,
                            shutter_angle: angle,
                            speed,
                            ..base
                        });
                    }
                }
            }
        }
    }
    sweep(
        "furnace, fps 0.001 and 10000, shutter 0.5 to 5 frame periods",
        &cases,
    );
}

#[test]
fn furnace_glass_of_extreme_ior_reads_one() {
    let glasses = [
        Surface::Glass(1.0),
        Surface::Glass(1.0001),
        Surface::Glass(10.0),
    ];
    let mut cases = grid(&glasses, &[1e-4, 1.0, 1e6], &[0.0, 1e6], &[2.0, 1e4]);
    for base in cases.clone() {
        cases.push(Furnace {
            speed: 1000.0,
            frame: 1_000_000,
            ..base
        });
    }
    for c in cases.iter_mut() {
        c.samples = 16;
    }
    sweep("furnace, glass ior 1.0, 1.0001, 10", &cases);
}

#[test]
fn furnace_fuzz_one_mirror_keeps_the_exact_fraction_of_rays() {
    let mut cases = grid(
        &[Surface::FuzzyMirror],
        &[1e-4, 1.0, 1e6],
        &[0.0, 1e6],
        &[2.0, 1e4],
    );
    for c in cases.iter_mut() {
        c.samples = 64;
    }
    let fig = sweep("furnace, metal fuzz 1 (binomial)", &cases);
    assert!(fig.tail >= TAIL);
}

#[test]
fn furnace_limb_crossing_the_frame_is_two_valued() {
    let surfaces = [
        Surface::Lambertian,
        Surface::Mirror,
        Surface::Glass(1.0),
        Surface::Glass(1.0001),
        Surface::Glass(1.5),
        Surface::Glass(10.0),
    ];
    let mut cases = Vec::new();
    for base in grid(&surfaces, &[1e-4, 1.0, 1e6], &[0.0, 1e6], &[2.0, 1e4]) {
        for zoom in [0.4, 1e-3, 1e-6] {
            cases.push(Furnace {
                aim: Aim::Limb { zoom },
                size: 32,
                samples: 16,
                ..base
            });
        }
    }
    let fig = sweep(
        "furnace, silhouette crossing the frame (zoom 0.4 to 1e-6)",
        &cases,
    );
    assert!(fig.partial > 0, "the limb must cross some pixels");
}

// ------------------------------------------------------------------------------------------
// Furnaces on the GPU

/// Renders on the GPU every furnace of `cases` it takes, checking each as on the CPU (to
/// [`EXACT_GPU`] where the CPU's answer is exact to [`EXACT`]); checks that it refuses every
/// other as `check` and `render` do (exit status 2, the way out named). Returns the worst
/// figures and the counts rendered and refused, or `None` where there is no GPU.
fn sweep_gpu(name: &str, cases: &[Furnace]) -> Option<(Figures, usize, usize)> {
    let gpu = common::gpu()?;
    let start = Instant::now();
    let on_gpu = raytrace_scene::scene_file::Overrides {
        device: Some(raytrace_core::scene::Device::Gpu),
        ..Default::default()
    };
    let (mut fig, mut rendered, mut refused) = (Figures::none(), 0, 0);
    for c in cases {
        let (text, _) = c.scene();
        let parsed = Scene::parse_with(&text, Path::new("furnace.toml"), &on_gpu);
        match parsed.and_then(|s| raytrace_render::devices::supported(s, &on_gpu)) {
            Err(e) => {
                let message = e.to_string();
                assert_eq!(e.exit_code(), 2, "{c:?}: {message}");
                assert!(message.contains("--device cpu"), "{c:?}: {message}");
                refused += 1;
            }
            Ok(_) => {
                fig = Figures::worst(fig, check_furnace_on(c, Tracer::Gpu(gpu)));
                rendered += 1;
            }
        }
    }
    eprintln!(
        "[stability] {name}, on the GPU: {rendered} rendered, {refused} refused; max |pixel - exact| {:.3e}, max two-valued residual {:.3e}, max |z| {:.2}, min binomial tail {:.3e}, partly covered pixels {}, glass samples cut at max_depth {}, {:.2} s",
        fig.exact,
        fig.two_valued,
        fig.z,
        fig.tail,
        fig.partial,
        fig.lost,
        start.elapsed().as_secs_f64()
    );
    Some((fig, rendered, refused))
}

/// Whether the GPU takes the furnace `c` (not refused for its floats).
fn gpu_takes(c: &Furnace) -> bool {
    let mut sc = scene(&c.scene().0);
    sc.render.device = raytrace_core::scene::Device::Gpu;
    raytrace_gpu::unsupported(&sc).is_none()
}

#[test]
fn furnaces_on_the_gpu_read_exactly_where_its_floats_suffice_and_are_refused_elsewhere() {
    // The CPU's still sweep (every radius, centre and camera distance, frames 1 and
    // 1,000,000) and its cameras from afar (1e8 and 1e10 radii).
    let mut cases = Vec::new();
    for base in grid(&OPAQUE_AND_GLASS, &RADII, &DISTANCES, &CAMERAS) {
        for frame in [1, 1_000_000] {
            cases.push(Furnace { frame, ..base });
        }
    }
    cases.extend(grid(&OPAQUE_AND_GLASS, &[1e-4, 1e-2], &[1e6], &[1e8, 1e10]));
    let Some((fig, rendered, refused)) = sweep_gpu("furnace, still", &cases) else {
        return;
    };
    assert!(fig.exact <= EXACT_GPU && rendered > 0 && refused > 0);
    // What decides: a radius below 2^-13 of the centre's distance is refused.
    let lambertian = |r, d| Furnace::new(Surface::Lambertian, r, d, 2.0);
    assert!(gpu_takes(&lambertian(1e-4, 0.0)) && gpu_takes(&lambertian(1e6, 1e6)));
    assert!(gpu_takes(&lambertian(1.0, 1e3)) && !gpu_takes(&lambertian(1e-2, 1e3)));
    assert!(!gpu_takes(&lambertian(1e-4, 1e6)) && !gpu_takes(&lambertian(1e2, 1e6)));
}

#[test]
fn moving_furnaces_on_the_gpu_read_between_albedo_and_one() {
    let mut cases = Vec::new();
    for base in grid(
        &OPAQUE_AND_GLASS,
        &[1e-4, 1.0, 1e6],
        &[0.0, 1e6],
        &[2.0, 1e4],
    ) {
        for (speed, angle) in [(0.5, 180.0), (1000.0, 180.0), (1000.0, 0.0)] {
            for frame in [1, 1_000_000] {
                cases.push(Furnace {
                    speed,
                    shutter_angle: angle,
                    frame,
                    samples: 16,
                    ..base
                });
            }
        }
    }
    let Some((fig, rendered, _)) = sweep_gpu("furnace, moving and frozen", &cases) else {
        return;
    };
    assert!(rendered > 0 && fig.partial > 0, "{fig:?}");
}

#[test]
fn glass_fuzz_and_limbs_on_the_gpu_keep_their_exact_distributions() {
    let glasses = [
        Surface::Glass(1.0),
        Surface::Glass(1.0001),
        Surface::Glass(10.0),
    ];
    let mut cases = grid(&glasses, &[1e-4, 1.0, 1e6], &[0.0], &[2.0, 1e4]);
    for c in cases.iter_mut() {
        c.samples = 16;
    }
    for mut c in grid(
        &[Surface::FuzzyMirror],
        &[1e-4, 1.0, 1e6],
        &[0.0, 1e6],
        &[2.0],
    ) {
        c.samples = 64;
        cases.push(c);
    }
    let surfaces = [
        Surface::Lambertian,
        Surface::Mirror,
        Surface::Glass(1.0001),
        Surface::Glass(1.5),
    ];
    for base in grid(&surfaces, &[1e-4, 1.0, 1e6], &[0.0], &[2.0, 1e4]) {
        for zoom in [0.4, 1e-3] {
            cases.push(Furnace {
                aim: Aim::Limb { zoom },
                samples: 16,
                ..base
            });
        }
    }
    let Some((fig, rendered, refused)) =
        sweep_gpu("furnace, glass ior 1 to 10, fuzz 1, limbs", &cases)
    else {
        return;
    };
    assert!(fig.tail >= TAIL && rendered > 0 && refused > 0, "{fig:?}");
}

// ------------------------------------------------------------------------------------------
// Rays grazing a silhouette, traced one by one

/// Rays aimed at impact parameters within a few units in the last place of the radius, on
/// both sides, traced through the tracer: every one returns the albedo (hit) or 1 (missed),
/// glass returns 1, nothing is lost to a self-intersection or absorbed at a grazing mirror.
#[test]
fn grazing_rays_are_neither_lost_nor_darkened() {
    let start = Instant::now();
    let surfaces = [
        Surface::Lambertian,
        Surface::Mirror,
        Surface::Glass(1.5),
        Surface::Glass(10.0),
    ];
    // Relative impact parameter 1 - delta: inside for delta > 0.
    let deltas = [
        -1e-3, -1e-8, -1e-12, -1e-14, -4e-16, -2.2e-16, -1.1e-16, 0.0, 1.1e-16, 2.2e-16, 4e-16,
        1e-14, 1e-12, 1e-10, 1e-8, 1e-3, 0.5,
    ];
    let rays_per_delta = 500u32;
    // Distance of the ray origins from the centre, in radii: a bounce off the sphere's
    // neighbourhood, the farthest camera of the furnaces, and far beyond.
    let mut cases = Vec::new();
    for s in surfaces {
        for r in [1e-4, 1.0, 1e6] {
            for d in [0.0, 1e6] {
                for o in [3.0, 1e4, 1e8] {
                    cases.push((s, r, d, o));
                }
            }
        }
    }
    // Per case: (hits, misses, failures as (delta, count, example)).
    type Tally = (u64, u64, Vec<(f64, u32, String)>);
    let tallies: Vec<Tally> = cases
        .par_iter()
        .map(|&(surface, r, dist, reach)| {
            let centre = DVec3::new(1.0, -0.6, 0.35).normalize() * dist;
            let text = format!(
                "[shot]\nshutter = 0.0\n[background]\ncolor = [1.0, 1.0, 1.0]\n[[sphere]]\ncenter = {}\nradius = {}\nmaterial = {}\n",
                v(centre),
                f(r),
                surface.toml()
            );
            let sc = scene(&text);
            let statics = StaticGeometry::new(&sc);
            let world = World::prepare(&sc, &statics, sc.shot.interval(1));
            let a = surface.albedo();
            let mut sampler = IndependentSampler::new(17, 1);
            let mut rng = raytrace_core::rng::Pcg32::new(r.to_bits(), dist.to_bits());
            let mut stats = TraceStats::default();
            let (mut hits, mut misses, mut failures) = (0u64, 0u64, Vec::new());
            // A unit direction resolves angles to about 1.1e-16, so from `reach` radii away
            // the impact parameter is known to about 1.1e-16 reach radii: only impact
            // parameters farther than that from the radius must hit or miss for sure.
            let clear = 1e-8f64.max(1e-15 * reach);
            for (di, &delta) in deltas.iter().enumerate() {
                let mut bad = 0u32;
                let mut example = String::new();
                for k in 0..rays_per_delta {
                    let mut u = || rng.next_f64() * 2.0 - 1.0;
                    // The origin `reach` radii from the centre. Its offset from the centre is
                    // exact (Sterbenz) near the sphere, and in any case computed exactly
                    // below, so the direction can be aimed at an impact parameter exact to
                    // an ulp of the radius even where the origin itself is rounded to 1e-10
                    // (near 1e6).
                    let origin = centre + DVec3::new(u(), u(), u()).normalize() * (reach * r);
                    let f = origin - centre;
                    let toward = -f.normalize();
                    let side = toward.any_orthonormal_vector();
                    let side = (side * u() + toward.cross(side) * u()).normalize();
                    let sin = r * (1.0 - delta) / f.length();
                    let dir = (toward * (1.0 - sin * sin).sqrt() + side * sin).normalize();
                    let ray = Ray {
                        origin,
                        dir,
                        time: 0.0,
                    };
                    sampler.start_sample(di as u32, k, 0);
                    let value = radiance(&world, ray, GLASS_DEPTH, &mut sampler, &mut stats);
                    let is = |w: DVec3| (value - w).abs().max_element() <= EXACT;
                    let problem = if !value.is_finite() {
                        Some(format!("returned {value}"))
                    } else if is(DVec3::ONE) {
                        misses += 1;
                        let inside = delta >= clear && !matches!(surface, Surface::Glass(_));
                        inside.then(|| "missed".to_string())
                    } else if is(a) {
                        hits += 1;
                        (delta <= -clear).then(|| "hit from outside the silhouette".to_string())
                    } else {
                        Some(format!("returned {value}, neither {a} nor 1"))
                    };
                    if let Some(p) = problem {
                        bad += 1;
                        if example.is_empty() {
                            example = format!("{p}: {ray:?}");
                        }
                    }
                }
                if bad > 0 {
                    failures.push((delta, bad, example));
                }
            }
            (hits, misses, failures)
        })
        .collect();
    let mut report = String::new();
    let (mut hits, mut misses) = (0, 0);
    for (&(surface, r, dist, reach), (h, m, failures)) in cases.iter().zip(&tallies) {
        hits += h;
        misses += m;
        for (delta, bad, example) in failures {
            report.push_str(&format!(
                "{surface:?} r {r:e} at {dist:e}, origin {reach:e} radii away, delta {delta:e}: {bad} of {rays_per_delta} wrong, e.g. {example}\n"
            ));
        }
    }
    let total = cases.len() as u64 * deltas.len() as u64 * rays_per_delta as u64;
    assert!(report.is_empty(), "grazing rays lost:\n{report}");
    eprintln!(
        "[stability] grazing rays: {total} paths ({hits} valued a, {misses} valued 1), none lost, {:.2} s",
        start.elapsed().as_secs_f64()
    );
}

// ------------------------------------------------------------------------------------------
// Contact

/// The cosine-weighted fraction of the hemisphere above a ground point `p` (unit normal `n`)
/// covered by the sphere at `c` of radius `s`: the form factor from a differential area to a
/// sphere wholly above its tangent plane, s^2 ((c - p).n) / |c - p|^3. Near the contact the
/// ball dips below the tangent plane of a ground point at distance rho by about rho^2 / 2R;
/// the formula then counts that sliver negatively where it should count zero, an error of
/// the order of (rho / 2R)^2, below 1e-6 for every point here.
fn form_factor(p: DVec3, n: DVec3, c: DVec3, s: f64) -> f64 {
    let w = c - p;
    let d = w.length();
    (s * s * w.dot(n) / (d * d * d)).clamp(0.0, 1.0)
}

/// A black ball of radius `s` resting on a grey ground sphere of radius 1e6, in a uniform
/// background of radiance 1, seen from `elevation` degrees. A camera ray that meets the
/// ball returns 0; one that meets the ground returns its albedo if its bounce escapes (one
/// minus the form factor of the ball) and 0 if it meets the ball. Every pixel's count of
/// escaped samples is binomial with a probability computed from the geometry alone: light
/// leaking through the contact raises it, acne or lost rays lower it.
fn check_contact(s: f64, elevation: f64) -> (f64, f64, u32, f64) {
    const GROUND: f64 = 1e6;
    const ALBEDO: f64 = 0.5;
    let size = 32;
    let n = 64;
    let ground_c = DVec3::new(0.0, -GROUND, 0.0);
    let ball_c = DVec3::new(0.0, s, 0.0);
    let (el, az) = (elevation.to_radians(), 30f64.to_radians());
    let from = DVec3::new(el.cos() * az.cos(), el.sin(), el.cos() * az.sin()) * (6.0 * s);
    // The frame's top edge 4 degrees (2 at the lowest elevation) below the horizon.
    let vfov = 2.0 * (elevation - if elevation > 10.0 { 4.0 } else { 2.0 });
    let text = format!(
        r#"
[shot]
shutter = 0.0
[output]
width = {size}
height = {size}
[render]
samples = {n}
max_depth = 8
[camera]
look_from = {from}
look_at = [0.0, 0.0, 0.0]
vfov = {vfov}
[background]
color = [1.0, 1.0, 1.0]
[[sphere]]
center = {gc}
radius = {gr}
material = {{ type = "lambertian", albedo = [{a}, {a}, {a}] }}
[[sphere]]
center = {bc}
radius = {br}
material = {{ type = "lambertian", albedo = [0.0, 0.0, 0.0] }}
"#,
        from = v(from),
        vfov = f(vfov),
        gc = v(ground_c),
        gr = f(GROUND),
        a = f(ALBEDO),
        bc = v(ball_c),
        br = f(s),
    );
    let sc = scene(&text);
    let what = format!("contact, scale {s}, elevation {elevation}");
    let result = render_checked(&sc, 1, &what);
    let view = view_of(&sc, 1);
    let (mut sum_k, mut sum_mean, mut sum_var) = (0.0, 0.0, 0.0);
    let mut worst_tail: f64 = 1.0;
    let mut ground_pixels = 0;
    let mut deepest: f64 = 1.0;
    for y in 0..size {
        for x in 0..size {
            let (k, _) = two_valued(
                result.film.get(x, y),
                DVec3::ZERO,
                DVec3::splat(ALBEDO),
                n,
                &what,
            );
            // Escape probability along the camera ray through (jx, jy); None on the ball.
            let escape = |jx: f64, jy: f64| -> Option<f64> {
                let ray = view.ray(x, y, (jx, jy), (0.5, 0.5), 0.0);
                let tb = intersect(ball_c, s, &ray, f64::INFINITY);
                let tg = intersect(ground_c, GROUND, &ray, tb.unwrap_or(f64::INFINITY));
                match (tb, tg) {
                    (_, Some(t)) => {
                        let sp = surface_point(ground_c, GROUND, &ray, t);
                        Some(1.0 - form_factor(sp.p, sp.normal, ball_c, s))
                    }
                    (Some(_), None) => None,
                    (None, None) => panic!("{what}: pixel ({x}, {y}) sees the sky"),
                }
            };
            let (lo, hi, mean, clean) = footprint(escape);
            let tail = binomial_surprise(n, k, lo, hi);
            assert!(
                tail >= TAIL,
                "{what}: pixel ({x}, {y}) has {k} of {n} samples escaping, probability in [{lo}, {hi}] (tail {tail:e})"
            );
            worst_tail = worst_tail.min(tail);
            if clean {
                ground_pixels += 1;
                deepest = deepest.min(mean);
                sum_k += k as f64;
                sum_mean += n as f64 * mean;
                sum_var += n as f64 * mean * (1.0 - mean);
            }
        }
    }
    // All the clean ground pixels together: acne or leaks of a fraction of a percent show.
    let z = (sum_k - sum_mean) / sum_var.sqrt();
    assert!(
        z.abs() <= Z_MAX,
        "{what}: ground escapes {sum_k} against {sum_mean} expected ({z} sigma)"
    );
    (z.abs(), worst_tail, ground_pixels, deepest)
}

#[test]
fn contact_neither_leaks_nor_shows_acne_at_any_scale() {
    let start = Instant::now();
    let mut cases = Vec::new();
    for s in [1e-3, 1e-2, 1e-1, 1.0, 1e1, 1e2, 1e3] {
        for elevation in [15.0, 5.0] {
            cases.push((s, elevation));
        }
    }
    let figures: Vec<(f64, f64, u32, f64)> = cases
        .par_iter()
        .map(|&(s, e)| check_contact(s, e))
        .collect();
    for ((s, e), (z, tail, px, deepest)) in cases.iter().zip(&figures) {
        eprintln!(
            "[stability] contact scale {s:e}, elevation {e}: |z| {z:.2} over {px} ground pixels, min tail {tail:.3e}, lowest escape probability of a ground pixel {deepest:.4}"
        );
    }
    eprintln!(
        "[stability] contact: max |z| {:.2}, min binomial tail {:.3e}, {:.2} s",
        figures.iter().map(|f| f.0).fold(0.0, f64::max),
        figures.iter().map(|f| f.1).fold(1.0, f64::min),
        start.elapsed().as_secs_f64()
    );
}

// ------------------------------------------------------------------------------------------
// Time spread late in a long shot

const LONG_SHOT: &str = r#"
[shot]
fps = 24.0
frames = 1000000
shutter = 0.020833333333333332
[output]
width = 1
height = 1
[render]
samples = 4096
max_depth = 4
seed = 9
[background]
color = [1.0, 1.0, 1.0]
"#;

/// The sample times of pixel (x, y) in `frame`, drawn as a frame's sampling draws them (the
/// camera's numbers), as fractions of the shutter; and the largest difference between a
/// time's fraction and the uniform number it was drawn from.
fn shutter_fractions(sc: &Scene, frame: u32, x: u32, y: u32, n: u32) -> (Vec<f64>, f64) {
    let uses = CameraUse {
        lens: sc.camera.aperture > 0.0,
        time: true,
    };
    let interval = sc.shot.interval(frame);
    let mut sampler = IndependentSampler::new(sc.render.seed, frame);
    let mut out = Vec::with_capacity(n as usize);
    let mut quantization: f64 = 0.0;
    for i in 0..n {
        sampler.start_sample(x, y, i);
        let u = sampler.camera(uses).time;
        let t = interval.at(u);
        assert!(interval.contains(t));
        let frac = (t - interval.open) / interval.duration();
        quantization = quantization.max((frac - u).abs());
        out.push(frac);
    }
    out.sort_by(f64::total_cmp);
    (out, quantization)
}

/// Distinct values, largest gap (including both ends) and Kolmogorov-Smirnov distance of
/// sorted fractions of [0, 1].
fn spread(sorted: &[f64]) -> (usize, f64, f64) {
    let mut distinct = sorted.to_vec();
    distinct.dedup();
    let mut gap = sorted[0].max(1.0 - sorted[sorted.len() - 1]);
    for w in sorted.windows(2) {
        gap = gap.max(w[1] - w[0]);
    }
    let n = sorted.len() as f64;
    let ks = sorted
        .iter()
        .enumerate()
        .map(|(i, &x)| (x - i as f64 / n).abs().max(((i + 1) as f64 / n - x).abs()))
        .fold(0.0, f64::max);
    (distinct.len(), gap, ks)
}

#[test]
fn sample_times_late_in_a_long_shot_cover_the_shutter_like_frame_one() {
    let sc = scene(LONG_SHOT);
    let n = 4096;
    for frame in [1, 1000, 1_000_000] {
        for (x, y) in [(0, 0), (7, 3)] {
            let (fr, quant) = shutter_fractions(&sc, frame, x, y, n);
            let (distinct, gap, ks) = spread(&fr);
            eprintln!(
                "[stability] time spread frame {frame} pixel ({x}, {y}): {distinct} distinct of {n}, largest gap {:.2}/{n} of the shutter, KS {ks:.4}, largest time rounding {quant:.2e} of the shutter",
                gap * n as f64
            );
            // 4096 uniform numbers of 32 bits: all distinct with probability 0.998 (fixed
            // seed); the largest of the gaps exceeds 16/n with probability 4096 e^-16 = 5e-4;
            // the KS distance exceeds 1.95/sqrt(n) with probability 1e-3.
            assert_eq!(distinct, n as usize, "frame {frame}: repeated sample times");
            assert!(gap < 16.0 / n as f64, "frame {frame}: gap {gap}");
            assert!(ks < 1.95 / (n as f64).sqrt(), "frame {frame}: KS {ks}");
            // At 4.2e4 s an f64 time resolves 7e-12 s: the draw keeps 1e-9 of the shutter.
            assert!(
                quant < 1e-9,
                "frame {frame}: times rounded by {quant} of the shutter"
            );
        }
    }
}

/// The same through the renderer: a black ball crosses a one-pixel camera's line of sight
/// during a known part of the shutter, so the pixel's count of dark samples is binomial with
/// that fraction, at frame 1 and at frame 1,000,000 alike.
#[test]
fn motion_blur_late_in_a_long_shot_covers_the_shutter_like_frame_one() {
    let shot = scene(LONG_SHOT).shot;
    let n = 4096;
    for frame in [1, 1_000_000] {
        let interval = shot.interval(frame);
        // The ball's centre moves along x at 4 radii per shutter from x0 at the opening; it
        // covers the line of sight (the z axis) while |x| < 1.
        for x0 in [-2.5, -4.0, 0.0, -4.75] {
            let speed = 4.0 / interval.duration();
            let start = x0 - speed * interval.open;
            let text = format!(
                "{LONG_SHOT}[camera]\nlook_from = [0.0, 0.0, 10.0]\nlook_at = [0.0, 0.0, 0.0]\nvfov = 1e-6\n[[sphere]]\ncenter = [{}, 0.0, 0.0]\nvelocity = [{}, 0.0, 0.0]\nradius = 1.0\nmaterial = {{ type = \"lambertian\", albedo = [0.0, 0.0, 0.0] }}\n",
                f(start),
                f(speed)
            );
            let sc = scene(&text);
            let result = render_checked(&sc, frame, "time spread render");
            let (lit, _) = two_valued(
                result.film.get(0, 0),
                DVec3::ZERO,
                DVec3::ONE,
                n,
                "time spread",
            );
            let covered = n - lit;
            let (u0, u1) = (
                ((-1.0 - x0) / 4.0f64).clamp(0.0, 1.0),
                ((1.0 - x0) / 4.0f64).clamp(0.0, 1.0),
            );
            let p = u1 - u0;
            // The pixel's footprint at the ball is 2e-7 wide: the window is exact to 1e-7.
            let tail = binomial_surprise(n, covered, p - 1e-6, p + 1e-6);
            eprintln!(
                "[stability] time spread render frame {frame}, window [{u0}, {u1}]: {covered} of {n} samples covered (expected {:.1}), tail {tail:.3e}",
                p * n as f64
            );
            assert!(
                tail >= TAIL,
                "frame {frame}: {covered} of {n} covered for a window of {p}"
            );
        }
    }
}

// ------------------------------------------------------------------------------------------
// Bad numbers

/// Scenes in which every numeric field of the format appears once, written as
/// `{{field=default}}`, where `field` is the name the validation must use for it.
/// Two scenes, because some fields exclude others (shutter and shutter_angle, camera orbit
/// and keyframes); the second also holds the keyframed sphere.
const TEMPLATE_A: &str = r#"
[shot]
fps = {{shot.fps=24.0}}
frames = 2
start_time = {{shot.start_time=0.5}}
shutter = {{shot.shutter=0.02}}
[output]
width = 8
height = 6
[render]
samples = 2
max_depth = 6
[camera]
look_from = [{{camera.look_from[0]=0.3}}, {{camera.look_from[1]=1.0}}, {{camera.look_from[2]=6.0}}]
look_at = [{{camera.look_at[0]=0.1}}, {{camera.look_at[1]=0.2}}, {{camera.look_at[2]=-0.4}}]
up = [{{camera.up[0]=0.1}}, {{camera.up[1]=1.0}}, {{camera.up[2]=0.2}}]
vfov = {{camera.vfov=40.0}}
aperture = {{camera.aperture=0.1}}
focus_distance = {{camera.focus_distance=6.0}}
orbit = { degrees_per_second = {{camera.orbit.degrees_per_second=20.0}} }
[background]
color = [{{background.color[0]=1.0}}, {{background.color[1]=0.9}}, {{background.color[2]=0.8}}]
[materials]
matte = { type = "lambertian", albedo = [{{materials.matte.albedo[0]=0.5}}, {{materials.matte.albedo[1]=0.4}}, {{materials.matte.albedo[2]=0.3}}] }
steel = { type = "metal", albedo = [{{materials.steel.albedo[0]=0.8}}, {{materials.steel.albedo[1]=0.7}}, {{materials.steel.albedo[2]=0.6}}], fuzz = {{materials.steel.fuzz=0.1}} }
glass = { type = "dielectric", ior = {{materials.glass.ior=1.5}} }
[[sphere]]
center = [{{sphere[0].center[0]=0.2}}, {{sphere[0].center[1]=-100.0}}, {{sphere[0].center[2]=0.3}}]
radius = {{sphere[0].radius=100.0}}
material = { type = "lambertian", albedo = [{{sphere[0].material.albedo[0]=0.5}}, {{sphere[0].material.albedo[1]=0.5}}, {{sphere[0].material.albedo[2]=0.5}}] }
[[sphere]]
center = [{{sphere[1].center[0]=-1.0}}, {{sphere[1].center[1]=0.5}}, {{sphere[1].center[2]=0.2}}]
radius = {{sphere[1].radius=0.5}}
material = "steel"
velocity = [{{sphere[1].velocity[0]=1.0}}, {{sphere[1].velocity[1]=0.1}}, {{sphere[1].velocity[2]=0.2}}]
[[sphere]]
center = [{{sphere[2].center[0]=1.0}}, {{sphere[2].center[1]=0.6}}, {{sphere[2].center[2]=0.1}}]
radius = {{sphere[2].radius=0.4}}
material = "glass"
orbit = { pivot = [{{sphere[2].orbit.pivot[0]=0.1}}, {{sphere[2].orbit.pivot[1]=0.6}}, {{sphere[2].orbit.pivot[2]=0.2}}], axis = [{{sphere[2].orbit.axis[0]=0.2}}, {{sphere[2].orbit.axis[1]=1.0}}, {{sphere[2].orbit.axis[2]=0.1}}], degrees_per_second = {{sphere[2].orbit.degrees_per_second=90.0}} }
[[sphere]]
center = [0.0, 1.5, 0.0]
radius = 0.3
material = { type = "metal", albedo = [{{sphere[3].material.albedo[0]=0.9}}, {{sphere[3].material.albedo[1]=0.9}}, {{sphere[3].material.albedo[2]=0.9}}], fuzz = {{sphere[3].material.fuzz=0.3}} }
[[sphere]]
center = [0.0, 0.3, 1.5]
radius = 0.3
material = { type = "dielectric", ior = {{sphere[4].material.ior=1.3}} }
[[sphere]]
center = [-0.5, 0.3, 1.0]
radius = 0.25
material = "matte"
"#;

const TEMPLATE_B: &str = r#"
[shot]
fps = 24.0
frames = 2
shutter_angle = {{shot.shutter_angle=180.0}}
[output]
width = 8
height = 6
[render]
samples = 2
max_depth = 6
[camera]
look_from = [0.0, 1.0, 6.0]
keyframes = [ { time = {{camera.keyframes[0].time=-1.0}}, look_from = [{{camera.keyframes[0].look_from[0]=0.1}}, {{camera.keyframes[0].look_from[1]=1.0}}, {{camera.keyframes[0].look_from[2]=6.0}}], look_at = [{{camera.keyframes[0].look_at[0]=0.1}}, {{camera.keyframes[0].look_at[1]=0.2}}, {{camera.keyframes[0].look_at[2]=0.3}}] }, { time = {{camera.keyframes[1].time=1.0}}, look_from = [{{camera.keyframes[1].look_from[0]=1.0}}, {{camera.keyframes[1].look_from[1]=1.2}}, {{camera.keyframes[1].look_from[2]=5.0}}], look_at = [{{camera.keyframes[1].look_at[0]=0.2}}, {{camera.keyframes[1].look_at[1]=0.1}}, {{camera.keyframes[1].look_at[2]=0.3}}] } ]
[background]
color = [1.0, 1.0, 1.0]
[[sphere]]
radius = 0.5
material = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
keyframes = [ { time = {{sphere[0].keyframes[0].time=-1.0}}, center = [{{sphere[0].keyframes[0].center[0]=0.1}}, {{sphere[0].keyframes[0].center[1]=0.5}}, {{sphere[0].keyframes[0].center[2]=0.2}}] }, { time = {{sphere[0].keyframes[1].time=1.0}}, center = [{{sphere[0].keyframes[1].center[0]=1.0}}, {{sphere[0].keyframes[1].center[1]=0.6}}, {{sphere[0].keyframes[1].center[2]=0.3}}] } ]
[[sphere]]
center = [0.0, -100.5, 0.0]
radius = 100.0
material = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
"#;

/// The fields of a template, in order, with their default values as written.
fn fields(template: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut rest = template;
    while let Some(i) = rest.find("{{") {
        let j = rest[i..].find("}}").expect("closed field") + i;
        let (name, default) = rest[i + 2..j].split_once('=').expect("field=default");
        out.push((name.to_string(), default.to_string()));
        rest = &rest[j + 2..];
    }
    out
}

/// The template with `field` set to `value` and every other field at its default.
fn instantiate(template: &str, field: &str, value: &str) -> String {
    let mut out = String::new();
    let mut rest = template;
    while let Some(i) = rest.find("{{") {
        let j = rest[i..].find("}}").expect("closed field") + i;
        let (name, default) = rest[i + 2..j].split_once('=').expect("field=default");
        out.push_str(&rest[..i]);
        out.push_str(if name == field { value } else { default });
        rest = &rest[j + 2..];
    }
    out.push_str(rest);
    out
}

fn parse(text: &str) -> Result<Scene, raytrace_core::Error> {
    Scene::parse(text, Path::new("bad.toml"))
}

/// Fields bounded below (> 0 or >= 0): negative zero is an error there, as it almost
/// always comes from a sign error upstream.
fn lower_bounded(field: &str) -> bool {
    let last = field.rsplit('.').next().unwrap();
    let last = last.split('[').next().unwrap();
    matches!(
        last,
        "fps"
            | "shutter"
            | "shutter_angle"
            | "vfov"
            | "aperture"
            | "focus_distance"
            | "color"
            | "albedo"
            | "fuzz"
            | "ior"
            | "radius"
    )
}

#[test]
fn every_numeric_field_rejects_nan_infinity_and_f32_overflow_by_name() {
    let mut checked = 0;
    for template in [TEMPLATE_A, TEMPLATE_B] {
        let defaults = instantiate(template, "", "");
        parse(&defaults).unwrap_or_else(|e| panic!("the template must be valid: {e}"));
        for (field, _) in fields(template) {
            for bad in [
                "nan", "-nan", "inf", "+inf", "-inf", "1e39", "-1e39", "3.5e38",
            ] {
                let text = instantiate(template, &field, bad);
                match parse(&text) {
                    Ok(_) => panic!("{field} = {bad} was accepted"),
                    Err(e) => {
                        assert_eq!(e.exit_code(), 2, "{field} = {bad}: {e}");
                        let msg = e.to_string();
                        assert!(
                            msg.contains(&field),
                            "{field} = {bad}: the message does not name the field: {msg}"
                        );
                    }
                }
                checked += 1;
            }
        }
    }
    eprintln!("[stability] bad numbers: {checked} scenes rejected, each naming its field");
}

/// The integer fields. A float where an integer belongs is a type error of the TOML layer,
/// reported at the value's line and column (not by the field's name).
const TEMPLATE_INT: &str = r#"
[shot]
frames = {{shot.frames=2}}
first_frame = {{shot.first_frame=1}}
[output]
width = {{output.width=8}}
height = {{output.height=6}}
[render]
samples = {{render.samples=2}}
max_depth = {{render.max_depth=4}}
seed = {{render.seed=0}}
"#;

#[test]
fn integer_fields_reject_non_integers_by_name() {
    let mut checked = 0;
    parse(&instantiate(TEMPLATE_INT, "", "")).expect("the template must be valid");
    for (field, _) in fields(TEMPLATE_INT) {
        for bad in ["nan", "inf", "-inf", "1e39", "-0.0", "2.5"] {
            let text = instantiate(TEMPLATE_INT, &field, bad);
            let e = parse(&text)
                .err()
                .unwrap_or_else(|| panic!("{field} = {bad} was accepted"));
            assert_eq!(e.exit_code(), 2);
            let msg = e.to_string();
            assert!(
                msg.contains(&format!("{field} must be an integer")),
                "{field} = {bad}: the message does not name the field: {msg}"
            );
            checked += 1;
        }
    }
    eprintln!("[stability] integer fields: {checked} scenes rejected, each naming its field");
}

#[test]
fn negative_zero_is_rejected_where_bounded_below_and_is_zero_in_coordinates() {
    let start = Instant::now();
    let (mut rejected, mut identical) = (0, 0);
    for template in [TEMPLATE_A, TEMPLATE_B] {
        for (field, _) in fields(template) {
            let negative = instantiate(template, &field, "-0.0");
            if lower_bounded(&field) {
                let e = parse(&negative)
                    .err()
                    .unwrap_or_else(|| panic!("{field} = -0.0 was accepted"));
                let msg = e.to_string();
                assert!(
                    msg.contains(&field),
                    "{field} = -0.0: the message does not name the field: {msg}"
                );
                rejected += 1;
            } else {
                let neg = parse(&negative).unwrap_or_else(|e| panic!("{field} = -0.0: {e}"));
                let pos = parse(&instantiate(template, &field, "0.0"))
                    .unwrap_or_else(|e| panic!("{field} = 0.0: {e}"));
                for frame in [1, 2] {
                    let a = render_checked(&neg, frame, &field);
                    let b = render_checked(&pos, frame, &field);
                    let bits = |r: &FrameResult| -> Vec<u64> {
                        r.film
                            .means()
                            .iter()
                            .flat_map(|p| p.to_array().map(f64::to_bits))
                            .collect()
                    };
                    assert!(
                        bits(&a) == bits(&b),
                        "{field} = -0.0 renders differently from 0.0 in frame {frame}"
                    );
                    assert_eq!(a.stats.rays, b.stats.rays, "{field}");
                }
                identical += 1;
            }
        }
    }
    eprintln!(
        "[stability] negative zero: {rejected} bounded fields reject it by name, {identical} coordinate fields render bit-identically to 0.0, {:.2} s",
        start.elapsed().as_secs_f64()
    );
}

#[test]
fn the_binary_refuses_a_bad_number_without_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let text = instantiate(TEMPLATE_A, "sphere[1].radius", "nan")
        .replace("[output]\n", "[output]\npath = \"out/f_####.exr\"\n");
    std::fs::write(dir.path().join("bad.toml"), text).unwrap();
    let bin = env!("CARGO_BIN_EXE_raytrace");
    for args in [&["check", "bad.toml"][..], &["render", "bad.toml"][..]] {
        let o = Command::new(bin)
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains("sphere[1].radius"), "{args:?}: {stderr}");
    }
    assert!(
        !dir.path().join("out").exists(),
        "a bad scene must write nothing"
    );
}
