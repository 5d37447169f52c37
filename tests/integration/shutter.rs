//! Shutter curves and the rolling shutter against answers computed independently: a streak's
//! profile is the curve convolved with the sphere's disc, a moving pole leans by its speed
//! times the readout, boxes hold every sphere over the whole exposure, and a still scene or a
//! box curve changes nothing.

use crate::common;

use common::{
    exr_attribute, exr_bits_and_attributes, exr_channels, exr_number, f, matches_plain_renders,
    render, run_ok, scene,
};
use exr::meta::attribute::{AttributeValue, Text};
use glam::DVec3;
use raytrace_core::bvh::TraversalStack;
use raytrace_core::film::Film;
use raytrace_core::ray::Ray;
use raytrace_core::rng::Pcg32;
use raytrace_core::scene::Scene;
use raytrace_core::world::{StaticGeometry, World, nearest_by_testing_every_sphere};

/// Distance from the camera to the plane the spheres move in.
const DEPTH: f64 = 10.0;
/// World units per pixel at that distance.
const PIXEL: f64 = 0.05;

/// The vertical field of view, in degrees, that makes pixels `PIXEL` wide at `DEPTH` in an
/// image `height` pixels high.
fn vfov(height: u32) -> f64 {
    2.0 * (0.5 * height as f64 * PIXEL / DEPTH).atan().to_degrees()
}

/// A shot of one frame, shutter open over [0, `shutter`] (or the whole exposure centred on 0
/// with a rolling shutter), a pinhole looking down -z from the origin at a white background,
/// with black spheres: a pixel's value is the fraction of its samples that miss every sphere.
fn shot(shot_keys: &str, width: u32, height: u32, samples: u32, sampler: &str) -> String {
    format!(
        r#"
[shot]
fps = 1.0
frames = 1
first_frame = 0
{shot_keys}
[output]
width = {width}
height = {height}
[render]
samples = {samples}
max_depth = 4
sampler = "{sampler}"
[camera]
look_from = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
vfov = {}
[background]
color = [1.0, 1.0, 1.0]
[materials]
black = {{ type = "lambertian", albedo = [0.0, 0.0, 0.0] }}
"#,
        f(vfov(height))
    )
}

/// A black sphere at `center` moving with `velocity`.
fn sphere(center: DVec3, radius: f64, velocity: DVec3) -> String {
    format!(
        "[[sphere]]\ncenter = {}\nradius = {}\nmaterial = \"black\"\nvelocity = {}\n",
        common::v(center),
        f(radius),
        common::v(velocity)
    )
}

/// Darkness (1 - value) of every pixel, row-major.
fn darkness(film: &Film) -> Vec<f64> {
    film.means().iter().map(|p| 1.0 - p.x).collect()
}

/// The streak scene: a sphere of radius 4 pixels crossing 64 pixels at constant image speed
/// while the shutter is open over [0, 1].
const STREAK_W: u32 = 128;
const STREAK_H: u32 = 12;
const STREAK_RADIUS: f64 = 4.0 * PIXEL;
const STREAK_FROM: f64 = -32.0 * PIXEL;
const STREAK_SPEED: f64 = 64.0 * PIXEL;

fn streak_scene(curve: &str, samples: u32) -> Scene {
    let keys = format!("shutter = 1.0\nshutter_position = \"start\"\nshutter_curve = {curve}");
    let text = shot(&keys, STREAK_W, STREAK_H, samples, "sobol")
        + &sphere(
            DVec3::new(STREAK_FROM, 0.0, -DEPTH),
            STREAK_RADIUS,
            DVec3::new(STREAK_SPEED, 0.0, 0.0),
        );
    scene(&text)
}

/// The expected column profile of the streak under the curve with weights `w` (a
/// piecewise-linear function of the shutter position): the sum over a column's pixels of the
/// fraction of the shutter, weighted by `w`, during which the ray through each point of the
/// pixel meets the sphere. Computed by quadrature (midpoints in time and in each pixel), with
/// the sphere's centre placed by hand and a ray-to-centre distance test, not by the renderer.
fn expected_profile(scene: &Scene, w: &dyn Fn(f64) -> f64) -> Vec<f64> {
    let view = scene.camera.view_at(0.0, STREAK_W, STREAK_H);
    let times = 400;
    let weights: Vec<f64> = (0..times)
        .map(|k| w((k as f64 + 0.5) / times as f64))
        .collect();
    let total: f64 = weights.iter().sum();
    let (sub_x, sub_y) = (4, 8);
    let mut profile = vec![0.0; STREAK_W as usize];
    for (x, column) in profile.iter_mut().enumerate() {
        for y in 0..STREAK_H {
            for i in 0..sub_x {
                for j in 0..sub_y {
                    let jitter = (
                        (i as f64 + 0.5) / sub_x as f64,
                        (j as f64 + 0.5) / sub_y as f64,
                    );
                    let ray = view.ray(x as u32, y, jitter, (0.5, 0.5), 0.0);
                    let mut covered = 0.0;
                    for (k, weight) in weights.iter().enumerate() {
                        let s = (k as f64 + 0.5) / times as f64;
                        let c = DVec3::new(STREAK_FROM + STREAK_SPEED * s, 0.0, -DEPTH);
                        let along = (c - ray.origin).dot(ray.dir);
                        if (c - ray.origin - along * ray.dir).length() < STREAK_RADIUS {
                            covered += weight;
                        }
                    }
                    *column += covered / total / (sub_x * sub_y) as f64;
                }
            }
        }
    }
    profile
}

/// Sums over the columns of `film`'s darkness.
fn column_profile(film: &Film) -> Vec<f64> {
    let d = darkness(film);
    (0..film.width as usize)
        .map(|x| {
            (0..film.height as usize)
                .map(|y| d[y * film.width as usize + x])
                .sum()
        })
        .collect()
}

/// The largest difference between two profiles averaged over runs of 4 columns.
fn largest_block_difference(a: &[f64], b: &[f64]) -> f64 {
    a.chunks(4)
        .zip(b.chunks(4))
        .map(|(x, y)| (x.iter().sum::<f64>() - y.iter().sum::<f64>()).abs() / 4.0)
        .fold(0.0, f64::max)
}

/// A frame rendered by one of the tracers: `render` (the CPU's) or the GPU's.
type Render<'a> = &'a dyn Fn(&Scene, u32) -> Film;

#[test]
fn streaks_have_the_shape_of_the_shutter_curve() {
    streaks(&render, 1024);
}

#[test]
fn streaks_have_the_shape_of_the_shutter_curve_on_the_gpu() {
    let Some(gpu) = common::gpu() else { return };
    streaks(&|s, f| common::render_gpu(gpu, s, f), 1024);
}

/// The streaks of the three curves, rendered with `samples` samples, against their profiles.
fn streaks(render: Render, samples: u32) {
    // A pixel's value is the mean of `samples` values that are each 0 or 1: its deviation is
    // at most 0.5 / sqrt(samples); a column's sum of 12 such, averaged over 4 columns, at most
    // sqrt(12 / 4) 0.5 / sqrt(samples) = 0.027 at 1024 samples. Five of those bound the
    // difference.
    let tolerance = 5.0 * (STREAK_H as f64 / 4.0).sqrt() * 0.5 / (samples as f64).sqrt();
    let trapezoid = |s: f64| (s / 0.2).min(1.0).min((1.0 - s) / 0.2);
    let curves: [(&str, &dyn Fn(f64) -> f64); 3] = [
        ("\"box\"", &|_| 1.0),
        ("\"triangle\"", &|s: f64| 1.0 - (2.0 * s - 1.0).abs()),
        ("[[0, 0], [0.2, 1], [0.8, 1], [1, 0]]", &trapezoid),
    ];
    let mut rendered = vec![];
    let mut expected = vec![];
    for (curve, w) in curves {
        let scene = streak_scene(curve, samples);
        let got = column_profile(&render(&scene, 0));
        let want = expected_profile(&scene, w);
        let worst = largest_block_difference(&got, &want);
        assert!(
            worst < tolerance,
            "{curve}: largest difference {worst} > {tolerance}\ngot  {got:.3?}\nwant {want:.3?}"
        );
        // The whole streak is there: its darkness integrates to the disc's area in pixels.
        let area: f64 = got.iter().sum();
        let disc = std::f64::consts::PI * 16.0;
        assert!((area - disc).abs() < 0.02 * disc, "{curve}: {area}");
        rendered.push(got);
        expected.push(want);
    }
    // The test tells the shapes apart: each expected profile is far from the others'.
    for (i, got) in rendered.iter().enumerate() {
        for (j, other) in expected.iter().enumerate() {
            if i != j {
                let apart = largest_block_difference(got, other);
                assert!(apart > 3.0 * tolerance, "{i} vs {j}: {apart}");
            }
        }
    }
    // Box: flat across the middle of the streak; triangle: nearly twice as dark in the middle
    // as a quarter of the way in (its weight there is half; the disc blunts the peak).
    let mid = |p: &[f64], x: usize| p[x - 2..x + 2].iter().sum::<f64>() / 4.0;
    let (centre, quarter) = (STREAK_W as usize / 2, STREAK_W as usize / 2 - 16);
    assert!((mid(&expected[0], centre) / mid(&expected[0], quarter) - 1.0).abs() < 0.01);
    let peak = mid(&rendered[1], centre) / mid(&rendered[1], quarter);
    assert!((1.8..2.0).contains(&peak), "{peak}");
}

/// The pole scene: a column of small spheres at x = 0 (at time 0) from the top of the image
/// to the bottom, moving right at `speed`.
const POLE_W: u32 = 64;
const POLE_H: u32 = 48;

fn pole_scene(shot_keys: &str, speed: f64, sampler: &str) -> Scene {
    let mut text = shot(shot_keys, POLE_W, POLE_H, 16, sampler);
    let half = 0.5 * POLE_H as f64 * PIXEL + 0.2;
    let mut y = -half;
    while y <= half {
        text += &sphere(DVec3::new(0.0, y, -DEPTH), 0.1, DVec3::new(speed, 0.0, 0.0));
        y += 0.1;
    }
    scene(&text)
}

/// The pole's x position (centroid of the darkness, in pixels from the left edge) in each row.
fn pole_positions(film: &Film) -> Vec<f64> {
    let d = darkness(film);
    (0..film.height as usize)
        .map(|y| {
            let row = &d[y * film.width as usize..(y + 1) * film.width as usize];
            let mass: f64 = row.iter().sum();
            row.iter()
                .enumerate()
                .map(|(x, v)| (x as f64 + 0.5) * v)
                .sum::<f64>()
                / mass
        })
        .collect()
}

/// The least-squares slope of `p` against the row index.
fn slope(p: &[f64]) -> f64 {
    let n = p.len() as f64;
    let mx = (n - 1.0) / 2.0;
    let my = p.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, y) in p.iter().enumerate() {
        sxy += (i as f64 - mx) * (y - my);
        sxx += (i as f64 - mx).powi(2);
    }
    sxy / sxx
}

#[test]
fn a_rolling_shutter_leans_a_moving_pole_by_speed_times_readout() {
    leans(&render);
}

#[test]
fn a_rolling_shutter_leans_a_moving_pole_by_speed_times_readout_on_the_gpu() {
    let Some(gpu) = common::gpu() else { return };
    leans(&|s, f| common::render_gpu(gpu, s, f));
}

fn leans(render: Render) {
    // Speed 100 units/s, readout 0.01 s: the bottom row sees the pole 1 unit (20 pixels)
    // farther right than the top row; the whole exposure is centred on time 0, where the pole
    // is at the image's centre.
    let (speed, readout) = (100.0, 0.01);
    let want = speed * readout / PIXEL;
    for sampler in ["independent", "sobol"] {
        for (direction, sign) in [("top-to-bottom", 1.0), ("bottom-to-top", -1.0)] {
            let keys = format!(
                "shutter = 0.0\nrolling_shutter = {{ readout = {readout}, direction = \"{direction}\" }}"
            );
            let p = pole_positions(&render(&pole_scene(&keys, speed, sampler), 0));
            let lean = slope(&p) * POLE_H as f64;
            assert!(
                (lean - sign * want).abs() < 0.02 * want,
                "{sampler} {direction}: bottom minus top {lean} px, want {} px\n{p:.2?}",
                sign * want
            );
            // Centred: the middle row sees the pole at the image's centre.
            let middle = (p[23] + p[24]) / 2.0;
            assert!((middle - 32.0).abs() < 0.3, "{middle}");
        }
        // A global shutter of zero length: upright.
        let p = pole_positions(&render(&pole_scene("shutter = 0.0", speed, sampler), 0));
        assert!((slope(&p) * POLE_H as f64).abs() < 0.2, "{p:?}");
    }
}

/// The pixels of a film as bits.
fn bits(film: &Film) -> Vec<[u64; 3]> {
    film.means()
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect()
}

#[test]
fn a_still_scene_is_unchanged_by_any_shutter_bit_for_bit() {
    unchanged_by_any_shutter(&render);
}

#[test]
fn a_still_scene_is_unchanged_by_any_shutter_bit_for_bit_on_the_gpu() {
    let Some(gpu) = common::gpu() else { return };
    unchanged_by_any_shutter(&|s, f| common::render_gpu(gpu, s, f));
}

fn unchanged_by_any_shutter(render: Render) {
    for sampler in ["independent", "sobol"] {
        let plain = bits(&render(&pole_scene("shutter = 0.02", 0.0, sampler), 0));
        for keys in [
            "shutter = 0.02\nrolling_shutter = { readout = 0.03 }",
            "shutter = 0.0\nrolling_shutter = { readout = 0.03, direction = \"bottom-to-top\" }",
            "shutter = 0.02\nshutter_curve = \"triangle\"\nrolling_shutter = { readout = 1.0 }",
        ] {
            let other = bits(&render(&pole_scene(keys, 0.0, sampler), 0));
            assert!(other == plain, "{sampler}: {keys}");
        }
        // Teeth: the same shutters change a moving pole.
        let moving = |keys: &str| bits(&render(&pole_scene(keys, 30.0, sampler), 0));
        assert!(
            moving("shutter = 0.02")
                != moving("shutter = 0.02\nrolling_shutter = { readout = 0.03 }")
        );
    }
}

#[test]
fn a_box_curve_and_no_readout_render_as_without_them_bit_for_bit() {
    box_curve_changes_nothing(&render);
}

#[test]
fn a_box_curve_and_no_readout_render_as_without_them_bit_for_bit_on_the_gpu() {
    let Some(gpu) = common::gpu() else { return };
    box_curve_changes_nothing(&|s, f| common::render_gpu(gpu, s, f));
}

fn box_curve_changes_nothing(render: Render) {
    for sampler in ["independent", "sobol"] {
        let base = "shutter = 0.02";
        let plain = bits(&render(&pole_scene(base, 30.0, sampler), 0));
        for extra in [
            "shutter_curve = \"box\"",
            "shutter_curve = [[0, 2], [0.5, 2], [1, 2]]",
            "rolling_shutter = { readout = 0.0 }",
        ] {
            let keys = format!("{base}\n{extra}");
            let other = bits(&render(&pole_scene(&keys, 30.0, sampler), 0));
            assert!(other == plain, "{sampler}: {extra}");
        }
        // Teeth: a triangle changes the image.
        let keys = format!("{base}\nshutter_curve = \"triangle\"");
        assert!(bits(&render(&pole_scene(&keys, 30.0, sampler), 0)) != plain);
    }
}

#[test]
fn boxes_hold_fast_spheres_over_a_long_readout() {
    // Fast spheres of every motion kind under a readout ten times the shutter: camera rays
    // at the times the rolling shutter gives their rows find the sphere that testing every
    // sphere finds.
    let keys = "shutter = 0.01\nshutter_curve = \"triangle\"\nrolling_shutter = { readout = 0.1 }";
    let mut spheres = sphere(
        DVec3::new(-1.0, 0.5, -DEPTH),
        0.2,
        DVec3::new(40.0, 0.0, 0.0),
    );
    spheres += &sphere(
        DVec3::new(1.0, -0.5, -DEPTH),
        0.3,
        DVec3::new(-30.0, 5.0, 0.0),
    );
    spheres += "[[sphere]]\ncenter = [0.0, 0.8, -10.0]\nradius = 0.2\nmaterial = \"black\"\norbit = { pivot = [0.0, 0.0, -10.0], axis = [0.0, 0.0, 1.0], degrees_per_second = 3000.0 }\n";
    spheres += "[[sphere]]\nradius = 0.25\nmaterial = \"black\"\nkeyframes = [ { time = -0.06, center = [-1.2, -0.8, -10.0] }, { time = 0.0, center = [1.2, 0.0, -10.0] }, { time = 0.06, center = [-1.2, 0.8, -10.0] } ]\n";
    let scene = scene(&(shot(keys, 64, 48, 1, "sobol") + &spheres));
    let statics = StaticGeometry::new(&scene);
    let whole = scene.shot.interval(0);
    assert!((whole.duration() - 0.11).abs() < 1e-12);
    let times = scene.shot.frame_times(0);
    let view = scene.camera.view_at(0.0, 64, 48);
    let rays: Vec<Ray> = {
        let mut r = Pcg32::new(9, 9);
        (0..20_000)
            .map(|_| {
                let (x, y) = (r.next_f64() * 64.0, r.next_f64() * 48.0);
                let time = times.time(r.next_f64(), y / 48.0);
                let (px, py) = (x.floor(), y.floor());
                view.ray(px as u32, py as u32, (x - px, y - py), (0.5, 0.5), time)
            })
            .collect()
    };
    let disagreements = |world: &World| {
        let mut stack = TraversalStack::default();
        let mut hits = 0;
        let mut wrong = 0;
        for ray in &rays {
            assert!(whole.contains(ray.time));
            let got = world
                .hit(ray, u32::MAX, &mut stack)
                .map(|h| (h.t, h.sphere));
            let want = nearest_by_testing_every_sphere(&scene, ray);
            match (got, want) {
                (Some((t, i)), Some((u, j))) if i == j && (t - u).abs() <= 1e-9 * u => hits += 1,
                (None, None) => {}
                _ => wrong += 1,
            }
        }
        (hits, wrong)
    };
    let (hits, wrong) = disagreements(&World::prepare(&scene, &statics, whole));
    assert_eq!(wrong, 0);
    assert!(hits > 1000, "{hits}");
    // Teeth: boxes for the first row's interval alone clip the spheres later rows see.
    // (the same spheres in a shot whose one frame is exposed over just that interval).
    let first_row = common::scene(
        &(shot(
            "shutter = 0.01\nshutter_position = \"start\"\nstart_time = -0.055",
            64,
            48,
            1,
            "sobol",
        ) + &spheres),
    )
    .shot
    .interval(0);
    assert_eq!(first_row.open, whole.open);
    let (_, clipped) = disagreements(&World::prepare(&scene, &statics, first_row));
    assert!(clipped > 100, "{clipped}");
}

/// A small shot that uses both, as a file.
const BOTH: &str = r#"
[shot]
fps = 24.0
frames = 2
shutter = 0.02
shutter_curve = [[0, 0], [0.2, 1], [0.8, 1], [1, 0]]
rolling_shutter = { readout = 0.01, direction = "bottom-to-top" }
[output]
path = "f_####.exr"
width = 40
height = 24
[render]
samples = 4
max_depth = 10
seed = 5
[camera]
look_from = [0.0, 1.0, 4.0]
look_at = [0.0, 0.5, 0.0]
vfov = 45.0
[[sphere]]
center = [0.0, -100.0, 0.0]
radius = 100.0
material = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
[[sphere]]
center = [0.0, 0.5, 0.0]
radius = 0.5
material = { type = "lambertian", albedo = [0.7, 0.2, 0.1] }
velocity = [20.0, 3.0, 0.0]
"#;

#[test]
fn check_and_the_exr_report_the_whole_exposure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), BOTH).unwrap();
    // Frame 2 at 1/24 s: the exposure of 0.02 + 0.01 s is centred on it.
    let (open, close) = (1.0 / 24.0 - 0.015, 1.0 / 24.0 + 0.015);
    let out = run_ok(d, &["check", "s.toml"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("shutter: curve [[0, 0], [0.2, 1], [0.8, 1], [1, 0]], rolling, readout 0.01 s bottom-to-top, exposure 0.03 s per frame"),
        "{text}"
    );
    let line = text
        .lines()
        .find(|l| l.starts_with("  2: shutter ["))
        .unwrap();
    let inside = &line[line.find('[').unwrap() + 1..line.find(']').unwrap()];
    let (a, b) = inside.split_once(", ").unwrap();
    let (a, b): (f64, f64) = (
        a.parse().unwrap(),
        b.trim_end_matches(" s").parse().unwrap(),
    );
    assert!(
        (a - open).abs() < 1e-15 && (b - close).abs() < 1e-15,
        "{line}"
    );
    run_ok(d, &["render", "s.toml", "--frames", "2"]);
    let (_, attrs) = exr_bits_and_attributes(&d.join("f_0002.exr"));
    assert!((exr_number(&attrs, "shutterOpen") - open).abs() < 1e-15);
    assert!((exr_number(&attrs, "shutterClose") - close).abs() < 1e-15);
    assert_eq!(exr_number(&attrs, "rollingShutterReadout"), 0.01);
    assert_eq!(
        exr_attribute(&attrs, "shutterCurve"),
        Some(AttributeValue::Text(Text::from(
            "[[0, 0], [0.2, 1], [0.8, 1], [1, 0]]"
        )))
    );
}

#[test]
fn budgets_work_with_a_curve_and_a_rolling_shutter() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), BOTH).unwrap();
    for sampler in ["independent", "sobol"] {
        let render = |extra: &[&str]| {
            let mut args = vec!["render", "s.toml", "--frames", "1", "--sampler", sampler];
            args.extend_from_slice(extra);
            run_ok(d, &args)
        };
        for (budget, value, stop) in [
            ("--noise-threshold", "0.05", "noise threshold reached"),
            ("--time-limit", "0.5", "(time limit)"),
        ] {
            let out = render(&[
                budget,
                value,
                "--passes",
                "samples",
                "-o",
                "budget_####.exr",
            ]);
            let stdout = String::from_utf8_lossy(&out.stdout);
            assert!(stdout.contains(stop), "{stdout}");
            let (_, a) = exr_bits_and_attributes(&d.join("budget_0001.exr"));
            assert!(exr_number(&a, "samples") >= 1.0);
            assert_eq!(exr_number(&a, "rollingShutterReadout"), 0.01);
            // Each pixel stopped at its own N samples: the same bits as exactly N samples in
            // one pass.
            let adaptive = exr_channels(&d.join("budget_0001.exr"));
            let counts = matches_plain_renders(&adaptive, |n| {
                render(&["--samples", &n.to_string(), "-o", "plain_####.exr"]);
                exr_channels(&d.join("plain_0001.exr"))
            });
            assert!(!counts.is_empty(), "{sampler} {budget}");
        }
    }
}
