//! Point caches against answers known in advance: a cache's points render as the same spheres
//! written one by one in TOML (with `velocity`, with `keyframes` for an interpolated
//! sequence, with per-sphere materials for colours), bit for bit, and the three PLY encodings
//! of the same points give the same image. Everything is rendered by the binary, and the
//! frames' pixels and passes compared as bits.

use crate::common;

use std::path::Path;

use std::collections::HashMap;

use common::{exr_channels, f, ok, run, text, v};
use glam::DVec3;
use raytrace_core::rng::Pcg32;
use raytrace_scene::ply::{Column, Encoding, Scalar, write_vertices};

/// The shot, camera and image every scene here shares; `shot` adds keys to `[shot]`.
fn head(shot: &str) -> String {
    format!(
        r#"[shot]
fps = 24.0
frames = 2
{shot}
[output]
width = 48
height = 36
passes = ["alpha", "depth", "normal", "albedo", "motion"]
[render]
samples = 4
max_depth = 6
[camera]
look_from = [0.0, 0.5, 7.0]
look_at = [0.0, 0.0, 0.0]
vfov = 40.0
[materials]
grey = {{ type = "lambertian", albedo = [0.6, 0.5, 0.4] }}
shiny = {{ type = "metal", albedo = [0.9, 0.8, 0.7], fuzz = 0.2 }}
"#
    )
}

/// A number a `float` PLY property holds exactly.
fn f32ish(x: f64) -> f64 {
    x as f32 as f64
}

/// `n` random points in a 4-unit cube: positions, velocities and radii, as `f32` values.
fn random_points(n: usize, seed: u64) -> (Vec<DVec3>, Vec<DVec3>, Vec<f64>) {
    let mut r = Pcg32::new(seed, 1);
    let mut u = || f32ish(r.next_f64() * 2.0 - 1.0);
    let mut p = Vec::new();
    let mut vel = Vec::new();
    let mut radii = Vec::new();
    for _ in 0..n {
        p.push(DVec3::new(u(), u(), u()) * 2.0);
        vel.push(DVec3::new(u(), u(), u()) * 8.0);
        radii.push(f32ish(0.15 + 0.1 * u().abs()));
    }
    (p, vel, radii)
}

/// Writes a PLY file of `columns` (name, type, values).
fn write_ply(path: &Path, encoding: Encoding, columns: &[(&str, Scalar, Vec<f64>)]) {
    let cols: Vec<Column> = columns
        .iter()
        .map(|(name, ty, values)| Column {
            name,
            ty: *ty,
            values,
        })
        .collect();
    let mut bytes = Vec::new();
    write_vertices(&mut bytes, encoding, &cols).unwrap();
    std::fs::write(path, bytes).unwrap();
}

/// Columns x, y, z of `p`, each as `ty`.
fn xyz<'a>(names: [&'a str; 3], ty: Scalar, p: &[DVec3]) -> Vec<(&'a str, Scalar, Vec<f64>)> {
    (0..3)
        .map(|k| (names[k], ty, p.iter().map(|q| q[k]).collect()))
        .collect()
}

/// A frame's channels by name, each as bits.
type Frame = HashMap<String, Vec<u32>>;

/// Renders frames 1 and 2 of `scene` (in `dir`) to EXR; returns each frame's channels.
fn render(dir: &Path, scene: &str) -> Vec<Frame> {
    let name = scene.trim_end_matches(".toml");
    let out = format!("{name}_####.exr");
    ok(dir, &["render", scene, "-q", "--threads", "2", "-o", &out]);
    (1..=2)
        .map(|frame| {
            exr_channels(&dir.join(format!("{name}_{frame:04}.exr")))
                .into_iter()
                .map(|(c, v)| (c, v.iter().map(|x| x.to_bits()).collect()))
                .collect()
        })
        .collect()
}

/// The motion vectors' channels.
const MOTION: [&str; 4] = ["forward.u", "forward.v", "backward.u", "backward.v"];

/// Asserts two renders have the same channels, each the same bits (but those of `except`),
/// and that their colour is not blank (something was hit).
fn assert_same_but(a: &[Frame], b: &[Frame], except: &[&str]) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        let mut names: Vec<&String> = x.keys().collect();
        names.sort();
        assert_eq!(names.len(), y.len());
        assert!(names.len() >= 3 + MOTION.len());
        for c in names.into_iter().filter(|c| !except.contains(&c.as_str())) {
            let n = x[c].iter().zip(&y[c]).filter(|(a, b)| a != b).count();
            let worst = x[c]
                .iter()
                .zip(&y[c])
                .map(|(a, b)| (f32::from_bits(*a) - f32::from_bits(*b)).abs())
                .fold(0f32, f32::max);
            assert!(
                x[c] == y[c],
                "channel {c} differs: {n} values, by up to {worst}"
            );
        }
        let r = &x["R"];
        assert!(r.iter().any(|&bits| bits != r[0]), "a blank frame");
    }
}

/// Asserts the scenes `points` and `spheres` (written in `dir`) render the same bits.
fn renders_the_same(dir: &Path, points: &str, spheres: &str) {
    std::fs::write(dir.join("points.toml"), points).unwrap();
    std::fs::write(dir.join("spheres.toml"), spheres).unwrap();
    assert_same(&render(dir, "points.toml"), &render(dir, "spheres.toml"));
}

/// Asserts two renders are the same bits, every channel.
fn assert_same(a: &[Frame], b: &[Frame]) {
    assert_same_but(a, b, &[]);
}

/// A cache of points with velocities, one file for every frame (points at time 0), renders as
/// the same spheres with `velocity`, frame for frame, passes included (motion vectors too).
#[test]
fn points_with_velocities_render_as_spheres_with_velocity() {
    let dir = tempfile::tempdir().unwrap();
    let (p, vel, radii) = random_points(80, 7);
    let mut cols = xyz(["x", "y", "z"], Scalar::F32, &p);
    cols.extend(xyz(["vx", "vy", "vz"], Scalar::F32, &vel));
    cols.push(("radius", Scalar::F32, radii.clone()));
    write_ply(
        &dir.path().join("cloud.ply"),
        Encoding::BinaryLittleEndian,
        &cols,
    );
    let points = head("") + "[[points]]\nfile = \"cloud.ply\"\nmaterial = \"grey\"\n";
    let mut spheres = head("");
    for i in 0..p.len() {
        spheres += &format!(
            "[[sphere]]\ncenter = {}\nvelocity = {}\nradius = {}\nmaterial = \"grey\"\n",
            v(p[i]),
            v(vel[i]),
            f(radii[i])
        );
    }
    renders_the_same(dir.path(), &points, &spheres);
}

/// A two-frame sequence interpolated by id (the second file shuffled, some points dying after
/// the first and some born in the second) renders frame 1 as the matched points keyframed
/// from their first to their second position, and the others moving by their velocity;
/// frame 2 (the last, with no next file) as every point of its file moving by its velocity.
#[test]
fn an_interpolated_sequence_renders_as_spheres_between_its_positions() {
    let dir = tempfile::tempdir().unwrap();
    let (p, vel, radii) = random_points(60, 11);
    let (q, later_vel, _) = random_points(60, 12);
    // Points 0..45 live on (moved by up to a unit), 45..60 die; 10 are born in frame 2.
    let q: Vec<DVec3> = (0..45)
        .map(|i| (p[i] + q[i] * 0.25).to_array().map(f32ish).into())
        .collect();
    let (born, born_vel, born_radii) = random_points(10, 13);
    let ids_1: Vec<f64> = (0..60).map(|i| 1000.0 + i as f64).collect();
    // The second file in another order: its ids, positions, velocities and radii.
    let order: Vec<usize> = (0..45).rev().collect();
    let mut ids_2: Vec<f64> = order.iter().map(|&i| ids_1[i]).collect();
    ids_2.extend((0..10).map(|k| 5000.0 + k as f64));
    let mut p2: Vec<DVec3> = order.iter().map(|&i| q[i]).collect();
    p2.extend(&born);
    let mut v2: Vec<DVec3> = order.iter().map(|&i| later_vel[i]).collect();
    v2.extend(&born_vel);
    let mut r2: Vec<f64> = order.iter().map(|&i| radii[i]).collect();
    r2.extend(&born_radii);
    let file = |p: &[DVec3], vel: &[DVec3], r: &[f64], ids: &[f64]| {
        let mut cols = xyz(["x", "y", "z"], Scalar::F32, p);
        cols.extend(xyz(
            ["velocity_x", "velocity_y", "velocity_z"],
            Scalar::F32,
            vel,
        ));
        cols.push(("pscale", Scalar::F32, r.to_vec()));
        cols.push(("id", Scalar::I32, ids.to_vec()));
        cols
    };
    write_ply(
        &dir.path().join("seq_0001.ply"),
        Encoding::BinaryBigEndian,
        &file(&p, &vel, &radii, &ids_1),
    );
    write_ply(
        &dir.path().join("seq_0002.ply"),
        Encoding::Ascii,
        &file(&p2, &v2, &r2, &ids_2),
    );
    // The shutter opens at each frame's time, for a whole frame: inside [t1, t2].
    let shot = "shutter_position = \"start\"\nshutter_angle = 360.0";
    let points = head(shot)
        + "[[points]]\nfile = \"seq_####.ply\"\nmaterial = \"shiny\"\nmotion = \"interpolate\"\n";
    std::fs::write(dir.path().join("points.toml"), points).unwrap();
    let (t1, t2) = (0.0, 1.0 / 24.0);
    // Frame 1: spheres moving from their first position towards their second, at the
    // velocity between the two kept as the `f32` the cache's columns hold (the exact
    // keyframed path differs from it by that rounding), and velocity spheres for those
    // that die.
    let mut first = head(shot);
    for i in 0..60 {
        let motion = if i < 45 {
            let u = ((q[i] - p[i]) / (t2 - t1)).as_vec3().as_dvec3();
            format!("center = {}\nvelocity = {}", v(p[i]), v(u))
        } else {
            format!("center = {}\nvelocity = {}", v(p[i]), v(vel[i]))
        };
        first += &format!(
            "[[sphere]]\n{motion}\nradius = {}\nmaterial = \"shiny\"\n",
            f(radii[i])
        );
    }
    // Frame 2: its file's points at t2, by their velocities: centre(t) = P + v (t - t2).
    let mut second = head(shot);
    for i in 0..p2.len() {
        second += &format!(
            "[[sphere]]\nkeyframes = [{{ time = {}, center = {} }}, {{ time = {}, center = {} }}]\nradius = {}\nmaterial = \"shiny\"\n",
            f(t2),
            v(p2[i]),
            f(t2 + 1.0),
            v(p2[i] + v2[i]),
            f(r2[i])
        );
    }
    std::fs::write(dir.path().join("first.toml"), first).unwrap();
    std::fs::write(dir.path().join("second.toml"), second).unwrap();
    let got = render(dir.path(), "points.toml");
    // The motion vectors differ by design: a keyframed sphere is held outside its keys, a
    // point moves on its line over the whole shot.
    assert_same_but(&got[..1], &render(dir.path(), "first.toml")[..1], &MOTION);
    // Frame 2's spheres move by velocity written as keys one second apart: the same line,
    // computed another way, so within rounding rather than bit for bit; the image agrees.
    let want = render(dir.path(), "second.toml");
    let (got, want) = (&got[1]["R"], &want[1]["R"]);
    let differing = got
        .iter()
        .zip(want)
        .filter(|(a, b)| (f32::from_bits(**a) - f32::from_bits(**b)).abs() > 1e-3)
        .count();
    assert!(differing * 100 < got.len(), "{differing} values differ");
}

/// The same points written as ASCII, binary little-endian and binary big-endian, with
/// properties of several types in different orders and an element and a property that are
/// not read, give the same image.
#[test]
fn ascii_little_and_big_endian_files_give_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let (p, vel, radii) = random_points(70, 21);
    let mut cols = xyz(["x", "y", "z"], Scalar::F64, &p);
    // A short y: whole numbers.
    cols[1] = (
        "y",
        Scalar::I16,
        p.iter().map(|q| (q.y * 2.0).round()).collect(),
    );
    cols.extend(xyz(["vx", "vy", "vz"], Scalar::F32, &vel));
    cols.push(("radius", Scalar::F64, radii));
    cols.push(("red", Scalar::U8, (0..70).map(|i| (i * 3) as f64).collect()));
    cols.push((
        "green",
        Scalar::U8,
        (0..70).map(|i| 255.0 - i as f64).collect(),
    ));
    cols.push(("blue", Scalar::U8, vec![128.0; 70]));
    cols.push(("density", Scalar::F32, vec![0.5; 70]));
    let mut images = Vec::new();
    for (k, enc) in [
        Encoding::Ascii,
        Encoding::BinaryLittleEndian,
        Encoding::BinaryBigEndian,
    ]
    .into_iter()
    .enumerate()
    {
        let mut c = cols.clone();
        c.rotate_left(3 * k);
        let name = format!("e{k}.ply");
        write_ply(&dir.path().join(&name), enc, &c);
        let scene = head("") + &format!("[[points]]\nfile = \"{name}\"\nmaterial = \"grey\"\n");
        std::fs::write(dir.path().join(format!("e{k}.toml")), scene).unwrap();
        images.push(render(dir.path(), &format!("e{k}.toml")));
    }
    assert_same(&images[0], &images[1]);
    assert_same(&images[1], &images[2]);
}

/// Colour attributes multiply the material's albedo: 8-bit `red green blue` (over 255) and
/// float `r g b`, on a lambertian and a metal cache, render as spheres whose inline materials
/// have the products as albedos.
#[test]
fn colour_attributes_equal_per_sphere_materials() {
    let dir = tempfile::tempdir().unwrap();
    let (p, vel, radii) = random_points(50, 31);
    let mut r = Pcg32::new(5, 5);
    let bytes: Vec<[f64; 3]> = (0..25)
        .map(|_| [0, 1, 2].map(|_| (r.next_u32() % 256) as f64))
        .collect();
    let floats: Vec<[f64; 3]> = (0..25)
        .map(|_| [0, 1, 2].map(|_| f32ish(r.next_f64())))
        .collect();
    let set = |range: std::ops::Range<usize>, names: [&'static str; 3], ty, c: &[[f64; 3]]| {
        let mut cols = xyz(["x", "y", "z"], Scalar::F32, &p[range.clone()]);
        cols.extend(xyz(["vx", "vy", "vz"], Scalar::F32, &vel[range.clone()]));
        cols.push(("radius", Scalar::F32, radii[range].to_vec()));
        for k in 0..3 {
            cols.push((names[k], ty, c.iter().map(|x| x[k]).collect()));
        }
        cols
    };
    write_ply(
        &dir.path().join("bytes.ply"),
        Encoding::BinaryLittleEndian,
        &set(0..25, ["red", "green", "blue"], Scalar::U8, &bytes),
    );
    write_ply(
        &dir.path().join("floats.ply"),
        Encoding::Ascii,
        &set(25..50, ["r", "g", "b"], Scalar::F32, &floats),
    );
    let points = head("")
        + "[[points]]\nfile = \"bytes.ply\"\nmaterial = \"grey\"\n"
        + "[[points]]\nfile = \"floats.ply\"\nmaterial = \"shiny\"\n";
    // The colour is kept as a 32-bit float: an 8-bit value over 255 rounded to f32.
    let tint = |albedo: DVec3, c: [f64; 3]| albedo * DVec3::from_array(c);
    let mut spheres = head("");
    for i in 0..50 {
        let material = if i < 25 {
            let c = bytes[i].map(|b| (b / 255.0) as f32 as f64);
            format!(
                "{{ type = \"lambertian\", albedo = {} }}",
                v(tint(DVec3::new(0.6, 0.5, 0.4), c))
            )
        } else {
            format!(
                "{{ type = \"metal\", albedo = {}, fuzz = 0.2 }}",
                v(tint(DVec3::new(0.9, 0.8, 0.7), floats[i - 25]))
            )
        };
        spheres += &format!(
            "[[sphere]]\ncenter = {}\nvelocity = {}\nradius = {}\nmaterial = {material}\n",
            v(p[i]),
            v(vel[i]),
            f(radii[i])
        );
    }
    renders_the_same(dir.path(), &points, &spheres);
}

/// `check` reads every file of the shot, and reports the points and the memory of each
/// frame; a frame past the cache's last file is an error naming the frame and the file,
/// found by `check` and by `render` before anything renders.
#[test]
fn check_reports_points_per_frame_and_finds_missing_files() {
    let dir = tempfile::tempdir().unwrap();
    ok(
        dir.path(),
        &[
            "generate",
            "-o",
            "caches/f_####.ply",
            "--frames",
            "2",
            "--points",
            "300",
        ],
    );
    let scene = head("").replace(
        "passes = [\"alpha\", \"depth\", \"normal\", \"albedo\", \"motion\"]\n",
        "",
    ) + "[[points]]\nfile = \"caches/f_####.ply\"\nmaterial = \"grey\"\n";
    std::fs::write(dir.path().join("s.toml"), &scene).unwrap();
    let out = ok(dir.path(), &["check", "s.toml"]);
    assert!(out.contains("points[0]: "), "{out}");
    let frame_lines: Vec<&str> = out.lines().filter(|l| l.contains(" points (")).collect();
    assert_eq!(frame_lines.len(), 2, "{out}");
    for l in frame_lines {
        assert!(l.contains("moving), memory about "), "{l}");
    }
    // Three frames, two files.
    std::fs::write(
        dir.path().join("s3.toml"),
        scene.replace("frames = 2", "frames = 3"),
    )
    .unwrap();
    for command in ["check", "render"] {
        let o = run(
            dir.path(),
            &[command, "s3.toml", "-q"][..if command == "check" { 2 } else { 3 }],
        );
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(t.contains("frame 3") && t.contains("f_0003.ply"), "{t}");
    }
    assert!(!dir.path().join("s3_0001.png").exists());
}

/// The fountain is the same files for the same seed, and its scene renders.
#[test]
fn the_fountain_is_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["a", "b"] {
        ok(
            dir.path(),
            &[
                "generate",
                "-o",
                &format!("{name}_##.ply"),
                "--frames",
                "3",
                "--points",
                "500",
                "--seed",
                "9",
            ],
        );
    }
    for frame in 1..=3 {
        let a = std::fs::read(dir.path().join(format!("a_{frame:02}.ply"))).unwrap();
        let b = std::fs::read(dir.path().join(format!("b_{frame:02}.ply"))).unwrap();
        assert_eq!(a, b);
    }
}

/// The shipped fountain scene renders from the cache its documented command writes.
#[test]
fn the_shipped_fountain_scene_renders_from_its_documented_cache() {
    let dir = tempfile::tempdir().unwrap();
    let scene =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/fountain.toml"))
            .unwrap();
    let command = "raytrace generate -o scenes/caches/fountain_####.ply --frames 48 --points 4000";
    assert!(
        scene.contains(command),
        "the scene documents its cache's command"
    );
    std::fs::create_dir(dir.path().join("scenes")).unwrap();
    std::fs::write(dir.path().join("scenes/fountain.toml"), &scene).unwrap();
    let args: Vec<&str> = command.split(' ').skip(1).collect();
    ok(dir.path(), &args);
    let out = ok(dir.path(), &["check", "scenes/fountain.toml"]);
    assert!(out.contains("over 48 frames, every file checked"), "{out}");
    let out = ok(
        dir.path(),
        &[
            "render",
            "scenes/fountain.toml",
            "--frames",
            "24",
            "--width",
            "64",
            "--height",
            "36",
            "--samples",
            "2",
            "-o",
            "f.exr",
            "--stats",
        ],
    );
    assert!(out.contains("points), prepare"), "{out}");
    let c = exr_channels(&dir.path().join("f.exr"));
    assert!(c["B"].iter().all(|x| x.is_finite()));
}
