//! Hostile point caches: each bad cache makes `render` and `check` exit 2 within 5 seconds
//! under a 1 GiB address-space limit, with a message naming the file (and the frame) and
//! what is wrong, no panic, and nothing written.

use crate::common;

use std::path::Path;
use std::process::{Command, Output};

use common::{run_limited, text};
use raytrace_scene::ply::{Column, Encoding, Scalar, write_vertices};

const SECONDS: u64 = 5;
const MEMORY_KIB: u64 = 1 << 20;

/// A scene of one sphere and a cache whose file (or sequence) is `file`.
fn scene(file: &str) -> String {
    format!(
        "[shot]\nframes = 2\n[output]\npath = \"out/f_####.png\"\nwidth = 8\nheight = 6\n\
         [render]\nsamples = 2\n[camera]\nlook_from = [0.0, 0.0, 5.0]\n\
         [[sphere]]\ncenter = [0.0, 0.0, -1.0]\nradius = 0.5\n\
         material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\n\
         [[points]]\nfile = \"{file}\"\nmaterial = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\nradius = 0.1\n"
    )
}

/// A binary little-endian PLY file of three points with float `x y z` and the extra
/// `columns`, with `bad` (point, column, value) written over one value.
fn ply(columns: &[(&str, Scalar)], bad: Option<(usize, &str, f64)>) -> Vec<u8> {
    let mut names = vec![("x", Scalar::F32), ("y", Scalar::F32), ("z", Scalar::F32)];
    names.extend(columns);
    let values: Vec<Vec<f64>> = names
        .iter()
        .map(|(name, _)| {
            (0..3)
                .map(|i| match bad {
                    Some((p, c, v)) if p == i && c == *name => v,
                    _ => 0.5 + i as f64,
                })
                .collect()
        })
        .collect();
    let cols: Vec<Column> = names
        .iter()
        .zip(&values)
        .map(|(&(name, ty), values)| Column { name, ty, values })
        .collect();
    let mut out = Vec::new();
    write_vertices(&mut out, Encoding::BinaryLittleEndian, &cols).unwrap();
    out
}

/// Asserts that `render` and `check` of `shot.toml` in `dir` exit 2 with every one of `want`
/// in the message and no panic, and that nothing was written.
fn refused(dir: &Path, want: &[&str]) {
    for args in [
        &["render", "shot.toml", "--threads", "2"][..],
        &["check", "shot.toml"][..],
    ] {
        let o: Output = run_limited(dir, args, SECONDS, MEMORY_KIB);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {t}");
        for w in want {
            assert!(t.contains(w), "{args:?}: {w:?} missing in: {t}");
        }
        assert!(!t.contains("panicked"), "{t}");
        assert!(!dir.join("out").exists(), "{args:?} wrote something");
    }
}

/// A folder with the scene (its cache `file`) and the files `files` (name, bytes).
fn setup(file: &str, files: &[(&str, Vec<u8>)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), scene(file)).unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    dir
}

#[test]
fn a_missing_file_and_frames_past_the_last_are_refused_naming_frame_and_file() {
    let d = setup("gone.ply", &[]);
    refused(d.path(), &["gone.ply", "frame 1", "No such file"]);
    // A sequence with a file for frame 1 only: frame 2 is past its last file.
    let d = setup("seq_####.ply", &[("seq_0001.ply", ply(&[], None))]);
    refused(d.path(), &["seq_0002.ply", "frame 2", "No such file"]);
}

#[test]
fn truncated_data_is_refused() {
    let mut bytes = ply(&[], None);
    bytes.truncate(bytes.len() - 5);
    let d = setup("t.ply", &[("t.ply", bytes)]);
    refused(
        d.path(),
        &[
            "t.ply",
            "declares 3 vertex rows",
            "truncated, or a wrong count",
        ],
    );
    // Text that ends early, long enough for its count: found as it is read, with the point.
    let text = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0.000 0.000 0.000\n1.000 1.000 1.000\n2.000 2.000\n";
    let d = setup("a.ply", &[("a.ply", text.to_vec())]);
    refused(
        d.path(),
        &["a.ply", "truncated: the file ends in vertex 2 of 3"],
    );
}

#[test]
fn a_header_declaring_more_points_than_the_file_holds_is_refused_before_allocating() {
    for count in ["1000000000", "2147483648", "18446744073709551615"] {
        let header = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {count}\nproperty double x\nproperty double y\nproperty double z\nproperty double radius\nend_header\n"
        );
        let mut bytes = header.into_bytes();
        bytes.extend([0u8; 64]);
        let d = setup("big.ply", &[("big.ply", bytes)]);
        refused(
            d.path(),
            &[
                "big.ply",
                &format!("declares {count} vertex rows"),
                "holds only 64 bytes",
            ],
        );
    }
}

#[test]
fn a_vertex_count_of_2_to_the_31_with_its_bytes_claimed_is_refused() {
    // A file as large as 2^31 one-byte points claim, sparse: nothing is allocated for them,
    // and a frame may hold at most 2^28 points.
    let header = "ply\nformat binary_little_endian 1.0\nelement vertex 2147483648\nproperty uchar x\nproperty uchar y\nproperty uchar z\nend_header\n";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), scene("huge.ply")).unwrap();
    let f = std::fs::File::create(dir.path().join("huge.ply")).unwrap();
    use std::io::Write;
    (&f).write_all(header.as_bytes()).unwrap();
    f.set_len(header.len() as u64 + 3 * (1 << 31)).unwrap();
    refused(
        dir.path(),
        &["huge.ply", "2147483648 points", "more than the 268435456"],
    );
}

#[test]
fn a_cache_without_x_is_refused() {
    let text = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nproperty float z\nend_header\n1 2\n";
    let d = setup("n.ply", &[("n.ply", text.to_vec())]);
    refused(d.path(), &["n.ply", "the vertex element has y but not x"]);
    let text = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\nend_header\n1 2\n";
    let d = setup("n.ply", &[("n.ply", text.to_vec())]);
    refused(d.path(), &["n.ply", "has x but not y"]);
}

#[test]
fn non_finite_positions_radii_and_velocities_are_refused_naming_the_point() {
    // (extra columns, (point, column, bad value), what the message says)
    type Case<'a> = (&'a [(&'a str, Scalar)], (usize, &'a str, f64), &'a str);
    let cases: [Case; 6] = [
        (
            &[],
            (1, "x", f64::NAN),
            "point 1: x is NaN, not a finite number",
        ),
        (
            &[],
            (2, "z", f64::INFINITY),
            "point 2: z is inf, not a finite number",
        ),
        (
            &[("radius", Scalar::F32)],
            (0, "radius", f64::NEG_INFINITY),
            "point 0: radius is -inf",
        ),
        (
            &[("pscale", Scalar::F64)],
            (2, "pscale", f64::NAN),
            "point 2: pscale is NaN",
        ),
        (
            &[
                ("vx", Scalar::F32),
                ("vy", Scalar::F32),
                ("vz", Scalar::F32),
            ],
            (1, "vy", f64::NAN),
            "point 1: vy is NaN",
        ),
        (
            &[("radius", Scalar::F64)],
            (0, "radius", 1e300),
            "point 0: radius is 1e300, beyond the 3.4e38",
        ),
    ];
    for (columns, bad, want) in cases {
        let d = setup("v.ply", &[("v.ply", ply(columns, Some(bad)))]);
        refused(d.path(), &["v.ply", "frame 1", want]);
    }
}

#[test]
fn a_negative_radius_is_refused() {
    let bytes = ply(&[("radius", Scalar::F32)], Some((2, "radius", -0.25)));
    let d = setup("r.ply", &[("r.ply", bytes)]);
    refused(
        d.path(),
        &["r.ply", "point 2: radius is -0.25; a radius must be >= 0"],
    );
}

#[test]
fn list_properties_where_numbers_are_expected_are_refused() {
    let text = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nproperty float y\nproperty float z\nend_header\n2 1 2 3 4\n";
    let d = setup("l.ply", &[("l.ply", text.to_vec())]);
    refused(
        d.path(),
        &[
            "l.ply",
            "property x is a list; a single number was expected",
        ],
    );
    let text = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar float radius\nend_header\n1 2 3 1 0.5\n";
    let d = setup("l.ply", &[("l.ply", text.to_vec())]);
    refused(d.path(), &["l.ply", "property radius is a list"]);
}

#[test]
fn a_directory_or_a_named_pipe_as_the_file_is_refused() {
    let d = setup("dir.ply", &[]);
    std::fs::create_dir(d.path().join("dir.ply")).unwrap();
    refused(d.path(), &["dir.ply", "is a directory, not a PLY file"]);
    let d = setup("pipe.ply", &[]);
    let made = Command::new("mkfifo")
        .arg(d.path().join("pipe.ply"))
        .status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo");
    refused(d.path(), &["pipe.ply", "is a named pipe, not a PLY file"]);
}

#[test]
fn colours_out_of_range_duplicate_ids_and_missing_velocities_are_refused() {
    let head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n";
    let text = format!(
        "{head}property float r\nproperty float g\nproperty float b\nend_header\n0 0 0 0.5 0.5 0.5\n1 1 1 0.5 1.5 0.5\n"
    );
    let d = setup("c.ply", &[("c.ply", text.into_bytes())]);
    refused(d.path(), &["c.ply", "point 1: g is 1.5, outside 0 to 1"]);
    let text = format!(
        "{head}property short red\nproperty uchar green\nproperty uchar blue\nend_header\n0 0 0 300 0 0\n1 1 1 0 0 0\n"
    );
    let d = setup("c.ply", &[("c.ply", text.into_bytes())]);
    refused(
        d.path(),
        &["c.ply", "point 0: red is 300, outside 0 to 255"],
    );
    // Interpolated by id, with an id twice in the next frame's file.
    let ids = |dup: bool| {
        let bad = dup.then_some((2, "id", 0.0));
        ply(&[("id", Scalar::I32)], bad)
    };
    let dir = tempfile::tempdir().unwrap();
    let text =
        scene("s_#.ply").replace("radius = 0.1\n", "radius = 0.1\nmotion = \"interpolate\"\n");
    std::fs::write(dir.path().join("shot.toml"), text).unwrap();
    std::fs::write(dir.path().join("s_1.ply"), ids(false)).unwrap();
    std::fs::write(dir.path().join("s_2.ply"), ids(true)).unwrap();
    refused(
        dir.path(),
        &["s_2.ply", "frame 2", "id 0 is held by two points (0 and 2)"],
    );
    // motion = "velocity" with no velocities in the file.
    let d = setup("v.ply", &[("v.ply", ply(&[], None))]);
    let text = scene("v.ply").replace("radius = 0.1\n", "radius = 0.1\nmotion = \"velocity\"\n");
    std::fs::write(d.path().join("shot.toml"), text).unwrap();
    refused(
        d.path(),
        &[
            "v.ply",
            "motion = \"velocity\", but the vertex element has no velocity columns (vx vy vz",
        ],
    );
}

#[test]
fn a_bad_cache_in_a_later_frame_keeps_the_frames_before_it() {
    // Values are checked as each frame's points are read: frame 2's NaN stops the run with
    // exit 2 after frame 1 is written, which stays whole (README, docs/robustness.md and
    // docs/scene-format.md say so alike).
    use common::hostile::{points, scene, setup};
    let header = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n\
                  property float y\nproperty float z\nend_header\n";
    let good = format!("{header}0 0 0\n");
    let bad = format!("{header}0 nan 0\n");
    let d = setup(
        &scene("f_####.png", &points("c_####.ply", "")),
        &[
            ("c_0001.ply", good.as_bytes()),
            ("c_0002.ply", bad.as_bytes()),
        ],
    );
    let o = run_limited(d.path(), &["render", "shot.toml"], SECONDS, MEMORY_KIB);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("shot.toml: points[0]: frame 2: c_0002.ply: point 0: y is NaN"),
        "{t}"
    );
    let first = image::open(d.path().join("f_0001.png")).unwrap();
    assert_eq!((first.width(), first.height()), (8, 6));
    // Nothing of frame 2, not even a temporary file.
    assert_eq!(
        common::hostile::names(d.path()),
        ["c_0001.ply", "c_0002.ply", "f_0001.png", "shot.toml"]
    );
}
