//! The reader and the writer together: encodings, types, skipped elements, bad files.

use std::path::Path;

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
        b"ply\nformat ascii 1.0\nelement vertex 2\nproperty uchar x\nend_header\n3 256\n",
        "vertex 1: x is \"256\"",
    );
    check(
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1.000 2.000\n",
        "truncated: the file ends in vertex 2 of 3",
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
