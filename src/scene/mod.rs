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
use crate::sampler::SamplerKind;
use crate::shutter::Shot;
use crate::sphere::SphereDesc;

/// Largest image side, in pixels, from a scene file or the command line.
pub const MAX_SIDE: u32 = 65536;

/// Where and how big frames are written.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputSettings {
    /// The output path pattern; runs of `#` become the zero-padded frame number.
    pub path: String,
    pub width: u32,
    pub height: u32,
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
}

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, Error> {
        Scene::load_with(path, &Overrides::default())
    }

    /// Reads a scene file, applies `overrides` and validates the result.
    pub fn load_with(path: &Path, overrides: &Overrides) -> Result<Scene, Error> {
        let text = std::fs::read_to_string(path).map_err(|e| match e.kind() {
            // A scene that is not there is bad input, not an output failure.
            std::io::ErrorKind::NotFound | std::io::ErrorKind::InvalidData => {
                Error::Scene(format!("{}: {e}", path.display()))
            }
            _ => Error::io(path, e),
        })?;
        Scene::parse_with(&text, path, overrides)
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
