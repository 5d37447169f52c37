//! The checks of the `[[points]]` tables: a file (a sequence when its name has a `#`), a
//! material, a radius > 0 if given, and a motion (`interpolate` only for a sequence, whose
//! next frame's file it reads).

use std::collections::BTreeMap;
use std::path::Path;

use super::Check;
use crate::material::Material;
use crate::path_pattern::FramePattern;
use crate::points::{PointCacheDesc, PointMotion};
use crate::scene_file::schema::{MaterialRef, RawPointMotion, RawPoints};

impl Check<'_> {
    /// The point caches, numbered from 0 (`points[0]`), with their files joined to the scene
    /// file's folder; inline materials are appended to `materials`.
    pub(super) fn points(
        &self,
        raw: &[RawPoints],
        source: &Path,
        names: &BTreeMap<&str, u32>,
        materials: &mut Vec<Material>,
    ) -> Result<Vec<PointCacheDesc>, String> {
        let mut out = Vec::with_capacity(raw.len());
        for (i, p) in raw.iter().enumerate() {
            let field = format!("points[{i}]");
            if p.file.trim().is_empty() {
                return self.err(format_args!("{field}.file must not be empty"));
            }
            let file = match source.parent() {
                Some(dir) if Path::new(&p.file).is_relative() => {
                    dir.join(&p.file).to_string_lossy().into_owned()
                }
                _ => p.file.clone(),
            };
            let file = FramePattern::new(file)
                .or_else(|e| self.err(format_args!("{field}.file \"{}\": {e}", p.file)))?;
            let material = match &p.material {
                MaterialRef::Name(n) => self.named_material(&field, n, names)?,
                MaterialRef::Inline(m) => {
                    materials.push(self.material(&format!("{field}.material"), m)?);
                    (materials.len() - 1) as u32
                }
            };
            let radius = match p.radius {
                Some(r) => Some(self.positive(&format!("{field}.radius"), r.0)?),
                None => None,
            };
            let motion = p.motion.map(|m| match m {
                RawPointMotion::Velocity => PointMotion::Velocity,
                RawPointMotion::Interpolate => PointMotion::Interpolate,
                RawPointMotion::None => PointMotion::Still,
            });
            let desc = PointCacheDesc {
                file,
                material,
                radius,
                motion,
            };
            if motion == Some(PointMotion::Interpolate) && !desc.is_sequence() {
                return self.err(format_args!(
                    "{field}.motion = \"interpolate\" moves each point to its place in the next frame file, and {field}.file is one file for every frame: name a sequence (with # for the frame number), or use velocity"
                ));
            }
            out.push(desc);
        }
        Ok(out)
    }
}
