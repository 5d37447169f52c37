//! Reading a scene file: its bytes (regular files only, of bounded size), its text, and the
//! parse and validation that make a [`Scene`] of it.

use std::path::{Path, PathBuf};

use super::overrides::Overrides;
use super::{pieces, report, scan, schema, validate};
use raytrace_core::error::Error;
use raytrace_core::scene::Scene;

/// Largest scene file read, in bytes (2 GiB). A million spheres as `raytrace generate` writes
/// them take 101 MB.
pub(crate) const MAX_FILE_BYTES: u64 = 2 << 30;

/// Scenes read from scene files: the file's bytes or text parsed, any [`Overrides`] applied,
/// and the result validated (the one validator, `validate`).
pub trait SceneFile: Sized {
    /// Reads and validates a scene file.
    fn load(path: &Path) -> Result<Self, Error>;

    /// Reads a scene file, applies `overrides` and validates the result. Only a regular file
    /// of at most [`MAX_FILE_BYTES`] is read (see [`read_scene`]).
    fn load_with(path: &Path, overrides: &Overrides) -> Result<Self, Error>;

    /// Parses and validates a scene file's contents: text that is not UTF-8 is refused with
    /// the line and column of the first byte that is not.
    fn parse_bytes(bytes: &[u8], source: &Path) -> Result<Self, Error>;

    /// [`SceneFile::parse_bytes`] with overrides.
    fn parse_bytes_with(bytes: &[u8], source: &Path, overrides: &Overrides) -> Result<Self, Error>;

    /// Parses and validates scene text; `source` is used in messages and for the default
    /// output path.
    fn parse(text: &str, source: &Path) -> Result<Self, Error>;

    /// Parses scene text, applies `overrides` and validates the result.
    ///
    /// A large file is cut at its `[[sphere]]` headers into pieces parsed and validated in
    /// parallel, so the whole document is never held as a TOML tree (a million spheres would
    /// take gigabytes). Messages are the same either way.
    fn parse_with(text: &str, source: &Path, overrides: &Overrides) -> Result<Self, Error>;
}

impl SceneFile for Scene {
    fn load(path: &Path) -> Result<Scene, Error> {
        Scene::load_with(path, &Overrides::default())
    }

    fn load_with(path: &Path, overrides: &Overrides) -> Result<Scene, Error> {
        let bytes = read_scene(path, MAX_FILE_BYTES)?;
        Scene::parse_bytes_with(&bytes, path, overrides)
    }

    fn parse_bytes(bytes: &[u8], source: &Path) -> Result<Scene, Error> {
        Scene::parse_bytes_with(bytes, source, &Overrides::default())
    }

    fn parse_bytes_with(
        bytes: &[u8],
        source: &Path,
        overrides: &Overrides,
    ) -> Result<Scene, Error> {
        match std::str::from_utf8(bytes) {
            Ok(text) => Scene::parse_with(text, source, overrides),
            Err(e) => Err(Error::Scene(report::not_utf8(
                &raytrace_core::error::elide_path(source),
                bytes,
                &e,
            ))),
        }
    }

    fn parse(text: &str, source: &Path) -> Result<Scene, Error> {
        Scene::parse_with(text, source, &Overrides::default())
    }

    fn parse_with(text: &str, source: &Path, overrides: &Overrides) -> Result<Scene, Error> {
        if text.len() >= pieces::PIECES_FROM_BYTES
            && let Some(result) =
                pieces::parse_in_pieces(text, source, overrides, pieces::PIECE_SPHERES)
        {
            return result;
        }
        parse_whole(text, source, overrides)
    }
}

/// Bytes per sphere while the scene file is read, beyond the [`Scene`] itself: the file's
/// text and its parsed form are gone once the scene is validated, but they set the peak of a
/// large scene. Calibrated on generated scenes of 10^4 to 10^6 spheres.
const LOAD_BYTES_PER_SPHERE: u64 = 300;

/// The bytes reading the scene file of `scene` holds at its peak, beyond the scene.
pub fn bytes_for(scene: &Scene) -> u64 {
    scene.spheres.len() as u64 * LOAD_BYTES_PER_SPHERE
}

/// A scene file's bytes, read once, from which scenes are made with any overrides, each
/// through the one validator: a command that renders one file with several settings (`converge`
/// with each sample count and sampler) never changes a validated scene.
#[derive(Clone, Debug)]
pub struct SceneSource {
    path: PathBuf,
    bytes: Vec<u8>,
}

impl SceneSource {
    /// Reads the scene file at `path` (as [`Scene::load`] does).
    pub fn read(path: &Path) -> Result<SceneSource, Error> {
        Ok(SceneSource {
            path: path.to_path_buf(),
            bytes: read_scene(path, MAX_FILE_BYTES)?,
        })
    }

    /// The scene with `overrides` applied, validated.
    pub fn scene(&self, overrides: &Overrides) -> Result<Scene, Error> {
        Scene::parse_bytes_with(&self.bytes, &self.path, overrides)
    }
}

/// Reads a scene file of at most `max` bytes. Only a regular file is opened: a directory, a
/// named pipe (whose opening would wait for a writer), a device (`/dev/zero` never ends) or a
/// socket is refused from its metadata, as is a path that cannot be resolved (missing, a loop
/// of links). At most `max + 1` bytes are read, whatever the file claims or becomes. Every
/// refusal is bad input ([`Error::Scene`], exit status 2), except a file that exists but cannot
/// be read ([`Error::Io`]).
pub(super) fn read_scene(path: &Path, max: u64) -> Result<Vec<u8>, Error> {
    use std::io::Read;
    // A path of any length is named by its start and end (see `elide_path`).
    let shown = raytrace_core::error::elide_path(path);
    let bad = |what: &dyn std::fmt::Display| Error::Scene(format!("{shown}: {what}"));
    let meta = std::fs::metadata(path).map_err(|e| bad(&e))?;
    let kind = raytrace_io::file_kind(&meta.file_type());
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
            raytrace_io::file_kind(&meta.file_type())
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
pub(super) fn parse_whole(
    text: &str,
    source: &Path,
    overrides: &Overrides,
) -> Result<Scene, Error> {
    let file = raytrace_core::error::elide_path(source);
    let located =
        |e: report::Located| Error::Scene(report::render(&file, text, e.span, &e.message));
    scan::scan(text, 0).map_err(located)?;
    let mut raw: schema::RawScene =
        toml::from_str(text).map_err(|e| located(report::toml_error(text, &e, 0)))?;
    let check = validate::Validator::new(&file, overrides);
    check.apply(&mut raw);
    check.scene(raw, source).map_err(Error::Scene)
}
