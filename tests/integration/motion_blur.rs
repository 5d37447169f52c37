//! Motion blur against answers computed independently: a frame with an open shutter is the
//! time average of the instants inside it, and a zero shutter is exactly an instant.

use crate::common;

use common::{block_means, f, render, render_with, scene, v};
use glam::DVec3;
use raytrace_core::motion::Motion;

/// A shot whose spheres move in every supported way, seen by a moving camera.
fn moving_scene(shutter: f64, start_time: f64, samples: u32, camera_orbit: bool) -> String {
    let cam_motion = if camera_orbit {
        "orbit = { degrees_per_second = 40.0 }"
    } else {
        ""
    };
    format!(
        r#"
[shot]
fps = 24.0
frames = 3
first_frame = 1
start_time = {start_time:?}
shutter = {shutter:?}
shutter_position = "start"
[output]
width = 64
height = 48
[render]
samples = {samples}
max_depth = 8
[camera]
look_from = [0.0, 1.0, 6.0]
look_at = [0.0, 0.5, 0.0]
vfov = 40.0
{cam_motion}
[background]
color = [1.0, 1.0, 1.0]
[materials]
red = {{ type = "lambertian", albedo = [0.7, 0.2, 0.1] }}
blue = {{ type = "lambertian", albedo = [0.1, 0.2, 0.7] }}
[[sphere]]
center = [0.0, -100.0, 0.0]
radius = 100.0
material = {{ type = "lambertian", albedo = [0.5, 0.5, 0.5] }}
[[sphere]]
center = [-1.5, 0.5, 0.0]
radius = 0.5
material = "red"
velocity = [30.0, 0.0, 0.0]
[[sphere]]
center = [1.0, 1.5, 0.0]
radius = 0.4
material = "blue"
orbit = {{ pivot = [0.0, 1.5, 0.0], axis = [0.0, 0.0, 1.0], degrees_per_second = 2000.0 }}
[[sphere]]
radius = 0.3
material = {{ type = "metal", albedo = [0.8, 0.8, 0.8], fuzz = 0.2 }}
keyframes = [ {{ time = 0.0, center = [-1.0, 0.3, 1.5] }}, {{ time = 0.05, center = [1.0, 0.3, 1.0] }}, {{ time = 0.1, center = [1.0, 1.3, 1.0] }} ]
"#
    )
}

/// Every path's value lies in [0, 1] (albedos < 1, background 1), so a pixel mean of `n`
/// samples has standard deviation at most 0.5/sqrt(n); a block of `b` pixels at most
/// 0.5/sqrt(n b). Two independent estimates differ by at most 5 of their combined deviations.
fn tolerance(samples_a: u32, samples_b: u32, block_pixels: u32) -> f64 {
    let var = 0.25 / (samples_a * block_pixels) as f64 + 0.25 / (samples_b * block_pixels) as f64;
    5.0 * var.sqrt()
}

fn assert_blur_equals_mean_of_instants(make: impl Fn(f64, f64, u32) -> String, shutter: f64) {
    let blur_samples = 256;
    let instants = 32;
    let per_instant = 8;
    let blurred = render(&scene(&make(shutter, 0.0, blur_samples)), 1);
    // Jittered stratified instants: an unbiased estimate of the same time integral.
    let mut rng = raytrace_core::rng::Pcg32::new(77, 1);
    let mut average = vec![DVec3::ZERO; blurred.means().len()];
    for k in 0..instants {
        let t = shutter * (k as f64 + rng.next_f64()) / instants as f64;
        let still = render_with(
            &scene(&make(0.0, t, per_instant)),
            1,
            per_instant,
            1000 + k as u64,
        );
        for (a, p) in average.iter_mut().zip(still.means()) {
            *a += p / instants as f64;
        }
    }
    let w = blurred.width;
    let avg_film =
        raytrace_core::film::Film::from_fn(w, blurred.height, |x, y| average[(y * w + x) as usize]);
    let block = 8;
    let tol = tolerance(blur_samples, instants * per_instant, block * block);
    let a = block_means(&blurred, block);
    let b = block_means(&avg_film, block);
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0, f64::max);
    assert!(
        worst < tol,
        "largest block difference {worst} exceeds {tol}"
    );
    // The test has teeth: the blurred frame differs from the sharp frame at shutter open.
    let sharp = render_with(&scene(&make(0.0, 0.0, blur_samples)), 1, blur_samples, 5);
    let s = block_means(&sharp, block);
    let moved = a
        .iter()
        .zip(&s)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0, f64::max);
    assert!(
        moved > 4.0 * tol,
        "the blur is too small to test anything ({moved})"
    );
}

#[test]
fn motion_blur_is_the_time_average_of_instants() {
    assert_blur_equals_mean_of_instants(|s, t, n| moving_scene(s, t, n, false), 0.1);
}

#[test]
fn camera_motion_blur_is_the_time_average_of_instants() {
    assert_blur_equals_mean_of_instants(|s, t, n| moving_scene(s, t, n, true), 0.1);
}

/// A scene in which a moving sphere behind the camera is seen only in a mirror: if scattered
/// rays did not keep their camera ray's time, the reflection would not be the time average.
fn mirror_scene(shutter: f64, start_time: f64, samples: u32) -> String {
    format!(
        r#"
[shot]
start_time = {start_time:?}
shutter = {shutter:?}
shutter_position = "start"
[output]
width = 64
height = 48
[render]
samples = {samples}
max_depth = 4
[camera]
look_from = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
vfov = 50.0
[background]
color = [1.0, 1.0, 1.0]
[[sphere]]
center = [0.0, 0.0, -10005.0]
radius = 10000.0
material = {{ type = "metal", albedo = [0.9, 0.9, 0.9], fuzz = 0.0 }}
[[sphere]]
center = [-2.5, 0.0, 3.0]
radius = 1.5
material = {{ type = "lambertian", albedo = [0.02, 0.03, 0.08] }}
velocity = [30.0, 0.0, 0.0]
"#
    )
}

#[test]
fn reflections_of_moving_spheres_are_blurred_like_the_spheres() {
    assert_blur_equals_mean_of_instants(mirror_scene, 0.1);
}

/// With a zero shutter, a shot of moving spheres and a moving camera is bit-identical to the
/// same shot with everything placed where it is at that instant.
#[test]
fn zero_shutter_equals_the_scene_placed_at_that_instant() {
    for &time in &[0.0, 0.0371, 1.5, 41666.625] {
        let moving = scene(&moving_scene(0.0, time, 16, true));
        let mut placed = String::from(&moving_scene(0.0, time, 16, false)[..]);
        // Replace the motion of each sphere by its position at `time`.
        let cut = placed.find("[[sphere]]").unwrap();
        placed.truncate(cut);
        let from = moving.camera.look_from.at(time);
        placed = placed.replace(
            "look_from = [0.0, 1.0, 6.0]",
            &format!("look_from = {}", v(from)),
        );
        for s in &moving.spheres {
            let c = s.motion.at(time);
            let m = moving.materials[s.material as usize];
            let mat = match m {
                raytrace_core::material::Material::Lambertian { albedo } => {
                    format!("{{ type = \"lambertian\", albedo = {} }}", v(albedo))
                }
                raytrace_core::material::Material::Metal { albedo, fuzz } => {
                    format!(
                        "{{ type = \"metal\", albedo = {}, fuzz = {} }}",
                        v(albedo),
                        f(fuzz)
                    )
                }
                raytrace_core::material::Material::Dielectric { ior } => {
                    format!("{{ type = \"dielectric\", ior = {} }}", f(ior))
                }
            };
            placed.push_str(&format!(
                "[[sphere]]\ncenter = {}\nradius = {}\nmaterial = {mat}\n",
                v(c),
                f(s.radius)
            ));
        }
        let placed = scene(&placed);
        assert!(
            placed
                .spheres
                .iter()
                .all(|s| matches!(s.motion, Motion::Still(_)))
        );
        let a = render(&moving, 1);
        let b = render(&placed, 1);
        assert!(
            a.means() == b.means(),
            "zero shutter at t = {time} differs from the placed scene"
        );
    }
}

#[test]
fn different_frames_get_different_noise_and_same_frames_repeat() {
    // A static scene: frames differ only by their noise.
    let text = moving_scene(0.0, 0.0, 4, false).replace("velocity = [30.0, 0.0, 0.0]", "");
    let s = scene(&text);
    let a = render(&s, 1);
    let b = render(&s, 2);
    assert!(a.means() != b.means());
    assert!(render(&s, 1).means() == a.means());
}

#[test]
fn thread_count_does_not_change_a_frame() {
    let s = scene(&moving_scene(0.1, 0.0, 8, true));
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| render(&s, 2));
    let three = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| render(&s, 2));
    assert!(one.means() == three.means());
}
