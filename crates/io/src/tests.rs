//! Tests of frame paths, formats, EXR and PNG writing and reading, and atomic writes.

use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::time::Duration;

use super::atomic::{Writer, host_name, parse_temp_name, split_target, temp_name, write_with};
use super::exr::fps_rational;
use super::*;
use raytrace_core::error::Error;
use raytrace_core::format::{FRAME_FORMATS, Format};
use raytrace_core::image::{COLOUR, Image, Precision, Values};
use raytrace_core::path_pattern::{FramePattern, pattern_has_frame_number};
use std::ffi::OsStr;

fn info() -> FrameInfo {
    FrameInfo {
        frame: 17,
        fps: 23.976,
        shutter_open: 0.6666666666666666,
        shutter_close: 0.6875000000000001,
        samples: 256,
        seed: u64::MAX - 12345,
        sampler: "sobol".to_string(),
        rolling_shutter_readout: None,
        shutter_curve: None,
        denoiser: None,
        extra: vec![
            ("achievedSamples".to_string(), 211.5),
            ("error".to_string(), 0.0125),
        ],
    }
}

/// Writes an image of `width` x `height` whose colour is `rgb` (interleaved RGB; an image
/// without a colour where `rgb` does not hold three values a pixel) to `path`, in the format
/// its extension names ([`write_image`]).
fn write_test_image(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[f32],
    info: &FrameInfo,
) -> Result<(), Error> {
    let format = Format::from_extension(path, FRAME_FORMATS).ok_or_else(|| Error::Output {
        path: path.to_path_buf(),
        message: Format::unsupported(FRAME_FORMATS, "output"),
    })?;
    let image = colour(width, height, rgb);
    write_image(path, format, &image, info)
}

/// An image whose colour is `rgb` (interleaved), or of no channel where `rgb` does not hold
/// three values a pixel.
fn colour(width: u32, height: u32, rgb: &[f32]) -> Image {
    match rgb.len() == 3 * width as usize * height as usize {
        true => Image::from_interleaved(width, height, COLOUR, rgb),
        false => Image::new(width, height),
    }
}

/// A small image whose pixels all differ, including values outside [0, 1].
fn pixels(width: u32, height: u32) -> Vec<f32> {
    (0..width * height * 3)
        .map(|i| (i as f32) * 0.173 - 0.5 + 1.0 / (i as f32 + 3.0))
        .collect()
}

fn dir_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// The path of `frame` for the pattern `text`.
fn frame_path(text: &str, frame: u32) -> PathBuf {
    raytrace_core::path_pattern::frame_path(&FramePattern::new(text).unwrap(), frame)
}

#[test]
fn frame_paths() {
    assert_eq!(
        frame_path("out/render.####.exr", 1),
        PathBuf::from("out/render.0001.exr")
    );
    assert_eq!(
        frame_path("r.####.exr", 12345),
        PathBuf::from("r.12345.exr")
    );
    assert_eq!(frame_path("r_##.png", 12345), PathBuf::from("r_12345.png"));
    assert_eq!(frame_path("r_#.png", 7), PathBuf::from("r_7.png"));
    assert_eq!(frame_path("r_#.png", 0), PathBuf::from("r_0.png"));
    assert_eq!(
        frame_path("shot##/f.###.exr", 5),
        PathBuf::from("shot05/f.005.exr")
    );
    assert_eq!(frame_path("still.exr", 5), PathBuf::from("still.exr"));
    assert_eq!(frame_path("é_##.png", 3), PathBuf::from("é_03.png"));
    assert_eq!(
        frame_path("f.##########.exr", u32::MAX),
        PathBuf::from("f.4294967295.exr")
    );
    assert!(pattern_has_frame_number("a.#.exr"));
    assert!(!pattern_has_frame_number("a.exr"));
}

#[test]
fn formats_by_extension() {
    let format_for = |p: &str| Format::of(Path::new(p), FRAME_FORMATS, "output");
    assert_eq!(format_for("a/b.exr"), Ok(Format::Exr));
    assert_eq!(format_for("b.EXR"), Ok(Format::Exr));
    assert_eq!(format_for("b.0001.png"), Ok(Format::Png));
    assert_eq!(format_for("b.PnG"), Ok(Format::Png));
    assert!(format_for("b.svg").is_err());
    assert_eq!(
        Format::of(Path::new("p.SVG"), &[Format::Png, Format::Svg], "plot"),
        Ok(Format::Svg)
    );
    for bad in ["b.jpg", "b", "b.exr.tmp", "exr", ".png"] {
        let e = format_for(bad).unwrap_err();
        assert!(
            e.contains(bad) && e.contains(".exr") && e.contains(".png"),
            "{e}"
        );
    }
}

#[test]
fn srgb_encoding() {
    assert_eq!(linear_to_srgb8(0.0), 0);
    assert_eq!(linear_to_srgb8(1.0), 255);
    assert_eq!(linear_to_srgb8(0.5), 188);
    assert_eq!(linear_to_srgb8(0.18), 118);
    // Both sides of the boundary of the two pieces: 12.92 * 0.0031308 * 255 = 10.31.
    assert_eq!(linear_to_srgb8(0.0031308), 10);
    assert_eq!(linear_to_srgb8(0.003131), 10);
    assert_eq!(linear_to_srgb8(0.0031), 10);
    assert_eq!(linear_to_srgb8(-3.0), 0);
    assert_eq!(linear_to_srgb8(7.0), 255);
    assert_eq!(linear_to_srgb8(f32::NAN), 0);
    assert_eq!(linear_to_srgb8(f32::INFINITY), 0);
    assert_eq!(linear_to_srgb8(f32::NEG_INFINITY), 0);
    let mut last = 0;
    for i in 0..=10_000 {
        let v = linear_to_srgb8(i as f32 / 10_000.0);
        assert!(v >= last);
        last = v;
    }
}

#[test]
fn frame_rates_as_rationals() {
    assert_eq!(fps_rational(24.0), Some((24, 1)));
    assert_eq!(fps_rational(1.0), Some((1, 1)));
    assert_eq!(fps_rational(23.976), Some((24000, 1001)));
    assert_eq!(fps_rational(24000.0 / 1001.0), Some((24000, 1001)));
    assert_eq!(fps_rational(29.97), Some((30000, 1001)));
    assert_eq!(fps_rational(59.94), Some((60000, 1001)));
    assert_eq!(fps_rational(12.5), Some((25, 2)));
    assert_eq!(fps_rational(23.98), Some((1199, 50)));
    assert_eq!(fps_rational(0.1), Some((1, 10)));
    let (n, d) = fps_rational(std::f64::consts::PI).unwrap();
    assert!(d <= 1_000_000 && (n as f64 / d as f64 - std::f64::consts::PI).abs() < 1e-9);
    for bad in [0.0, -24.0, f64::NAN, f64::INFINITY, 1e12, 1e-9] {
        assert_eq!(fps_rational(bad), None, "{bad}");
    }
}

#[test]
fn exr_round_trip() {
    use ::exr::meta::attribute::{AttributeValue, Text};
    use ::exr::prelude::*;

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.0017.exr");
    let (w, h) = (7, 5);
    let rgb = pixels(w, h);
    write_test_image(&path, w, h, &rgb, &info()).unwrap();
    assert_eq!(dir_names(dir.path()), vec!["f.0017.exr"]);

    let meta = ::exr::meta::MetaData::read_from_file(&path, false).unwrap();
    assert_eq!(meta.headers.len(), 1);
    assert_eq!(meta.headers[0].compression, Compression::ZIP16);

    let image = read_all_data_from_file(&path).unwrap();
    let layer = &image.layer_data[0];
    assert_eq!(layer.size, Vec2(w as usize, h as usize));
    let channels = &layer.channel_data.list;
    let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
    assert_eq!(names, vec!["B", "G", "R"], "stored in alphabetical order");
    for (c, offset) in channels.iter().zip([2, 1, 0]) {
        let Levels::Singular(FlatSamples::F32(samples)) = &c.sample_data else {
            panic!("channel {} is not f32", c.name)
        };
        let expected: Vec<u32> = rgb
            .iter()
            .skip(offset)
            .step_by(3)
            .map(|v| v.to_bits())
            .collect();
        let got: Vec<u32> = samples.iter().map(|v| v.to_bits()).collect();
        assert_eq!(got, expected, "channel {}", c.name);
    }

    let a = &layer.attributes;
    assert_eq!(a.frames_per_second, Some((24000, 1001)));
    let get = |name: &str| a.other.get(&Text::from(name)).cloned();
    let i = info();
    assert_eq!(get("frame"), Some(AttributeValue::I32(17)));
    assert_eq!(
        get("shutterOpen"),
        Some(AttributeValue::F64(i.shutter_open))
    );
    assert_eq!(
        get("shutterClose"),
        Some(AttributeValue::F64(i.shutter_close))
    );
    assert_eq!(get("samples"), Some(AttributeValue::I32(256)));
    assert_eq!(
        get("seed"),
        Some(AttributeValue::Text(Text::from("18446744073709539270")))
    );
    assert_eq!(
        get("sampler"),
        Some(AttributeValue::Text(Text::from("sobol")))
    );
    assert_eq!(get("achievedSamples"), Some(AttributeValue::F64(211.5)));
    assert_eq!(get("error"), Some(AttributeValue::F64(0.0125)));
}

#[test]
fn exr_shutter_attributes_only_when_the_shot_has_them() {
    use ::exr::meta::attribute::{AttributeValue, Text};
    let dir = tempfile::tempdir().unwrap();
    let read = |info: &FrameInfo, name: &str| {
        let path = dir.path().join(format!("{name}.exr"));
        write_test_image(&path, 1, 1, &[0.25, 0.5, 1.0], info).unwrap();
        let image = ::exr::prelude::read_all_data_from_file(&path).unwrap();
        let a = image.layer_data[0].attributes.other.clone();
        (
            a.get(&Text::from("rollingShutterReadout")).cloned(),
            a.get(&Text::from("shutterCurve")).cloned(),
        )
    };
    assert_eq!(read(&info(), "plain"), (None, None));
    let rolling = FrameInfo {
        rolling_shutter_readout: Some(0.015),
        shutter_curve: Some("triangle".into()),
        ..info()
    };
    assert_eq!(
        read(&rolling, "rolling"),
        (
            Some(AttributeValue::F64(0.015)),
            Some(AttributeValue::Text(Text::from("triangle")))
        )
    );
    // The names are reserved for these fields.
    let taken = FrameInfo {
        extra: vec![("rollingShutterReadout".into(), 1.0)],
        ..info()
    };
    let path = dir.path().join("taken.exr");
    assert!(write_test_image(&path, 1, 1, &[0.0; 3], &taken).is_err());
}

#[test]
fn exr_large_numbers_become_doubles() {
    use ::exr::meta::attribute::{AttributeValue, Text};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.exr");
    let info = FrameInfo {
        frame: u32::MAX,
        samples: 1 << 31,
        fps: 24.0,
        extra: vec![],
        ..info()
    };
    write_test_image(&path, 1, 1, &[0.25, 0.5, 1.0], &info).unwrap();
    let image = ::exr::prelude::read_all_data_from_file(&path).unwrap();
    let a = &image.layer_data[0].attributes;
    assert_eq!(a.frames_per_second, Some((24, 1)));
    assert_eq!(
        a.other.get(&Text::from("frame")),
        Some(&AttributeValue::F64(u32::MAX as f64))
    );
    assert_eq!(
        a.other.get(&Text::from("samples")),
        Some(&AttributeValue::F64(2147483648.0))
    );
}

#[test]
fn bad_extra_attributes_are_rejected_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub/x.exr");
    let rgb = pixels(2, 2);
    for (name, why) in [
        ("", "1 to 31"),
        ("an_attribute_name_of_32_letters_", "1 to 31"),
        ("seed", "reserved"),
        ("framesPerSecond", "reserved"),
        ("a\nb", "control"),
        ("日本", "Latin-1"),
    ] {
        let info = FrameInfo {
            extra: vec![(name.to_string(), 1.0)],
            ..info()
        };
        let e = write_test_image(&path, 2, 2, &rgb, &info).unwrap_err();
        assert!(matches!(e, Error::Output { .. }), "{e}");
        assert!(
            e.to_string().contains(why) && e.to_string().contains("x.exr"),
            "{e}"
        );
    }
    let twice = FrameInfo {
        extra: vec![("a".into(), 1.0), ("a".into(), 2.0)],
        ..info()
    };
    assert!(
        write_test_image(&path, 2, 2, &rgb, &twice)
            .unwrap_err()
            .to_string()
            .contains("twice")
    );
    let no_rate = FrameInfo { fps: 0.0, ..info() };
    let e = write_test_image(&path, 2, 2, &rgb, &no_rate).unwrap_err();
    assert!(e.to_string().contains("frame rate"), "{e}");
    assert!(!dir.path().join("sub").exists(), "nothing created");
}

#[test]
fn png_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.0001.PNG");
    let (w, h) = (3, 2);
    #[rustfmt::skip]
    let rgb = vec![
        0.0, 0.5, 1.0,   0.18, 2.0, -1.0,   0.0031308, 0.25, 0.75,
        1.0, 1.0, 1.0,   0.5, 0.5, 0.5,     0.01, 0.1, 0.9,
    ];
    write_test_image(&path, w, h, &rgb, &info()).unwrap();
    assert_eq!(dir_names(dir.path()), vec!["f.0001.PNG"]);
    let image = ::image::ImageReader::open(&path)
        .unwrap()
        .with_guessed_format()
        .unwrap()
        .decode()
        .unwrap();
    assert_eq!(image.color(), ::image::ColorType::Rgb8);
    let image = image.to_rgb8();
    assert_eq!(image.dimensions(), (w, h));
    let expected: Vec<u8> = rgb.iter().map(|&v| linear_to_srgb8(v)).collect();
    assert_eq!(image.as_raw(), &expected);
    assert_eq!(
        &image.as_raw()[..9],
        &[0, 188, 255, 118, 255, 0, 10, 137, 225]
    );
    assert_eq!(image.get_pixel(1, 1).0, [188, 188, 188]);
}

#[test]
fn parent_folders_are_created() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a/b/c/f.0001.exr");
    write_test_image(&path, 2, 1, &pixels(2, 1), &info()).unwrap();
    assert!(path.is_file());
    assert_eq!(dir_names(&dir.path().join("a/b/c")), vec!["f.0001.exr"]);
}

#[test]
fn relative_bare_file_name_works() {
    // A bare name writes into the current folder; only check the split, not the disk.
    let (d, f) = split_target(Path::new("f.exr")).unwrap();
    assert_eq!((d, f), (PathBuf::from("."), OsStr::new("f.exr")));
    assert!(split_target(Path::new("out/..")).is_err());
}

#[test]
fn overwrite_replaces_and_leaves_only_the_frame() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.png");
    write_test_image(&path, 1, 1, &[0.0, 0.0, 0.0], &info()).unwrap();
    write_test_image(&path, 1, 1, &[1.0, 1.0, 1.0], &info()).unwrap();
    let image = ::image::open(&path).unwrap().to_rgb8();
    assert_eq!(image.as_raw(), &[255, 255, 255]);
    assert_eq!(dir_names(dir.path()), vec!["f.png"]);
}

#[test]
fn invalid_input_fails_early_and_keeps_the_existing_frame() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.exr");
    fs::write(&path, b"previous frame").unwrap();
    for (w, h, len) in [(2, 2, 11), (2, 2, 13), (0, 2, 0), (2, 0, 0)] {
        let e = write_test_image(&path, w, h, &vec![0.5; len], &info()).unwrap_err();
        assert!(
            matches!(&e, Error::Output { path: p, .. } if *p == path),
            "{e}"
        );
        assert!(e.to_string().contains("f.exr"));
    }
    let e = write_test_image(&dir.path().join("f.tif"), 1, 1, &[0.0; 3], &info()).unwrap_err();
    assert!(matches!(e, Error::Output { .. }) && e.to_string().contains(".exr or .png"));
    assert_eq!(e.to_string().matches("f.tif").count(), 1, "{e}");
    assert_eq!(fs::read(&path).unwrap(), b"previous frame");
    assert_eq!(dir_names(dir.path()), vec!["f.exr"]);
}

#[test]
fn failed_rename_keeps_nothing_behind() {
    // The target is a non-empty folder, so the final rename fails after the data was
    // written; the temporary file must be gone and the folder untouched.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.exr");
    fs::create_dir(&path).unwrap();
    fs::write(path.join("keep"), b"x").unwrap();
    let e = write_test_image(&path, 2, 2, &pixels(2, 2), &info()).unwrap_err();
    assert!(matches!(&e, Error::Io { path: p, .. } if *p == path), "{e}");
    assert_eq!(dir_names(dir.path()), vec!["f.exr"]);
    assert_eq!(dir_names(&path), vec!["keep"]);
}

#[test]
fn a_name_too_long_fails_cleanly_and_removes_the_folders_it_made() {
    // A file name the file system refuses (ENAMETOOLONG, for root too): the folders made
    // for it are removed again, and an existing frame beside it is untouched.
    let dir = tempfile::tempdir().unwrap();
    let keep = dir.path().join("a/f.0001.exr");
    write_test_image(&keep, 2, 2, &pixels(2, 2), &info()).unwrap();
    let before = fs::read(&keep).unwrap();
    let long = dir.path().join(format!("a/b/c/{}.exr", "x".repeat(300)));
    let e = write_test_image(&long, 2, 2, &pixels(2, 2), &info()).unwrap_err();
    assert!(matches!(&e, Error::Io { path: p, .. } if *p == long), "{e}");
    assert_eq!(dir_names(&dir.path().join("a")), vec!["f.0001.exr"]);
    assert_eq!(fs::read(&keep).unwrap(), before);
    let e = check_target(&long).unwrap_err();
    assert!(e.contains("304 bytes long") && e.contains("255"), "{e}");
}

#[test]
fn a_failed_write_removes_its_temporary_file_and_new_folders() {
    // The writer fails half way (as on a full disk): nothing is left, not even the folders
    // created for the file, while a folder that existed stays.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("new/deeper/f.exr");
    let e = write_with(&path, |w| {
        use std::io::Write;
        w.write_all(&[7u8; 100_000]).unwrap();
        Err(Error::io(
            &path,
            std::io::Error::other("No space left on device"),
        ))
    })
    .unwrap_err();
    assert!(e.to_string().contains("No space left"), "{e}");
    assert!(
        dir_names(dir.path()).is_empty(),
        "{:?}",
        dir_names(dir.path())
    );
    fs::create_dir(dir.path().join("old")).unwrap();
    let path = dir.path().join("old/f.exr");
    write_with(&path, |_| {
        Err(Error::io(&path, std::io::Error::other("full")))
    })
    .unwrap_err();
    assert_eq!(dir_names(dir.path()), vec!["old"]);
    assert!(dir_names(&dir.path().join("old")).is_empty());
}

#[test]
fn paths_too_long_for_the_system_are_refused_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(check_target(&dir.path().join("out/f.0001.exr")), Ok(()));
    let e = check_target(Path::new(&format!("{}/f.exr", "d/".repeat(2100)))).unwrap_err();
    assert!(
        e.contains("the path is 4206 bytes long") && e.contains("4095"),
        "{e}"
    );
    assert!(e.len() < 600, "the path is shortened: {e}");
    // The temporary file's name is longer than its target's: the target's name must leave
    // room for it.
    let name = "n".repeat(240);
    let e = check_target(Path::new(&format!("out/{name}.exr"))).unwrap_err();
    assert!(
        e.contains("244 bytes long") && e.contains("temporary"),
        "{e}"
    );
    let e = check_target(Path::new("out/..")).unwrap_err();
    assert!(e.contains("no file name"), "{e}");
}

#[test]
fn a_folder_that_cannot_be_written_is_refused_before_writing_and_the_disk_is_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    // A writable folder: its missing folders and the temporary file are made and removed.
    assert_eq!(check_target(&dir.path().join("a/b/f.0001.exr")), Ok(()));
    assert!(dir_names(dir.path()).is_empty());
    // A file where a folder must be, and a folder the system will not make (procfs refuses
    // a new folder to root too): refused, naming the path.
    fs::write(dir.path().join("file"), b"x").unwrap();
    let e = check_target(&dir.path().join("file/f.exr")).unwrap_err();
    assert!(e.contains("file/f.exr cannot be written: "), "{e}");
    #[cfg(target_os = "linux")]
    {
        let e = check_target(Path::new("/proc/nope/x.csv")).unwrap_err();
        assert!(e.starts_with("/proc/nope/x.csv cannot be written: "), "{e}");
    }
    assert_eq!(dir_names(dir.path()), vec!["file"]);
}

#[test]
fn unusable_parent_fails_cleanly() {
    // A parent "folder" that is a file cannot be created; this fails even for root.
    let dir = tempfile::tempdir().unwrap();
    let blocker = dir.path().join("out");
    fs::write(&blocker, b"not a folder").unwrap();
    let path = blocker.join("f.0001.png");
    let e = write_test_image(&path, 2, 2, &pixels(2, 2), &info()).unwrap_err();
    assert!(matches!(&e, Error::Io { path: p, .. } if *p == path), "{e}");
    assert!(e.to_string().contains("f.0001.png"), "{e}");
    assert_eq!(dir_names(dir.path()), vec!["out"]);
    assert_eq!(fs::read(&blocker).unwrap(), b"not a folder");
}

#[test]
fn temp_names_are_hidden_ours_and_parseable() {
    let name = temp_name(OsStr::new("f.0001.exr"), Some("node-7"), 4242, 0xabc);
    assert_eq!(
        name,
        OsStr::new(".f.0001.exr.node-7.4242.0000000000000abc.tmp")
    );
    assert!(
        Format::of(Path::new(&name), FRAME_FORMATS, "output").is_err(),
        "never taken for a frame"
    );
    let node7 = Writer {
        host: Some("node-7"),
        pid: 4242,
    };
    assert_eq!(
        parse_temp_name(&name, OsStr::new("f.0001.exr")),
        Some(node7)
    );
    assert_eq!(parse_temp_name(&name, OsStr::new("f.0002.exr")), None);
    assert_eq!(parse_temp_name(&name, OsStr::new("0001.exr")), None);
    assert_eq!(parse_temp_name(&name, OsStr::new("f.0001")), None);
    // Earlier versions' names, without the machine.
    let old = temp_name(OsStr::new("f.0001.exr"), None, 4242, 0xabc);
    assert_eq!(old, OsStr::new(".f.0001.exr.4242.0000000000000abc.tmp"));
    assert_eq!(
        parse_temp_name(&old, OsStr::new("f.0001.exr")),
        Some(Writer {
            host: None,
            pid: 4242
        })
    );
    // A host of digits only is a host.
    assert_eq!(
        parse_temp_name(
            OsStr::new(".f.0001.exr.1.2.0000000000000abc.tmp"),
            OsStr::new("f.0001.exr")
        ),
        Some(Writer {
            host: Some("1"),
            pid: 2
        })
    );
    // This machine's name as names carry it: letters, digits and '-'.
    if let Some(host) = host_name() {
        assert!(!host.is_empty() && host.len() <= 63, "{host}");
        assert!(host.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-'));
    }
    for other in [
        "f.0001.exr",
        ".f.0001.exr.tmp",
        ".f.0001.exr.4242.tmp",
        ".f.0001.exr.4242.0000000000000abc",
        ".f.0001.exr.4242.0000000000000ABC.tmp",
        ".f.0001.exr.4242.000000000000abc.tmp",
        ".f.0001.exr.x.0000000000000abc.tmp",
        ".f.0001.exr..0000000000000abc.tmp",
        ".f.0001.exr.a.b.2.0000000000000abc.tmp",
        ".f.0001.exr.a_b.2.0000000000000abc.tmp",
        ".f.0001.exr..2.0000000000000abc.tmp",
        ".f.0001.exr.99999999999.0000000000000abc.tmp",
        "f.0001.exr.4242.0000000000000abc.tmp",
    ] {
        assert_eq!(
            parse_temp_name(OsStr::new(other), OsStr::new("f.0001.exr")),
            None,
            "{other}"
        );
    }
}

#[cfg(target_os = "linux")]
#[test]
fn stale_temp_files_are_removed_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("f.0001.exr");
    let name = OsStr::new("f.0001.exr");
    let temp = |host: Option<&str>, pid: u32, random: u64| {
        dir.path().join(temp_name(name, host, pid, random))
    };
    let age = |path: &Path, seconds: u64| {
        File::options()
            .write(true)
            .open(path)
            .unwrap()
            .set_modified(std::time::SystemTime::now() - Duration::from_secs(seconds))
            .unwrap();
    };
    // A pid above the kernel's maximum (4194304) can never be running.
    let dead = 4_000_000_000;
    let own = std::process::id();
    let here = host_name().expect("Linux has a host name");
    let elsewhere = if here == "other-node" {
        "node-9"
    } else {
        "other-node"
    };
    // This machine's, writer gone: removed at once, however young.
    let ours_dead = temp(Some(here), dead, 1);
    // This machine's, writer running: kept, however old.
    let ours_live = temp(Some(here), own, 2);
    // Another machine's: kept while young (it may be writing it), removed when old, whatever
    // its pid means here.
    let theirs_young = temp(Some(elsewhere), dead, 3);
    let theirs_old = temp(Some(elsewhere), own, 4);
    // An earlier version's (no machine): the pid must be gone here and the file old.
    let legacy_young = temp(None, dead, 5);
    let legacy_old = temp(None, dead, 6);
    let legacy_live = temp(None, own, 7);
    let other_target = dir
        .path()
        .join(temp_name(OsStr::new("f.0002.exr"), Some(here), dead, 8));
    let lookalike = dir.path().join(".f.0001.exr.4000000000.zz.tmp");
    let folder = temp(Some(here), dead, 9);
    for f in [
        &ours_dead,
        &ours_live,
        &theirs_young,
        &theirs_old,
        &legacy_young,
        &legacy_old,
        &legacy_live,
        &other_target,
        &lookalike,
        &target,
    ] {
        fs::write(f, b"x").unwrap();
    }
    fs::create_dir(&folder).unwrap();
    for f in [&ours_live, &theirs_old, &legacy_old, &legacy_live] {
        age(f, 3600);
    }

    let mut removed = remove_stale_temp_files(&target, Duration::from_secs(600)).unwrap();
    removed.sort();
    let mut want = vec![ours_dead.clone(), theirs_old.clone(), legacy_old.clone()];
    want.sort();
    assert_eq!(removed, want);
    for f in [
        &ours_live,
        &theirs_young,
        &legacy_young,
        &legacy_live,
        &other_target,
        &lookalike,
        &target,
        &folder,
    ] {
        assert!(f.exists(), "{}", f.display());
    }
    // Without a minimum age, the young ones of other machines go too.
    let mut removed = remove_stale_temp_files(&target, Duration::ZERO).unwrap();
    removed.sort();
    let mut want = vec![theirs_young, legacy_young];
    want.sort();
    assert_eq!(removed, want);
    // A folder that does not exist, or a regular file, holds nothing stale.
    for nothing in ["nope/f.exr", "f.0001.exr/f.exr"] {
        let path = dir.path().join(nothing);
        assert!(
            remove_stale_temp_files(&path, Duration::ZERO)
                .unwrap()
                .is_empty()
        );
    }
}

#[test]
fn complete_frames_are_told_from_empty_and_truncated_ones() {
    let dir = tempfile::tempdir().unwrap();
    for (name, w, h) in [("f.exr", 7, 5), ("g.png", 7, 5), ("big.exr", 200, 150)] {
        let path = dir.path().join(name);
        write_test_image(&path, w, h, &pixels(w, h), &info()).unwrap();
        assert_eq!(check_frame_file(&path), Ok(()), "{name}");
        let bytes = fs::read(&path).unwrap();
        for cut in [1, 2, 9, bytes.len() / 2, bytes.len() - 40, bytes.len() - 1] {
            let short = dir.path().join(format!("short_{cut}_{name}"));
            fs::write(&short, &bytes[..cut]).unwrap();
            let e = check_frame_file(&short).expect_err(&format!("{name} cut to {cut} bytes"));
            assert!(
                e.contains("truncated") || e.contains("not a readable"),
                "{e}"
            );
        }
        let empty = dir.path().join(format!("empty_{name}"));
        fs::write(&empty, b"").unwrap();
        assert_eq!(check_frame_file(&empty), Err("0 bytes".to_string()));
    }
    let folder = dir.path().join("d.exr");
    fs::create_dir(&folder).unwrap();
    assert_eq!(check_frame_file(&folder), Err("not a file".to_string()));
    assert!(check_frame_file(&dir.path().join("none.exr")).is_err());
}

#[test]
fn passes_channels_are_written_by_name_and_type_and_checked_first() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (3, 2);
    let channel = |v: f32| {
        (0..w * h)
            .map(|i| v + i as f32 * 0.25)
            .collect::<Vec<f32>>()
    };
    let channels = [
        ("A", Precision::Half, channel(0.0)),
        ("Z", Precision::Float, channel(1e10)),
        ("forward.u", Precision::Float, channel(-3.3)),
    ];
    let mut frame = colour(w, h, &pixels(w, h));
    for (name, precision, values) in &channels {
        frame.set(name, *precision, Values::Float(values.clone()));
    }
    let path = dir.path().join("p.exr");
    write_image(&path, Format::Exr, &frame, &info()).unwrap();
    let image = ::exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    let list = &image.layer_data[0].channel_data.list;
    let find = |name: &str| list.iter().find(|c| c.name.to_string() == name).unwrap();
    for (name, precision, values) in &channels {
        let read: Vec<f32> = find(name).sample_data.values_as_f32().collect();
        let half = matches!(find(name).sample_data, ::exr::prelude::FlatSamples::F16(_));
        assert_eq!(half, *precision == Precision::Half);
        // Quarters are exact in half; the rest are floats, exact.
        assert_eq!(&read, values, "{name}");
    }
    // The colour reads back as without passes; the header keeps its attributes.
    let rgb = read_exr_colour(&path).unwrap().interleaved(COLOUR).unwrap();
    assert_eq!(rgb[15], pixels(w, h)[15]);
    assert!(check_frame_file(&path).is_ok());
    // A frame without its colour, or anything but alpha in a PNG: nothing is written.
    let bad = dir.path().join("bad.exr");
    let e = write_image(&bad, Format::Exr, &frame.select(&["A"]), &info());
    assert!(e.unwrap_err().to_string().contains("no colour"));
    let png = dir.path().join("bad.png");
    let e = write_image(&png, Format::Png, &frame, &info());
    assert!(e.unwrap_err().to_string().contains("not channel Z"));
    assert_eq!(dir_names(dir.path()), ["p.exr"]);
}
