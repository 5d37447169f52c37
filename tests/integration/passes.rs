//! Passes for compositing, checked against analytic answers: coverage against the projected
//! area of a sphere, depth against the distance along the view axis, normals, motion vectors
//! against the projection of the true motion (computed here with a pinhole camera of the
//! test's own), variance against the spread between seeds; the colour with passes against the
//! colour without; and the frames as files (OpenImageIO's `oiiotool`, PNG alpha, bad input).

use crate::common;

use std::path::Path;
use std::process::Command;

use glam::{DVec2, DVec3};
use raytrace_core::image::{COLOUR, Image};
use raytrace_core::renderer::{Budget, CpuShot, FrameJob, FrameResult};
use raytrace_core::scene::Scene;

use common::{ok, run, run_ok, scene};

fn render(scene: &Scene, frame: u32) -> FrameResult {
    let statics = CpuShot::new(scene);
    FrameJob::new(scene, frame).sample(&statics).unwrap()
}

fn passes(r: &FrameResult) -> &Image {
    &r.image
}

/// A pinhole camera of the test's own: the image plane at the focal length `f` in pixels,
/// x to the right, y downward, (0, 0) at the top-left corner.
#[derive(Clone, Copy)]
struct Pinhole {
    from: DVec3,
    u: DVec3,
    v: DVec3,
    w: DVec3,
    f: f64,
    width: f64,
    height: f64,
}

impl Pinhole {
    fn new(from: DVec3, at: DVec3, vfov: f64, width: u32, height: u32) -> Pinhole {
        let w = (from - at).normalize();
        let u = DVec3::Y.cross(w).normalize();
        let v = w.cross(u);
        let f = 0.5 * height as f64 / (vfov.to_radians() / 2.0).tan();
        Pinhole {
            from,
            u,
            v,
            w,
            f,
            width: width as f64,
            height: height as f64,
        }
    }

    fn project(&self, p: DVec3) -> DVec2 {
        let d = p - self.from;
        let z = -d.dot(self.w);
        DVec2::new(
            0.5 * self.width + self.f * d.dot(self.u) / z,
            0.5 * self.height - self.f * d.dot(self.v) / z,
        )
    }

    /// The unit direction of the ray through image point (x, y).
    fn dir(&self, x: f64, y: f64) -> DVec3 {
        let (a, b) = (
            (x - 0.5 * self.width) / self.f,
            (0.5 * self.height - y) / self.f,
        );
        (a * self.u + b * self.v - self.w).normalize()
    }
}

/// Where the ray from `o` along unit `d` first hits the sphere (`c`, `r`), if it passes within
/// `inside` r of the centre.
fn hit(o: DVec3, d: DVec3, c: DVec3, r: f64, inside: f64) -> Option<DVec3> {
    let b = (o - c).dot(d);
    let closest = (o - c) - b * d;
    if closest.length() > inside * r {
        return None;
    }
    let t = -b - (r * r - closest.length_squared()).sqrt();
    Some(o + t * d)
}

/// The area of the image of a sphere (centre `c`, radius `r`, in camera coordinates: x right,
/// y up, z the distance in front) on the plane z = f: the cone from the eye tangent to the
/// sphere cut by the plane is the conic `k |x|^2 - (c.x)^2 <= 0` with k = |c|^2 - r^2, whose
/// area is pi |det A| / det(A2)^(3/2) for its matrix A in (X, Y, 1) and A's upper 2x2 A2.
fn projected_area(c: DVec3, r: f64, f: f64) -> f64 {
    let k = c.length_squared() - r * r;
    let cp = [c.x, c.y, c.z * f];
    let diag = [k, k, k * f * f];
    let a = |i: usize, j: usize| (if i == j { diag[i] } else { 0.0 }) - cp[i] * cp[j];
    let det3 = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
        - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
    let det2 = a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0);
    std::f64::consts::PI * det3.abs() / det2.powf(1.5)
}

const CAMERA: &str = r#"
[camera]
look_from = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
up = [0.0, 1.0, 0.0]
vfov = 40.0
"#;

#[test]
fn the_projected_area_formula_is_a_circle_on_the_axis() {
    // On the axis the image is a disc of radius f tan(asin(r / d)).
    let (r, d, f) = (1.0_f64, 5.0_f64, 100.0_f64);
    let disc = std::f64::consts::PI * (f * (r / d).asin().tan()).powi(2);
    assert!((projected_area(DVec3::new(0.0, 0.0, d), r, f) / disc - 1.0).abs() < 1e-12);
}

#[test]
fn alpha_of_a_still_sphere_covers_its_projected_disc() {
    let text = format!(
        "[output]\npath = \"t.exr\"\nwidth = 64\nheight = 64\npasses = [\"alpha\"]\n[render]\nsamples = 64\nmax_depth = 1\n{CAMERA}
[[sphere]]
center = [0.0, 0.0, -5.0]
radius = 1.0
material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}
"
    );
    let s = scene(&text);
    let r = render(&s, 1);
    let alpha = passes(&r).floats("A").unwrap().to_vec();
    let sum: f64 = alpha.iter().map(|&a| a as f64).sum();
    let f = Pinhole::new(DVec3::ZERO, -DVec3::Z, 40.0, 64, 64).f;
    let area = projected_area(DVec3::new(0.0, 0.0, 5.0), 1.0, f);
    assert!((sum / area - 1.0).abs() < 0.005, "{sum} {area}");
    assert!(alpha.iter().all(|&a| (0.0..=1.0).contains(&a)));
    assert_eq!(alpha[0], 0.0);
    assert_eq!(alpha[32 * 64 + 32], 1.0);
}

#[test]
fn alpha_of_a_moving_sphere_is_the_time_average_of_its_projected_area() {
    // A box shutter open from t = 0 to 0.5 s while the sphere moves from x = -1 to 1 at a
    // depth of 5, and 0.8 below the axis (off the axis its image is an ellipse), inside the
    // view throughout.
    let text = format!(
        "[shot]\nshutter = 0.5\nshutter_position = \"start\"
[output]\nwidth = 64\nheight = 64\npasses = [\"alpha\"]\n[render]\nsamples = 64\nmax_depth = 1\n{CAMERA}
[[sphere]]
center = [-1.0, -0.8, -5.0]
velocity = [4.0, 0.0, 0.0]
radius = 0.5
material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}
"
    );
    let s = scene(&text);
    let r = render(&s, 1);
    let sum: f64 = passes(&r)
        .floats("A")
        .unwrap()
        .iter()
        .map(|&a| a as f64)
        .sum();
    let f = Pinhole::new(DVec3::ZERO, -DVec3::Z, 40.0, 64, 64).f;
    let n = 2000;
    let mean_area: f64 = (0..n)
        .map(|i| {
            let t = 0.5 * (i as f64 + 0.5) / n as f64;
            projected_area(DVec3::new(-1.0 + 4.0 * t, -0.8, 5.0), 0.5, f)
        })
        .sum::<f64>()
        / n as f64;
    assert!((sum / mean_area - 1.0).abs() < 0.01, "{sum} {mean_area}");
}

#[test]
fn depth_of_a_huge_sphere_is_the_distance_along_the_view_axis() {
    // A sphere of radius 1e5 whose near surface is the plane z = -3 to within 5e-5 across
    // the view: the depth is 3 at every pixel, where the ray lengths reach 3.2.
    let text = format!(
        "[output]\npath = \"t.exr\"\nwidth = 24\nheight = 16\npasses = [\"depth\", \"alpha\"]\n[render]\nsamples = 4\nmax_depth = 1\n{CAMERA}
[[sphere]]
center = [0.0, 0.0, -100003.0]
radius = 100000.0
material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}
"
    );
    let r = render(&scene(&text), 1);
    let p = passes(&r);
    assert!(p.floats("A").unwrap().iter().all(|&a| a == 1.0));
    for &z in p.floats("Z").unwrap() {
        assert!((z - 3.0).abs() < 1e-4, "{z}");
    }
}

#[test]
fn normals_are_unit_where_covered_and_face_the_camera() {
    let text = format!(
        "[output]\npath = \"t.exr\"\nwidth = 48\nheight = 32\npasses = [\"normal\", \"alpha\", \"depth\"]\n[render]\nsamples = 16\nmax_depth = 1\n{CAMERA}
[[sphere]]
center = [0.3, -0.2, -4.0]
radius = 1.0
material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}
"
    );
    let r = render(&scene(&text), 1);
    let p = passes(&r);
    let cam = Pinhole::new(DVec3::ZERO, -DVec3::Z, 40.0, 48, 32);
    let (a, z) = (p.floats("A").unwrap(), p.floats("Z").unwrap());
    let n = |i: usize| {
        let c = |name| p.floats(name).unwrap()[i] as f64;
        DVec3::new(c("N.X"), c("N.Y"), c("N.Z"))
    };
    let mut covered = 0;
    for i in 0..48 * 32 {
        let (x, y) = ((i % 48) as f64 + 0.5, (i / 48) as f64 + 0.5);
        if a[i] == 1.0 {
            covered += 1;
            assert!((n(i).length() - 1.0).abs() < 0.01, "{}", n(i).length());
            assert!(n(i).dot(-cam.dir(x, y)) > 0.0);
            // Inside the disc: the sphere's normal where the pixel's centre ray hits it.
            let c = DVec3::new(0.3, -0.2, -4.0);
            if let Some(q) = hit(DVec3::ZERO, cam.dir(x, y), c, 1.0, 0.8) {
                assert!((n(i) - (q - c)).length() < 0.01, "{} {}", n(i), q - c);
                assert!((z[i] as f64 + q.z).abs() < 0.01);
            }
        } else if a[i] == 0.0 {
            assert_eq!(n(i), DVec3::ZERO);
            assert_eq!(z[i], 1e10);
        }
    }
    assert!(covered > 100);
}

/// The motion pass of a one-sphere scene against the projection of the sphere's and camera's
/// motion computed here: for every pixel whose centre ray hits well inside the sphere, the
/// point hit, carried by `centre_at(t +- 1/fps) - centre_at(t)`, projected through `camera_at`
/// those times, less its projection now (v upward). Returns (forward, backward) pairs,
/// (measured, expected).
#[allow(clippy::type_complexity)]
fn motion_against(
    text: &str,
    t: f64,
    fps: f64,
    radius: f64,
    centre_at: impl Fn(f64) -> DVec3,
    camera_at: impl Fn(f64) -> Pinhole,
) -> Vec<((DVec2, DVec2), (DVec2, DVec2))> {
    let r = render(&scene(text), 1);
    let p = passes(&r);
    let (w, h) = (p.width() as usize, p.height() as usize);
    let ch = |name, i| p.floats(name).unwrap()[i] as f64;
    let cam = camera_at(t);
    let mut out = Vec::new();
    for i in 0..w * h {
        let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
        let Some(q) = hit(cam.from, cam.dir(x, y), centre_at(t), radius, 0.8) else {
            continue;
        };
        assert_eq!(p.floats("A").unwrap()[i], 1.0);
        let here = cam.project(q);
        let moved = |dt: f64| {
            let q2 = q + centre_at(t + dt) - centre_at(t);
            let d = camera_at(t + dt).project(q2) - here;
            DVec2::new(d.x, -d.y)
        };
        let measured = (
            DVec2::new(ch("forward.u", i), ch("forward.v", i)),
            DVec2::new(ch("backward.u", i), ch("backward.v", i)),
        );
        out.push((measured, (moved(1.0 / fps), moved(-1.0 / fps))));
    }
    assert!(out.len() > 50, "{} pixels inside the sphere", out.len());
    out
}

fn assert_close(measured: DVec2, expected: DVec2, relative: f64) {
    assert!(
        (measured - expected).length() <= relative * expected.length() + 1e-3,
        "measured {measured}, expected {expected}"
    );
}

const MOTION: &str = "[output]\npath = \"t.exr\"\nwidth = 48\nheight = 32\npasses = [\"motion\", \"alpha\"]\n[render]\nsamples = 16\nmax_depth = 1\n";

#[test]
fn motion_of_a_sphere_with_a_velocity_is_its_velocity_over_fps_projected() {
    // A still camera, no shutter (the motion is still there), a sphere moving sideways and
    // away at (3, 1, -2) units a second, 24 fps, at frame 1 (t = 0.25 s).
    let text = format!(
        "[shot]\nfps = 24.0\nshutter = 0.0\nstart_time = 0.25\n{MOTION}{CAMERA}
[[sphere]]
center = [-0.75, -0.25, -4.5]
velocity = [3.0, 1.0, -2.0]
radius = 1.0
material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}
"
    );
    let c = |t: f64| DVec3::new(-0.75, -0.25, -4.5) + t * DVec3::new(3.0, 1.0, -2.0);
    let cam = |_| Pinhole::new(DVec3::ZERO, -DVec3::Z, 40.0, 48, 32);
    for ((forward, backward), (ef, eb)) in motion_against(&text, 0.25, 24.0, 1.0, c, cam) {
        assert_close(forward, ef, 0.01);
        assert_close(backward, eb, 0.01);
        assert!(forward.length() > 1.0);
    }
    // Sideways only, at constant depth: backward = -forward, and forward = f v / (fps z).
    let text = text.replace("[3.0, 1.0, -2.0]", "[3.0, 0.0, 0.0]");
    let c = |t: f64| DVec3::new(-0.75, -0.25, -4.5) + t * DVec3::new(3.0, 0.0, 0.0);
    let f = cam(0.0).f;
    let r = render(&scene(&text), 1);
    let p = passes(&r);
    for ((forward, backward), (ef, _)) in motion_against(&text, 0.25, 24.0, 1.0, c, cam) {
        assert_close(forward, ef, 0.01);
        assert_close(backward, -forward, 1e-6);
        assert!(forward.y.abs() < 1e-6 && forward.x > 0.0);
    }
    // Against the depth pass: forward.u z = f v / fps, within 1%, where the pixel is covered.
    let (a, u) = (p.floats("A").unwrap(), p.floats("forward.u").unwrap());
    let with_depth = scene(&text.replace("\"motion\", \"alpha\"", "\"depth\""));
    let z = render(&with_depth, 1).image.floats("Z").unwrap().to_vec();
    let mut n = 0;
    for i in 0..a.len() {
        if a[i] == 1.0 {
            n += 1;
            let expected = f * 3.0 / 24.0 / z[i] as f64;
            assert!(
                (u[i] as f64 / expected - 1.0).abs() < 0.01,
                "{} {expected}",
                u[i]
            );
        }
    }
    assert!(n > 50);
}

#[test]
fn motion_on_an_orbit_follows_the_circle_both_ways() {
    // An orbit in a plane facing the camera, 720 degrees a second about (0, 0, -5): one frame
    // at 24 fps is 30 degrees of arc, so forward and backward differ by the circle's bend.
    let text = format!(
        "[shot]\nfps = 24.0\nshutter = 0.0\nstart_time = 0.1\n{MOTION}{CAMERA}
[[sphere]]
center = [1.2, 0.0, -5.0]
orbit = {{ pivot = [0.0, 0.0, -5.0], axis = [0.0, 0.0, 1.0], degrees_per_second = 720.0 }}
radius = 0.7
material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}
"
    );
    let c = |t: f64| {
        let a = (720.0 * t).to_radians();
        DVec3::new(1.2 * a.cos(), 1.2 * a.sin(), -5.0)
    };
    let cam = |_| Pinhole::new(DVec3::ZERO, -DVec3::Z, 40.0, 48, 32);
    for ((forward, backward), (ef, eb)) in motion_against(&text, 0.1, 24.0, 0.7, c, cam) {
        assert_close(forward, ef, 0.01);
        assert_close(backward, eb, 0.01);
        // Not mirror images: their sum is the chord's bend toward the pivot, 2 (1 - cos 30)
        // of the radius, about 0.27 of it.
        let bend = forward + backward;
        assert_close(bend, ef + eb, 0.05);
        assert!(bend.length() > 0.2 * forward.length());
    }
}

#[test]
fn a_still_sphere_under_an_orbiting_camera_gets_the_cameras_motion() {
    // The camera turns about look_at at 240 degrees a second (10 degrees a frame at 24 fps).
    let text = format!(
        "[shot]\nfps = 24.0\nshutter = 0.0\nstart_time = 0.05\n{MOTION}
[camera]
look_from = [0.0, 0.5, 6.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
vfov = 40.0
orbit = {{ degrees_per_second = 240.0 }}
[[sphere]]
center = [0.5, 0.2, 0.0]
radius = 1.0
material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}
"
    );
    let c = |_| DVec3::new(0.5, 0.2, 0.0);
    let cam = |t: f64| {
        // Counter-clockwise about +y (right-hand rule).
        let (s, co) = (240.0 * t).to_radians().sin_cos();
        let from = DVec3::new(6.0 * s, 0.5, 6.0 * co);
        Pinhole::new(from, DVec3::ZERO, 40.0, 48, 32)
    };
    for ((forward, backward), (ef, eb)) in motion_against(&text, 0.05, 24.0, 1.0, c, cam) {
        assert_close(forward, ef, 0.01);
        assert_close(backward, eb, 0.01);
        assert!(forward.length() > 1.0);
    }
}

#[test]
fn variance_matches_the_spread_between_seeds() {
    let text = format!(
        "[output]\npath = \"t.exr\"\nwidth = 48\nheight = 32\npasses = [\"variance\"]\n[render]\nsamples = 8\nmax_depth = 4\nsampler = \"independent\"\n{CAMERA}
[[sphere]]
center = [0.0, 0.0, -4.0]
radius = 1.0
material = {{ type = \"lambertian\", albedo = [0.7, 0.5, 0.3] }}
[[sphere]]
center = [0.0, -101.0, -4.0]
radius = 100.0
material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}
"
    );
    let mut s = scene(&text);
    let a = render(&s, 1);
    s.render.seed = 99;
    let b = render(&s, 1);
    let mut spread = 0.0;
    let mut estimated = 0.0;
    let va = passes(&a);
    for (i, (pa, pb)) in a.film.means().iter().zip(b.film.means()).enumerate() {
        let d = *pa - pb;
        // E[(a - b)^2] = 2 Var(mean) for independent renders.
        spread += (d * d).element_sum() / 2.0;
        estimated += ["variance.R", "variance.G", "variance.B"]
            .iter()
            .map(|c| va.floats(c).unwrap()[i] as f64)
            .sum::<f64>();
    }
    assert!(estimated > 0.0);
    assert!(
        (estimated / spread - 1.0).abs() < 0.1,
        "{estimated} {spread}"
    );
}

/// A scene with everything moving: a velocity, an orbit, keyframes, an orbiting camera with a
/// lens, glass and metal.
fn busy(passes: &str, extra: &str) -> String {
    format!(
        r#"[shot]
fps = 24.0
shutter_angle = 180.0
[output]
path = "t.exr"
width = 40
height = 24
passes = {passes}
[render]
samples = 8
max_depth = 6
{extra}
[camera]
look_from = [0.0, 1.0, 6.0]
look_at = [0.0, 0.0, 0.0]
vfov = 40.0
aperture = 0.2
orbit = {{ degrees_per_second = 30.0 }}
[[sphere]]
center = [0.0, -100.5, 0.0]
radius = 100.0
material = {{ type = "lambertian", albedo = [0.5, 0.5, 0.5] }}
[[sphere]]
center = [-1.0, 0.0, 0.0]
velocity = [2.0, 0.5, 0.0]
radius = 0.5
material = {{ type = "dielectric", ior = 1.5 }}
[[sphere]]
center = [1.0, 0.0, 0.0]
orbit = {{ pivot = [0.0, 0.0, 0.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 400.0 }}
radius = 0.4
material = {{ type = "metal", albedo = [0.8, 0.6, 0.2], fuzz = 0.3 }}
[[sphere]]
keyframes = [{{ time = 0.0, center = [0.0, 1.0, -1.0] }}, {{ time = 1.0, center = [0.0, 2.0, 1.0] }}]
radius = 0.3
material = {{ type = "lambertian", albedo = [0.2, 0.8, 0.2] }}
"#
    )
}

const ALL: &str = r#"["alpha", "depth", "normal", "albedo", "motion", "variance"]"#;

fn bits(r: &FrameResult) -> (Vec<u64>, Vec<Vec<u32>>) {
    let colour = r
        .film
        .means()
        .iter()
        .flat_map(|p| p.to_array().map(f64::to_bits))
        .collect();
    // The passes' channels: those beside the colour.
    let passes = r
        .image
        .channels()
        .iter()
        .filter(|c| !COLOUR.0.contains(&c.name))
        .map(|c| c.floats().unwrap().iter().map(|v| v.to_bits()).collect())
        .collect();
    (colour, passes)
}

#[test]
fn colour_with_passes_is_the_same_bits_as_without() {
    for sampler in ["sobol", "independent"] {
        let extra = format!("sampler = \"{sampler}\"");
        let without = render(&scene(&busy("[]", &extra)), 3);
        let with = render(&scene(&busy(ALL, &extra)), 3);
        assert_eq!(without.image.channels().len(), 3, "the colour alone");
        assert_eq!(bits(&with).0, bits(&without).0);
        assert_eq!(with.film.all_pixels(), without.film.all_pixels());
    }
}

/// Asserts that frame 2 of `s` is the same bits, colour and passes, on one thread and on
/// three after frame 1 (as in a range), and in passes of 1, 1, 2, 4 samples under a budget
/// that stops at 8 (the scene's samples); returns it.
fn same_bits_across_threads_ranges_and_budgets(s: &Scene) -> FrameResult {
    let statics = CpuShot::new(s);
    let pool = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
    };
    let one = pool(1).install(|| FrameJob::new(s, 2).sample(&statics).unwrap());
    let three = pool(3).install(|| {
        FrameJob::new(s, 1).sample(&statics).unwrap();
        FrameJob::new(s, 2).sample(&statics).unwrap()
    });
    assert_eq!(bits(&one), bits(&three));
    let budget = Budget {
        noise_threshold: Some(1e-12),
        max_samples: Some(8),
        ..Budget::default()
    };
    let budgeted = FrameJob::new(s, 2).budget(budget).sample(&statics).unwrap();
    assert_eq!(budgeted.stats.rounds, 4);
    assert_eq!(bits(&budgeted), bits(&one));
    one
}

#[test]
fn passes_are_the_same_bits_across_threads_ranges_and_budgets() {
    same_bits_across_threads_ranges_and_budgets(&scene(&busy(ALL, "")));
}

#[test]
fn a_transparent_background_adds_black_where_camera_rays_miss_and_lights_the_rest() {
    let text = |transparent: bool| {
        format!(
            "[output]\npath = \"t.exr\"\nwidth = 32\nheight = 24\npasses = [\"alpha\", \"albedo\"]\n[render]\nsamples = 8\n{CAMERA}
[background]\ncolor = [0.5, 0.6, 0.7]\ntransparent = {transparent}
[[sphere]]
center = [0.0, 0.0, -4.0]
radius = 1.0
material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}
"
        )
    };
    let opaque = render(&scene(&text(false)), 1);
    let clear = render(&scene(&text(true)), 1);
    let alpha = passes(&clear).floats("A").unwrap().to_vec();
    let albedo = passes(&clear).floats("albedo.B").unwrap().to_vec();
    let (mut inside, mut outside) = (0, 0);
    for (i, &a) in alpha.iter().enumerate() {
        let (c, o) = (clear.film.means()[i], opaque.film.means()[i]);
        if a == 0.0 {
            outside += 1;
            assert_eq!(c, DVec3::ZERO);
            assert!((o - DVec3::new(0.5, 0.6, 0.7)).abs().max_element() < 1e-12);
            // The albedo of a miss is still the background's radiance.
            assert!((albedo[i] - 0.7).abs() < 1e-6);
        } else if a == 1.0 {
            // Every camera ray hit: the background lit the sphere through scattered rays.
            inside += 1;
            assert!(c.min_element() > 0.0);
            assert_eq!(c, o);
        }
    }
    assert!(inside > 20 && outside > 200);
}

// ---- Files ----

fn write_scene(dir: &Path, text: &str) -> std::path::PathBuf {
    let path = dir.join("s.toml");
    std::fs::write(&path, text).unwrap();
    path
}

const SMALL: &str = r#"[output]
path = "s_####.exr"
width = 16
height = 12
[render]
samples = 4
[camera]
look_from = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
vfov = 40.0
[[sphere]]
center = [0.0, 0.0, -4.0]
velocity = [1.0, 0.0, 0.0]
radius = 1.0
material = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
"#;

const CHANNELS: [&str; 18] = [
    "R",
    "G",
    "B",
    "A",
    "Z",
    "N.X",
    "N.Y",
    "N.Z",
    "albedo.R",
    "albedo.G",
    "albedo.B",
    "forward.u",
    "forward.v",
    "backward.u",
    "backward.v",
    "variance.R",
    "variance.G",
    "variance.B",
];

#[test]
fn exr_frames_hold_the_passes_channels_by_name_and_type() {
    let dir = tempfile::tempdir().unwrap();
    write_scene(dir.path(), SMALL);
    run_ok(
        dir.path(),
        &[
            "render",
            "-q",
            "--passes",
            "alpha,depth,normal,albedo,motion,variance",
            "s.toml",
            "-o",
            "o_####.exr",
        ],
    );
    let path = dir.path().join("o_0001.exr");
    let image = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    assert_eq!(image.layer_data.len(), 1);
    let channels = &image.layer_data[0].channel_data.list;
    let mut names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
    names.sort();
    let mut expected: Vec<String> = CHANNELS.iter().map(|s| s.to_string()).collect();
    expected.sort();
    assert_eq!(names, expected);
    for c in channels {
        let half = matches!(c.sample_data, exr::prelude::FlatSamples::F16(_));
        let name = c.name.to_string();
        let should = name == "A" || name.starts_with("N.") || name.starts_with("albedo.");
        assert_eq!(half, should, "{name}");
    }
    // The colour is the same as written without passes.
    let plain = dir.path().join("p.exr");
    run_ok(dir.path(), &["render", "-q", "s.toml", "-o", "p.exr"]);
    assert_eq!(
        raytrace_io::read_exr_colour(&plain).unwrap(),
        raytrace_io::read_exr_colour(&path).unwrap()
    );

    // OpenImageIO lists the channels by name.
    if Command::new("oiiotool").arg("--help").output().is_err() {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "oiiotool is missing (Debian: openimageio-tools; .ci/run installs it as root)"
        );
        eprintln!("note: oiiotool is not installed; the OpenImageIO check was skipped");
        return;
    }
    let info = Command::new("oiiotool")
        .args(["--info", "-v"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(info.status.success());
    let text = String::from_utf8_lossy(&info.stdout);
    let line = text
        .lines()
        .find(|l| l.contains("channel list:"))
        .unwrap_or_else(|| panic!("no channel list in\n{text}"));
    let listed: Vec<&str> = line
        .split_once(':')
        .unwrap()
        .1
        .split(',')
        .map(|c| c.trim().split(' ').next().unwrap())
        .collect();
    let mut listed_sorted = listed.clone();
    listed_sorted.sort();
    let mut expected: Vec<&str> = CHANNELS.to_vec();
    expected.sort();
    assert_eq!(listed_sorted, expected, "{line}");
    assert!(
        line.contains("A (half)") && line.contains("Z (float)"),
        "{line}"
    );
}

#[test]
fn png_frames_take_alpha_as_straight_rgba() {
    let dir = tempfile::tempdir().unwrap();
    let text = SMALL.replace("velocity = [1.0, 0.0, 0.0]\n", "")
        + "[background]\ncolor = [0.2, 0.2, 0.2]\ntransparent = true\n";
    write_scene(dir.path(), &text);
    for (out, passes) in [("a.png", "alpha"), ("a.exr", "alpha")] {
        run_ok(
            dir.path(),
            &["render", "-q", "--passes", passes, "s.toml", "-o", out],
        );
    }
    let png = image::open(dir.path().join("a.png")).unwrap();
    let rgba = png.as_rgba8().expect("an RGBA PNG");
    let layer = exr::prelude::read_all_flat_layers_from_file(dir.path().join("a.exr")).unwrap();
    let list = &layer.layer_data[0].channel_data.list;
    let get = |name: &str| -> Vec<f32> {
        let c = list.iter().find(|c| c.name.to_string() == name).unwrap();
        c.sample_data.values_as_f32().collect()
    };
    let (a, r) = (get("A"), get("R"));
    let (mut partial, mut empty) = (0, 0);
    for (i, p) in rgba.pixels().enumerate() {
        assert_eq!(p.0[3], (a[i].clamp(0.0, 1.0) * 255.0 + 0.5).floor() as u8);
        if a[i] == 0.0 {
            empty += 1;
            assert_eq!(p.0, [0, 0, 0, 0]);
        } else {
            // Straight: the premultiplied colour over its alpha.
            assert_eq!(p.0[0], raytrace_io::linear_to_srgb8(r[i] / a[i]));
            if a[i] < 1.0 {
                partial += 1;
            }
        }
    }
    assert!(partial > 0 && empty > 0);
}

#[test]
fn bad_passes_are_refused_by_name_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &[&str], &str); 5] = [
        (
            "[output]\npath = \"o.exr\"\npasses = [\"alpha\", \"beauty\"]\n",
            &[],
            "s.toml:3:20",
        ),
        (
            "[output]\npath = \"o.exr\"\npasses = [\"depth\", \"alpha\", \"depth\"]\n",
            &[],
            "output.passes: \"depth\" is listed twice",
        ),
        (
            "[output]\npath = \"o.png\"\npasses = [\"alpha\", \"normal\"]\n",
            &[],
            "output.passes: pass \"normal\" cannot be written to a PNG output",
        ),
        (
            "[output]\npath = \"o.png\"\n",
            &["--passes", "alpha,motion"],
            "--passes: pass \"motion\" cannot be written to a PNG output (output.path ends in .png)",
        ),
        ("", &["--passes", "alpha,zdepth"], "--passes"),
    ];
    for (text, args, message) in cases {
        write_scene(dir.path(), text);
        let out = run(dir.path(), &[&["render", "-q", "s.toml"], args].concat());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(message), "{message:?} not in {stderr}");
        assert!(!stderr.contains("panicked"));
        let files: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(files.len(), 1, "only the scene: {files:?}");
    }
}

#[test]
fn budgets_and_converge_work_with_passes() {
    let dir = tempfile::tempdir().unwrap();
    write_scene(
        dir.path(),
        &SMALL.replace("[output]\n", &format!("[output]\npasses = {ALL}\n")),
    );
    let out = dir.path().join("b.exr");
    run_ok(
        dir.path(),
        &[
            "render",
            "-q",
            "--noise-threshold",
            "0.05",
            "--max-samples",
            "16",
            "s.toml",
            "-o",
            "b.exr",
        ],
    );
    let image = exr::prelude::read_all_flat_layers_from_file(&out).unwrap();
    assert_eq!(image.layer_data[0].channel_data.list.len(), 18);
    run_ok(
        dir.path(),
        &[
            "converge",
            "--max-samples",
            "4",
            "--reference-samples",
            "16",
            "s.toml",
            "--csv",
            "c.csv",
        ],
    );
    assert!(dir.path().join("c.csv").exists());
}

#[test]
fn passes_work_with_shutter_curves_and_rolling_shutters() {
    // The busy scene under a trapezoid curve and a rolling shutter: the colour is the same bits
    // with and without passes, and the passes the same bits across threads and under a budget.
    let shutters = |passes: &str| {
        busy(passes, "").replace(
            "shutter_angle = 180.0",
            "shutter_angle = 180.0\nshutter_curve = [[0, 0], [0.2, 1], [0.8, 1], [1, 0]]\n\
             rolling_shutter = { readout = 0.01, direction = \"bottom-to-top\" }",
        )
    };
    let plain = scene(&busy(ALL, ""));
    let s = scene(&shutters(ALL));
    assert!(s.shot.rolling.is_some());
    let with = render(&s, 2);
    let without = render(&scene(&shutters("[]")), 2);
    assert_eq!(bits(&with).0, bits(&without).0);
    // The shutters change the picture and its passes (the test would see a shutter ignored).
    let before = render(&plain, 2);
    assert_ne!(bits(&with).0, bits(&before).0);
    assert_ne!(bits(&with).1, bits(&before).1);
    assert_eq!(
        bits(&same_bits_across_threads_ranges_and_budgets(&s)),
        bits(&with)
    );
}

#[test]
fn check_lists_the_passes_and_a_transparent_background() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), SMALL);
    let check = || ok(dir.path(), &["check", "s.toml"]);
    assert!(!check().contains("passes:"));
    let text = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(
        &scene,
        text.replace("[output]\n", "[output]\npasses = [\"motion\", \"alpha\"]\n")
            + "[background]\ntransparent = true\n",
    )
    .unwrap();
    let out = check();
    assert!(
        out.contains("passes: colour, alpha, motion (transparent background)\n"),
        "{out}"
    );
}
