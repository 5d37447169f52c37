//! Simulation formats against answers known in advance, with files written here (no program
//! from outside; tests/integration/lammps.rs runs LAMMPS itself):
//!
//! - the same points as an extended XYZ file, a LAMMPS dump and a PLY file render the same
//!   bits;
//! - a colour map: a point's albedo pass is the map's colour at its value (decoded to
//!   linear), with the range given and with the range found over the selected frames;
//! - `types` give radii and materials per type: as two caches of PLY files, one a material;
//! - `snapshots = "timestep"`: a frame shows the last snapshot at or before its time;
//! - interpolation through a periodic box (nearest image, image flags, unwrapped positions)
//!   renders as the file's velocities equal to that motion.

use crate::common;

use std::path::Path;

use common::{assert_same_bits, ok, render_bits};
use glam::DVec3;
use raytrace_core::colormap::Colormap;
use raytrace_scene::ply::{Column, Encoding, Scalar, write_vertices};

/// A scene of a few big spheres before the camera, with `points` as its cache table.
pub(crate) fn scene(frames: u32, points: &str) -> String {
    format!(
        r#"[shot]
fps = 24.0
frames = {frames}
[output]
width = 40
height = 30
passes = ["albedo", "depth"]
[render]
samples = 2
max_depth = 3
[camera]
look_from = [0.0, 0.0, 12.0]
look_at = [0.0, 0.0, 0.0]
vfov = 40.0
[materials]
grey = {{ type = "lambertian", albedo = [0.6, 0.5, 0.4] }}
shiny = {{ type = "metal", albedo = [0.9, 0.8, 0.7], fuzz = 0.2 }}
[[points]]
material = "grey"
{points}
"#
    )
}

pub(crate) fn write(dir: &Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

/// A PLY file of doubles: positions, and the columns `extra` (name, values).
fn write_ply(path: &Path, centers: &[DVec3], extra: &[(&str, Vec<f64>)]) {
    let axis = |k: usize| -> Vec<f64> { centers.iter().map(|c| c[k]).collect() };
    let xyz = [axis(0), axis(1), axis(2)];
    let mut cols: Vec<Column> = ["x", "y", "z"]
        .iter()
        .zip(&xyz)
        .map(|(name, values)| Column {
            name,
            ty: Scalar::F64,
            values,
        })
        .collect();
    for (name, values) in extra {
        cols.push(Column {
            name,
            ty: Scalar::F64,
            values,
        });
    }
    let mut bytes = Vec::new();
    write_vertices(&mut bytes, Encoding::BinaryLittleEndian, &cols).unwrap();
    std::fs::write(path, bytes).unwrap();
}

/// Five points with velocities and radii, exact in text with `{:?}`.
pub(crate) fn points() -> (Vec<DVec3>, Vec<DVec3>, Vec<f64>) {
    let c: Vec<DVec3> = (0..5)
        .map(|i| {
            DVec3::new(
                i as f64 * 1.7 - 3.4,
                (i % 2) as f64 * 0.9 - 0.45,
                -(i as f64) * 0.3,
            )
        })
        .collect();
    let v: Vec<DVec3> = (0..5)
        .map(|i| DVec3::new(0.5 * i as f64, -1.25, 0.75))
        .collect();
    let r: Vec<f64> = (0..5).map(|i| 0.6 + 0.1 * i as f64).collect();
    (c, v, r)
}

/// A LAMMPS snapshot of the points: `id type x y z vx vy vz radius c_val` in an orthogonal
/// box of `bounds`, flags `flags`.
pub(crate) fn lammps_snapshot(
    timestep: u64,
    c: &[DVec3],
    v: &[DVec3],
    r: &[f64],
    values: &[f64],
    flags: &str,
) -> String {
    let mut s = format!(
        "ITEM: TIMESTEP\n{timestep}\nITEM: NUMBER OF ATOMS\n{}\nITEM: BOX BOUNDS {flags}\n-8 8\n-8 8\n-8 8\nITEM: ATOMS id type x y z vx vy vz radius c_val\n",
        c.len()
    );
    for i in 0..c.len() {
        s += &format!(
            "{} {} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}\n",
            i + 1,
            1 + i % 2,
            c[i].x,
            c[i].y,
            c[i].z,
            v[i].x,
            v[i].y,
            v[i].z,
            r[i],
            values[i]
        );
    }
    s
}

/// The points as an extended XYZ file: species, positions, velocities and radii.
pub(crate) fn xyz_text(c: &[DVec3], v: &[DVec3], r: &[f64]) -> String {
    let mut xyz = format!(
        "{}\nLattice=\"16 0 0 0 16 0 0 0 16\" Origin=\"-8 -8 -8\" Properties=species:S:1:pos:R:3:velo:R:3:radius:R:1 pbc=\"F F F\"\n",
        c.len()
    );
    for i in 0..c.len() {
        xyz += &format!(
            "Ar {:?} {:?} {:?} {:?} {:?} {:?} {:?}\n",
            c[i].x, c[i].y, c[i].z, v[i].x, v[i].y, v[i].z, r[i]
        );
    }
    xyz
}

/// The same points as extended XYZ, a LAMMPS dump and PLY render the same bits.
#[test]
fn xyz_lammps_and_ply_give_the_same_image() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let (c, v, r) = points();
    let values = vec![0.0; 5];
    write(
        dir,
        "p.lammpstrj",
        &lammps_snapshot(0, &c, &v, &r, &values, "ff ff ff"),
    );
    write(dir, "p.xyz", &xyz_text(&c, &v, &r));
    let col = |k: usize| -> Vec<f64> { v.iter().map(|x| x[k]).collect() };
    write_ply(
        &dir.join("p.ply"),
        &c,
        &[
            ("vx", col(0)),
            ("vy", col(1)),
            ("vz", col(2)),
            ("radius", r.clone()),
        ],
    );
    for name in ["p.lammpstrj", "p.xyz", "p.ply"] {
        write(
            dir,
            &format!("{name}.toml"),
            &scene(2, &format!("file = \"{name}\"\n")),
        );
    }
    let ply = render_bits(dir, "p.ply.toml", 1..=2);
    assert_same_bits(&render_bits(dir, "p.lammpstrj.toml", 1..=2), &ply);
    assert_same_bits(&render_bits(dir, "p.xyz.toml", 1..=2), &ply);
}

/// The albedo pass of frame `frame` (half floats, as written), per pixel.
fn albedo(path: &Path) -> Vec<[f32; 3]> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let channel = |name: &str| -> Vec<f32> {
        let c = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap();
        match &c.sample_data {
            exr::image::FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
            exr::image::FlatSamples::F32(v) => v.clone(),
            _ => panic!("{name}"),
        }
    };
    let (r, g, b) = (
        channel("albedo.R"),
        channel("albedo.G"),
        channel("albedo.B"),
    );
    (0..r.len()).map(|i| [r[i], g[i], b[i]]).collect()
}

/// The map's colour at `t` as the albedo pass stores it (linear, in half floats).
fn stored(map: Colormap, t: f64) -> [f32; 3] {
    map.linear(t)
        .map(|x| exr::prelude::f16::from_f32(x).to_f32())
}

/// One big still point a frame in the middle of the image, coloured by `c_val`: the albedo
/// of the image's middle pixel is the map's colour at the point's value; with the range
/// found over the shot's frames, the frames' least value takes the map's start, the
/// greatest its end.
#[test]
fn a_points_albedo_is_the_colour_maps_colour_at_its_value() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let values = [2.0, 4.5, 3.0];
    let mut dump = String::new();
    for (k, x) in values.iter().enumerate() {
        dump += &lammps_snapshot(
            k as u64,
            &[DVec3::ZERO],
            &[DVec3::ZERO],
            &[2.0],
            &[*x],
            "pp pp pp",
        );
    }
    write(dir, "v.lammpstrj", &dump);
    let middle =
        |frame: u32, name: &str| albedo(&dir.join(format!("{name}_{frame:04}.exr")))[15 * 40 + 20];
    for (map, range, name) in [
        (Colormap::Magma, "color_range = [1.0, 5.0]\n", "given"),
        (Colormap::Turbo, "", "found"),
    ] {
        let points = format!(
            "file = \"v.lammpstrj\"\ncolor_by = \"c_val\"\ncolormap = \"{}\"\n{range}",
            map.name()
        );
        write(dir, &format!("{name}.toml"), &scene(3, &points));
        ok(
            dir,
            &[
                "render",
                &format!("{name}.toml"),
                "-q",
                "-o",
                &format!("{name}_####.exr"),
            ],
        );
        let (lo, hi) = if range.is_empty() {
            (2.0, 4.5)
        } else {
            (1.0, 5.0)
        };
        for (frame, x) in (1..=3).zip(values) {
            let want = stored(map, (x - lo) / (hi - lo));
            assert_eq!(
                middle(frame, name),
                want,
                "{name}: frame {frame}, value {x}"
            );
        }
    }
    // A chunk of the shot colours as the whole shot does: the range is the selection's.
    ok(
        dir,
        &[
            "render",
            "found.toml",
            "-q",
            "-o",
            "chunk_####.exr",
            "--chunk-size",
            "1",
            "--chunk",
            "2",
        ],
    );
    assert_eq!(
        middle(3, "chunk"),
        stored(Colormap::Turbo, (3.0 - 2.0) / 2.5)
    );
}

/// `types`: type 2's points with their own radius and material render as a second cache of
/// them (as PLY files, one a material), type 1's with the table's.
#[test]
fn types_give_radii_and_materials_per_type() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let (c, v, r) = points();
    write(
        dir,
        "t.lammpstrj",
        &lammps_snapshot(0, &c, &v, &r, &[0.0; 5], "ff ff ff"),
    );
    // Type 1 (points 0, 2, 4) keeps its radius column; type 2 (1, 3) is radius 0.9, shiny.
    let types = "types = { \"2\" = { radius = 0.9, material = \"shiny\" } }\n";
    write(
        dir,
        "types.toml",
        &scene(1, &format!("file = \"t.lammpstrj\"\n{types}")),
    );
    let pick = |idx: &[usize]| -> (Vec<DVec3>, Vec<DVec3>, Vec<f64>) {
        (
            idx.iter().map(|&i| c[i]).collect(),
            idx.iter().map(|&i| v[i]).collect(),
            idx.iter().map(|&i| r[i]).collect(),
        )
    };
    for (name, idx, radius) in [
        ("one.ply", vec![0, 2, 4], None),
        ("two.ply", vec![1, 3], Some(0.9)),
    ] {
        let (c, v, r) = pick(&idx);
        let col = |k: usize| -> Vec<f64> { v.iter().map(|x| x[k]).collect() };
        let r = radius.map_or(r.clone(), |x| vec![x; r.len()]);
        write_ply(
            &dir.join(name),
            &c,
            &[
                ("vx", col(0)),
                ("vy", col(1)),
                ("vz", col(2)),
                ("radius", r),
            ],
        );
    }
    let ply =
        scene(1, "file = \"one.ply\"\n") + "[[points]]\nfile = \"two.ply\"\nmaterial = \"shiny\"\n";
    write(dir, "ply.toml", &ply);
    assert_same_bits(
        &render_bits(dir, "types.toml", 1..=1),
        &render_bits(dir, "ply.toml", 1..=1),
    );
}

/// With `snapshots = "timestep"`, snapshots at timesteps 0, 2 and 4 of 0.25 s sit at frames
/// 1, 3 and 5 of a 4 fps shot, and frames 2 and 4 show the snapshot before them: as PLY
/// files written for each frame.
#[test]
fn timestep_snapshots_are_shown_from_their_time_on() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let (c, _, r) = points();
    let still = vec![DVec3::ZERO; 5];
    let shifted = |k: usize| -> Vec<DVec3> {
        c.iter()
            .map(|p| *p + DVec3::new(0.0, 0.5 * k as f64, 0.0))
            .collect()
    };
    let mut dump = String::new();
    for k in 0..3 {
        dump += &lammps_snapshot(2 * k as u64, &shifted(k), &still, &r, &[0.0; 5], "pp pp pp");
    }
    write(dir, "ts.lammpstrj", &dump);
    let text = scene(
        5,
        "file = \"ts.lammpstrj\"\nsnapshots = \"timestep\"\ndt = 0.25\n",
    )
    .replace("fps = 24.0", "fps = 4.0");
    write(dir, "ts.toml", &text);
    for frame in 1..=5usize {
        write_ply(
            &dir.join(format!("ts_{frame:04}.ply")),
            &shifted((frame - 1) / 2),
            &[("radius", r.clone())],
        );
    }
    let ply = scene(5, "file = \"ts_####.ply\"\n").replace("fps = 24.0", "fps = 4.0");
    write(dir, "ply.toml", &ply);
    assert_same_bits(
        &render_bits(dir, "ts.toml", 1..=5),
        &render_bits(dir, "ply.toml", 1..=5),
    );
}

/// A point at x = 7.5 then at x = -7.5 in a periodic box 16 wide moves by the nearest image,
/// +1 a frame (not -15): `interpolate` renders as the dump with that velocity written in it,
/// whether the next position is wrapped (nearest image), wrapped with image flags, or
/// unwrapped (`xu`).
#[test]
fn interpolation_through_a_periodic_box_takes_the_short_way() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let dt = 1.0 / 24.0;
    let snap = |t: u64, columns: &str, rows: &[String]| {
        let mut s = format!(
            "ITEM: TIMESTEP\n{t}\nITEM: NUMBER OF ATOMS\n{}\nITEM: BOX BOUNDS pp pp pp\n-8 8\n-8 8\n-8 8\nITEM: ATOMS {columns}\n",
            rows.len()
        );
        for r in rows {
            s += r;
            s += "\n";
        }
        s
    };
    let (p, q) = (7.5f64, -7.5f64);
    // The velocity each form gives, computed as the reader's rule does.
    let wrapped = ((q - p) + 16.0) / dt;
    let unwrapped = ((q + 16.0) - p) / dt;
    let cases = [
        (
            "x",
            "id x y z",
            format!("1 {p:?} 0 0"),
            format!("1 {q:?} 0 0"),
            wrapped,
        ),
        (
            "i",
            "id x y z ix iy iz",
            format!("1 {p:?} 0 0 0 0 0"),
            format!("1 {q:?} 0 0 1 0 0"),
            wrapped,
        ),
        (
            "u",
            "id xu yu zu",
            format!("1 {p:?} 0 0"),
            format!("1 {:?} 0 0", q + 16.0),
            unwrapped,
        ),
    ];
    for (name, columns, a, b, v) in cases {
        let interpolated = snap(0, columns, std::slice::from_ref(&a)) + &snap(1, columns, &[b]);
        write(dir, &format!("{name}.lammpstrj"), &interpolated);
        let with_v = snap(
            0,
            &format!("{columns} vx vy vz"),
            &[format!("{a} {v:?} 0 0")],
        );
        write(dir, &format!("{name}_v.lammpstrj"), &with_v);
        let cache = |file: &str, motion: &str| {
            scene(
                1,
                &format!("file = \"{file}\"\nradius = 0.75\nmotion = \"{motion}\"\n"),
            )
            .replace(
                "look_from = [0.0, 0.0, 12.0]",
                "look_from = [7.0, 0.0, 12.0]",
            )
            .replace("look_at = [0.0, 0.0, 0.0]", "look_at = [7.0, 0.0, 0.0]")
        };
        write(
            dir,
            &format!("{name}.toml"),
            &cache(&format!("{name}.lammpstrj"), "interpolate"),
        );
        write(
            dir,
            &format!("{name}_v.toml"),
            &cache(&format!("{name}_v.lammpstrj"), "velocity"),
        );
        assert_same_bits(
            &render_bits(dir, &format!("{name}.toml"), 1..=1),
            &render_bits(dir, &format!("{name}_v.toml"), 1..=1),
        );
    }
}

/// Base64 of `bytes` (RFC 4648, padded).
fn base64(bytes: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let w = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            s.push(if k <= c.len() {
                A[(w >> (18 - 6 * k) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    s
}

/// The points as little-endian doubles, a point's components together.
fn le(values: &[f64]) -> Vec<u8> {
    values.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// The points as a legacy ASCII VTK file, with cells and a field to read past: positions,
/// radii and velocities.
pub(crate) fn vtk_legacy_ascii(c: &[DVec3], v: &[DVec3], r: &[f64]) -> String {
    let flat = |p: &[DVec3]| -> Vec<f64> { p.iter().flat_map(|q| q.to_array()).collect() };
    let text = |x: &[f64]| -> String {
        x.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let n = c.len();
    let cells: String = (0..n).map(|i| format!("1 {i}\n")).collect();
    let ids: Vec<String> = (0..n).map(|i| i.to_string()).collect();
    format!(
        "# vtk DataFile Version 3.0\nparticles\nASCII\nDATASET POLYDATA\nPOINTS {n} double\n{}\nVERTICES {n} {}\n{cells}POINT_DATA {n}\nSCALARS radius double 1\nLOOKUP_TABLE default\n{}\nVECTORS velocity double\n{}\nFIELD FieldData 1\nid 1 {n} int\n{}\n",
        text(&flat(c)),
        2 * n,
        text(r),
        text(&flat(v)),
        ids.join(" ")
    )
}

/// The same points as legacy VTK (ASCII and BINARY) and XML VTK (ASCII, inline base64 with
/// the header encoded apart, appended raw and zlib-compressed in blocks) render as the PLY
/// file does.
#[test]
fn vtk_files_give_the_image_ply_gives() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let (c, v, r) = points();
    let flat = |p: &[DVec3]| -> Vec<f64> { p.iter().flat_map(|q| q.to_array()).collect() };
    let text = |x: &[f64]| -> String {
        x.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let (pos, vel) = (flat(&c), flat(&v));
    // Legacy ASCII and BINARY (big-endian), with cells and a lookup table to read past.
    write(dir, "a.vtk", &vtk_legacy_ascii(&c, &v, &r));
    let be = |x: &[f64]| -> Vec<u8> { x.iter().flat_map(|x| x.to_be_bytes()).collect() };
    let mut binary = b"# vtk DataFile Version 3.0\nparticles\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 double\n".to_vec();
    binary.extend(be(&pos));
    binary.extend(b"\nPOINT_DATA 5\nVECTORS velocity double\n");
    binary.extend(be(&vel));
    binary.extend(b"\nSCALARS radius double\n");
    binary.extend(be(&r));
    binary.extend(b"\n");
    std::fs::write(dir.join("b.vtk"), binary).unwrap();
    // XML: ASCII.
    let array = |name: &str, comps: u8, body: &str, format: &str| {
        format!(
            "<DataArray type=\"Float64\" Name=\"{name}\" NumberOfComponents=\"{comps}\" format=\"{format}\">{body}</DataArray>\n"
        )
    };
    let xml = |kind: &str, attrs: &str, arrays: [String; 3], appended: &[u8]| {
        let mut s = format!(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"{kind}\" version=\"1.0\" byte_order=\"LittleEndian\" {attrs}>\n<{kind}>\n<Piece NumberOfPoints=\"5\">\n<PointData>\n{}{}</PointData>\n<Points>\n{}</Points>\n</Piece>\n</{kind}>\n",
            arrays[1], arrays[2], arrays[0]
        )
        .into_bytes();
        if !appended.is_empty() {
            s.extend(b"<AppendedData encoding=\"raw\">\n_");
            s.extend(appended);
            s.extend(b"\n</AppendedData>\n");
        }
        s.extend(b"</VTKFile>\n");
        s
    };
    let ascii = xml(
        "PolyData",
        "",
        [
            array("Points", 3, &text(&pos), "ascii"),
            array("velocity", 3, &text(&vel), "ascii"),
            array("radius", 1, &text(&r), "ascii"),
        ],
        &[],
    );
    std::fs::write(dir.join("c.vtp"), ascii).unwrap();
    // XML: inline base64, a 64-bit byte count encoded apart from the data.
    let inline = |x: &[f64]| base64(&(x.len() as u64 * 8).to_le_bytes()) + &base64(&le(x));
    let b64 = xml(
        "UnstructuredGrid",
        "header_type=\"UInt64\"",
        [
            array("Points", 3, &inline(&pos), "binary"),
            array("Velocity", 3, &inline(&vel), "binary"),
            array("RADIUS", 1, &inline(&r), "binary"),
        ],
        &[],
    );
    std::fs::write(dir.join("d.vtu"), b64).unwrap();
    // XML: appended raw, zlib in blocks of 16 bytes, 32-bit block tables.
    let mut appended = Vec::new();
    let mut offsets = Vec::new();
    for x in [&pos, &vel, &r] {
        offsets.push(appended.len());
        let raw = le(x);
        let blocks: Vec<Vec<u8>> = raw
            .chunks(16)
            .map(|c| {
                let mut e =
                    flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
                std::io::Write::write_all(&mut e, c).unwrap();
                e.finish().unwrap()
            })
            .collect();
        let last = raw.len() % 16;
        for w in [blocks.len(), 16, last] {
            appended.extend((w as u32).to_le_bytes());
        }
        for b in &blocks {
            appended.extend((b.len() as u32).to_le_bytes());
        }
        for b in blocks {
            appended.extend(b);
        }
    }
    let at = |name: &str, comps: u8, k: usize| {
        format!(
            "<DataArray type=\"Float64\" Name=\"{name}\" NumberOfComponents=\"{comps}\" format=\"appended\" offset=\"{}\"/>\n",
            offsets[k]
        )
    };
    let zipped = xml(
        "PolyData",
        "compressor=\"vtkZLibDataCompressor\"",
        [at("Points", 3, 0), at("velocity", 3, 1), at("radius", 1, 2)],
        &appended,
    );
    std::fs::write(dir.join("e.vtp"), zipped).unwrap();
    let col = |k: usize| -> Vec<f64> { v.iter().map(|x| x[k]).collect() };
    write_ply(
        &dir.join("p.ply"),
        &c,
        &[
            ("vx", col(0)),
            ("vy", col(1)),
            ("vz", col(2)),
            ("radius", r.clone()),
        ],
    );
    write(dir, "p.toml", &scene(1, "file = \"p.ply\"\n"));
    let ply = render_bits(dir, "p.toml", 1..=1);
    for name in ["a.vtk", "b.vtk", "c.vtp", "d.vtu", "e.vtp"] {
        let toml = format!("{name}.toml");
        write(dir, &toml, &scene(1, &format!("file = \"{name}\"\n")));
        assert_same_bits(&render_bits(dir, &toml, 1..=1), &ply);
    }
}
