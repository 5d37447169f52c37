//! A real LAMMPS simulation (examples/lammps/crossing.in: a Lennard-Jones gas whose atoms cross
//! the faces of its periodic box) rendered from its dumps, against answers known in advance:
//!
//! - a snapshot written as a PLY file (by this test, from the dump's text) renders the same
//!   bits as the dump;
//! - the dump of scaled positions (`xs ys zs`) renders the same bits as the dump of positions
//!   (`x y z`), and so does the dump with image flags, the same dump gzipped, and the series
//!   of one file a snapshot (`dump.*.lammpstrj`);
//! - an atom whose path crosses a face of the box during the shutter renders as the two
//!   spheres placed by hand on either side (a PLY file of the atoms moved into the box and
//!   their copies across the faces, computed here).
//!
//! `lmp` comes from Debian's `lammps` package (`.ci/run` installs it); without it the tests
//! are skipped with a note, except under CI=true, where they fail.

use crate::common;

use std::io::Write;
use std::path::{Path, PathBuf};

use common::{assert_same_bits, have_lammps, render_bits, run_lammps};
use glam::DVec3;
use raytrace_scene::ply::{Column, Encoding, Scalar, write_vertices};

/// The shot's rate, and the time between the dump's snapshots in LAMMPS time units (20 steps
/// of 0.005): a snapshot a frame, velocities scaled into units per second.
const FPS: f64 = 24.0;
const SNAPSHOT_TAU: f64 = 0.1;
const SIDE: f64 = 8.0;

/// Runs the simulation in a new folder; its dumps are there.
fn simulate() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/lammps/crossing.in");
    run_lammps(&input, dir.path());
    dir
}

/// A scene of the shot (frames 1 to 11, a snapshot each) with `points` as its cache table.
fn scene(points: &str) -> String {
    format!(
        r#"[shot]
fps = {FPS:?}
frames = 11
[output]
width = 48
height = 36
passes = ["albedo", "depth"]
[render]
samples = 2
max_depth = 3
[camera]
look_from = [4.0, 4.0, 22.0]
look_at = [4.0, 4.0, 4.0]
vfov = 36.0
[materials]
grey = {{ type = "lambertian", albedo = [0.6, 0.5, 0.4] }}
[[points]]
material = "grey"
radius = 0.35
{points}
"#
    )
}

/// The lines `velocity_scale` and friends for the dump `file`.
fn dump(file: &str, extra: &str) -> String {
    format!(
        "file = \"{file}\"\nvelocity_scale = {:?}\n{extra}",
        SNAPSHOT_TAU * FPS
    )
}

/// A snapshot as the test reads it: ids, positions, velocities (scaled into units per
/// second as the scene scales them).
struct Atoms {
    centers: Vec<DVec3>,
    velocities: Vec<DVec3>,
}

/// Snapshot `k` (from 0) of a dump with columns `id type x y z vx vy vz ...`.
fn snapshot(path: &Path, k: usize) -> Atoms {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let mut seen = 0;
    loop {
        let line = lines.next().expect("the snapshot");
        if line != "ITEM: NUMBER OF ATOMS" {
            continue;
        }
        let n: usize = lines.next().unwrap().trim().parse().unwrap();
        if seen < k {
            seen += 1;
            continue;
        }
        for _ in 0..4 {
            lines.next();
        }
        let header = lines.next().unwrap();
        assert!(
            header.starts_with("ITEM: ATOMS id type x y z vx vy vz"),
            "{header}"
        );
        let mut atoms = Atoms {
            centers: Vec::new(),
            velocities: Vec::new(),
        };
        for line in lines.take(n) {
            let f: Vec<f64> = line
                .split_whitespace()
                .map(|x| x.parse().unwrap())
                .collect();
            atoms.centers.push(DVec3::new(f[2], f[3], f[4]));
            atoms
                .velocities
                .push(DVec3::new(f[5], f[6], f[7]) * (SNAPSHOT_TAU * FPS));
        }
        return atoms;
    }
}

/// Writes `atoms` as a binary PLY file of doubles (every value exact).
fn write_ply(path: &Path, atoms: &Atoms) {
    let col = |f: &dyn Fn(usize) -> f64| -> Vec<f64> { (0..atoms.centers.len()).map(f).collect() };
    let values = [
        col(&|i| atoms.centers[i].x),
        col(&|i| atoms.centers[i].y),
        col(&|i| atoms.centers[i].z),
        col(&|i| atoms.velocities[i].x),
        col(&|i| atoms.velocities[i].y),
        col(&|i| atoms.velocities[i].z),
    ];
    let names = ["x", "y", "z", "vx", "vy", "vz"];
    let cols: Vec<Column> = names
        .iter()
        .zip(&values)
        .map(|(name, values)| Column {
            name,
            ty: Scalar::F64,
            values,
        })
        .collect();
    let mut bytes = Vec::new();
    write_vertices(&mut bytes, Encoding::BinaryLittleEndian, &cols).unwrap();
    std::fs::write(path, bytes).unwrap();
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The dump's first snapshot as a PLY file renders the same bits as the dump (the box
/// ignored, so neither moves nor copies an atom).
#[test]
fn a_snapshot_renders_as_the_same_points_written_as_ply() {
    if !have_lammps() {
        return;
    }
    let d = simulate();
    let dir = d.path();
    write_ply(
        &dir.join("first.ply"),
        &snapshot(&dir.join("dump.x.lammpstrj"), 0),
    );
    write(
        dir,
        "dump.toml",
        &scene(&dump("dump.x.lammpstrj", "periodic = false\n")),
    );
    write(dir, "ply.toml", &scene("file = \"first.ply\"\n"));
    assert_same_bits(
        &render_bits(dir, "dump.toml", 1..=1),
        &render_bits(dir, "ply.toml", 1..=1),
    );
}

/// Scaled positions, image flags, gzip and a series of one file a snapshot render as the
/// plain dump does, frame for frame.
#[test]
fn every_form_of_the_dump_renders_the_same_bits() {
    if !have_lammps() {
        return;
    }
    let d = simulate();
    let dir = d.path();
    let text = std::fs::read(dir.join("dump.x.lammpstrj")).unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(&text).unwrap();
    std::fs::write(dir.join("dump.x.lammpstrj.gz"), gz.finish().unwrap()).unwrap();
    let frames = 1..=4;
    write(dir, "x.toml", &scene(&dump("dump.x.lammpstrj", "")));
    let reference = render_bits(dir, "x.toml", frames.clone());
    for (name, file) in [
        ("xs.toml", "dump.xs.lammpstrj"),
        ("u.toml", "dump.u.lammpstrj"),
        ("gz.toml", "dump.x.lammpstrj.gz"),
        ("series.toml", "dump.*.lammpstrj"),
    ] {
        write(dir, name, &scene(&dump(file, "format = \"lammps\"\n")));
        assert_same_bits(&reference, &render_bits(dir, name, frames.clone()));
    }
}

/// Where each atom is drawn, computed by hand: its path over the frame's shutter moved by
/// whole boxes to start inside the box, and a copy across each face it crosses.
fn placed_by_hand(atoms: &Atoms, time: f64, open: f64, close: f64) -> (Atoms, usize) {
    let mut out = Atoms {
        centers: Vec::new(),
        velocities: Vec::new(),
    };
    let mut copies = Vec::new();
    for (&p, &v) in atoms.centers.iter().zip(&atoms.velocities) {
        let start = p + v * (open - time);
        let end = p + v * (close - time);
        let shift = -(start / SIDE).floor() * SIDE;
        let crossed = ((end + shift) / SIDE).floor();
        out.centers.push(p + shift);
        out.velocities.push(v);
        // One face crossed per direction at most in this simulation; two at once: a copy
        // across both as well.
        for mask in 1..8u32 {
            let pick = |k: usize| {
                if mask & (1 << k) != 0 {
                    crossed[k]
                } else {
                    0.0
                }
            };
            let through = DVec3::new(pick(0), pick(1), pick(2));
            let used = (0..3).all(|k| mask & (1 << k) == 0 || crossed[k] != 0.0);
            if used {
                copies.push((p, shift - through * SIDE, v));
            }
        }
    }
    let n = copies.len();
    for (p, s, v) in copies {
        out.centers.push(p + s);
        out.velocities.push(v);
    }
    (out, n)
}

/// Atoms crossing the box's faces render as the spheres placed by hand on both sides.
#[test]
fn atoms_crossing_the_box_render_as_their_images_placed_by_hand() {
    if !have_lammps() {
        return;
    }
    let d = simulate();
    let dir = d.path();
    write(dir, "dump.toml", &scene(&dump("dump.x.lammpstrj", "")));
    let shutter = 0.5 / FPS;
    let mut crossing = 0;
    for frame in 1..=3u32 {
        let time = (frame - 1) as f64 / FPS;
        let atoms = snapshot(&dir.join("dump.x.lammpstrj"), frame as usize - 1);
        let (drawn, copies) =
            placed_by_hand(&atoms, time, time - shutter / 2.0, time + shutter / 2.0);
        crossing += copies;
        write_ply(&dir.join(format!("hand_{frame:04}.ply")), &drawn);
    }
    assert!(
        crossing > 0,
        "no atom crosses a face in frames 1 to 3: nothing is tested"
    );
    write(dir, "hand.toml", &scene("file = \"hand_####.ply\"\n"));
    assert_same_bits(
        &render_bits(dir, "dump.toml", 1..=3),
        &render_bits(dir, "hand.toml", 1..=3),
    );
}
