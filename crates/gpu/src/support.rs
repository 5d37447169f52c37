//! What the GPU path renders, and what it refuses before anything is rendered.
//!
//! The GPU traces every feature of the format: the three motions, the camera's motion and
//! lens, shutter positions, curves and rolling shutters, the three materials and both
//! backgrounds, point caches, passes, budgets, with the CPU's integrand, in `f32`: WGSL
//! has no `f64`. An `f32` carries 24 bits, so a coordinate `X` is resolved to about
//! `2^-24 X` (6e-8 of it), where the CPU's `f64` resolves `1.1e-16 X`. Scenes whose numbers
//! `f32` cannot carry faithfully are refused here, when the scene is validated (`check` and
//! `render` exit 2), never rendered differently; docs/gpu.md lists the limits and the
//! stability suite (tests/integration/stability.rs) which of its extreme cases pass on the GPU and which
//! are refused.
//!
//!
//! Point caches (`[[points]]`) are traced on the GPU as on the CPU: each frame's points are
//! uploaded with the frame's words (`super::upload`), so they are paged over bindings like the
//! spheres. Their number is known only once a frame's files are surveyed, so the size limit
//! takes it apart ([`too_large`], with the most points a frame of the shot holds); their
//! coordinates are the files' `f32` values, which the GPU takes as they are.

use super::context::pages_here;
use super::pages::Pages;
use super::shot::mib;
use raytrace_core::motion::Motion;
use raytrace_core::scene::Scene;
use raytrace_core::show::{show, show_approx};
use raytrace_core::shutter::Interval;

/// A sphere's radius must be at least this fraction (2^-13) of its centre's largest
/// coordinate over the shot: an `f32` then places its surface to `2^-24 / 2^-13 = 2^-11` of
/// its radius (0.05%), and a ray leaving it is offset by well under a thousandth of it.
pub(crate) const MIN_RADIUS_FRACTION: f64 = 1.0 / 8192.0;

/// Largest coordinate (and radius) the GPU takes: squares and products of such numbers stay
/// far inside the `f32` range (3.4e38), with room for the slab test's reciprocals.
pub(crate) const MAX_COORDINATE: f64 = 1e15;

/// Smallest radius the GPU takes: its square stays a normal `f32` (above 1.2e-38).
pub(crate) const MIN_RADIUS: f64 = 1e-15;

/// The camera's position, resolved to `2^-24` of its largest coordinate, must be resolved
/// to at least 2^-6 of a pixel's footprint on the plane in focus: the footprint must be at
/// least this fraction (2^-18) of that coordinate.
pub(crate) const CAMERA_FRACTION: f64 = 1.0 / 262_144.0;

/// Smallest angle a pixel may span, in radians (2^-17): 64 times the resolution of an `f32`
/// unit direction (about 2^-23), so the directions of neighbouring pixels stay apart.
pub(crate) const MIN_PIXEL_ANGLE: f64 = 1.0 / 131_072.0;

/// Largest angle an orbit may sweep over a frame's exposure widened by a frame period on
/// each side (where the motion pass looks), in degrees: ten turns. The GPU adds the angle in
/// `f32`, resolved to `2^-24` of it (4e-6 radians at 3600 degrees).
pub(crate) const MAX_SWEEP_DEGREES: f64 = 3600.0;

/// Why the GPU path does not render a scene.
#[derive(Clone, Debug, PartialEq)]
pub enum Unsupported {
    /// A coordinate (of a sphere's path over the shot, or the camera's) or a radius beyond
    /// [`MAX_COORDINATE`]; `what` names it (`sphere[3]`, `camera.look_from`).
    Far { what: String, value: f64 },
    /// A radius below [`MIN_RADIUS`].
    Tiny { sphere: usize, radius: f64 },
    /// A radius below [`MIN_RADIUS_FRACTION`] of the sphere's largest coordinate.
    Small {
        sphere: usize,
        radius: f64,
        coordinate: f64,
    },
    /// A pixel's footprint at the focus distance below [`CAMERA_FRACTION`] of the camera's
    /// largest coordinate.
    FarCamera { coordinate: f64, footprint: f64 },
    /// A pixel spanning less than [`MIN_PIXEL_ANGLE`].
    NarrowView { pixel_angle: f64 },
    /// An orbit sweeping more than [`MAX_SWEEP_DEGREES`] over a frame's widened exposure.
    FastOrbit { what: String, sweep: f64 },
    /// The frame's (or the shot's) words could need more bytes than the pages of the
    /// adapter a render would take hold ([`Pages::bytes`]), with `points` points in a frame
    /// (the most a frame of the shot holds, 0 where the scene has no point caches or they
    /// are not counted yet).
    TooLarge {
        bytes: u64,
        pages: Pages,
        points: u64,
    },
}

/// Why the GPU path does not render `scene`, if it does not: the first limit it passes, in
/// the order of [`Unsupported`]'s kinds (spheres in order, then the camera, then the size of
/// its spheres' words, against the adapter's limits: [`too_large`] without points; its point
/// caches' are counted once their files are surveyed).
pub fn unsupported(scene: &Scene) -> Option<Unsupported> {
    let shot = &scene.shot;
    let period = 1.0 / shot.fps;
    let whole = shot.whole_interval();
    // Every time the GPU evaluates a path at: every frame's exposure, and a frame period
    // beyond it for the motion pass.
    let times = Interval {
        open: whole.open - period,
        close: whole.close + period,
    };
    let sweep_time = shot.exposure() + 2.0 * period;
    for (i, s) in scene.spheres.iter().enumerate() {
        let what = || format!("sphere[{i}]");
        let coordinate = largest_coordinate(&s.motion, times);
        if coordinate.is_nan() || coordinate > MAX_COORDINATE {
            return Some(Unsupported::Far {
                what: what(),
                value: coordinate,
            });
        }
        if s.radius > MAX_COORDINATE {
            return Some(Unsupported::Far {
                what: format!("sphere[{i}].radius"),
                value: s.radius,
            });
        }
        if s.radius < MIN_RADIUS {
            return Some(Unsupported::Tiny {
                sphere: i,
                radius: s.radius,
            });
        }
        if s.radius < MIN_RADIUS_FRACTION * coordinate {
            return Some(Unsupported::Small {
                sphere: i,
                radius: s.radius,
                coordinate,
            });
        }
        if let Some(sweep) = sweep(&s.motion, sweep_time) {
            return Some(Unsupported::FastOrbit {
                what: format!("sphere[{i}].orbit"),
                sweep,
            });
        }
    }
    camera(scene, times, sweep_time).or_else(|| too_large(scene, 0))
}

/// Whether `scene`'s words, with `points` points in a frame (the most a frame of its shot
/// holds), could take more than the pages of the adapter a render would take hold: the GPU's
/// one limit on point caches, checked once their files are surveyed. Only a scene beyond
/// what every device binds (WebGPU's limits, within
/// [`MAX_BINDING_VARIABLE`](super::MAX_BINDING_VARIABLE)) looks for the adapter (once a process).
pub fn too_large(scene: &Scene, points: u64) -> Option<Unsupported> {
    let bytes = buffer_bytes(scene, points);
    if bytes <= Pages::guaranteed().bytes() {
        return None;
    }
    let pages = pages_here();
    (bytes > pages.bytes()).then_some(Unsupported::TooLarge {
        bytes,
        pages,
        points,
    })
}

/// The camera's limits.
fn camera(scene: &Scene, times: Interval, sweep_time: f64) -> Option<Unsupported> {
    let cam = &scene.camera;
    let coordinate = largest_coordinate(&cam.look_from, times);
    for (what, motion) in [
        ("camera.look_from", &cam.look_from),
        ("camera.look_at", &cam.look_at),
    ] {
        let value = largest_coordinate(motion, times);
        if value.is_nan() || value > MAX_COORDINATE {
            return Some(Unsupported::Far {
                what: what.to_string(),
                value,
            });
        }
    }
    let tan = (cam.vfov.to_radians() / 2.0).tan();
    let pixel_angle = 2.0 * tan / scene.output.height as f64;
    if pixel_angle < MIN_PIXEL_ANGLE {
        return Some(Unsupported::NarrowView { pixel_angle });
    }
    let focus = cam
        .focus_distance
        .unwrap_or_else(|| shortest_view(&cam.look_from, &cam.look_at));
    let footprint = pixel_angle * focus;
    if footprint < CAMERA_FRACTION * coordinate {
        return Some(Unsupported::FarCamera {
            coordinate,
            footprint,
        });
    }
    sweep(&cam.look_from, sweep_time).map(|sweep| Unsupported::FastOrbit {
        what: "camera.orbit".to_string(),
        sweep,
    })
}

/// The largest magnitude of a coordinate of `motion`'s positions over `times`.
fn largest_coordinate(motion: &Motion, times: Interval) -> f64 {
    let b = motion.prepare(times).bounds(times, 0.0);
    b.min.abs().max(b.max.abs()).max_element()
}

/// The angle an orbit sweeps in `seconds`, if more than [`MAX_SWEEP_DEGREES`].
fn sweep(motion: &Motion, seconds: f64) -> Option<f64> {
    match motion {
        Motion::Orbit { orbit, .. } => {
            let sweep = orbit.degrees_per_second.abs() * seconds;
            (sweep > MAX_SWEEP_DEGREES).then_some(sweep)
        }
        _ => None,
    }
}

/// The shortest distance from `look_from` to `look_at` over the shot: at each key, and
/// between keys where both move linearly (an orbit keeps the distance).
fn shortest_view(from: &Motion, at: &Motion) -> f64 {
    let mut times = vec![0.0];
    for m in [from, at] {
        if let Motion::Keyframes(keys) = m {
            times.extend(keys.iter().map(|k| k.time));
        }
    }
    times.sort_by(f64::total_cmp);
    let view = |t: f64| at.at(t) - from.at(t);
    let mut shortest = view(times[0]).length();
    for w in times.windows(2) {
        let (_, d) = raytrace_core::camera::shortest_on_segment(view(w[0]), view(w[1]));
        shortest = shortest.min(d);
    }
    shortest
}

/// The most bytes the shot's or one frame's buffer holds (the larger), with `points` points
/// in the frame, counted generously: every sphere's record, a hierarchy of at most two
/// entries a sphere, a motion record for every animated sphere and another for the motion
/// pass, every key twice; every point's record and look, a hierarchy of at most two entries a
/// point (a hierarchy's entries are its nodes' children: each node has two at least, each
/// leaf one primitive at least), a group a `[[points]]` table (its sets share a time) with
/// its padding, a look a material. Where the world prepares every sphere per frame
/// ([`raytrace_core::world::one_hierarchy`]), the still ones too are in the frame's buffer.
pub(super) fn buffer_bytes(scene: &Scene, points: u64) -> u64 {
    use super::layout::{
        ENTRY_WORDS, HEADER_WORDS, KEY_WORDS, LOOK_WORDS, MATERIAL_WORDS, MOTION_WORDS,
        POINT_GROUP_WORDS, POINT_WORDS, SPHERE_WORDS, TABLE_WORDS,
    };
    use raytrace_core::world::one_hierarchy;
    let sphere = (SPHERE_WORDS + 2 * ENTRY_WORDS) as u64;
    let mut shot = TABLE_WORDS as u64 + MATERIAL_WORDS as u64 * scene.materials.len() as u64;
    let mut frame = HEADER_WORDS as u64 + 3 * scene.shot.curve.points().len() as u64;
    for m in [&scene.camera.look_from, &scene.camera.look_at] {
        frame += (MOTION_WORDS + KEY_WORDS * (keys(m) + 2)) as u64;
    }
    let merged = one_hierarchy(scene);
    for s in &scene.spheres {
        if s.motion.is_animated() {
            let record = (MOTION_WORDS + 1 + KEY_WORDS * (keys(&s.motion) + 2)) as u64;
            frame += sphere + 2 * record;
        } else if merged {
            frame += sphere + 1;
        } else {
            shot += sphere;
            frame += 1;
        }
    }
    let point = (POINT_WORDS + LOOK_WORDS + 2 * ENTRY_WORDS) as u64;
    frame += points * point
        + (POINT_GROUP_WORDS + 8) as u64 * scene.points.len() as u64
        + LOOK_WORDS as u64 * scene.materials.len() as u64
        + 8;
    4 * shot.max(frame)
}

/// Bytes a frame of `scene` with `points` points holds for the GPU beyond what the CPU's
/// path holds, counted on the host, where a software device (lavapipe) keeps its buffers and
/// a hardware one its read-back buffers, for a film of `stride` pass sums a pixel (those
/// written and those its finishing reads): the driver's own ([`GPU_FLOOR_BYTES`]); the
/// shot's and the frame's words, as written, as copied for the upload and on the device; the
/// film on the device with its read-back buffers and work entries; each round's per-pixel
/// targets.
pub fn frame_bytes(scene: &Scene, points: u64, stride: usize) -> u64 {
    let pixels = scene.output.width as u64 * scene.output.height as u64;
    GPU_FLOOR_BYTES
        + 3 * buffer_bytes(scene, points)
        + super::device_film::film_bytes(pixels, stride as u32)
        + 4 * pixels
}

/// Resident bytes the GPU path adds to the process whatever the frame: the Vulkan driver and,
/// for a software device, its shader compiler. Measured: the peak of a 48x27 render of a
/// scene without spheres on lavapipe is 142 MiB (the tracer compiled for one page of words,
/// `context::Tracer`; 119.5 MiB before the words were paged), where the CPU path's is 9 MiB.
pub(crate) const GPU_FLOOR_BYTES: u64 = 152 << 20;

/// A motion's keys (0 for other kinds).
fn keys(m: &Motion) -> u32 {
    match m {
        Motion::Keyframes(k) => k.len() as u32,
        _ => 0,
    }
}

/// What is beyond the GPU's limits, in words.
impl std::fmt::Display for Unsupported {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let text = match self {
            Unsupported::Far { what, value } => format!(
                "{what} reaches a coordinate of {}, beyond the {} the GPU takes",
                show_approx(*value),
                show(MAX_COORDINATE)
            ),
            Unsupported::Tiny { sphere, radius } => format!(
                "sphere[{sphere}].radius is {}, below the {} the GPU takes",
                show(*radius),
                show(MIN_RADIUS)
            ),
            Unsupported::Small {
                sphere,
                radius,
                coordinate,
            } => format!(
                "sphere[{sphere}].radius {} is less than {} of its largest coordinate {}, so a 32-bit float would place its surface to worse than 1/2048 of its radius (the GPU takes a radius of at least {})",
                show(*radius),
                show_approx(MIN_RADIUS_FRACTION),
                show_approx(*coordinate),
                show_approx(MIN_RADIUS_FRACTION * coordinate)
            ),
            Unsupported::FarCamera {
                coordinate,
                footprint,
            } => format!(
                "the camera reaches a coordinate of {}, where a 32-bit float resolves it to more than 1/64 of a pixel's footprint at the focus distance ({}; the GPU takes a footprint of at least {} of the coordinate)",
                show_approx(*coordinate),
                show_approx(*footprint),
                show_approx(CAMERA_FRACTION)
            ),
            Unsupported::NarrowView { pixel_angle } => format!(
                "camera.vfov gives pixels {} radians wide, less than the {} the GPU's 32-bit directions resolve to 1/64",
                show_approx(*pixel_angle),
                show_approx(MIN_PIXEL_ANGLE)
            ),
            Unsupported::FastOrbit { what, sweep } => format!(
                "{what} sweeps {} degrees over a frame's exposure and a frame period on each side, more than the {} the GPU takes",
                show_approx(*sweep),
                show(MAX_SWEEP_DEGREES)
            ),
            Unsupported::TooLarge {
                bytes,
                pages,
                points,
            } => format!(
                "its spheres{} could need {} in one of the GPU's two buffers of words, more than the {} this GPU binds for one ({} bindings of {}; the adapter binds at most {} a storage buffer)",
                match points {
                    0 => String::new(),
                    n => format!(" and the {n} points of its largest frame"),
                },
                mib(*bytes),
                mib(pages.bytes()),
                pages.count(),
                mib(4 * pages.page_words() as u64),
                mib(pages.binding())
            ),
        };
        f.write_str(&text)
    }
}

#[cfg(test)]
mod tests {
    use raytrace_scene::scene_file::SceneFile;
    use std::path::Path;

    use super::*;
    use crate::layout::{H_POINT_GROUP_N, H_POINTS, POINT_WORDS, PT_LOOK};
    use crate::upload::{FrameWords, ShotWords};
    use raytrace_core::pass::PassSet;
    use raytrace_core::passes::SumLayout;
    use raytrace_core::points::FramePoints;
    use raytrace_core::prepared::PreparedFrame;
    use raytrace_core::world::{MERGE_LIMIT, StaticGeometry};

    /// A scene of `still` spheres standing still and `moving` moving ones, each on `keys`
    /// keyframes.
    fn scene(still: usize, moving: usize, keys: usize) -> Scene {
        let mut text = String::from(
            "[shot]\nframes = 3\n[output]\npath = \"f_####.exr\"\nwidth = 8\nheight = 8\npasses = [\"motion\"]\n[materials]\nm = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\n",
        );
        for i in 0..still {
            let x = (i % 200) as f64 * 0.1;
            let z = -5.0 - (i / 200) as f64 * 0.1;
            text +=
                &format!("[[sphere]]\ncenter = [{x}, 0.0, {z}]\nradius = 0.04\nmaterial = \"m\"\n");
        }
        for i in 0..moving {
            let x = i as f64 * 0.1;
            let path: Vec<String> = (0..keys)
                .map(|k| {
                    let y = 1.0 + 0.2 * (k % 2) as f64;
                    format!(
                        "{{ time = {}, center = [{x}, {y}, -5.0] }}",
                        k as f64 * 0.01
                    )
                })
                .collect();
            text += &format!(
                "[[sphere]]\nradius = 0.04\nmaterial = \"m\"\nkeyframes = [{}]\n",
                path.join(", ")
            );
        }
        Scene::parse(&text, Path::new("s.toml")).unwrap()
    }

    #[test]
    fn the_buffers_are_never_larger_than_counted() {
        // Still scenes, small scenes whose every sphere is in the frame's hierarchy (one of
        // them with a path of many keys, which the frame's buffer holds besides the still
        // spheres), a larger one whose still spheres stay in the shot's buffer, and a larger
        // one, mostly animated, whose every sphere the world prepares per frame.
        let limit = MERGE_LIMIT;
        for (still, moving, keys) in [
            (0, 0, 0),
            (300, 0, 0),
            (0, 40, 3),
            (300, 5, 3),
            (limit - 1, 1, 20_000),
            (limit, 3, 3),
            (limit, limit / 2, 2),
        ] {
            let s = scene(still, moving, keys);
            let counted = buffer_bytes(&s, 0);
            let statics = StaticGeometry::new(&s);
            let shot = ShotWords::new(&s, &statics);
            assert!(
                4 * shot.words.0.len() as u64 <= counted,
                "{still} + {moving}: shot"
            );
            let layout = SumLayout::new(PassSet::EMPTY.with(raytrace_core::pass::Pass::Motion));
            for frame in 1..=3 {
                let none = FramePoints::none();
                let prepared = PreparedFrame::new(&s, &statics, &none, frame);
                let f = FrameWords::new(&prepared, &shot, &layout);
                assert!(
                    4 * f.words.0.len() as u64 <= counted,
                    "{still} + {moving}: frame {frame}"
                );
            }
        }
    }

    /// Two caches' points, at two times (two groups, two hierarchies), one set with colours
    /// (a look a point) and moving, one still without (a look for its material).
    fn frame_points(n: usize) -> FramePoints {
        use glam::Vec3;
        use raytrace_core::points::PointSet;
        let at = |i: usize| Vec3::new((i % 50) as f32 * 0.1, (i / 50) as f32 * 0.1, -5.0);
        FramePoints {
            sets: vec![
                PointSet {
                    time: 0.01,
                    centers: (0..n).map(at).collect(),
                    velocities: vec![Vec3::new(1.0, 0.5, 0.0); n],
                    radius: 0.04,
                    colors: (0..n).map(|i| [(i % 7) as f32 / 7.0, 0.5, 1.0]).collect(),
                    ..PointSet::default()
                },
                PointSet {
                    time: 0.02,
                    centers: (0..n / 2).map(|i| at(i) + Vec3::Z).collect(),
                    radii: (0..n / 2).map(|i| 0.01 + (i % 5) as f32 * 0.01).collect(),
                    ..PointSet::default()
                },
            ],
        }
    }

    #[test]
    fn a_frames_points_are_never_larger_than_counted() {
        let table = "[[points]]\nfile = \"p_####.ply\"\nmaterial = \"m\"\nradius = 0.04\n";
        for (still, moving) in [(0, 0), (20, 3)] {
            let mut s = scene(still, moving, 2);
            let materials =
                "[materials]\nm = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\n";
            let text = format!("{materials}{table}{table}");
            let tables = Scene::parse(&text, Path::new("p.toml")).unwrap();
            s.points = tables.points;
            let statics = StaticGeometry::new(&s);
            let shot = ShotWords::new(&s, &statics);
            let layout = SumLayout::new(PassSet::EMPTY.with(raytrace_core::pass::Pass::Motion));
            for n in [0, 1, 7, 5000] {
                let points = frame_points(n);
                let prepared = PreparedFrame::new(&s, &statics, &points, 2);
                let f = FrameWords::new(&prepared, &shot, &layout);
                let counted = buffer_bytes(&s, points.len() as u64);
                assert!(4 * f.words.0.len() as u64 <= counted, "{n} points");
                // A point of a set with colours has a look of its own, the others share one.
                let w = &f.words.0;
                let records = w[H_POINTS as usize] as usize;
                let mut looks: Vec<u32> = (0..points.len())
                    .map(|i| w[records + POINT_WORDS as usize * i + PT_LOOK as usize])
                    .collect();
                looks.sort_unstable();
                looks.dedup();
                assert_eq!(looks.len(), n + usize::from(n > 1), "{n}");
                let groups = f.words.0[H_POINT_GROUP_N as usize];
                assert_eq!(groups, u32::from(n > 0) + u32::from(n > 1), "{n}");
            }
        }
    }
}
