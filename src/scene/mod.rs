//! The validated scene: everything a render needs, with defaults applied, names resolved and
//! every value checked, command-line overrides included. Nothing downstream re-validates.
//!
//! A scene file goes through three steps, one file each:
//! - [`schema`]: the TOML format as typed serde structs (unknown keys rejected);
//! - [`validate`]: the one validator, from those raw values (with any [`Overrides`] applied to
//!   them first) to a [`Scene`], naming the field of any bad value;
//! - [`pieces`]: large files cut at their `[[sphere]]` headers and parsed in parallel.
//!
//! Before any document is parsed, [`scan`] checks it against limits that bound the parse's
//! memory; [`report`] words the errors found in the text.
//!
//! [`generate`] writes large random test scenes as scene-file text.

pub mod generate;
mod pieces;
mod report;
mod scan;
mod schema;
mod validate;

#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};

use crate::camera::CameraRig;
use crate::error::Error;
use crate::material::{Background, Material};
use crate::passes::{Pass, PassSet};
use crate::sampler::SamplerKind;
use crate::shutter::Shot;
use crate::sphere::SphereDesc;

/// Largest image side, in pixels, from a scene file or the command line.
pub const MAX_SIDE: u32 = 65536;

/// Largest scene file read, in bytes (2 GiB). A million spheres as `raytrace generate` writes
/// them take 101 MB.
pub const MAX_FILE_BYTES: u64 = 2 << 30;

/// Where and how big frames are written.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputSettings {
    /// The output path pattern; runs of `#` become the zero-padded frame number. `{scene}`
    /// has already been replaced by the scene file's name without extension.
    pub path: String,
    pub width: u32,
    pub height: u32,
    /// `[output] clip` (or `--clip`): a clip to assemble from the frames after rendering
    /// (`.mp4`, `.gif`, `.apng` or `.png`), `{scene}` replaced as in `path`.
    pub clip: Option<String>,
    /// The passes written beside the colour (`[output] passes`, or `--passes`).
    pub passes: PassSet,
}

/// Sampling settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Samples per pixel, >= 1.
    pub samples: u32,
    /// Longest path in bounces; a path that reaches it returns black.
    pub max_depth: u32,
    pub seed: u64,
    /// How samples are placed (`[render] sampler`).
    pub sampler: SamplerKind,
}

/// A validated scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The file the scene was read from (used in messages and for the default output path).
    pub source: PathBuf,
    pub shot: Shot,
    pub output: OutputSettings,
    pub render: RenderSettings,
    pub camera: CameraRig,
    pub background: Background,
    /// `[background] transparent`: camera rays that miss every sphere add black, so the
    /// colour is premultiplied by the alpha pass.
    pub transparent: bool,
    /// Every material used by a sphere; spheres refer to them by index.
    pub materials: Vec<Material>,
    pub spheres: Vec<SphereDesc>,
}

/// Values given on the command line in place of the scene file's. They are written into the
/// file's raw values before validation, so the one validator checks them with the same rules
/// and messages (which name the flag: `--width must be in 1..=65536, got 0`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overrides {
    /// `--output`: replaces `[output] path`.
    pub output: Option<String>,
    /// `--width`: replaces `[output] width`.
    pub width: Option<u32>,
    /// `--height`: replaces `[output] height`.
    pub height: Option<u32>,
    /// `--samples`: replaces `[render] samples`.
    pub samples: Option<u32>,
    /// `--seed`: replaces `[render] seed`.
    pub seed: Option<u64>,
    /// `--sampler`: replaces `[render] sampler`.
    pub sampler: Option<SamplerKind>,
    /// `--clip`: replaces `[output] clip`.
    pub clip: Option<String>,
    /// `--passes`: replaces `[output] passes` (in the order given, duplicates included, so
    /// the validator names them).
    pub passes: Option<Vec<Pass>>,
}

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, Error> {
        Scene::load_with(path, &Overrides::default())
    }

    /// Reads a scene file, applies `overrides` and validates the result. Only a regular file
    /// of at most [`MAX_FILE_BYTES`] is read (see [`read_scene`]).
    pub fn load_with(path: &Path, overrides: &Overrides) -> Result<Scene, Error> {
        let bytes = read_scene(path, MAX_FILE_BYTES)?;
        Scene::parse_bytes_with(&bytes, path, overrides)
    }

    /// Parses and validates a scene file's contents: text that is not UTF-8 is refused with
    /// the line and column of the first byte that is not.
    pub fn parse_bytes(bytes: &[u8], source: &Path) -> Result<Scene, Error> {
        Scene::parse_bytes_with(bytes, source, &Overrides::default())
    }

    /// [`Scene::parse_bytes`] with overrides.
    pub fn parse_bytes_with(
        bytes: &[u8],
        source: &Path,
        overrides: &Overrides,
    ) -> Result<Scene, Error> {
        match std::str::from_utf8(bytes) {
            Ok(text) => Scene::parse_with(text, source, overrides),
            Err(e) => Err(Error::Scene(report::not_utf8(
                &source.display().to_string(),
                bytes,
                &e,
            ))),
        }
    }

    /// Parses and validates scene text; `source` is used in messages and for the default
    /// output path.
    pub fn parse(text: &str, source: &Path) -> Result<Scene, Error> {
        Scene::parse_with(text, source, &Overrides::default())
    }

    /// Parses scene text, applies `overrides` and validates the result.
    ///
    /// A large file is cut at its `[[sphere]]` headers into pieces parsed and validated in
    /// parallel, so the whole document is never held as a TOML tree (a million spheres would
    /// take gigabytes). Messages are the same either way.
    pub fn parse_with(text: &str, source: &Path, overrides: &Overrides) -> Result<Scene, Error> {
        if text.len() >= pieces::PIECES_FROM_BYTES
            && let Some(result) =
                pieces::parse_in_pieces(text, source, overrides, pieces::PIECE_SPHERES)
        {
            return result;
        }
        parse_whole(text, source, overrides)
    }
}

/// Reads a scene file of at most `max` bytes. Only a regular file is opened: a directory, a
/// named pipe (whose opening would wait for a writer), a device (`/dev/zero` never ends) or a
/// socket is refused from its metadata, as is a path that cannot be resolved (missing, a loop
/// of links). At most `max + 1` bytes are read, whatever the file claims or becomes. Every
/// refusal is bad input ([`Error::Scene`], exit status 2), except a file that exists but cannot
/// be read ([`Error::Io`]).
fn read_scene(path: &Path, max: u64) -> Result<Vec<u8>, Error> {
    use std::io::Read;
    // A path of any length is named by its start and end (see `clip_path`).
    let shown = crate::error::clip_path(path);
    let bad = |what: &dyn std::fmt::Display| Error::Scene(format!("{shown}: {what}"));
    let meta = std::fs::metadata(path).map_err(|e| bad(&e))?;
    let kind = file_kind(&meta.file_type());
    if !meta.is_file() {
        return Err(bad(&format_args!(
            "is {kind}, not a scene file (scenes are read from regular files only)"
        )));
    }
    let too_big = |size: &dyn std::fmt::Display| {
        bad(&format_args!(
            "is {size}, more than the {} a scene file may be",
            bytes_text(max)
        ))
    };
    if meta.len() > max {
        return Err(too_big(&bytes_text(meta.len())));
    }
    // A scene that cannot be opened (gone, or not readable) is bad input, as a missing one is.
    let file = std::fs::File::open(path).map_err(|e| bad(&e))?;
    // The path may have been replaced since its metadata was read.
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(bad(&format_args!(
            "is {}, not a scene file (scenes are read from regular files only)",
            file_kind(&meta.file_type())
        )));
    }
    let mut bytes = Vec::with_capacity(meta.len().min(max) as usize);
    file.take(max + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > max {
        return Err(too_big(&format_args!("longer than its size says")));
    }
    Ok(bytes)
}

/// What kind of file system object a path is, for messages.
fn file_kind(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a named pipe";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else if t.is_file() {
        "a file"
    } else {
        "not a regular file"
    }
}

/// `2 GiB`, `3.5 GiB`, `100 MiB`, `12 bytes`.
fn bytes_text(n: u64) -> String {
    let units = [(1u64 << 30, "GiB"), (1 << 20, "MiB"), (1 << 10, "KiB")];
    for (size, unit) in units {
        if n >= size {
            let x = n as f64 / size as f64;
            return if x.fract() == 0.0 {
                format!("{x} {unit}")
            } else {
                format!("{x:.1} {unit}")
            };
        }
    }
    format!("{n} bytes")
}

/// Parses the whole document at once.
fn parse_whole(text: &str, source: &Path, overrides: &Overrides) -> Result<Scene, Error> {
    let file = source.display().to_string();
    let located =
        |e: report::Located| Error::Scene(report::render(&file, text, e.span, &e.message));
    scan::scan(text, 0).map_err(located)?;
    let mut raw: schema::RawScene =
        toml::from_str(text).map_err(|e| located(report::toml_error(text, &e, 0)))?;
    let check = validate::Check::new(&file, overrides);
    check.apply(&mut raw);
    check.scene(raw, source).map_err(Error::Scene)
}
