//! The reader and the writer together: encodings, types, skipped elements, bad files.

use std::path::Path;

use super::header::MAX_HEADER;
use super::*;

fn write_file(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Reads properties `names` of the vertex element as rows.
fn rows(path: &Path, names: &[&str]) -> Result<Vec<Vec<f64>>, String> {
    let f = PlyFile::open(path).map_err(message)?;
    let (k, e) = f.header().element("vertex").ok_or("no vertex")?;
    let wanted: Vec<usize> = names.iter().map(|n| e.property(n).unwrap()).collect();
    let mut out = Vec::new();
    f.read_rows(k, &wanted, |_, v| {
        out.push(v.to_vec());
        Ok(())
    })
    .map_err(message)?;
    Ok(out)
}

fn message(e: PlyError) -> String {
    match e {
        PlyError::Bad(m) => m,
        PlyError::Io(e) => e.to_string(),
    }
}

/// The same columns written in the three encodings read back as the same numbers, with
/// every type, properties in another order, and other elements and lists skipped.
#[test]
fn three_encodings_read_the_same_values() {
    let dir = tempfile::tempdir().unwrap();
    let values: [&[f64]; 8] = [
        &[-128.0, 0.0, 127.0],
        &[0.0, 200.0, 255.0],
        &[-32768.0, 5.0, 32767.0],
        &[0.0, 1.0, 65535.0],
        &[-2147483648.0, 7.0, 2147483647.0],
        &[0.0, 3.0, 4294967295.0],
        &[0.1f32 as f64, -1e30f32 as f64, f32::MIN_POSITIVE as f64],
        &[0.1, -1e300, 5e-324],
    ];
    let types = [
        Scalar::I8,
        Scalar::U8,
        Scalar::I16,
        Scalar::U16,
        Scalar::I32,
        Scalar::U32,
        Scalar::F32,
        Scalar::F64,
    ];
    let names = ["a", "b", "c", "d", "e", "f", "g", "h"];
    let columns: Vec<Column> = (0..8)
        .map(|k| Column {
            name: names[k],
            ty: types[k],
            values: values[k],
        })
        .collect();
    let mut got = Vec::new();
    for enc in [
        Encoding::Ascii,
        Encoding::BinaryLittleEndian,
        Encoding::BinaryBigEndian,
    ] {
        let mut bytes = Vec::new();
        write_vertices(&mut bytes, enc, &columns).unwrap();
        let p = write_file(&dir, "v.ply", &bytes);
        let r = rows(&p, &["h", "a", "g", "b", "c", "d", "e", "f"]).unwrap();
        got.push(r);
    }
    assert_eq!(got[0], got[1]);
    assert_eq!(got[1], got[2]);
    assert_eq!(got[0][2][0], 5e-324);
    assert_eq!(got[0][0][1], -128.0);
    // An element before the vertices, with a list, and a list inside them: skipped.
    let text = "ply\nformat ascii 1.0\ncomment made by hand\nelement camera 2\nproperty list uchar int ids\nproperty float f\nelement vertex 2\nproperty list uchar float junk\nproperty double y\nproperty int x\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n2 7 8 0.5\n0 1.5\n3 1 2 3 0.25 -4\n1 7.5 9.5 6\n3 0 1 2\n";
    let p = write_file(&dir, "t.ply", text.as_bytes());
    assert_eq!(
        rows(&p, &["x", "y"]).unwrap(),
        [vec![-4.0, 0.25], vec![6.0, 9.5]]
    );
    let mut bin = b"ply\nformat binary_big_endian 1.0\nelement camera 1\nproperty list uchar int ids\nelement vertex 1\nproperty list uchar float junk\nproperty short x\nend_header\n".to_vec();
    bin.extend([2, 0, 0, 0, 1, 0, 0, 0, 2]);
    bin.extend([1, 0, 0, 0, 0]);
    bin.extend((-3i16).to_be_bytes());
    let p = write_file(&dir, "b.ply", &bin);
    assert_eq!(rows(&p, &["x"]).unwrap(), [vec![-3.0]]);
}

#[test]
fn bad_files_are_refused_with_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let head =
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nend_header\n";
    let check = |bytes: &[u8], want: &str| {
        let p = write_file(&dir, "bad.ply", bytes);
        let got = rows(&p, &["x"]).unwrap_err();
        assert!(got.contains(want), "{got:?} lacks {want:?}");
    };
    // Two of three rows: refused at opening, from the size.
    let mut short = head.as_bytes().to_vec();
    short.extend([0; 8]);
    check(
        &short,
        "declares 3 vertex rows, at least 4 bytes each, but the file holds only 8",
    );
    check(
        b"ply\nformat binary_little_endian 1.0\nelement vertex 2147483648\nproperty float x\nend_header\n",
        "declares 2147483648 vertex rows",
    );
    check(
        b"ply\nformat ascii 1.0\nelement vertex 18446744073709551615\nproperty float x\nend_header\n1\n",
        "declares 18446744073709551615 vertex rows",
    );
    check(b"", "empty");
    check(b"plyx\n", "not a PLY file");
    check(
        b"ply\nformat ascii 1.0\nelement vertex 1\n",
        "ends inside its header",
    );
    check(b"ply\nformat ascii 2.0\nend_header\n", "version 2.0");
    check(
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty real x\nend_header\n",
        "unknown property type \"real\"",
    );
    check(
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\nabc\n",
        "vertex 0: x is \"abc\", not a value of type float",
    );
    check(
        b"ply\nformat ascii 1.0\nelement vertex 2\nproperty uchar x\nend_header\n3\n256\n",
        "line 7: vertex 1: x is \"256\"",
    );
    check(
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1.000\n2.000\n",
        "line 8: truncated: the file ends in vertex 2 of 3",
    );
    // A list where a number is wanted.
    let p = write_file(
        &dir,
        "l.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nend_header\n1 2\n",
    );
    let f = PlyFile::open(&p).unwrap();
    let got = message(f.read_rows(0, &[0], |_, _| Ok(())).unwrap_err());
    assert!(
        got.contains("property x of element vertex is a list"),
        "{got}"
    );
    // A directory.
    let got = message(PlyFile::open(dir.path()).err().unwrap());
    assert!(got.contains("is a directory"), "{got}");
    // A header without end.
    let big = vec![b'a'; MAX_HEADER + 10];
    let mut text = b"ply\ncomment ".to_vec();
    text.extend(big);
    check(&text, "no end_header");
    // Data shorter than its lists say: truncated, with the row.
    let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty list uchar int l\nproperty uchar x\nend_header\n".to_vec();
    bin.extend([0, 1, 9, 0, 0]);
    check(&bin, "truncated: the file ends in vertex 1 of 2");
}

/// ASCII rows: one line each, exactly their values, nothing after the last; found with the
/// file's line.
#[test]
fn ascii_rows_are_lines_of_exactly_their_values() {
    let dir = tempfile::tempdir().unwrap();
    let head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty list uchar int l\nelement face 1\nproperty int f\nend_header\n";
    let read = |body: &str| {
        let p = write_file(&dir, "a.ply", format!("{head}{body}").as_bytes());
        rows(&p, &["x"])
    };
    // Lines 9 and 10 hold the vertices, 11 the face.
    assert_eq!(read("1 2 7 8\n2 0\n5\n").unwrap(), [vec![1.0], vec![2.0]]);
    // Blank lines, blanks at line ends, CR LF line ends.
    assert_eq!(
        read("\n1 2 7 8 \t\r\n\r\n2 0\r\n5\r\n\n\n").unwrap(),
        [vec![1.0], vec![2.0]]
    );
    for (body, want) in [
        (
            "1 2 7 8 9\n2 0\n5\n",
            "line 9: vertex 0 has more values than its 2 properties: \"9\" after l",
        ),
        (
            "1 2 7\n8\n2 0\n5\n",
            "line 9: vertex 0 ends after 3 values, short of its 2 properties",
        ),
        (
            "1 2 7 8\n2 0\n5",
            "line 11: the file ends inside face 0, with no line end after its last value",
        ),
        (
            "1 2 7 8\n2 0\n5\n6\n",
            "line 12: text after the 1 face rows the header declares: \"6\"",
        ),
        (
            "1 2 7 8\n2 0\n5\n\n  x\n",
            "line 13: text after the 1 face rows",
        ),
        (
            "1 2 7 8\n2 0\n",
            "line 11: truncated: the file ends in face 0 of 1",
        ),
        ("1 2 7 8\n2 0", "line 10: the file ends inside vertex 1"),
        ("1 2 7 8\nz 0\n5\n", "line 10: vertex 1: x is \"z\""),
        (
            "1 2 7 8\n2 1      \n",
            "line 10: truncated: the file ends in vertex 1 of 2",
        ),
    ] {
        let got = read(body).unwrap_err();
        assert!(got.contains(want), "{body:?}: {got:?} lacks {want:?}");
    }
}

/// Header lines that end in CR alone are named as such, not as an empty file.
#[test]
fn cr_only_line_ends_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(
        &dir,
        "cr.ply",
        b"ply\rformat ascii 1.0\relement vertex 1\rproperty float x\rend_header\r1\r",
    );
    let got = rows(&p, &["x"]).unwrap_err();
    assert!(
        got.starts_with("header line 1 holds a carriage return (CR)"),
        "{got}"
    );
    let p = write_file(
        &dir,
        "cr2.ply",
        b"ply\r\nformat ascii 1.0\relement vertex 1\r\n",
    );
    let got = rows(&p, &["x"]).unwrap_err();
    assert!(
        got.starts_with("header line 2 holds a carriage return"),
        "{got}"
    );
    let p = write_file(&dir, "one.ply", b"ply");
    let got = rows(&p, &["x"]).unwrap_err();
    assert!(got.contains("ends inside its first line"), "{got}");
}

/// Rows with more unused bytes than `read::SKIP_BYTES` (64 KiB) are read by their used bytes alone; they
/// give the values a read of whole rows gives.
#[test]
fn wide_rows_give_the_same_values_read_by_their_used_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let n = 5;
    let values: Vec<Vec<f64>> = (0..4)
        .map(|c| (0..n).map(|i| (c * 100 + i) as f64 + 0.5).collect())
        .collect();
    let junk: Vec<f64> = (0..n).map(|i| -(i as f64)).collect();
    let names: Vec<String> = (0..20_000).map(|k| format!("j{k}")).collect();
    // x, 20,000 junk floats (80 KB), y z w: wanted x, z (the span from x to z is the row).
    let mut columns = vec![Column {
        name: "x",
        ty: Scalar::F32,
        values: &values[0],
    }];
    columns.extend(names.iter().map(|name| Column {
        name,
        ty: Scalar::F32,
        values: &junk,
    }));
    for (k, name) in ["y", "z", "w"].into_iter().enumerate() {
        columns.push(Column {
            name,
            ty: Scalar::F64,
            values: &values[k + 1],
        });
    }
    for enc in [Encoding::BinaryLittleEndian, Encoding::BinaryBigEndian] {
        let mut bytes = Vec::new();
        write_vertices(&mut bytes, enc, &columns).unwrap();
        let p = write_file(&dir, "w.ply", &bytes);
        // y and w: a span of 16 bytes of a row of 80,028; x and w: the whole row.
        let got = rows(&p, &["w", "y"]).unwrap();
        let want: Vec<Vec<f64>> = (0..n).map(|i| vec![values[3][i], values[1][i]]).collect();
        assert_eq!(got, want);
        let whole = rows(&p, &["w", "x"]).unwrap();
        assert_eq!(whole.iter().map(|r| r[0]).collect::<Vec<_>>(), values[3]);
        assert_eq!(whole.iter().map(|r| r[1]).collect::<Vec<_>>(), values[0]);
    }
}

/// Rows read in chunks bounded in bytes: rows across several chunks come out in order.
#[test]
fn rows_across_chunks_come_out_in_order() {
    let dir = tempfile::tempdir().unwrap();
    // 1,000 properties of 4 bytes: 262 rows a chunk of 1 MiB; 1,000 rows are four chunks.
    let n = 1000;
    let x: Vec<f64> = (0..n).map(f64::from).collect();
    let names: Vec<String> = (0..999).map(|k| format!("j{k}")).collect();
    let zeros = vec![0.0; n as usize];
    let mut columns = vec![Column {
        name: "x",
        ty: Scalar::I32,
        values: &x,
    }];
    columns.extend(names.iter().map(|name| Column {
        name,
        ty: Scalar::F32,
        values: &zeros,
    }));
    let mut bytes = Vec::new();
    write_vertices(&mut bytes, Encoding::BinaryLittleEndian, &columns).unwrap();
    let p = write_file(&dir, "c.ply", &bytes);
    let got: Vec<f64> = rows(&p, &["x"])
        .unwrap()
        .into_iter()
        .map(|r| r[0])
        .collect();
    assert_eq!(got, x);
}

#[test]
fn an_error_of_the_caller_stops_the_reading() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = Vec::new();
    let v: Vec<f64> = (0..100_000).map(f64::from).collect();
    write_vertices(
        &mut bytes,
        Encoding::BinaryLittleEndian,
        &[Column {
            name: "x",
            ty: Scalar::F32,
            values: &v,
        }],
    )
    .unwrap();
    let p = write_file(&dir, "v.ply", &bytes);
    let f = PlyFile::open(&p).unwrap();
    let mut seen = 0;
    let e = f
        .read_rows(0, &[0], |i, v| {
            seen += 1;
            if v[0] == 54321.0 {
                Err(format!("point {i} is bad"))
            } else {
                Ok(())
            }
        })
        .unwrap_err();
    assert_eq!(message(e), "point 54321 is bad");
    assert_eq!(seen, 54322);
}

/// Rows read in parts, on several threads: every row handed over once with its number and
/// the values read in order, in both binary encodings, with an unused property between the
/// wanted ones; the first bad row's error on any number of threads; a file cut short after
/// it was opened found at its first missing row.
#[test]
fn rows_read_in_parts_are_the_rows_read_in_order() {
    let dir = tempfile::tempdir().unwrap();
    // 15-byte rows: 17,476 a part, so 50,000 rows are three parts.
    let n = 50_000usize;
    let x: Vec<f64> = (0..n).map(|i| i as f64 * 0.25 - 3000.0).collect();
    let pad: Vec<f64> = (0..n).map(|i| (i % 251) as f64).collect();
    let y: Vec<f64> = (0..n).map(|i| (i % 30_000) as f64 - 15_000.0).collect();
    let z: Vec<f64> = (0..n).map(|i| f64::from(i as f32 * 1.5e-3)).collect();
    let columns = [
        Column {
            name: "x",
            ty: Scalar::F64,
            values: &x,
        },
        Column {
            name: "pad",
            ty: Scalar::U8,
            values: &pad,
        },
        Column {
            name: "y",
            ty: Scalar::I16,
            values: &y,
        },
        Column {
            name: "z",
            ty: Scalar::F32,
            values: &z,
        },
    ];
    let pool = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    };
    for enc in [Encoding::BinaryLittleEndian, Encoding::BinaryBigEndian] {
        let mut bytes = Vec::new();
        write_vertices(&mut bytes, enc, &columns).unwrap();
        let p = write_file(&dir, "p.ply", &bytes);
        let names = ["z", "x", "y"];
        let in_order = rows(&p, &names).unwrap();
        assert_eq!(in_order[n - 1], [z[n - 1], x[n - 1], y[n - 1]]);
        // `read_rows_in_parts`, each row's number and values kept, with `bad` rows refused.
        let in_parts = |threads: usize, bad: &[u64]| -> Result<Vec<(u64, Vec<f64>)>, String> {
            let f = PlyFile::open(&p).unwrap();
            let (k, e) = f.header().element("vertex").unwrap();
            let wanted: Vec<usize> = names.iter().map(|m| e.property(m).unwrap()).collect();
            let per = f.part_rows(k, &wanted).expect("binary rows of fixed size");
            assert_eq!(per, (1 << 18) / 15);
            let mut got = vec![Vec::new(); n.div_ceil(per as usize)];
            assert_eq!(got.len(), 3);
            pool(threads).install(|| f_read(&p, k, &wanted, got.iter_mut().collect(), bad))?;
            Ok(got.into_iter().flatten().collect())
        };
        for threads in [1, 3] {
            let got = in_parts(threads, &[]).unwrap();
            assert!(got.iter().map(|r| r.0).eq(0..n as u64));
            assert!(got.iter().map(|r| &r.1).eq(in_order.iter()));
            // Bad rows in the second and third parts: the first is named.
            let e = in_parts(threads, &[45_000, 20_000]).unwrap_err();
            assert_eq!(e, "row 20000 is bad");
        }
        // Cut after opening, inside row 30,000.
        let cut = |read: &mut dyn FnMut(PlyFile) -> Result<(), PlyError>| {
            let p = write_file(&dir, "cut.ply", &bytes);
            let f = PlyFile::open(&p).unwrap();
            let header = bytes.len() - 15 * n;
            std::fs::OpenOptions::new()
                .write(true)
                .open(&p)
                .unwrap()
                .set_len((header + 15 * 30_000 + 7) as u64)
                .unwrap();
            message(read(f).unwrap_err())
        };
        // (Read in order, this file lies in the reader's buffer from the opening on.)
        let want = "truncated: the file ends in vertex 30000 of 50000 (rows counted from 0)";
        let parts = || vec![(); 3];
        assert_eq!(
            cut(&mut |f| f.read_rows_in_parts(0, &[0], parts(), |_, _, _| Ok(()))),
            want
        );
    }
}

/// [`PlyFile::read_rows_in_parts`] of the file at `p`, each part's rows pushed onto its own
/// list; the rows `bad` refused.
fn f_read(
    p: &Path,
    element: usize,
    wanted: &[usize],
    parts: Vec<&mut Vec<(u64, Vec<f64>)>>,
    bad: &[u64],
) -> Result<(), String> {
    PlyFile::open(p)
        .unwrap()
        .read_rows_in_parts(element, wanted, parts, |part, i, v| {
            if bad.contains(&i) {
                return Err(format!("row {i} is bad"));
            }
            part.push((i, v.to_vec()));
            Ok(())
        })
        .map_err(message)
}
