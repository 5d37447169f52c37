//! The validated scene: everything a render needs, with defaults applied, names resolved and
//! every value checked. Built from a scene file by [`crate::scene_file`]; nothing downstream
//! re-validates.

use std::path::{Path, PathBuf};

use crate::camera::CameraRig;
use crate::error::Error;
use crate::material::{Background, Material};
use crate::sampler::SamplerKind;
use crate::shutter::Shot;
use crate::sphere::SphereDesc;

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

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, Error> {
        let text = std::fs::read_to_string(path).map_err(|e| match e.kind() {
            // A scene that is not there is bad input, not an output failure.
            std::io::ErrorKind::NotFound | std::io::ErrorKind::InvalidData => {
                Error::Scene(format!("{}: {e}", path.display()))
            }
            _ => Error::io(path, e),
        })?;
        Scene::parse(&text, path)
    }

    /// Parses and validates scene text; `source` is used in messages only.
    pub fn parse(text: &str, source: &Path) -> Result<Scene, Error> {
        crate::scene_file::parse(text, source)
    }
}
