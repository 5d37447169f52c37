//! Hostile PLY point caches, third round: headers of many lines (read in time linear in their
//! size), rows of many unused properties (read through buffers bounded in bytes, within the
//! memory estimate), ASCII rows with more or fewer values than their properties, files cut
//! inside a value or with text after their rows, CR-only line ends, and ids beyond the range
//! of 64-bit integers. Each run ends within 5 seconds under a 1 GiB address-space limit.

use crate::common;

use common::hostile::{points, refused, run, scene, setup};
use common::text;
use raytrace_scene::ply::{Column, Encoding, Scalar, write_vertices};

/// An ASCII PLY file of float `x y z` rows: the header (7 lines), then `body`.
fn ascii(body: &str) -> Vec<u8> {
    format!(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nend_header\n{body}"
    )
    .into_bytes()
}

/// The scene with the cache `c.ply` holding `bytes`.
fn cache(bytes: &[u8]) -> tempfile::TempDir {
    setup(
        &scene("f_####.png", &points("c.ply", "")),
        &[("c.ply", bytes)],
    )
}

/// `render` and `check` refuse the scene in `dir` with each of `want` in the message.
fn both_refuse(dir: &std::path::Path, want: &[&str]) {
    let kept = common::hostile::names(dir);
    let kept: Vec<&str> = kept.iter().map(String::as_str).collect();
    for args in [&["render", "shot.toml"][..], &["check", "shot.toml"][..]] {
        refused(dir, args, want, &kept);
    }
}

fn accepted(dir: &std::path::Path) -> String {
    let o = run(dir, &["check", "shot.toml"]);
    assert_eq!(o.status.code(), Some(0), "{}", common::shorten(&text(&o)));
    text(&o)
}

#[test]
fn ascii_rows_hold_exactly_their_properties_and_nothing_follows_them() {
    // Rows start at line 8.
    let d = cache(&ascii("0 0 0\n1 1 1 9\n2 2 2\n"));
    both_refuse(
        d.path(),
        &[
            "c.ply",
            "line 9: vertex 1 has more values than its 3 properties: \"9\"",
        ],
    );
    let d = cache(&ascii("0 0 0\n1 1\n1 2 2 2\n"));
    both_refuse(
        d.path(),
        &[
            "c.ply",
            "line 9: vertex 1 ends after 2 values, short of its 3 properties",
        ],
    );
    // Cut inside its last value (`0.1` cut to `0`): no line end after it.
    let d = cache(&ascii("0 0 0\n1 1 1\n2 2 0"));
    both_refuse(
        d.path(),
        &[
            "c.ply",
            "line 10: the file ends inside vertex 2",
            "truncated",
        ],
    );
    let d = cache(&ascii("0 0 0\n1 1 1\n2 2 2\n3 3 3\n"));
    both_refuse(
        d.path(),
        &["c.ply", "line 11: text after the 3 vertex rows", "\"3\""],
    );
    // The same after an element that follows the vertices (read to the end of the file).
    let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                end_header\n0 0 0\n3 0 0 0\nextra\n";
    let d = cache(text.as_bytes());
    both_refuse(d.path(), &["c.ply", "line 12: text after the 1 face rows"]);
    let text = text.replace("3 0 0 0\n", "3 0 0 0 0\n");
    let d = cache(text.as_bytes());
    both_refuse(d.path(), &["c.ply", "line 11: face 0 has more values"]);
    // What a good file may hold: CR LF line ends, blank lines, spaces and tabs at line ends.
    let d = cache(&ascii("0 0 0\r\n1 1 1 \t\r\n\r\n2 2 2\r\n\n"));
    let t = accepted(d.path());
    assert!(t.contains("3 points"), "{t}");
}

#[test]
fn a_header_with_cr_only_line_ends_is_named_as_such() {
    let bytes: Vec<u8> = ascii("0 0 0\n1 1 1\n2 2 2\n")
        .into_iter()
        .map(|b| if b == b'\n' { b'\r' } else { b })
        .collect();
    let d = cache(&bytes);
    both_refuse(d.path(), &["c.ply", "carriage return"]);
    let t = refused(
        d.path(),
        &["check", "shot.toml"],
        &[],
        &["c.ply", "shot.toml"],
    );
    assert!(!t.contains("empty"), "{t}");
    // A file that is empty is still called empty.
    let d = cache(b"");
    both_refuse(d.path(), &["c.ply", "empty: not a PLY file"]);
}

#[test]
fn ids_beyond_64_bit_integers_are_out_of_range_not_duplicates() {
    let file = |ids: &[f64]| {
        let xs = [0.0, 1.0, 2.0];
        let cols = [
            Column {
                name: "x",
                ty: Scalar::F32,
                values: &xs,
            },
            Column {
                name: "y",
                ty: Scalar::F32,
                values: &xs,
            },
            Column {
                name: "z",
                ty: Scalar::F32,
                values: &xs,
            },
            Column {
                name: "id",
                ty: Scalar::F64,
                values: ids,
            },
        ];
        let mut out = Vec::new();
        write_vertices(&mut out, Encoding::BinaryLittleEndian, &cols).unwrap();
        out
    };
    let interpolated = points("s_#.ply", "motion = \"interpolate\"\n");
    let d = setup(
        &scene("f_####.png", &interpolated),
        &[
            ("s_1.ply", &file(&[1e30, 2e30, 3.0])),
            ("s_2.ply", &file(&[1.0, 2.0, 3.0])),
        ],
    );
    both_refuse(
        d.path(),
        &["s_1.ply", "point 0: id is 1e30", "not below the 2^53"],
    );
    let t = refused(
        d.path(),
        &["check", "shot.toml"],
        &[],
        &["s_1.ply", "s_2.ply", "shot.toml"],
    );
    assert!(!t.contains("held by two points"), "{t}");
    // The largest ids told apart from every other, -(2^53 - 1) and 2^53 - 1, are kept apart;
    // 2^53 is refused, as 2^53 + 1 reads as it.
    let d = setup(
        &scene("f_####.png", &interpolated),
        &[
            (
                "s_1.ply",
                &file(&[-(2f64.powi(53) - 1.0), 2f64.powi(53) - 1.0, 3.0]),
            ),
            ("s_2.ply", &file(&[1.0, 2.0, 3.0])),
        ],
    );
    accepted(d.path());
    let d = setup(
        &scene("f_####.png", &interpolated),
        &[
            ("s_1.ply", &file(&[1.0, 2f64.powi(53), 3.0])),
            ("s_2.ply", &file(&[1.0, 2.0, 3.0])),
        ],
    );
    both_refuse(
        d.path(),
        &["s_1.ply", "point 1: id is 9.007199254740992e15", "2^53"],
    );
}

/// A binary PLY header: `extra` lines before a vertex element of `rows` rows of float x, y,
/// z and `unused` uchar properties after them.
fn wide_header(extra: &str, rows: u64, unused: usize, ty: &str) -> String {
    let mut h = format!("ply\nformat binary_little_endian 1.0\n{extra}element vertex {rows}\n");
    h += "property float x\nproperty float y\nproperty float z\n";
    for i in 0..unused {
        h += &format!("property {ty} p{i}\n");
    }
    h + "end_header\n"
}

#[test]
fn headers_of_many_lines_are_read_in_time_linear_in_their_size() {
    // 55,000 elements and 45,000 properties (each about 900 KB of header): every element and
    // property name was compared with every one before it (1.5e9 comparisons a read).
    let mut elements = String::new();
    for i in 0..55_000 {
        elements += &format!("element e{i} 0\n");
    }
    for (extra, unused) in [(elements.as_str(), 0), ("", 45_000)] {
        let header = wide_header(extra, 1, unused, "uchar");
        assert!(header.len() > 800_000 && header.len() < 1 << 20);
        let mut bytes = header.into_bytes();
        bytes.resize(bytes.len() + 12 + unused, 0);
        let d = cache(&bytes);
        let t = accepted(d.path());
        assert!(t.contains("1 points"), "{t}");
    }
}

/// A sparse binary PLY file `c.ply` in `dir` of `rows` rows: float x, y, z (all 0) and
/// `unused` float properties.
fn sparse(dir: &std::path::Path, rows: u64, unused: usize) {
    let header = wide_header("", rows, unused, "float");
    let path = dir.join("c.ply");
    std::fs::write(&path, header.as_bytes()).unwrap();
    let f = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
    f.set_len(header.len() as u64 + rows * 4 * (3 + unused as u64))
        .unwrap();
}

#[test]
fn rows_of_many_unused_properties_are_read_without_their_bytes_in_memory() {
    // 8,000 rows of 44,003 floats (176 KB a row, 1.4 GB of data, a sparse file): the read
    // buffer was 16,384 rows (or all of them), 1.4 GB, past the 1 GiB limit. Rows this wide
    // are read by their used bytes alone.
    let d = cache(b"");
    sparse(d.path(), 8_000, 44_000);
    let t = accepted(d.path());
    assert!(t.contains("8000 points"), "{t}");
    let o = run(
        d.path(),
        &["render", "shot.toml", "--frames", "1", "--threads", "2"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

#[test]
fn the_read_buffer_is_bounded_in_bytes_and_within_the_memory_estimate() {
    // 16,384 rows of 1,003 floats (4 KB a row): the read buffer was 16,384 rows, 66 MB, far
    // outside the estimate; now 1 MiB of rows, counted in it.
    let d = cache(b"");
    sparse(d.path(), 16_384, 1_000);
    let o = run(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--frames",
            "1",
            "--stats",
            "--threads",
            "2",
        ],
    );
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    let mib = |after: &str| -> f64 {
        let rest = &t[t.find(after).unwrap_or_else(|| panic!("{after}: {t}")) + after.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    let (estimate, peak) = (mib("memory: about "), mib("peak memory "));
    println!("estimate {estimate} MiB, peak {peak} MiB");
    assert!(
        peak <= estimate,
        "peak {peak} MiB, estimate {estimate} MiB: {t}"
    );
}

/// `c.ply` of float `x y z radius` rows `0..n` (a band across the camera's view), in
/// `encoding`, with point `bad`'s radius `radius`.
fn line_of_points(encoding: Encoding, n: usize, bad: Option<(usize, f64)>) -> Vec<u8> {
    let x: Vec<f64> = (0..n)
        .map(|i| (i as f64 * 4.0 / n as f64 - 2.0) as f32 as f64)
        .collect();
    let zeros = vec![0.0; n];
    let mut radius = vec![0.3; n];
    if let Some((i, r)) = bad {
        radius[i] = r;
    }
    let columns =
        [("x", &x), ("y", &zeros), ("z", &zeros), ("radius", &radius)].map(|(name, values)| {
            Column {
                name,
                ty: Scalar::F32,
                values,
            }
        });
    let mut bytes = Vec::new();
    write_vertices(&mut bytes, encoding, &columns).unwrap();
    bytes
}

#[test]
fn binary_rows_read_in_parts_give_what_text_rows_read_in_order_give() {
    // 16-byte rows, 16,384 a part: 60,000 points are four parts, read on two threads, where
    // an ASCII file's rows are read one after another.
    let n = 60_000;
    let encodings = [
        Encoding::Ascii,
        Encoding::BinaryLittleEndian,
        Encoding::BinaryBigEndian,
    ];
    // Bad radii in the third and fourth parts: the first is named, whichever way.
    for encoding in encodings {
        let mut bytes = line_of_points(encoding, n, Some((40_000, -1.0)));
        if encoding != Encoding::Ascii {
            // Another in the last part, in place (the rows' last 4 bytes are the radius).
            let at = bytes.len() - 16 * (n - 55_000) + 12;
            bytes[at..at + 4].copy_from_slice(&match encoding {
                Encoding::BinaryBigEndian => f32::NAN.to_be_bytes(),
                _ => f32::NAN.to_le_bytes(),
            });
        }
        both_refuse(
            cache(&bytes).path(),
            &["c.ply", "point 40000: radius is -1; a radius must be >= 0"],
        );
    }
    // The same frames from the same points.
    let frames: Vec<Vec<u8>> = encodings
        .map(|encoding| {
            let d = cache(&line_of_points(encoding, n, None));
            let o = run(
                d.path(),
                &["render", "shot.toml", "--frames", "1", "--threads", "2"],
            );
            assert_eq!(o.status.code(), Some(0), "{}", common::shorten(&text(&o)));
            std::fs::read(d.path().join("f_0001.png")).unwrap()
        })
        .into();
    // Not the background alone: the points are in view.
    let d = cache(&line_of_points(Encoding::Ascii, 1, None));
    run(d.path(), &["render", "shot.toml", "--frames", "1"]);
    assert_ne!(
        std::fs::read(d.path().join("f_0001.png")).unwrap(),
        frames[0]
    );
    assert_eq!(frames[0], frames[1]);
    assert_eq!(frames[1], frames[2]);
}
