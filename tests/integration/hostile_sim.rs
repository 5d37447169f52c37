//! Hostile simulation files (LAMMPS dumps, extended XYZ, VTK): each bad file makes `render`
//! and `check` exit 2 within 5 seconds under a 1 GiB address-space limit, with a message
//! naming the file, the line or snapshot and the point, and what is wrong; no panic, nothing
//! written. And the point-cache survey's bounds (issue 31): a single file over four billion
//! frames is read once; `check` reads each file once; the next snapshot's points are in the
//! memory estimate; duplicate ids are refused before the next file is read. And the fourth
//! round's (issue 41): motion past a periodic box refused by `check` as by `render`, the
//! snapshot index counted and bounded, a gzip bomb of blank lines, VTK files padded with NULs.

use crate::common;

use std::io::Write;
use std::path::Path;

use common::{run_limited, text};

const SECONDS: u64 = 5;
const MEMORY_KIB: u64 = 1 << 20;

/// A scene whose cache is `file` with the extra keys `keys`.
fn scene(file: &str, keys: &str) -> String {
    format!(
        "[shot]\nframes = 2\n[output]\npath = \"out/f_####.png\"\nwidth = 8\nheight = 6\n\
         [render]\nsamples = 2\n[camera]\nlook_from = [0.0, 0.0, 5.0]\n\
         [[points]]\nfile = \"{file}\"\nmaterial = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\nradius = 0.1\n{keys}"
    )
}

/// Asserts `render` and `check` of `shot.toml` in `dir` exit 2 with every one of `want` in
/// the message, no panic, nothing written.
fn refused(dir: &Path, want: &[&str]) {
    for args in [
        &["render", "shot.toml", "--threads", "2"][..],
        &["check", "shot.toml"][..],
    ] {
        let o = run_limited(dir, args, SECONDS, MEMORY_KIB);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {t}");
        for w in want {
            assert!(t.contains(w), "{args:?}: {w:?} missing in: {t}");
        }
        assert!(!t.contains("panicked"), "{t}");
        assert!(!dir.join("out").exists(), "{args:?} wrote something");
    }
}

/// A folder with the scene (cache `file`, keys `keys`) and the files `files`.
fn setup(file: &str, keys: &str, files: &[(&str, Vec<u8>)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), scene(file, keys)).unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    dir
}

/// A dump of two snapshots of two atoms (lines 1-11, then 12-22).
fn dump() -> String {
    let snap = |t: u32| {
        format!(
            "ITEM: TIMESTEP\n{t}\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS pp pp pp\n0 4\n0 4\n0 4\nITEM: ATOMS id type x y z vx vy vz c_ke\n1 1 0.5 0.5 0.5 0.1 0 0 1.5\n2 2 1.5 1.5 1.5 0 0.1 0 2.5\n"
        )
    };
    snap(0) + &snap(10)
}

fn bad_dump(from: &str, to: &str) -> Vec<u8> {
    let d = dump();
    assert!(d.contains(from));
    d.replacen(from, to, 1).into_bytes()
}

#[test]
fn a_truncated_last_snapshot_and_counts_beyond_the_data_are_refused() {
    let mut cut = dump().into_bytes();
    cut.truncate(cut.len() - 20);
    let d = setup("d.lammpstrj", "", &[("d.lammpstrj", cut)]);
    refused(
        d.path(),
        &[
            "d.lammpstrj",
            "snapshot 2 (timestep 10)",
            "line 22",
            "the file ends inside atom 1's line (truncated)",
        ],
    );
    // Cut at the end of a line: a whole atom missing.
    let whole = dump();
    let cut = &whole[..whole.len() - 28];
    let d = setup(
        "d.lammpstrj",
        "",
        &[("d.lammpstrj", cut.as_bytes().to_vec())],
    );
    refused(
        d.path(),
        &[
            "d.lammpstrj",
            "snapshot 2 (timestep 10)",
            "the file ends after 1 of the 2 atoms",
            "truncated",
        ],
    );
    // A count far beyond the lines: found by counting lines, nothing allocated for it.
    let big = dump().replacen("ATOMS\n2\n", "ATOMS\n200000000\n", 1);
    let d = setup("d.lammpstrj", "", &[("d.lammpstrj", big.into_bytes())]);
    refused(
        d.path(),
        &[
            "d.lammpstrj",
            "snapshot 1 (timestep 0)",
            "of the 200000000 atoms",
            "a wrong count",
        ],
    );
    let huge = dump().replacen("ATOMS\n2\n", "ATOMS\n18446744073709551615\n", 1);
    let d = setup("d.lammpstrj", "", &[("d.lammpstrj", huge.into_bytes())]);
    refused(
        d.path(),
        &[
            "d.lammpstrj",
            "18446744073709551615 points, more than the 268435456",
        ],
    );
}

#[test]
fn missing_positions_non_numeric_fields_and_bad_boxes_are_refused() {
    let d = setup(
        "d.lammpstrj",
        "",
        &[("d.lammpstrj", bad_dump("id type x y z", "id type q r s"))],
    );
    refused(
        d.path(),
        &["d.lammpstrj", "no position columns: x y z, or xs ys zs"],
    );
    let d = setup(
        "d.lammpstrj",
        "",
        &[("d.lammpstrj", bad_dump("id type x y z", "id type q y z"))],
    );
    refused(d.path(), &["d.lammpstrj", "the file has y but not x"]);
    let d = setup(
        "d.lammpstrj",
        "",
        &[(
            "d.lammpstrj",
            bad_dump("2 2 1.5 1.5 1.5 0 0.1", "2 2 1.5 1.5 1.5 0 zero"),
        )],
    );
    refused(
        d.path(),
        &[
            "d.lammpstrj",
            "snapshot 1 (timestep 0): line 11: atom 1: vy is \"zero\", not a number",
        ],
    );
    let d = setup(
        "d.lammpstrj",
        "",
        &[(
            "d.lammpstrj",
            bad_dump("2 2 1.5 1.5 1.5 0 0.1 0 2.5", "2 2 1.5 1.5 nan 0 0.1 0 2.5"),
        )],
    );
    refused(
        d.path(),
        &["d.lammpstrj", "point 1: z is NaN, not a finite number"],
    );
    let d = setup(
        "d.lammpstrj",
        "",
        &[("d.lammpstrj", bad_dump("0 4\n0 4\n0 4", "0 4\n4 0\n0 4"))],
    );
    refused(
        d.path(),
        &[
            "d.lammpstrj: line 7: the box's y bounds are 4 to 0: the upper must not be less than the lower",
        ],
    );
    let d = setup(
        "d.lammpstrj",
        "",
        &[("d.lammpstrj", bad_dump("0 4\n0 4\n0 4", "0 4\n0 4\n0 inf"))],
    );
    refused(
        d.path(),
        &[
            "d.lammpstrj",
            "line 8: box bound inf is not a finite number",
        ],
    );
}

#[test]
fn a_cut_gzip_stream_is_refused() {
    let text: String = (0..40).map(|_| dump()).collect();
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(text.as_bytes()).unwrap();
    let mut bytes = e.finish().unwrap();
    bytes.truncate(bytes.len() * 2 / 3);
    let d = setup("d.lammpstrj.gz", "", &[("d.lammpstrj.gz", bytes)]);
    refused(
        d.path(),
        &["d.lammpstrj.gz", "the gzip stream is cut short or corrupt"],
    );
}

#[test]
fn a_color_by_column_some_snapshot_lacks_is_refused() {
    let second = dump().rfind("ITEM: ATOMS").unwrap();
    let mut text = dump();
    text.replace_range(
        second..,
        "ITEM: ATOMS id type x y z vx vy vz\n1 1 0.5 0.5 0.5 0.1 0 0\n2 2 1.5 1.5 1.5 0 0.1 0\n",
    );
    for range in ["", "color_range = [0.0, 3.0]\n"] {
        let keys = format!("color_by = \"c_ke\"\n{range}");
        let d = setup(
            "d.lammpstrj",
            &keys,
            &[("d.lammpstrj", text.clone().into_bytes())],
        );
        refused(
            d.path(),
            &[
                "d.lammpstrj",
                "snapshot 2 (timestep 10)",
                "color_by names the column c_ke, which the file does not have",
            ],
        );
    }
}

#[test]
fn xyz_counts_that_lie_and_properties_that_do_not_match_are_refused() {
    let frame = |n: usize| {
        let mut s = format!("{n}\nProperties=species:S:1:pos:R:3\n");
        for i in 0..2 {
            s += &format!("Ar {i} 0 0\n");
        }
        s
    };
    // Claims 3, holds 2, then the next frame: its count line read as an atom.
    let d = setup(
        "a.xyz",
        "",
        &[("a.xyz", (frame(3) + &frame(2)).into_bytes())],
    );
    refused(d.path(), &["a.xyz", "line 5", "the count line", "lies"]);
    // Claims 3 at the end of the file.
    let d = setup(
        "a.xyz",
        "",
        &[("a.xyz", (frame(2) + &frame(3)).into_bytes())],
    );
    refused(
        d.path(),
        &[
            "a.xyz",
            "snapshot 2",
            "the count line lies, or the file is truncated",
        ],
    );
    let wrong = "2\nProperties=species:S:1:pos:R:3:radius:R:1\nAr 0 0 0\nAr 1 0 0\n";
    let d = setup("a.xyz", "", &[("a.xyz", wrong.as_bytes().to_vec())]);
    refused(
        d.path(),
        &["a.xyz", "4 fields for the 5 columns Properties= declares"],
    );
    let typo = "1\nProperties=species:S:1:pos:Q:3\nAr 0 0 0\n";
    let d = setup("a.xyz", "", &[("a.xyz", typo.as_bytes().to_vec())]);
    refused(d.path(), &["a.xyz", "line 2: property pos has type \"Q\""]);
}

/// Issue 31, row 2: a single-file cache over a shot of 4,294,967,295 frames is read once, not
/// once a frame: `check` and `render`'s survey before its first frame are quick.
#[test]
fn a_single_file_over_four_billion_frames_is_read_once() {
    let dir = tempfile::tempdir().unwrap();
    let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 -2\n";
    std::fs::write(dir.path().join("one.ply"), text).unwrap();
    let shot = scene("one.ply", "").replace("frames = 2", "frames = 4294967295");
    std::fs::write(dir.path().join("shot.toml"), shot).unwrap();
    let o = run_limited(dir.path(), &["check", "shot.toml"], SECONDS, MEMORY_KIB);
    let t = text_of(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(t.contains("points: 1 to 1 a frame over 4294967295 frames, every file checked (1 files read once each)"), "{t}");
    // render surveys every frame's caches before refusing --temporal without --denoise.
    let o = run_limited(
        dir.path(),
        &["render", "shot.toml", "--temporal"],
        SECONDS,
        MEMORY_KIB,
    );
    let t = text_of(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("--temporal"), "{t}");
}

fn text_of(o: &std::process::Output) -> String {
    text(o)
}

/// A binary PLY file of `ids` at the origin (float x y z, int id).
fn ids_ply(ids: impl ExactSizeIterator<Item = i32>) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty int id\nend_header\n",
        ids.len()
    )
    .into_bytes();
    for id in ids {
        out.extend([0u8; 12]);
        out.extend(id.to_le_bytes());
    }
    out
}

/// Issue 31, rows 4 and 6: `check` reads each file of an interpolated sequence once (not as
/// the frame's own and again as the frame before's next), and the next frame's points are in
/// the memory estimate of the frame that reads them.
#[test]
fn check_reads_each_file_once_and_counts_the_next_file_in_memory() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s_1.ply"), ids_ply(0..10)).unwrap();
    std::fs::write(dir.path().join("s_2.ply"), ids_ply(0..200_000)).unwrap();
    std::fs::write(dir.path().join("s_3.ply"), ids_ply(0..10)).unwrap();
    let memory = |motion: &str| -> (String, f64) {
        let shot = scene("s_#.ply", &format!("motion = \"{motion}\"\n"))
            .replace("frames = 2", "frames = 3");
        std::fs::write(dir.path().join("shot.toml"), shot).unwrap();
        let o = run_limited(dir.path(), &["check", "shot.toml"], SECONDS, MEMORY_KIB);
        let t = text_of(&o);
        assert_eq!(o.status.code(), Some(0), "{t}");
        let line = t
            .lines()
            .find(|l| l.trim_start().starts_with("1: "))
            .unwrap()
            .to_string();
        let mib: f64 = line
            .rsplit("memory about ")
            .next()
            .unwrap()
            .trim_end_matches(" MiB")
            .parse()
            .unwrap();
        (t, mib)
    };
    let (t, interpolated) = memory("interpolate");
    assert!(t.contains("(3 files read once each)"), "{t}");
    let (_, still) = memory("none");
    // 200,000 next points at 48 bytes each, at least, beyond frame 1's own.
    let next = 200_000.0 * 48.0 / 1048576.0;
    assert!(
        interpolated - still >= next - 0.1,
        "{interpolated} MiB against {still} MiB without the next file"
    );
}

/// Issue 31, row 6: a frame's own duplicate ids are refused before the next frame's file is
/// read (a file of 6 million points whose ids are all 0, before a next file as large), within
/// a memory limit that holds one file's points but not both.
#[test]
fn duplicate_ids_are_refused_before_the_next_file_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let n = 6_000_000;
    std::fs::write(
        dir.path().join("s_1.ply"),
        ids_ply(std::iter::repeat_n(0, n)),
    )
    .unwrap();
    std::fs::write(dir.path().join("s_2.ply"), ids_ply(0..n as i32)).unwrap();
    let shot = scene("s_#.ply", "motion = \"interpolate\"\n");
    std::fs::write(dir.path().join("shot.toml"), shot).unwrap();
    for args in [
        &["render", "shot.toml", "--threads", "2"][..],
        &["check", "shot.toml"][..],
    ] {
        let o = run_limited(dir.path(), args, 10, 700 << 10);
        let t = text_of(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {t}");
        assert!(
            t.contains("s_1.ply") && t.contains("id 0 is held by two points"),
            "{t}"
        );
        assert!(!dir.path().join("out").exists());
    }
}

#[test]
fn malformed_vtk_is_refused() {
    let legacy = |points: &str, radius: &str| {
        format!(
            "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 2 {points}\n0 0 0 1 1 1\nPOINT_DATA 2\nSCALARS radius float 1\nLOOKUP_TABLE default\n{radius}\n"
        )
        .into_bytes()
    };
    let d = setup("a.vtk", "", &[("a.vtk", legacy("banana", "0.1 0.2"))]);
    refused(d.path(), &["a.vtk", "line 5: unknown type \"banana\""]);
    // One radius short: the file ends inside the array.
    let d = setup("a.vtk", "", &[("a.vtk", legacy("float", "0.1"))]);
    refused(
        d.path(),
        &[
            "a.vtk",
            "SCALARS radius: the file ends after 1 of its 2 values",
        ],
    );
    // Counts beyond the file, refused before anything is allocated.
    let big = String::from_utf8(legacy("float", "0.1 0.2"))
        .unwrap()
        .replace("POINTS 2", "POINTS 3000000000");
    let d = setup("a.vtk", "", &[("a.vtk", big.into_bytes())]);
    refused(
        d.path(),
        &["a.vtk", "POINTS: 9000000000 values, more than the"],
    );
    let xml = |n: u32, ty: &str, radius: &str| {
        format!(
            "<VTKFile type=\"PolyData\" version=\"1.0\">\n<PolyData>\n<Piece NumberOfPoints=\"{n}\">\n<PointData>\n<DataArray type=\"{ty}\" Name=\"radius\" format=\"ascii\">{radius}</DataArray>\n</PointData>\n<Points>\n<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 1 1</DataArray>\n</Points>\n</Piece>\n</PolyData>\n</VTKFile>\n"
        )
        .into_bytes()
    };
    let d = setup("a.vtp", "", &[("a.vtp", xml(2, "Banana", "0.1 0.2"))]);
    refused(
        d.path(),
        &["a.vtp", "line 5: DataArray radius has type \"Banana\""],
    );
    let d = setup("a.vtp", "", &[("a.vtp", xml(2, "Float32", "0.1"))]);
    refused(
        d.path(),
        &[
            "a.vtp",
            "array radius: 1 values where its points need 2 (a wrong length)",
        ],
    );
    let d = setup("a.vtp", "", &[("a.vtp", xml(2, "Float32", "0.1 0.2 0.3"))]);
    refused(
        d.path(),
        &[
            "a.vtp",
            "array radius: more values than its points need (2)",
        ],
    );
    let d = setup(
        "a.vtp",
        "",
        &[("a.vtp", xml(200_000_000, "Float32", "0.1 0.2"))],
    );
    refused(d.path(), &["a.vtp", "cannot hold its"]);
    // An appended array whose byte count is not its points'.
    let mut lying = b"<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\">\n<PolyData>\n<Piece NumberOfPoints=\"1\">\n<Points>\n<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"appended\" offset=\"0\"/>\n</Points>\n</Piece>\n</PolyData>\n<AppendedData encoding=\"raw\">\n_".to_vec();
    lying.extend(8u32.to_le_bytes());
    lying.extend([0u8; 12]);
    lying.extend(b"\n</AppendedData>\n</VTKFile>\n");
    let d = setup("a.vtp", "", &[("a.vtp", lying)]);
    refused(
        d.path(),
        &[
            "a.vtp",
            "array Points: it declares 8 bytes, and 3 values of 4 bytes need 12",
        ],
    );
}

#[test]
fn a_flat_box_is_refused_only_where_it_is_periodic() {
    // A zero lattice that no direction wraps, and a LAMMPS box of no x extent with `ff`
    // bounds: not used as boxes, so the points render.
    let xyz = b"1\nLattice=\"0 0 0 0 0 0 0 0 0\" pbc=\"F F F\"\nAr 0 0 0\n".to_vec();
    let lammps = dump().replace(
        "ITEM: BOX BOUNDS pp pp pp\n0 4\n",
        "ITEM: BOX BOUNDS ff pp pp\n5 5\n",
    );
    assert!(lammps.contains("5 5\n"));
    for (file, bytes, keys) in [
        ("a.xyz", xyz.clone(), ""),
        ("a.xyz", xyz.clone(), "periodic = false\n"),
        (
            "d.lammpstrj",
            lammps.clone().into_bytes(),
            "periodic = false\n",
        ),
    ] {
        let d = setup(file, keys, &[(file, bytes)]);
        for args in [&["check", "shot.toml"][..], &["render", "shot.toml"]] {
            let o = run_limited(d.path(), args, SECONDS, MEMORY_KIB);
            assert_eq!(
                o.status.code(),
                Some(0),
                "{file} {keys:?} {args:?}: {}",
                text(&o)
            );
        }
    }
    // Made periodic, the flat box is refused.
    let d = setup("a.xyz", "periodic = true\n", &[("a.xyz", xyz)]);
    refused(
        d.path(),
        &["a.xyz", "the box is periodic and its edges span no volume"],
    );
}

/// A shot's exposure that would carry a point across more than one box edge (`vx = 1e30` in
/// a periodic box) is refused by `check` as by `render`, with the same message in short
/// numbers (1/48 s at 24 fps, a box of 4: 5.208e27 edges).
#[test]
fn a_path_longer_than_the_periodic_box_is_refused_by_check_as_by_render() {
    let fast = bad_dump("0.5 0.5 0.5 0.1 0 0", "0.5 0.5 0.5 1e30 0 0");
    let d = setup("d.lammpstrj", "", &[("d.lammpstrj", fast)]);
    refused(
        d.path(),
        &[
            "d.lammpstrj: snapshot 1 (timestep 0): point 0 moves 5.208e27 box edges along edge a in a frame's exposure of 0.02083 s (velocity 1e30, 0, 0)",
        ],
    );
    // Not periodic along x: drawn as it moves.
    let open = dump()
        .replace("pp pp pp", "ff pp pp")
        .replacen("0.1 0 0", "1e30 0 0", 1);
    let d = setup("d.lammpstrj", "", &[("d.lammpstrj", open.into_bytes())]);
    let o = run_limited(d.path(), &["check", "shot.toml"], SECONDS, MEMORY_KIB);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

/// One-atom XYZ snapshots, `n` of them, gzipped.
fn one_atom_snapshots(n: usize) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    for _ in 0..n {
        e.write_all(b"1\n\nA 0 0 0\n").unwrap();
    }
    e.finish().unwrap()
}

/// The snapshot index is in the memory estimate (300,000 snapshots: about 60 MiB of the
/// estimate), within a quarter of the peak; a cache past the 2^20 snapshots an index may
/// hold is refused as its index reaches them, gzipped one-atom snapshots too (they grew past
/// 3 GB and aborted). About 3 s.
#[test]
fn the_snapshot_index_is_in_the_estimate_and_bounded() {
    let d = setup("m.xyz.gz", "", &[("m.xyz.gz", one_atom_snapshots(300_000))]);
    let o = run_limited(
        d.path(),
        &["render", "shot.toml", "--stats", "--threads", "2"],
        SECONDS,
        MEMORY_KIB,
    );
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    let estimate = common::mib_after(&t, "memory: about ");
    let peak = common::mib_after(&t, "peak memory ");
    assert!(estimate > 60.0, "{t}");
    assert!(
        (estimate - peak).abs() <= 0.25 * peak,
        "estimate {estimate} MiB, peak {peak} MiB"
    );
    let d = setup(
        "m.xyz.gz",
        "",
        &[("m.xyz.gz", one_atom_snapshots((1 << 20) + 1))],
    );
    let o = run_limited(d.path(), &["check", "shot.toml"], SECONDS, MEMORY_KIB);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("m.xyz.gz: snapshot 1048577: the cache holds more than 1048576 snapshots"),
        "{t}"
    );
}

/// A gzip bomb of blank lines: 1 GiB of line ends after a snapshot, made of 1024 gzip
/// members of 1 MiB each (about 1 MB), refused after the 1 MiB of blank lines a file may
/// hold in a row, in milliseconds (it was decompressed for minutes).
#[test]
fn a_gzip_bomb_of_blank_lines_is_refused() {
    let member = {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
        e.write_all(&vec![b'\n'; 1 << 20]).unwrap();
        e.finish().unwrap()
    };
    let mut bomb = one_atom_snapshots(1);
    for _ in 0..1024 {
        bomb.extend_from_slice(&member);
    }
    assert!(bomb.len() < 2 << 20);
    let d = setup("bomb.xyz.gz", "", &[("bomb.xyz.gz", bomb)]);
    refused(
        d.path(),
        &[
            "bomb.xyz.gz",
            "line 1048580: more than 1048576 bytes of blank lines from line 4",
        ],
    );
}

/// VTK files of 3 GiB, a small file padded with NULs (made sparse): refused unread, as
/// larger than their 2 points may need (they were read whole: 6.4 GB and an abort, and a
/// `.vtp` accepted); a `.vtp` with a few NULs after `</VTKFile>` is refused for them.
#[test]
fn vtk_files_padded_with_nuls_are_refused_unread() {
    let legacy =
        b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 1 1\n"
            .to_vec();
    let xml = b"<VTKFile type=\"PolyData\" version=\"1.0\">\n<PolyData>\n<Piece NumberOfPoints=\"2\">\n<Points>\n<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 1 1</DataArray>\n</Points>\n</Piece>\n</PolyData>\n</VTKFile>\n".to_vec();
    for (name, bytes) in [("a.vtk", legacy), ("a.vtp", xml.clone())] {
        let d = setup(name, "", &[(name, bytes)]);
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(d.path().join(name))
            .unwrap();
        f.set_len(3 << 30).unwrap();
        refused(
            d.path(),
            &[
                name,
                "holds 3221225472 bytes, more than the 16785408 its 2 points may need",
            ],
        );
    }
    let mut padded = xml;
    padded.extend([0u8; 1000]);
    let d = setup("a.vtp", "", &[("a.vtp", padded)]);
    refused(
        d.path(),
        &["a.vtp", "line 10: the file does not end with </VTKFile>"],
    );
}
