//! Writing finished frames to disk as EXR (linear float) or PNG (8-bit sRGB).
//!
//! Every frame is written to a hidden temporary file next to its target, flushed to disk and
//! then renamed over the target, so a reader (or a crashed render) never sees a partial
//! frame: the target holds either the previous complete file or the new complete file.
//! Temporary files are named `.{file name}.{pid}.{16 hex digits}.tmp`; a run that is killed
//! mid-write can leave one behind, which [`remove_stale_temp_files`] cleans up later.

use std::ffi::{OsStr, OsString};
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::error::Error;

/// The output path of `frame` for a file name pattern.
///
/// Every run of `#` in the pattern becomes the frame number, zero-padded to the length of the
/// run (`render.####.exr` → `render.0001.exr`). A number with more digits than the run is
/// written in full, never truncated (frame 12345 with `##` → `12345`).
///
/// A pattern without any `#` is returned unchanged, so every frame then writes the same
/// file; callers rendering more than one frame should check [`pattern_has_frame_number`].
pub fn frame_path(pattern: &str, frame: u32) -> PathBuf {
    let mut out = String::with_capacity(pattern.len() + 8);
    let mut chars = pattern.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '#' {
            let mut width = 1;
            while chars.next_if_eq(&'#').is_some() {
                width += 1;
            }
            out.push_str(&format!("{frame:0width$}"));
        } else {
            out.push(c);
        }
    }
    PathBuf::from(out)
}

/// Whether the pattern contains a `#` run, that is, whether different frames get different
/// paths from [`frame_path`].
pub fn pattern_has_frame_number(pattern: &str) -> bool {
    pattern.contains('#')
}

/// An output file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// OpenEXR: linear 32-bit float RGB, ZIP compressed, with the frame's metadata.
    Exr,
    /// PNG: 8-bit RGB, sRGB encoded, clamped to [0, 1]. No metadata.
    Png,
}

const UNSUPPORTED_FORMAT: &str =
    "unsupported output format (the file name must end in .exr or .png)";

/// The format of `path`, from its extension (`.exr` or `.png`, in any letter case).
pub fn format_for(path: &Path) -> Result<Format, String> {
    let ext = path
        .extension()
        .and_then(OsStr::to_str)
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr") => Ok(Format::Exr),
        Some("png") => Ok(Format::Png),
        _ => Err(format!("{}: {UNSUPPORTED_FORMAT}", path.display())),
    }
}

/// The metadata stored with a frame (in EXR headers; PNG files carry none).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameInfo {
    /// The frame number.
    pub frame: u32,
    /// Frames per second of the shot, > 0.
    pub fps: f64,
    /// Absolute time in seconds the shutter opens.
    pub shutter_open: f64,
    /// Absolute time in seconds the shutter closes.
    pub shutter_close: f64,
    /// Samples per pixel requested.
    pub samples: u32,
    /// The seed of the frame's random numbers.
    pub seed: u64,
    /// The name of the sampler that placed the samples.
    pub sampler: String,
    /// Further numeric attributes, stored as doubles under their names. A name must be 1 to
    /// 255 printable Latin-1 characters, must be unique, and must not be one of the names
    /// above nor a standard OpenEXR attribute name.
    pub extra: Vec<(String, f64)>,
}

/// Names of the custom EXR attributes written from [`FrameInfo`].
pub mod attribute_names {
    /// The frame number: an int, or a double above `i32::MAX`.
    pub const FRAME: &str = "frame";
    /// Shutter opening time in seconds, a double.
    pub const SHUTTER_OPEN: &str = "shutterOpen";
    /// Shutter closing time in seconds, a double.
    pub const SHUTTER_CLOSE: &str = "shutterClose";
    /// Samples per pixel: an int, or a double above `i32::MAX`.
    pub const SAMPLES: &str = "samples";
    /// The 64-bit seed as decimal text (no EXR attribute type holds a u64).
    pub const SEED: &str = "seed";
    /// The sampler's name, as text.
    pub const SAMPLER: &str = "sampler";
    /// All of the above.
    pub const ALL: &[&str] = &[FRAME, SHUTTER_OPEN, SHUTTER_CLOSE, SAMPLES, SEED, SAMPLER];
}

/// Writes one frame to `path`, in the format its extension names (see [`format_for`]).
///
/// `rgb` holds linear RGB, row-major, top row first, three floats per pixel. Parent folders
/// are created as needed. The file appears atomically (see the module documentation); on
/// any failure nothing is left behind and an existing file at `path` is untouched. Errors
/// name `path`.
pub fn write_frame(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[f32],
    info: &FrameInfo,
) -> Result<(), Error> {
    let output_error = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    if width == 0 || height == 0 {
        return Err(output_error(format!(
            "cannot write an empty {width}x{height} image"
        )));
    }
    let expected = (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(3));
    if expected != Some(rgb.len()) {
        return Err(output_error(format!(
            "{} floats given for a {width}x{height} RGB image (expected {})",
            rgb.len(),
            expected.map_or("more than fit in memory".to_string(), |n| n.to_string())
        )));
    }
    let format = format_for(path).map_err(|_| output_error(UNSUPPORTED_FORMAT.to_string()))?;
    // Validate the metadata before touching the disk.
    let exr_attributes = match format {
        Format::Exr => Some(exr_attributes(info).map_err(output_error)?),
        Format::Png => None,
    };
    write_atomically(path, |writer| match exr_attributes {
        Some(attributes) => write_exr(writer, path, width, height, rgb, attributes),
        None => write_png(writer, path, width, height, rgb),
    })
}

/// Writes `bytes` to `path` as [`write_frame`] writes a frame: through a temporary file beside
/// it, renamed into place, so readers never see a partial file.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    write_atomically(path, |writer| {
        writer.write_all(bytes).map_err(|e| Error::io(path, e))
    })
}

/// Creates `path`'s folder, has `write` fill a new temporary file beside `path`, syncs it and
/// renames it into place. The temporary file is removed on any failure.
fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), Error>,
) -> Result<(), Error> {
    let (dir, file_name) = split_target(path)?;
    fs::create_dir_all(&dir).map_err(|e| Error::io(path, e))?;

    let (mut temp, file) = TempFile::create(&dir, file_name).map_err(|e| Error::io(path, e))?;
    let mut writer = BufWriter::new(file);
    write(&mut writer)?;
    let file = writer
        .into_inner()
        .map_err(|e| Error::io(path, e.into_error()))?;
    file.sync_all().map_err(|e| Error::io(path, e))?;
    drop(file);
    fs::rename(&temp.path, path).map_err(|e| Error::io(path, e))?;
    temp.armed = false;
    sync_dir(&dir);
    Ok(())
}

/// Reads the RGB channels of an EXR file as linear radiance: (width, height, pixels
/// row-major, top row first). Errors are the decoder's message.
pub fn read_exr_rgb(path: &Path) -> Result<(usize, usize, Vec<glam::DVec3>), String> {
    use exr::prelude::read_first_rgba_layer_from_file;
    use glam::DVec3;
    let image = read_first_rgba_layer_from_file(
        path,
        |size, _| {
            (
                size.width(),
                vec![DVec3::ZERO; size.width() * size.height()],
            )
        },
        |(w, pixels): &mut (usize, Vec<DVec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            pixels[pos.y() * *w + pos.x()] = DVec3::new(r as f64, g as f64, b as f64);
        },
    )
    .map_err(|e| e.to_string())?;
    let size = image.layer_data.size;
    let (_, pixels) = image.layer_data.channel_data.pixels;
    Ok((size.width(), size.height(), pixels))
}

/// The folder (`.` for a bare file name) and file name of a target path.
fn split_target(path: &Path) -> Result<(PathBuf, &OsStr), Error> {
    let Some(file_name) = path.file_name() else {
        return Err(Error::Output {
            path: path.to_path_buf(),
            message: "not a file path (it has no file name)".to_string(),
        });
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok((dir, file_name))
}

/// Makes a rename in `dir` durable. Best effort: some file systems refuse to sync folders.
fn sync_dir(dir: &Path) {
    #[cfg(unix)]
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dir;
}

/// A temporary file that is removed when dropped, unless disarmed after the final rename.
struct TempFile {
    path: PathBuf,
    armed: bool,
}

impl TempFile {
    /// Creates a new, empty temporary file for the target `file_name` in `dir`.
    fn create(dir: &Path, file_name: &OsStr) -> io::Result<(TempFile, File)> {
        let mut attempts = 0;
        loop {
            let path = dir.join(temp_name(file_name, std::process::id(), random_u64()));
            match OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(file) => return Ok((TempFile { path, armed: true }, file)),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && attempts < 16 => {
                    attempts += 1
                }
                Err(e) => return Err(e),
            }
        }
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if self.armed {
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// `.{file_name}.{pid}.{random as 16 lowercase hex digits}.tmp`
fn temp_name(file_name: &OsStr, pid: u32, random: u64) -> OsString {
    let mut name = OsString::from(".");
    name.push(file_name);
    name.push(format!(".{pid}.{random:016x}.tmp"));
    name
}

/// If `name` is a temporary file name of ours for the target `file_name`, the pid in it.
fn parse_temp_name(name: &OsStr, file_name: &OsStr) -> Option<u32> {
    let name = name.as_encoded_bytes();
    let target = file_name.as_encoded_bytes();
    let rest = name
        .strip_prefix(b".")?
        .strip_prefix(target)?
        .strip_prefix(b".")?;
    let rest = rest.strip_suffix(b".tmp")?;
    let dot = rest.iter().position(|&b| b == b'.')?;
    let (pid, random) = (&rest[..dot], &rest[dot + 1..]);
    let random_ok = random.len() == 16
        && random
            .iter()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(b));
    if pid.is_empty() || pid.len() > 10 || !pid.iter().all(u8::is_ascii_digit) || !random_ok {
        return None;
    }
    std::str::from_utf8(pid).ok()?.parse().ok()
}

/// 64 unpredictable-enough bits for temporary file names, without an extra dependency:
/// std's randomly keyed hasher over a process-wide counter and the clock.
fn random_u64() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u64(COUNTER.fetch_add(1, Ordering::Relaxed));
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH);
    h.write_u128(now.map_or(0, |d| d.as_nanos()));
    h.finish()
}

/// Whether process `pid` may still be running. Only answers "no" when it can tell for sure
/// (Linux with `/proc` mounted); everywhere else every process counts as alive.
fn process_may_be_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    if cfg!(target_os = "linux") && Path::new("/proc/self").exists() {
        return Path::new("/proc").join(pid.to_string()).exists();
    }
    true
}

/// Removes temporary files that an interrupted earlier run left behind while writing
/// `target`, and returns their paths.
///
/// Only regular files named exactly as [`write_frame`] names its temporary files for this
/// target are candidates, and of those only the ones whose writing process is known to be
/// gone (Linux: no `/proc/{pid}`; elsewhere nothing is ever removed) and that were last
/// modified at least `min_age` ago. Pids are only meaningful on this machine: when several
/// machines write into a shared folder, pass a `min_age` longer than any frame takes to
/// write (minutes), so a file another machine is still writing is never taken for stale.
///
/// A missing folder is not an error.
pub fn remove_stale_temp_files(target: &Path, min_age: Duration) -> Result<Vec<PathBuf>, Error> {
    let (dir, file_name) = split_target(target)?;
    let entries = match fs::read_dir(&dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::io(&dir, e)),
    };
    let mut removed = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(&dir, e))?;
        let Some(pid) = parse_temp_name(&entry.file_name(), file_name) else {
            continue;
        };
        if process_may_be_alive(pid) {
            continue;
        }
        let path = entry.path();
        let Ok(meta) = fs::symlink_metadata(&path) else {
            continue;
        };
        if !meta.file_type().is_file() {
            continue;
        }
        if !min_age.is_zero() {
            let age = meta.modified().ok().and_then(|m| m.elapsed().ok());
            if age.is_none_or(|age| age < min_age) {
                continue;
            }
        }
        match fs::remove_file(&path) {
            Ok(()) => removed.push(path),
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => return Err(Error::io(&path, e)),
        }
    }
    Ok(removed)
}

// ---------------------------------------------------------------------------------------
// EXR

/// A frame rate as the rational of the standard `framesPerSecond` attribute.
///
/// Whole numbers are exact (`24` → 24/1); the NTSC rates `n * 1000/1001` written to a few
/// decimals are recognised (`23.976` → 24000/1001, `29.97` → 30000/1001); anything else is
/// the closest continued-fraction convergent with a denominator of at most 1,000,000.
/// `None` for rates that are not finite and positive or do not fit.
pub fn fps_rational(fps: f64) -> Option<(i32, u32)> {
    if !fps.is_finite() || fps <= 0.0 || fps > i32::MAX as f64 {
        return None;
    }
    if fps.fract() == 0.0 {
        return Some((fps as i32, 1));
    }
    let ntsc = (fps * 1.001).round();
    if ntsc >= 1.0 && (fps * 1.001 - ntsc).abs() <= 1e-5 * ntsc && ntsc * 1000.0 <= i32::MAX as f64
    {
        return Some(((ntsc as i32) * 1000, 1001));
    }
    const MAX_DENOMINATOR: f64 = 1_000_000.0;
    // Convergents h/k of the continued fraction of fps.
    let (mut h_prev, mut h) = (1.0_f64, fps.floor());
    let (mut k_prev, mut k) = (0.0_f64, 1.0_f64);
    let mut x = fps - fps.floor();
    while x > 1e-12 && (h / k - fps).abs() > 1e-12 * fps {
        let y = 1.0 / x;
        let a = y.floor();
        x = y - a;
        let (h_next, k_next) = (a * h + h_prev, a * k + k_prev);
        if k_next > MAX_DENOMINATOR || h_next > i32::MAX as f64 {
            break;
        }
        (h_prev, h, k_prev, k) = (h, h_next, k, k_next);
    }
    if h < 1.0 {
        return None;
    }
    Some((h as i32, k as u32))
}

/// An integer attribute, or a double when the value does not fit an `i32`.
fn int_attribute(value: u32) -> exr::meta::attribute::AttributeValue {
    use exr::meta::attribute::AttributeValue;
    match i32::try_from(value) {
        Ok(v) => AttributeValue::I32(v),
        Err(_) => AttributeValue::F64(value as f64),
    }
}

/// The layer attributes of a frame, or a message saying what is wrong with `info`.
fn exr_attributes(info: &FrameInfo) -> Result<exr::meta::header::LayerAttributes, String> {
    use exr::meta::attribute::{AttributeValue, Text};
    use exr::meta::header::{LayerAttributes, standard_names};

    let mut attributes = LayerAttributes {
        frames_per_second: Some(
            fps_rational(info.fps)
                .ok_or_else(|| format!("invalid frame rate {} for the EXR header", info.fps))?,
        ),
        software_name: Some(Text::from(concat!("raytrace ", env!("CARGO_PKG_VERSION")))),
        ..LayerAttributes::default()
    };
    let other = &mut attributes.other;
    other.insert(
        Text::from(attribute_names::FRAME),
        int_attribute(info.frame),
    );
    other.insert(
        Text::from(attribute_names::SHUTTER_OPEN),
        AttributeValue::F64(info.shutter_open),
    );
    other.insert(
        Text::from(attribute_names::SHUTTER_CLOSE),
        AttributeValue::F64(info.shutter_close),
    );
    other.insert(
        Text::from(attribute_names::SAMPLES),
        int_attribute(info.samples),
    );
    other.insert(
        Text::from(attribute_names::SEED),
        AttributeValue::Text(Text::from(info.seed.to_string().as_str())),
    );
    other.insert(
        Text::from(attribute_names::SAMPLER),
        AttributeValue::Text(
            Text::new_or_none(&info.sampler)
                .ok_or_else(|| format!("sampler name \"{}\" is not Latin-1", info.sampler))?,
        ),
    );
    for (name, value) in &info.extra {
        let bad = |why: &str| format!("extra attribute name \"{name}\" {why}");
        // Up to 31 characters: longer names need the file's long-name flag.
        if name.is_empty() || name.len() > 31 {
            return Err(bad("must have 1 to 31 characters"));
        }
        if name.chars().any(char::is_control) {
            return Err(bad("contains a control character"));
        }
        let text = Text::new_or_none(name).ok_or_else(|| bad("has characters outside Latin-1"))?;
        if attribute_names::ALL.contains(&name.as_str())
            || standard_names::ALL.contains(&name.as_bytes())
        {
            return Err(bad("is reserved"));
        }
        if other.insert(text, AttributeValue::F64(*value)).is_some() {
            return Err(bad("appears twice"));
        }
    }
    Ok(attributes)
}

fn write_exr(
    writer: &mut BufWriter<File>,
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[f32],
    attributes: exr::meta::header::LayerAttributes,
) -> Result<(), Error> {
    use exr::prelude::{
        Blocks, Compression, Encoding, Image, Layer, LineOrder, SpecificChannels, Vec2,
        WritableImage,
    };

    let w = width as usize;
    let pixels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let i = 3 * (p.y() * w + p.x());
        (rgb[i], rgb[i + 1], rgb[i + 2])
    });
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    // The exr crate writes custom attributes in the iteration order of a randomly seeded
    // HashMap, so the same frame would get different bytes in different processes. Write the
    // image without them, then splice them into the header in name order.
    let mut attributes = attributes;
    let mut custom: Vec<_> = attributes.other.drain().collect();
    custom.sort_by(|a, b| a.0.as_slice().cmp(b.0.as_slice()));
    let layer = Layer::new((w, height as usize), attributes, encoding, pixels);
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_buffered(&mut bytes)
        .map_err(|e| match e {
            exr::error::Error::Io(e) => Error::io(path, e),
            other => Error::Output {
                path: path.to_path_buf(),
                message: format!("EXR encoder: {other}"),
            },
        })?;
    let chunks = (height as usize).div_ceil(16);
    let bytes = splice_exr_attributes(bytes.into_inner(), &custom, chunks).map_err(|message| {
        Error::Output {
            path: path.to_path_buf(),
            message,
        }
    })?;
    writer.write_all(&bytes).map_err(|e| Error::io(path, e))
}

/// Inserts `attributes` at the end of the header of a single-part scanline EXR file with
/// `chunks` chunks, and moves the offset table's entries by the inserted length. (OpenEXR file
/// layout: magic and version, attributes as `name\0 type\0 size value`, a null byte, the offset
/// table of u64 file positions, the chunks.)
fn splice_exr_attributes(
    file: Vec<u8>,
    attributes: &[(
        exr::meta::attribute::Text,
        exr::meta::attribute::AttributeValue,
    )],
    chunks: usize,
) -> Result<Vec<u8>, String> {
    use exr::meta::attribute::AttributeValue;
    let malformed = || "EXR encoder produced an unexpected header".to_string();
    // Find the null byte that ends the header.
    let mut pos = 8;
    loop {
        let name_end = pos
            + file
                .get(pos..)
                .and_then(|r| r.iter().position(|&b| b == 0))
                .ok_or_else(malformed)?;
        if name_end == pos {
            break;
        }
        let type_end = name_end
            + 1
            + file
                .get(name_end + 1..)
                .and_then(|r| r.iter().position(|&b| b == 0))
                .ok_or_else(malformed)?;
        let size_bytes: [u8; 4] = file
            .get(type_end + 1..type_end + 5)
            .ok_or_else(malformed)?
            .try_into()
            .unwrap();
        pos = type_end + 5 + u32::from_le_bytes(size_bytes) as usize;
    }
    let mut inserted = Vec::new();
    for (name, value) in attributes {
        let (kind, data): (&str, Vec<u8>) = match value {
            AttributeValue::I32(v) => ("int", v.to_le_bytes().to_vec()),
            AttributeValue::F64(v) => ("double", v.to_le_bytes().to_vec()),
            AttributeValue::Text(t) => ("string", t.as_slice().to_vec()),
            other => return Err(format!("unsupported custom attribute {other:?}")),
        };
        inserted.extend_from_slice(name.as_slice());
        inserted.push(0);
        inserted.extend_from_slice(kind.as_bytes());
        inserted.push(0);
        inserted.extend_from_slice(&(data.len() as u32).to_le_bytes());
        inserted.extend_from_slice(&data);
    }
    let delta = inserted.len() as u64;
    let table = pos + 1;
    let mut out = Vec::with_capacity(file.len() + inserted.len());
    out.extend_from_slice(&file[..pos]);
    out.extend_from_slice(&inserted);
    out.push(0);
    for i in 0..chunks {
        let at = table + 8 * i;
        let entry: [u8; 8] = file
            .get(at..at + 8)
            .ok_or_else(malformed)?
            .try_into()
            .unwrap();
        out.extend_from_slice(&(u64::from_le_bytes(entry) + delta).to_le_bytes());
    }
    out.extend_from_slice(&file[table + 8 * chunks..]);
    Ok(out)
}

// ---------------------------------------------------------------------------------------
// PNG

/// Encodes a linear value as an 8-bit sRGB value with the exact piecewise sRGB curve,
/// clamped to [0, 1] and rounded to nearest. Non-finite values give 0.
pub fn linear_to_srgb8(v: f32) -> u8 {
    if !v.is_finite() {
        return 0;
    }
    let x = (v as f64).clamp(0.0, 1.0);
    let e = if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
}

fn write_png(
    writer: &mut BufWriter<File>,
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[f32],
) -> Result<(), Error> {
    use image::ImageEncoder;
    use image::codecs::png::PngEncoder;

    let bytes: Vec<u8> = rgb.iter().map(|&v| linear_to_srgb8(v)).collect();
    PngEncoder::new(&mut *writer)
        .write_image(&bytes, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| match e {
            image::ImageError::IoError(e) => Error::io(path, e),
            other => Error::Output {
                path: path.to_path_buf(),
                message: format!("PNG encoder: {other}"),
            },
        })?;
    writer.flush().map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info() -> FrameInfo {
        FrameInfo {
            frame: 17,
            fps: 23.976,
            shutter_open: 0.6666666666666666,
            shutter_close: 0.6875000000000001,
            samples: 256,
            seed: u64::MAX - 12345,
            sampler: "sobol".to_string(),
            extra: vec![
                ("achievedSamples".to_string(), 211.5),
                ("error".to_string(), 0.0125),
            ],
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
        assert_eq!(format_for(Path::new("a/b.exr")), Ok(Format::Exr));
        assert_eq!(format_for(Path::new("b.EXR")), Ok(Format::Exr));
        assert_eq!(format_for(Path::new("b.0001.png")), Ok(Format::Png));
        assert_eq!(format_for(Path::new("b.PnG")), Ok(Format::Png));
        for bad in ["b.jpg", "b", "b.exr.tmp", "exr", ".png"] {
            let e = format_for(Path::new(bad)).unwrap_err();
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
        use exr::meta::attribute::{AttributeValue, Text};
        use exr::prelude::*;

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.0017.exr");
        let (w, h) = (7, 5);
        let rgb = pixels(w, h);
        write_frame(&path, w, h, &rgb, &info()).unwrap();
        assert_eq!(dir_names(dir.path()), vec!["f.0017.exr"]);

        let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
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
    fn exr_large_numbers_become_doubles() {
        use exr::meta::attribute::{AttributeValue, Text};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.exr");
        let info = FrameInfo {
            frame: u32::MAX,
            samples: 1 << 31,
            fps: 24.0,
            extra: vec![],
            ..info()
        };
        write_frame(&path, 1, 1, &[0.25, 0.5, 1.0], &info).unwrap();
        let image = exr::prelude::read_all_data_from_file(&path).unwrap();
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
            let e = write_frame(&path, 2, 2, &rgb, &info).unwrap_err();
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
            write_frame(&path, 2, 2, &rgb, &twice)
                .unwrap_err()
                .to_string()
                .contains("twice")
        );
        let no_rate = FrameInfo { fps: 0.0, ..info() };
        let e = write_frame(&path, 2, 2, &rgb, &no_rate).unwrap_err();
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
        write_frame(&path, w, h, &rgb, &info()).unwrap();
        assert_eq!(dir_names(dir.path()), vec!["f.0001.PNG"]);
        let image = image::ImageReader::open(&path)
            .unwrap()
            .with_guessed_format()
            .unwrap()
            .decode()
            .unwrap();
        assert_eq!(image.color(), image::ColorType::Rgb8);
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
        write_frame(&path, 2, 1, &pixels(2, 1), &info()).unwrap();
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
        write_frame(&path, 1, 1, &[0.0, 0.0, 0.0], &info()).unwrap();
        write_frame(&path, 1, 1, &[1.0, 1.0, 1.0], &info()).unwrap();
        let image = image::open(&path).unwrap().to_rgb8();
        assert_eq!(image.as_raw(), &[255, 255, 255]);
        assert_eq!(dir_names(dir.path()), vec!["f.png"]);
    }

    #[test]
    fn invalid_input_fails_early_and_keeps_the_existing_frame() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.exr");
        fs::write(&path, b"previous frame").unwrap();
        for (w, h, len) in [(2, 2, 11), (2, 2, 13), (0, 2, 0), (2, 0, 0)] {
            let e = write_frame(&path, w, h, &vec![0.5; len], &info()).unwrap_err();
            assert!(
                matches!(&e, Error::Output { path: p, .. } if *p == path),
                "{e}"
            );
            assert!(e.to_string().contains("f.exr"));
        }
        let e = write_frame(&dir.path().join("f.tif"), 1, 1, &[0.0; 3], &info()).unwrap_err();
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
        let e = write_frame(&path, 2, 2, &pixels(2, 2), &info()).unwrap_err();
        assert!(matches!(&e, Error::Io { path: p, .. } if *p == path), "{e}");
        assert_eq!(dir_names(dir.path()), vec!["f.exr"]);
        assert_eq!(dir_names(&path), vec!["keep"]);
    }

    #[cfg(unix)]
    #[test]
    fn read_only_folder_fails_cleanly() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let ro = dir.path().join("ro");
        fs::create_dir(&ro).unwrap();
        let path = ro.join("f.0001.exr");
        fs::write(&path, b"previous frame").unwrap();
        fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).unwrap();
        // Root ignores permissions: only check the failure when it really is read-only.
        let probe = ro.join("probe");
        let enforced = fs::write(&probe, b"").is_err();
        let _ = fs::remove_file(&probe);
        if enforced {
            for p in [&path, &ro.join("g.png")] {
                let e = write_frame(p, 2, 2, &pixels(2, 2), &info()).unwrap_err();
                assert!(matches!(&e, Error::Io { path: q, .. } if q == p), "{e}");
                assert!(e.to_string().contains(&*p.to_string_lossy()), "{e}");
            }
        } else {
            eprintln!("permissions are not enforced (running as root?): skipping this check");
        }
        fs::set_permissions(&ro, fs::Permissions::from_mode(0o755)).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"previous frame");
        assert_eq!(dir_names(&ro), vec!["f.0001.exr"]);
    }

    #[test]
    fn unusable_parent_fails_cleanly() {
        // A parent "folder" that is a file cannot be created; this fails even for root.
        let dir = tempfile::tempdir().unwrap();
        let blocker = dir.path().join("out");
        fs::write(&blocker, b"not a folder").unwrap();
        let path = blocker.join("f.0001.png");
        let e = write_frame(&path, 2, 2, &pixels(2, 2), &info()).unwrap_err();
        assert!(matches!(&e, Error::Io { path: p, .. } if *p == path), "{e}");
        assert!(e.to_string().contains("f.0001.png"), "{e}");
        assert_eq!(dir_names(dir.path()), vec!["out"]);
        assert_eq!(fs::read(&blocker).unwrap(), b"not a folder");
    }

    #[test]
    fn temp_names_are_hidden_ours_and_parseable() {
        let name = temp_name(OsStr::new("f.0001.exr"), 4242, 0xabc);
        assert_eq!(name, OsStr::new(".f.0001.exr.4242.0000000000000abc.tmp"));
        assert!(
            format_for(Path::new(&name)).is_err(),
            "never taken for a frame"
        );
        assert_eq!(parse_temp_name(&name, OsStr::new("f.0001.exr")), Some(4242));
        assert_eq!(parse_temp_name(&name, OsStr::new("f.0002.exr")), None);
        assert_eq!(parse_temp_name(&name, OsStr::new("0001.exr")), None);
        assert_eq!(parse_temp_name(&name, OsStr::new("f.0001")), None);
        for other in [
            "f.0001.exr",
            ".f.0001.exr.tmp",
            ".f.0001.exr.4242.tmp",
            ".f.0001.exr.4242.0000000000000abc",
            ".f.0001.exr.4242.0000000000000ABC.tmp",
            ".f.0001.exr.4242.000000000000abc.tmp",
            ".f.0001.exr.x.0000000000000abc.tmp",
            ".f.0001.exr..0000000000000abc.tmp",
            ".f.0001.exr.1.2.0000000000000abc.tmp",
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
        // A pid above the kernel's maximum (4194304) can never be running.
        let dead = 4_000_000_000;
        let own = std::process::id();
        let stale = dir
            .path()
            .join(temp_name(OsStr::new("f.0001.exr"), dead, 1));
        let live = dir.path().join(temp_name(OsStr::new("f.0001.exr"), own, 2));
        let other_target = dir
            .path()
            .join(temp_name(OsStr::new("f.0002.exr"), dead, 3));
        let lookalike = dir.path().join(".f.0001.exr.4000000000.zz.tmp");
        let folder = dir
            .path()
            .join(temp_name(OsStr::new("f.0001.exr"), dead, 4));
        for f in [&stale, &live, &other_target, &lookalike, &target] {
            fs::write(f, b"x").unwrap();
        }
        fs::create_dir(&folder).unwrap();

        // Too recent for a minimum age.
        assert!(
            remove_stale_temp_files(&target, Duration::from_secs(600))
                .unwrap()
                .is_empty()
        );
        let removed = remove_stale_temp_files(&target, Duration::ZERO).unwrap();
        assert_eq!(removed, vec![stale.clone()]);
        assert!(!stale.exists());
        for f in [&live, &other_target, &lookalike, &target, &folder] {
            assert!(f.exists(), "{}", f.display());
        }
        // Old enough once its modification time is in the past.
        let old = dir
            .path()
            .join(temp_name(OsStr::new("f.0001.exr"), dead, 5));
        let file = File::create(&old).unwrap();
        file.set_modified(std::time::SystemTime::now() - Duration::from_secs(3600))
            .unwrap();
        drop(file);
        assert_eq!(
            remove_stale_temp_files(&target, Duration::from_secs(600)).unwrap(),
            vec![old]
        );
        // A folder that does not exist holds nothing stale.
        let missing = dir.path().join("nope/f.exr");
        assert!(
            remove_stale_temp_files(&missing, Duration::ZERO)
                .unwrap()
                .is_empty()
        );
    }
}
