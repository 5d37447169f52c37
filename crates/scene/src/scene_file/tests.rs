//! Tests of scene parsing and validation, whole and in pieces.

use crate::scene_file::SceneFile;
use std::path::Path;

use glam::DVec3;

use super::load::{MAX_FILE_BYTES, parse_whole, read_scene};
use super::overrides::Overrides;
use super::pieces::parse_in_pieces;
use raytrace_core::error::Error;
use raytrace_core::material::{Background, Material};
use raytrace_core::motion::Motion;
use raytrace_core::sampler::SamplerKind;
use raytrace_core::scene::{MAX_SIDE, RenderSettings, Scene};
use raytrace_core::shutter::Shot;
use raytrace_core::shutter::ShutterPosition;

fn parse(text: &str, source: &Path) -> Result<Scene, Error> {
    Scene::parse(text, source)
}

fn ok(text: &str) -> Scene {
    parse(text, Path::new("s.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn err(text: &str) -> String {
    match parse(text, Path::new("s.toml")) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn empty_scene_has_every_default() {
    let s = ok("");
    assert_eq!(s.shot, Shot::default());
    assert_eq!(s.shot.shutter, 1.0 / 48.0);
    assert_eq!(s.output.path, "s_####.png");
    assert_eq!((s.output.width, s.output.height), (400, 225));
    assert_eq!(
        s.render,
        RenderSettings {
            samples: 16,
            max_depth: 50,
            seed: 0,
            sampler: SamplerKind::Sobol,
            device: raytrace_core::scene::Device::Cpu,
        }
    );
    assert_eq!(s.camera.look_from, Motion::Still(DVec3::ZERO));
    assert_eq!(s.camera.look_at, Motion::Still(DVec3::new(0.0, 0.0, -1.0)));
    assert_eq!(
        (s.camera.up, s.camera.vfov, s.camera.aperture),
        (DVec3::Y, 90.0, 0.0)
    );
    assert_eq!(s.camera.focus_distance, None);
    assert_eq!(s.background, Background::Sky);
    assert!(s.spheres.is_empty() && s.materials.is_empty());
}

#[test]
fn the_contracts_example_parses() {
    // The contract's own example, copied into this file (the project reads nothing beside it).
    let example = CONTRACT_EXAMPLE;
    let s = ok(example);
    assert_eq!(s.spheres.len(), 4);
    assert_eq!(s.shot.shutter, 0.0208333);
    assert!(matches!(s.spheres[1].motion, Motion::Velocity { .. }));
    assert!(matches!(s.spheres[2].motion, Motion::Keyframes(_)));
    assert!(matches!(s.spheres[3].motion, Motion::Orbit { .. }));
    assert_eq!(s.materials.len(), 3);
    assert_eq!(s.background, Background::Uniform(DVec3::ONE));
}

const CONTRACT_EXAMPLE: &str = r#"
[shot]
fps = 24.0
frames = 48
first_frame = 1
start_time = 0.0
shutter = 0.0208333
shutter_position = "center"
[output]
path = "renders/shot_####.exr"
[render]
samples = 100
[camera]
look_from = [13.0, 2.0, 3.0]
look_at = [0.0, 0.0, 0.0]
vfov = 20.0
aperture = 0.1
focus_distance = 10.0
[background]
color = [1.0, 1.0, 1.0]
[materials]
ground = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
steel  = { type = "metal", albedo = [0.7, 0.6, 0.5], fuzz = 0.0 }
glass  = { type = "dielectric", ior = 1.5 }
[[sphere]]
center = [0.0, -1000.0, 0.0]
radius = 1000.0
material = "ground"
[[sphere]]
center = [1.2, 0.2, 3.4]
radius = 0.2
material = "steel"
velocity = [0.0, 0.25, 0.0]
[[sphere]]
radius = 0.5
material = "glass"
keyframes = [ { time = 0.0, center = [0, 1, 0] }, { time = 1.0, center = [2, 1, 0] } ]
[[sphere]]
center = [0.0, 1.0, 0.0]
radius = 0.3
material = "steel"
orbit = { pivot = [0.0, 1.0, 0.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 90.0 }
"#;

#[test]
fn shutter_angle_and_seconds() {
    assert_eq!(
        ok("[shot]\nfps = 25\nshutter_angle = 90\n").shot.shutter,
        0.01
    );
    assert_eq!(ok("[shot]\nshutter = 0.004\n").shot.shutter, 0.004);
    assert_eq!(
        ok("[shot]\nshutter_position = \"end\"\n").shot.position,
        ShutterPosition::End
    );
}

#[test]
fn materials_by_name_and_inline() {
    let s = ok(r#"
[materials]
a = { type = "metal", albedo = [0.1, 0.2, 0.3] }
[[sphere]]
center = [0, 0, 0]
radius = 1
material = "a"
[[sphere]]
center = [0, 0, 0]
radius = 1
material = { type = "dielectric", ior = 1.33 }
"#);
    assert_eq!(
        s.materials[s.spheres[0].material as usize],
        Material::Metal {
            albedo: DVec3::new(0.1, 0.2, 0.3),
            fuzz: 0.0
        }
    );
    assert_eq!(
        s.materials[s.spheres[1].material as usize],
        Material::Dielectric { ior: 1.33 }
    );
}

#[test]
fn orbit_axis_is_normalised_and_camera_motions_convert() {
    let s = ok(
        "[[sphere]]\ncenter = [1, 0, 0]\nradius = 0.1\nmaterial = { type = \"lambertian\", albedo = [1, 1, 1] }\norbit = { pivot = [0, 0, 0], axis = [0, 2, 0], degrees_per_second = 10 }\n",
    );
    let Motion::Orbit { orbit, .. } = &s.spheres[0].motion else {
        panic!()
    };
    assert_eq!(orbit.axis, DVec3::Y);
    let s = ok(
        "[camera]\nlook_from = [0, 1, 5]\nlook_at = [0, 1, 0]\norbit = { degrees_per_second = 45 }\n",
    );
    let Motion::Orbit { origin, orbit } = &s.camera.look_from else {
        panic!()
    };
    assert_eq!(
        (*origin, orbit.pivot, orbit.axis),
        (
            DVec3::new(0.0, 1.0, 5.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::Y
        )
    );
    let s = ok(r#"
[camera]
look_from = [0, 0, 5]
look_at = [0, 0, 0]
keyframes = [ { time = 0 }, { time = 1, look_from = [5, 0, 0] }, { time = 2, look_at = [0, 1, 0] } ]
"#);
    let (Motion::Keyframes(f), Motion::Keyframes(a)) = (&s.camera.look_from, &s.camera.look_at)
    else {
        panic!()
    };
    assert_eq!(
        f.iter().map(|k| k.position).collect::<Vec<_>>(),
        [
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::new(5.0, 0.0, 0.0),
            DVec3::new(5.0, 0.0, 0.0)
        ]
    );
    assert_eq!(
        a.iter().map(|k| k.position).collect::<Vec<_>>(),
        [DVec3::ZERO, DVec3::ZERO, DVec3::Y]
    );
}

#[test]
fn malformed_scenes_name_the_place() {
    let sphere = |extra: &str| {
        format!(
            "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\n{extra}"
        )
    };
    let cases: Vec<(String, &str)> = vec![
        ("[shot]\nfpz = 3\n".into(), "s.toml:2:1"),
        ("[camera]\nlook_from = [0, 0]\n".into(), "s.toml:2:"),
        ("[[sphere]]\ncenter = [0, 0, 0]\nmaterial = \"x\"\n".into(), "radius"),
        ("[shot]\nfps = nan\n".into(), "shot.fps must be a finite number, got nan"),
        ("[shot]\nfps = inf\n".into(), "shot.fps"),
        ("[shot]\nstart_time = 1e39\n".into(), "shot.start_time is too large"),
        ("[shot]\nshutter = -0.0\n".into(), "shot.shutter must be >= 0, got -0"),
        ("[shot]\nframes = 0\n".into(), "shot.frames must be in 1"),
        ("[shot]\nframes = -4\n".into(), "shot.frames"),
        ("[shot]\nfirst_frame = 4294967295\nframes = 2\n".into(), "first_frame + shot.frames"),
        ("[camera]\naperture = -0.0\n".into(), "camera.aperture"),
        ("[camera]\nvfov = 180\n".into(), "camera.vfov must be < 180"),
        ("[camera]\nup = [0, 0, 2]\n".into(), "parallel"),
        ("[camera]\nup = [0, 0, 0]\n".into(), "camera.up"),
        ("[camera]\norbit = { degrees_per_second = 1 }\nkeyframes = [ { time = 0 } ]\n".into(), "at most one of orbit and keyframes"),
        ("[camera]\nkeyframes = []\n".into(), "camera.keyframes must have at least one key"),
        ("[camera]\nkeyframes = [ { time = 1 }, { time = 1 } ]\n".into(), "camera.keyframes[1].time must be greater"),
        ("[camera]\nkeyframes = [ { time = 0, look_at = [0, 0, 0] } ]\n".into(), "camera.keyframes[0]: look_from and look_at must differ"),
        (sphere("velocity = [1, 0, 0]\norbit = { pivot = [0, 0, 0], axis = [0, 1, 0], degrees_per_second = 1 }\n"), "sphere[0]: give at most one"),
        (sphere("keyframes = [ { time = 0, center = [0, 0, 0] } ]\n"), "keyframes replace center"),
        (sphere("orbit = { pivot = [0, 0, 0], axis = [0, 0, 0], degrees_per_second = 1 }\n"), "sphere[0].orbit.axis must be a non-zero"),
        (sphere("velocity = [0, nan, 0]\n"), "sphere[0].velocity[1]"),
        ("[[sphere]]\ncenter = [0, 0, 0]\nradius = -0.0\nmaterial = \"m\"\n[materials]\nm = { type = \"dielectric\", ior = 1 }\n".into(), "sphere[0].radius must be > 0, got -0"),
        ("[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"steel\"\n".into(), "sphere[0].material \"steel\" is not a material"),
        ("[materials]\nm = { type = \"plastic\" }\n".into(), "plastic"),
        ("[materials]\nm = { type = \"metal\", albedo = [1, 1, 1], fuzz = 2 }\n".into(), "materials.m.fuzz must be in [0, 1], got 2"),
        ("[materials]\nm = { type = \"metal\", albedo = [1, 1, 1], shine = 2 }\n".into(), "shine"),
        ("[materials]\nm = { type = \"lambertian\", albedo = [-1, 1, 1] }\n".into(), "materials.m.albedo[0] must be >= 0"),
        ("[background]\ncolor = [1, 1, inf]\n".into(), "background.color[2]"),
        ("[output]\nwidth = 0\n".into(), "output.width"),
        ("[output]\npath = \"f_####.tiff\"\n".into(), "output.path \"f_####.tiff\": the file name must end in .exr or .png"),
        ("[render]\nseed = -1\n".into(), "render.seed"),
        ("[render]\nsamples = 0\n".into(), "render.samples"),
        ("[shot]\nshutter = 0.1\nshutter_angle = 10\n".into(), "at most one of shutter and shutter_angle"),
        ("[shot]\nshutter_position = \"middle\"\n".into(), "s.toml:2:"),
        ("[shot\n".into(), "s.toml:1:"),
        ("[shot]\nfps = 1e-38\nframes = 100\n".into(), "out of range"),
    ];
    for (text, want) in cases {
        let e = err(&text);
        assert!(e.contains(want), "{text:?}: {e:?} lacks {want:?}");
        assert!(e.starts_with("s.toml"), "{e}");
    }
}

/// The parse in pieces agrees with the whole parse: same scene, or the same message.
/// Unbalanced brackets make the cut impossible (`must_cut` false): then it is the
/// fallback that must agree.
fn same_both_ways(text: &str, must_cut: bool) {
    let whole = parse_whole(text, Path::new("s.toml"), &Overrides::default());
    for per_piece in [1, 2, 3, 1000] {
        let pieces = parse_in_pieces(text, Path::new("s.toml"), &Overrides::default(), per_piece);
        assert!(
            pieces.is_some() || !must_cut,
            "not cut into pieces:\n{text}"
        );
        let pieces = pieces.unwrap_or_else(|| parse(text, Path::new("s.toml")));
        match (&whole, &pieces) {
            (Ok(a), Ok(b)) => assert_eq!(a, b),
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{text}"),
            _ => panic!("{text}\nwhole: {whole:?}\npieces: {pieces:?}"),
        }
    }
}

#[test]
fn pieces_agree_with_the_whole_parse() {
    let sphere = |i: usize, extra: &str| {
        format!(
            "[[sphere]]\ncenter = [{i}, 0, 0]\nradius = 1\nmaterial = {}\n{extra}",
            if i.is_multiple_of(2) {
                "\"a\"".to_string()
            } else {
                format!("{{ type = \"dielectric\", ior = 1.{i} }}")
            }
        )
    };
    let spheres = |n: usize, bad: Option<(usize, &str)>| {
        (0..n)
            .map(|i| match bad {
                Some((j, extra)) if j == i => sphere(i, extra),
                _ => sphere(i, "velocity = [0, 1, 0]\n"),
            })
            .collect::<String>()
    };
    let head = "# [[sphere]] in a comment\n[shot]\nframes = 3\n[materials]\na = { type = \"metal\", albedo = [0.5, 0.5, 0.5] }\n";
    let cases = [
        format!("{head}{}", spheres(7, None)),
        // Settings after the spheres, a multi-line string holding a header, a
        // multi-line array with brackets at line starts.
        format!(
            "{}[output]\npath = \"\"\"\n[[sphere]]\nx_####.png\"\"\"\n[camera]\nlook_from = [\n[0][0],\n1, 2]\n{head}",
            spheres(5, None)
        ),
        format!(
            "{}[output]\npath = \"\"\"x\n[[sphere]]\n_####.png\"\"\"\n{head}",
            spheres(5, None)
        ),
        // Sub-tables of a sphere.
        format!(
            "{head}{}{}",
            spheres(3, None),
            sphere(
                3,
                "[sphere.orbit]\npivot = [0, 0, 0]\naxis = [0, 1, 0]\ndegrees_per_second = 9\n"
            )
        ),
        format!(
            "{head}{}[[sphere]]\nradius = 1\nmaterial = \"a\"\n[[sphere.keyframes]]\ntime = 0\ncenter = [0, 0, 0]\n[[sphere.keyframes]]\ntime = 1\ncenter = [1, 0, 0]\n",
            spheres(4, None)
        ),
        // Errors: syntax in a late sphere, values in a sphere, settings and a piece both bad.
        format!("{head}{}", spheres(6, Some((4, "velocity = [0, 1\n")))),
        format!("{head}{}", spheres(6, Some((5, "radius = 2\n")))),
        format!("{head}{}", spheres(6, Some((3, "colour = 2\n")))),
        format!(
            "{head}{}",
            spheres(6, Some((4, "velocity = [0, nan, 0]\n")))
        ),
        format!("{head}{}", spheres(6, Some((2, "orbit = 1\n")))),
        format!(
            "{}{head}[shot]\nfps = 2\n",
            spheres(6, Some((4, "velocity = [0, 1\n")))
        ),
        format!(
            "{}{head}[camera]\nvfov = 200\n",
            spheres(6, Some((1, "velocity = [0, nan, 0]\n")))
        ),
        format!("{head}{}", spheres(6, Some((2, "material = \"nope\"\n")))),
        format!("{head}[render]\nsamples = 0\n{}", spheres(3, None)),
        format!("{head}{}[[sphere]]\ncenter = [0, 0, 0]\n", spheres(3, None)),
        format!("{head}{}[[sphere]\n", spheres(3, None)),
        spheres(3, None),
    ];
    for (i, text) in cases.iter().enumerate() {
        same_both_ways(text, ![5, 10, 15].contains(&i));
    }
    same_both_ways(
        &super::generate::scene_text(&super::generate::RandomScene {
            spheres: 3000,
            moving: 0.5,
            seed: 9,
            frames: 1,
        }),
        true,
    );
}

/// Layouts the pieces cannot follow are parsed whole.
#[test]
fn unusual_layouts_are_parsed_whole() {
    let s = "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"a\"\n";
    for text in [
        format!("[materials]\na = {{ type = \"dielectric\", ior = 1 }}\n[\"sphere\"]\nx = 1\n{s}"),
        format!(
            "{s}[materials]\na = {{ type = \"dielectric\", ior = 1 }}\n[sphere.orbit]\nx = 1\n"
        ),
        format!("sphere = []\n{s}"),
    ] {
        assert!(
            parse_in_pieces(&text, Path::new("s.toml"), &Overrides::default(), 1).is_none(),
            "{text}"
        );
        assert!(parse(&text, Path::new("s.toml")).is_err());
    }
}

#[test]
fn negative_zero_coordinates_are_zero() {
    let s = ok("[camera]\nlook_from = [-0.0, 0, 0]\n");
    assert_eq!(s.camera.look_from.at(0.0), DVec3::ZERO);
}

#[test]
fn overrides_are_validated_as_the_file_is_and_name_the_flag() {
    let file = "[output]\nwidth = 100\nheight = 50\n[render]\nsamples = 4\n";
    let with = |o: Overrides| Scene::parse_with(file, Path::new("s.toml"), &o);
    let s = with(Overrides {
        width: Some(32),
        samples: Some(9),
        seed: Some(u64::MAX >> 1),
        output: Some("o_#.exr".into()),
        sampler: Some(SamplerKind::Independent),
        ..Overrides::default()
    })
    .unwrap();
    assert_eq!((s.output.width, s.output.height), (32, 50));
    assert_eq!((s.render.samples, s.render.seed), (9, u64::MAX >> 1));
    assert_eq!(s.output.path, "o_#.exr");
    assert_eq!(s.render.sampler, SamplerKind::Independent);
    for (o, want) in [
        (
            Overrides {
                width: Some(0),
                ..Overrides::default()
            },
            "--width must be in 1..=65536, got 0",
        ),
        (
            Overrides {
                height: Some(MAX_SIDE + 1),
                ..Overrides::default()
            },
            "--height must be in 1..=65536, got 65537",
        ),
        (
            Overrides {
                samples: Some(0),
                ..Overrides::default()
            },
            "--samples must be in 1..",
        ),
        (
            Overrides {
                output: Some("f.tif".into()),
                ..Overrides::default()
            },
            "--output \"f.tif\": the file name must end in .exr or .png",
        ),
    ] {
        let e = with(o).unwrap_err().to_string();
        assert!(e.starts_with(want), "{e}");
    }
    // The same rule for the file's own value names the field and the file.
    let e = Scene::parse("[output]\nwidth = 0\n", Path::new("s.toml"))
        .unwrap_err()
        .to_string();
    assert_eq!(e, "s.toml: output.width must be in 1..=65536, got 0");
}

/// The first line of a message (the rest is the source line and the caret).
fn first_line(e: &str) -> &str {
    e.lines().next().unwrap_or("")
}

#[test]
fn vectors_and_colours_take_exactly_three_numbers() {
    for (text, want) in [
        (
            "[camera]\nlook_from = [0, 0, 0, \"x\", [1], {a = 1}]\n",
            "s.toml:2:13: camera.look_from: expected 3 numbers, found 6",
        ),
        (
            "[camera]\nlook_from = [0, 0]\n",
            "s.toml:2:13: camera.look_from: expected 3 numbers, found 2",
        ),
        (
            "[[sphere]]\ncenter = [0, 0, -1, 99]\nradius = 1\nmaterial = { type = \"dielectric\", ior = 1.5 }\n",
            "s.toml:2:10: sphere[0].center: expected 3 numbers, found 4",
        ),
        (
            "[background]\ncolor = [0.1, 0.2, 0.3, nan]\n",
            "s.toml:2:9: background.color: expected 3 numbers, found 4",
        ),
        (
            "[camera]\nup = []\n",
            "s.toml:2:6: camera.up: expected 3 numbers, found 0",
        ),
        (
            "[camera]\nup = [0, \"1\", 0]\n",
            "s.toml:2:10: camera.up[1]: expected a number, found the string \"1\"",
        ),
        (
            "[camera]\nup = 1\n",
            "s.toml:2:6: camera.up: expected an array of 3 numbers, found the integer 1",
        ),
    ] {
        let e = err(text);
        assert_eq!(first_line(&e), want, "{text}");
    }
}

#[test]
fn schema_errors_name_the_field_and_say_what_was_expected_and_found() {
    let e = err("[shot]\nfps = \"big\"\n");
    assert_eq!(
        e,
        "s.toml:2:7: shot.fps: expected a number, found the string \"big\"\n  |\n2 | fps = \"big\"\n  |       ^^^^^"
    );
    for (text, want) in [
        (
            "[shot]\nshutter_position = \"middle\"\n",
            "s.toml:2:20: shot.shutter_position: expected one of \"start\", \"center\", \"end\", found \"middle\"",
        ),
        (
            "[render]\nsampler = 3\n",
            "s.toml:2:11: render.sampler: expected one of \"sobol\", \"independent\", found the integer 3",
        ),
        (
            "[shot]\nfps = 1\nfps = 2\n",
            "s.toml:3:1: duplicate key `fps`",
        ),
        ("[shot]\n[shot]\n", "s.toml:2:2: duplicate table [shot]"),
        (
            "[shot]\nfpz = 1\n",
            "s.toml:2:1: shot: unknown key `fpz`, expected one of fps, frames, first_frame, start_time, shutter, shutter_angle, shutter_position, shutter_curve, rolling_shutter",
        ),
        (
            "camera = 5\n",
            "s.toml:1:10: camera: expected a table, found the integer 5",
        ),
        (
            "[materials]\nm = 5\n",
            "s.toml:2:5: materials.m: expected a material table, found the integer 5",
        ),
        (
            "[materials]\nm = { type = \"plastic\" }\n",
            "s.toml:2:14: materials.m.type: expected one of \"lambertian\", \"metal\", \"dielectric\", found \"plastic\"",
        ),
        (
            "[materials]\nm = { type = \"lambertian\", albedo = [1, 1, 1], ior = 2 }\n",
            "s.toml:2:5: materials.m: unknown key `ior` for a lambertian material, expected one of type, albedo",
        ),
        (
            "[materials]\nm = { type = \"metal\", albedo = [1, 1, 1], shine = 2 }\n",
            "s.toml:2:43: materials.m: unknown key `shine`, expected one of type, albedo, fuzz, ior",
        ),
        (
            "[materials]\nm = { albedo = [1, 1, 1] }\n",
            "s.toml:2:5: materials.m: missing key `type` (one of \"lambertian\", \"metal\", \"dielectric\")",
        ),
        (
            "[materials]\nm = { type = \"dielectric\" }\n",
            "s.toml:2:5: materials.m: missing key `ior` (a dielectric material needs it)",
        ),
        (
            "[[sphere]]\ncenter = [0, 0, 0]\nmaterial = { type = \"metal\", albedo = [1, true, 1] }\nradius = 1\n",
            "s.toml:3:43: sphere[0].material.albedo[1]: expected a number, found the boolean true",
        ),
        (
            "[[sphere]]\ncenter = [0, 0, 0]\nmaterial = \"m\"\n",
            "s.toml:1:1: sphere[0]: missing key `radius`",
        ),
        (
            "[camera]\nkeyframes = [ { time = 1979-05-27 } ]\n",
            "s.toml:2:24: camera.keyframes[0].time: expected a number, found the date-time 1979-05-27",
        ),
        (
            "[camera]\nkeyframes = 3\n",
            "s.toml:2:13: camera.keyframes: expected an array, found the integer 3",
        ),
        (
            "[materials]\nm = [1]\n",
            "s.toml:2:5: materials.m: expected a material table, found an array of 1 value",
        ),
        (
            "sphere = 1\n",
            "s.toml:1:10: sphere: expected an array, found the integer 1",
        ),
    ] {
        let e = err(text);
        assert_eq!(first_line(&e), want, "{text}");
        // The source line follows, with a caret.
        assert!(e.lines().nth(3).is_some_and(|l| l.contains('^')), "{e}");
    }
}

#[test]
fn shutter_curves_and_rolling_shutters_parse() {
    use raytrace_core::shutter::{ReadoutDirection, RollingShutter, ShutterCurve};
    let s = ok("[shot]\nshutter = 0.02\n");
    assert_eq!(
        (s.shot.curve.clone(), s.shot.rolling),
        (ShutterCurve::Box, None)
    );
    for (written, curve) in [
        ("\"box\"", ShutterCurve::Box),
        ("\"triangle\"", ShutterCurve::Triangle),
        (
            "[[0, 0], [0.2, 1], [0.8, 1.0], [1.0, 0]]",
            ShutterCurve::Points(vec![(0.0, 0.0), (0.2, 1.0), (0.8, 1.0), (1.0, 0.0)]),
        ),
        (
            "[[0, 0.5], [1, 0]]",
            ShutterCurve::Points(vec![(0.0, 0.5), (1.0, 0.0)]),
        ),
    ] {
        let s = ok(&format!("[shot]\nshutter_curve = {written}\n"));
        assert_eq!(s.shot.curve, curve, "{written}");
    }
    let s = ok("[shot]\nrolling_shutter = { readout = 0.01 }\n");
    assert_eq!(
        s.shot.rolling,
        Some(RollingShutter {
            readout: 0.01,
            direction: ReadoutDirection::TopToBottom
        })
    );
    let s = ok("[shot]\nrolling_shutter = { readout = 0, direction = \"bottom-to-top\" }\n");
    assert_eq!(
        s.shot.rolling,
        Some(RollingShutter {
            readout: 0.0,
            direction: ReadoutDirection::BottomToTop
        })
    );
}

#[test]
fn bad_shutter_curves_are_named_at_their_place() {
    for (curve, want) in [
        (
            "\"gauss\"",
            "s.toml:2:17: shot.shutter_curve: expected \"box\", \"triangle\" or an array of [s, w] points, found \"gauss\"",
        ),
        (
            "[[0, 0], [0.5, 1], [0.4, 1], [1, 0]]",
            "s.toml:2:37: shot.shutter_curve[2][0]: expected a number greater than 0.5 and less than 1, found the number 0.4",
        ),
        (
            "[[0.1, 0], [1, 1]]",
            "s.toml:2:19: shot.shutter_curve[0][0]: expected 0 (the first point's s), found the number 0.1",
        ),
        (
            "[[0, 0], [0.5, -1], [1, 0]]",
            "s.toml:2:32: shot.shutter_curve[1][1]: expected a finite number >= 0 (the weight w), found the integer -1",
        ),
        (
            "[[0, 0], [0.5, inf], [1, 0]]",
            "s.toml:2:32: shot.shutter_curve[1][1]: expected a finite number >= 0 (the weight w), found the number inf",
        ),
        (
            "[[0, 0], [0.5, 1], [0.9, 0]]",
            "s.toml:2:37: shot.shutter_curve[2][0]: expected 1 (the last point's s, after 0.5), found the number 0.9",
        ),
        (
            "[[0, 1]]",
            "s.toml:2:17: shot.shutter_curve: expected at least 2 points [s, w], found 1",
        ),
        (
            "[[0, 1], [1e-300, 1], [1e-301, 1], [1, 1]]",
            "s.toml:2:40: shot.shutter_curve[2][0]: expected a number greater than 1e-300 and less than 1, found the number 1e-301",
        ),
        (
            "[[0, 0], [1, 0]]",
            "s.toml:2:17: shot.shutter_curve: expected a weight w above 0 somewhere (a shutter that opens), found only zeros",
        ),
        (
            "[[0, 0, 1], [1, 1]]",
            "s.toml:2:18: shot.shutter_curve[0]: expected 2 numbers [s, w], found 3",
        ),
        (
            "[[0, 0], 1]",
            "s.toml:2:26: shot.shutter_curve[1]: expected an array of 2 numbers [s, w], found the integer 1",
        ),
        (
            "[[0, 0], [0.5, \"1\"], [1, 0]]",
            "s.toml:2:32: shot.shutter_curve[1][1]: expected a number, found the string \"1\"",
        ),
    ] {
        let text = format!("[shot]\nshutter_curve = {curve}\n");
        let e = err(&text);
        assert_eq!(first_line(&e), want, "{text}");
        assert!(e.lines().nth(3).is_some_and(|l| l.contains('^')), "{e}");
    }
    // As many points as any array holds, and not one more.
    let points = |n: usize| {
        let p: Vec<String> = (0..n)
            .map(|i| format!("[{}, 1]", i as f64 / (n - 1) as f64))
            .collect();
        format!("[shot]\nshutter_curve = [{}]\n", p.join(", "))
    };
    assert!(
        matches!(ok(&points(4096)).shot.curve, raytrace_core::shutter::ShutterCurve::Points(p) if p.len() == 4096)
    );
    assert!(
        first_line(&err(&points(4097))).starts_with(
            "s.toml:2:17: shot.shutter_curve: expected an array of at most 4096 values (only shot.shutter_curve takes more than 3 values), found 4097 values"
        )
    );
    for (text, want) in [
        (
            "[shot]\nrolling_shutter = { readout = -0.01 }\n",
            "s.toml: shot.rolling_shutter.readout must be >= 0, got -0.01",
        ),
        (
            "[shot]\nrolling_shutter = { readout = 0.01, direction = \"up\" }\n",
            "s.toml:2:49: shot.rolling_shutter.direction: expected one of \"top-to-bottom\", \"bottom-to-top\", found \"up\"",
        ),
        (
            "[shot]\nrolling_shutter = { direction = \"bottom-to-top\" }\n",
            "s.toml:2:19: shot.rolling_shutter: missing key `readout`",
        ),
        (
            "[shot]\nrolling_shutter = { readout = 0.01, rows = 3 }\n",
            "s.toml:2:", // the unknown key, at its place
        ),
    ] {
        let e = err(text);
        assert!(first_line(&e).starts_with(want), "{text}: {e}");
    }
}

/// No Rust or serde type names in any message, whatever the wrong value.
#[test]
fn messages_hold_no_internal_names() {
    let wrong = [
        "\"s\"",
        "1",
        "1.5",
        "true",
        "[1]",
        "{ a = 1 }",
        "1979-05-27",
        "[]",
    ];
    let fields = [
        ("shot", "fps"),
        ("shot", "frames"),
        ("shot", "shutter_position"),
        ("output", "path"),
        ("render", "sampler"),
        ("render", "device"),
        ("camera", "look_from"),
        ("camera", "orbit"),
        ("camera", "keyframes"),
        ("background", "color"),
        ("materials", "m"),
    ];
    for (table, key) in fields {
        for w in wrong {
            let text = format!("[{table}]\n{key} = {w}\n");
            if let Err(e) = parse(&text, Path::new("s.toml")) {
                let e = e.to_string();
                for name in [
                    "Raw", "struct", "enum", "f64", "i64", "u64", "i128", "sequence", "map",
                    "variant", "field",
                ] {
                    assert!(!e.contains(name), "{text}: {e}");
                }
            }
        }
        for w in wrong {
            let text = format!("[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = {w}\n");
            let e = err(&text);
            assert!(!e.contains("Raw") && !e.contains("enum"), "{text}: {e}");
        }
    }
}

#[test]
fn numbers_are_shown_short_and_as_written() {
    let e = err("[render]\nseed = 18446744073709551615\n");
    assert_eq!(
        e,
        "s.toml: render.seed must be in 0..=9223372036854775807, got 18446744073709551615"
    );
    let e = err("[render]\nseed = 170141183460469231731687303715884105727\n");
    assert!(
        e.ends_with("got 170141183460469231731687303715884105727"),
        "{e}"
    );
    // A tiny fps makes the default shutter angle's shutter overflow: fps is to blame.
    let e = err("[shot]\nfps = 1e-300\n");
    assert_eq!(
        e,
        "s.toml: shot.fps gives a shutter of 5e299 s (shutter_angle 180 / 360 / fps 1e-300), more than 3.4e38; got 1e-300"
    );
    let e = err("[shot]\nfps = 1e-38\nframes = 100\n");
    assert_eq!(
        e,
        "s.toml: shot: the last frame's time (9.925e39 s) is out of range; check shot.fps and shot.frames"
    );
    assert_eq!(raytrace_core::show::show_approx(1.0 / 48.0), "0.02083");
    assert_eq!(
        raytrace_core::show::show_approx(4.9999999999999995e299),
        "5e299"
    );
    assert_eq!(raytrace_core::show::show_approx(123456.0), "123500");
    assert_eq!(raytrace_core::show::show(2.0), "2");
    assert_eq!(raytrace_core::show::show(-0.0), "-0");
    assert_eq!(raytrace_core::show::show(0.1), "0.1");
    assert_eq!(raytrace_core::show::show(1e300), "1e300");
    assert_eq!(raytrace_core::show::show(f64::NEG_INFINITY), "-inf");
}

#[test]
fn integer_fields_take_whole_floats() {
    let s = ok("[shot]\nframes = 2.0\nfirst_frame = 0.0\n[output]\nwidth = 8e0\n");
    assert_eq!(
        (s.shot.frames, s.shot.first_frame, s.output.width),
        (2, 0, 8)
    );
    for (text, want) in [
        (
            "[shot]\nframes = 2.5\n",
            "s.toml: shot.frames must be an integer, got 2.5",
        ),
        (
            "[shot]\nfirst_frame = -0.0\n",
            "s.toml: shot.first_frame must be an integer, got -0 (negative zero)",
        ),
        (
            "[shot]\nframes = 1e16\n",
            "s.toml: shot.frames must be an integer, got 1e16",
        ),
        (
            "[shot]\nframes = 1e15\n",
            "s.toml: shot.frames must be in 1..=4294967295, got 1000000000000000",
        ),
        (
            "[render]\nsamples = nan\n",
            "s.toml: render.samples must be an integer, got nan",
        ),
    ] {
        assert_eq!(err(text), want, "{text}");
    }
}

#[test]
fn long_arrays_are_refused_before_the_parse_whole_or_in_pieces() {
    let text = format!("[camera]\nlook_from = [{}0]\n", "0, ".repeat(4_999_999));
    // The scan's message: the parse (1 GB and seconds for this line) never ran.
    let e = err(&text);
    assert_eq!(
        first_line(&e),
        "s.toml:2:13: camera.look_from: expected an array of at most 4096 values (only shot.shutter_curve takes more than 3 values), found 5000000 values"
    );
    // In a sphere, and in the settings after the spheres, pieces give the same message.
    let sphere = "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = { type = \"dielectric\", ior = 1.5 }\n";
    let long = format!("[{}0]", "0, ".repeat(5000));
    let cases = [
        format!(
            "{}[[sphere]]\nradius = 1\nvelocity = {long}\n{}",
            sphere.repeat(3),
            sphere.repeat(2)
        ),
        format!("{}[camera]\nup = {long}\n", sphere.repeat(3)),
        // A limit passed late in the file is reported before an earlier syntax error.
        format!(
            "{}[[sphere]]\nradius = \n{}[camera]\nup = {long}\n",
            sphere.repeat(3),
            sphere.repeat(2)
        ),
    ];
    for text in &cases {
        same_both_ways(text, true);
        let e = err(text);
        assert!(e.contains("found 5001 values"), "{e}");
    }
}

#[test]
fn binary_garbage_gets_a_place() {
    let e = Scene::parse_bytes(b"[shot]\nfps = 1\n# caf\xe9\n", Path::new("s.toml"))
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "s.toml:3:6: the file is not UTF-8 text: byte 0xE9\n  |\n3 | # caf\u{fffd}\n  |      ^"
    );
    let e = Scene::parse_bytes(b"\xff\xfe[\x00s", Path::new("s.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("s.toml:1:1: the file is not UTF-8 text: byte 0xFF (the file looks like UTF-16; scenes are UTF-8)"),
        "{e}"
    );
    let e = Scene::parse_bytes(b"a = 1 # \xe2\x82", Path::new("s.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("s.toml:1:9: the file ends inside a UTF-8 character: 0xE2 0x82"),
        "{e}"
    );
    for (text, want) in [
        (
            "[shot]\nfps = 1\0\n",
            "s.toml:2:8: control character U+0000 in the text",
        ),
        (
            "[shot]\nf\0ps = 1\n",
            "s.toml:2:2: control character U+0000 in the text",
        ),
        (
            "[output]\npath = \"a\u{1b}b.png\"\n",
            "s.toml:2:10: control character U+001B",
        ),
    ] {
        let e = err(text);
        assert!(e.starts_with(want), "{text:?}: {e}");
    }
    // Escaped, a control character is a string's business (here: no file extension).
    let e = err("[output]\npath = \"a\\u0000b\"\n");
    assert!(e.starts_with("s.toml: output.path \"a\\u{0}b\""), "{e}");
    // Long names are cut, long lists shortened.
    let mut text = String::from("[materials]\n");
    for i in 0..20 {
        text.push_str(&format!(
            "m{i:02} = {{ type = \"dielectric\", ior = 1.5 }}\n"
        ));
    }
    text.push_str(&format!(
        "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"{}\"\n",
        "x".repeat(1000)
    ));
    let e = err(&text);
    assert!(e.len() < 200, "{e}");
    assert!(
        e.contains("(known: m00, m01, m02, m03, m04, m05, m06, m07, m08, m09, and 10 more)"),
        "{e}"
    );
}

#[test]
fn only_regular_files_of_bounded_size_are_read() {
    use std::time::Duration;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let refused = |p: &Path, want: &str| {
        let e = Scene::load(p).unwrap_err();
        assert_eq!(e.exit_code(), 2, "{e}");
        let e = e.to_string();
        assert!(e.starts_with(&p.display().to_string()), "{e}");
        assert!(e.contains(want), "{e}");
    };
    refused(d, "is a directory, not a scene file");
    refused(&d.join("missing.toml"), "No such file");
    std::os::unix::fs::symlink(d.join("b.toml"), d.join("a.toml")).unwrap();
    std::os::unix::fs::symlink(d.join("a.toml"), d.join("b.toml")).unwrap();
    refused(&d.join("a.toml"), "symbolic links");
    refused(Path::new("/dev/zero"), "is a device");
    // A sparse file larger than the limit is refused from its size, unread.
    let big = d.join("big.toml");
    std::fs::File::create(&big)
        .unwrap()
        .set_len(MAX_FILE_BYTES + 1)
        .unwrap();
    refused(&big, "is 2.0 GiB, more than the 2 GiB a scene file may be");
    // A file whose size says 0 (as /proc files do) is still read no further than the limit.
    let e = read_scene(Path::new("/proc/self/status"), 16).unwrap_err();
    assert!(
        e.to_string()
            .ends_with("is longer than its size says, more than the 16 bytes a scene file may be"),
        "{e}"
    );
    // A named pipe is refused without waiting for a writer.
    let fifo = d.join("pipe.toml");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|s| s.success()) {
        let (tx, rx) = std::sync::mpsc::channel();
        let f = fifo.clone();
        std::thread::spawn(move || tx.send(Scene::load(&f).map(|_| ()).map_err(|e| e.to_string())));
        let e = rx
            .recv_timeout(Duration::from_secs(20))
            .expect("loading a named pipe blocked")
            .unwrap_err();
        assert!(e.contains("is a named pipe, not a scene file"), "{e}");
    }
    let good = d.join("good.toml");
    std::fs::write(&good, "[shot]\nframes = 2\n").unwrap();
    assert_eq!(Scene::load(&good).unwrap().shot.frames, 2);
}

#[test]
fn camera_paths_are_checked_between_keys_exactly() {
    let sphere = "[[sphere]]\ncenter = [0, 0, -1]\nradius = 0.5\nmaterial = {type = \"lambertian\", albedo = [0.5, 0.5, 0.5]}\n";
    // look_from passes through look_at half-way between two keys where both views are fine.
    let text = format!(
        "[shot]\nfps = 1\nstart_time = 0.5\nshutter = 0\n[camera]\nlook_from = [0, 0, 1]\nlook_at = [0, 0, 0]\nkeyframes = [{{time = 0}}, {{time = 1, look_from = [0, 0, -1]}}]\n{sphere}"
    );
    assert_eq!(
        err(&text),
        "s.toml: camera.keyframes[0..1]: look_from meets look_at at t = 0.5 s"
    );
    // The view turns through straight down (parallel to up) between the keys.
    let text = "[camera]\nlook_at = [0, 0, 0]\nkeyframes = [{time = 2, look_from = [-1, 1, 0]}, {time = 4, look_from = [1, 1, 0]}]\n";
    assert_eq!(
        err(text),
        "s.toml: camera.keyframes[0..1]: the view direction [0, -1, 0] is parallel to camera.up [0, 1, 0] at t = 3 s"
    );
    // Within the tolerance, not exactly.
    let text = "[camera]\nup = [0, 0, 1]\nlook_at = [0, 0, 0]\nkeyframes = [{time = 0, look_from = [-1, 1e-13, 0]}, {time = 1, look_from = [1, 1e-13, 0]}]\n";
    assert_eq!(
        err(text),
        "s.toml: camera.keyframes[0..1]: look_from comes within 1e-13 of look_at at t = 0.5 s, too close to give a view direction (at most 1e-12 of their distance from the origin, or 1e-100)"
    );
    let text = "[camera]\nlook_at = [0, 0, 0]\nkeyframes = [{time = 0, look_from = [-1, 1, 1e-12]}, {time = 1, look_from = [1, 1, 1e-12]}]\n";
    assert!(
        err(text).starts_with(
            "s.toml: camera.keyframes[0..1]: the view direction [0, -1, -1e-12] is within 5.73e-11 degrees of camera.up [0, 1, 0] at t = 0.5 s"
        ),
        "{}",
        err(text)
    );
    // The same paths just clear of the tolerance are fine, and the third segment is checked.
    ok(
        "[camera]\nup = [0, 0, 1]\nlook_at = [0, 0, 0]\nkeyframes = [{time = 0, look_from = [-1, 1e-11, 0]}, {time = 1, look_from = [1, 1e-11, 0]}]\n",
    );
    let e = err(
        "[camera]\nlook_at = [0, 0, 0]\nkeyframes = [{time = 0, look_from = [0, 0, 1]}, {time = 1, look_from = [1, 0, 1]}, {time = 2, look_from = [1, 0, 2]}, {time = 3, look_from = [-1, 0, -2]}]\n",
    );
    assert_eq!(
        e,
        "s.toml: camera.keyframes[2..3]: look_from meets look_at at t = 2.5 s"
    );
    // Near-coincident points far from the origin: the view is lost to rounding.
    let e = err("[camera]\nlook_from = [1e6, 0, 0]\nlook_at = [1e6, 0, 1e-7]\n");
    assert!(
        e.starts_with("s.toml: camera: look_from comes within 1e-7 of look_at, too close"),
        "{e}"
    );
    ok("[camera]\nlook_from = [1e6, 0, 0]\nlook_at = [1e6, 0, 1e-5]\n");
    // An orbit starting on its axis looks along up all the way round.
    let e = err(
        "[camera]\nlook_from = [0, 5, 0]\nlook_at = [0, 0, 0]\norbit = { degrees_per_second = 10 }\n",
    );
    assert_eq!(
        e,
        "s.toml: camera: the view direction [0, -5, 0] is parallel to camera.up [0, 1, 0]"
    );
    // An up vector too short to normalize.
    let e = err("[camera]\nup = [0, 1e-200, 0]\n");
    assert_eq!(
        e,
        "s.toml: camera.up [0, 1e-200, 0] is too short (1e-200), at least 1e-100"
    );
    ok("[camera]\nup = [0, 1e-50, 0]\n");
}

#[test]
fn orbit_axes_of_any_length_are_normalised_exactly() {
    for scale in ["1e-300", "1e-160", "1", "3e38"] {
        let s = ok(&format!(
            "[[sphere]]\ncenter = [1, 0, 0]\nradius = 0.1\nmaterial = {{ type = \"lambertian\", albedo = [1, 1, 1] }}\norbit = {{ pivot = [0, 0, 0], axis = [0, {scale}, 0], degrees_per_second = 10 }}\n"
        ));
        let Motion::Orbit { orbit, .. } = &s.spheres[0].motion else {
            panic!()
        };
        assert_eq!(orbit.axis, DVec3::Y, "{scale}");
    }
}

#[test]
fn colours_are_bounded_so_no_pixel_can_overflow() {
    for (text, want) in [
        (
            "[background]\ncolor = [3e38, 1, 1]\n",
            "s.toml: background.color[0] must be in [0, 1000000], got 3e38",
        ),
        (
            "[materials]\nm = { type = \"metal\", albedo = [1, 3e38, 1] }\n",
            "s.toml: materials.m.albedo[1] must be in [0, 1], got 3e38",
        ),
        (
            "[materials]\nm = { type = \"lambertian\", albedo = [1, 1, 1.0000001] }\n",
            "s.toml: materials.m.albedo[2] must be in [0, 1], got 1.0000001",
        ),
    ] {
        assert_eq!(err(text), want);
    }
    let s = ok(
        "[background]\ncolor = [1e6, 0, 1]\n[materials]\nm = { type = \"metal\", albedo = [1, 0, 1] }\n",
    );
    assert_eq!(s.background, Background::Uniform(DVec3::new(1e6, 0.0, 1.0)));
}

#[test]
fn passes_and_a_transparent_background_parse_and_are_checked() {
    use raytrace_core::pass::{Pass, PassSet};
    let s = ok(
        "[output]\npath = \"o.exr\"\npasses = [\"motion\", \"alpha\"]\n[background]\ntransparent = true\n",
    );
    assert_eq!(
        s.output.passes,
        PassSet::EMPTY.with(Pass::Alpha).with(Pass::Motion)
    );
    assert!(s.transparent);
    // Without a colour the background is still the sky.
    assert_eq!(s.background, Background::Sky);
    let s = ok("[background]\ncolor = [0.5, 0.5, 0.5]\n");
    assert!(!s.transparent && s.output.passes.is_empty());
    // A PNG takes alpha.
    assert!(
        ok("[output]\npasses = [\"alpha\"]\n")
            .output
            .passes
            .contains(Pass::Alpha)
    );
    assert_eq!(
        first_line(&err("[output]\npasses = [\"alpha\", \"beauty\"]\n")),
        "s.toml:2:20: output.passes[1]: expected one of \"alpha\", \"depth\", \"normal\", \"albedo\", \"motion\", \"variance\", \"samples\", \"noisy\", found \"beauty\""
    );
    assert_eq!(
        first_line(&err("[background]\ntransparent = 1\n")),
        "s.toml:2:15: background.transparent: expected a boolean, found the integer 1"
    );
    assert_eq!(
        err("[output]\npath = \"o.exr\"\npasses = [\"depth\", \"normal\", \"depth\"]\n"),
        "s.toml: output.passes: \"depth\" is listed twice (entry 2); list each pass once"
    );
    assert!(
        err("[output]\npasses = [\"alpha\", \"variance\"]\n").starts_with(
            "s.toml: output.passes: pass \"variance\" cannot be written to a PNG output (output.path ends in .png)"
        )
    );
    // The flag replaces the file's list, and messages name it.
    let o = Overrides {
        passes: Some(vec![Pass::Depth]),
        ..Overrides::default()
    };
    let text = "[output]\npath = \"o.exr\"\npasses = [\"alpha\"]\n";
    let s = Scene::parse_with(text, Path::new("s.toml"), &o).unwrap();
    assert_eq!(s.output.passes, PassSet::EMPTY.with(Pass::Depth));
    let o = Overrides {
        passes: Some(vec![Pass::Alpha, Pass::Alpha]),
        ..Overrides::default()
    };
    let e = Scene::parse_with(text, Path::new("s.toml"), &o).unwrap_err();
    assert_eq!(
        e.to_string(),
        "--passes: \"alpha\" is listed twice (entry 1); list each pass once"
    );
}

#[test]
fn the_device_is_the_cpu_unless_the_file_or_the_flag_names_the_gpu() {
    use raytrace_core::scene::Device;
    assert_eq!(ok("").render.device, Device::Cpu);
    assert_eq!(
        ok("[render]\ndevice = \"gpu\"\n").render.device,
        Device::Gpu
    );
    assert_eq!(
        ok("[render]\ndevice = \"cpu\"\n").render.device,
        Device::Cpu
    );
    assert_eq!(
        first_line(&err("[render]\ndevice = \"tpu\"\n")),
        "s.toml:2:10: render.device: expected one of \"cpu\", \"gpu\", found \"tpu\""
    );
    let gpu = Overrides {
        device: Some(Device::Gpu),
        ..Overrides::default()
    };
    let s = Scene::parse_with("[render]\ndevice = \"cpu\"\n", Path::new("s.toml"), &gpu).unwrap();
    assert_eq!(s.render.device, Device::Gpu);
}
