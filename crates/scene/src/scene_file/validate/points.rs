//! The checks of the `[[points]]` tables: a file (a sequence when its name has a `#`, a
//! series of one file a snapshot when it has a `*`), its format, a material, a radius > 0 if
//! given, a motion (`interpolate` only where there is a next snapshot to move to: a sequence,
//! a series or a format whose files hold several), the snapshots' time, the velocity scale,
//! the looks (`color_by` with its map and range, `radius_by`, `types`).
//!
//! With `color_by`, the map's colour replaces the material's albedo: the table's material
//! (and each type's) is appended again with a white albedo, which the colour multiplies.

use std::collections::BTreeMap;
use std::path::Path;

use super::Validator;
use crate::scene_file::schema::{MaterialRef, RawPointMotion, RawPoints, RawSnapshots};
use raytrace_core::material::Material;
use raytrace_core::points::{
    CacheFormat, ColorBy, PointCacheDesc, PointMotion, SnapshotTime, TypeLook,
};

/// Most entries of a `types` table.
const MAX_TYPES: usize = 4096;
use raytrace_core::path_pattern::FramePattern;

impl Validator<'_> {
    /// The point caches, numbered from 0 (`points[0]`), with their files joined to the scene
    /// file's folder; inline materials (and white copies for `color_by`) are appended to
    /// `materials`.
    pub(super) fn points(
        &self,
        raw: &[RawPoints],
        source: &Path,
        names: &BTreeMap<&str, u32>,
        materials: &mut Vec<Material>,
    ) -> Result<Vec<PointCacheDesc>, String> {
        let mut out = Vec::with_capacity(raw.len());
        for (i, p) in raw.iter().enumerate() {
            out.push(self.point_cache(&format!("points[{i}]"), p, source, names, materials)?);
        }
        Ok(out)
    }

    fn point_cache(
        &self,
        field: &str,
        p: &RawPoints,
        source: &Path,
        names: &BTreeMap<&str, u32>,
        materials: &mut Vec<Material>,
    ) -> Result<PointCacheDesc, String> {
        let file = self.cache_file(field, p, source)?;
        let format = p
            .format
            .map_or_else(|| CacheFormat::from_name(&p.file), |f| f.0);
        let color_by = self.color_by(field, p)?;
        let mut material = |m: &MaterialRef, at: &str| -> Result<u32, String> {
            let index = match m {
                MaterialRef::Name(n) => self.named_material(at, n, names)?,
                MaterialRef::Inline(m) => {
                    materials.push(self.material(&format!("{at}.material"), m)?);
                    (materials.len() - 1) as u32
                }
            };
            // The map's colour replaces the albedo: a white copy that the colour multiplies.
            match (&color_by, materials[index as usize]) {
                (None, _) => Ok(index),
                (Some(_), Material::Dielectric { .. }) => self.err(format_args!(
                    "{at}.material is glass, which has no albedo for {field}.color_by to colour"
                )),
                (Some(_), m) => {
                    materials.push(m.with_albedo(glam::DVec3::ONE));
                    Ok((materials.len() - 1) as u32)
                }
            }
        };
        let base = material(&p.material, field)?;
        let radius = match p.radius {
            Some(r) => Some(self.positive(&format!("{field}.radius"), r.0)?),
            None => None,
        };
        let motion = p.motion.map(|m| match m {
            RawPointMotion::Velocity => PointMotion::Velocity,
            RawPointMotion::Interpolate => PointMotion::Interpolate,
            RawPointMotion::None => PointMotion::Still,
        });
        let snapshots = self.snapshot_time(field, p, format)?;
        let velocity_scale = match p.velocity_scale {
            Some(s) => self.num(&format!("{field}.velocity_scale"), s.0)?,
            None => 1.0,
        };
        let types = self.type_looks(field, p, &mut material)?;
        for (key, column) in [("radius_by", &p.radius_by), ("color_by", &p.color_by)] {
            if column.as_ref().is_some_and(|c| c.trim().is_empty()) {
                return self.err(format_args!("{field}.{key} must name a column"));
            }
        }
        let desc = PointCacheDesc {
            file,
            format,
            material: base,
            radius,
            motion,
            snapshots,
            velocity_scale,
            periodic: p.periodic,
            color_by,
            radius_by: p.radius_by.clone(),
            types,
        };
        let moves_on = desc.is_sequence() || desc.is_series() || format.has_snapshots();
        if motion == Some(PointMotion::Interpolate) && !moves_on {
            return self.err(format_args!(
                "{field}.motion = \"interpolate\" moves each point to its place in the next snapshot, and {field}.file is one {} file for every frame: name a sequence (with # for the frame number) or a series (with *), or use velocity",
                format.name()
            ));
        }
        Ok(desc)
    }

    /// The file of cache `p` (at `field`), joined to the scene file `source`'s folder: one
    /// file, a sequence (`#`) or a series (one `*`, in the file's name).
    fn cache_file(
        &self,
        field: &str,
        p: &RawPoints,
        source: &Path,
    ) -> Result<FramePattern, String> {
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
        if p.file.contains('*') {
            let name = Path::new(&p.file).file_name().map(|n| n.to_string_lossy());
            let stars = p.file.matches('*').count();
            if p.file.contains('#') || stars > 1 || !name.is_some_and(|n| n.contains('*')) {
                return self.err(format_args!(
                    "{field}.file may hold one '*' (any number: a series of one file a snapshot), in the file's name, and no '#' with it"
                ));
            }
        }
        Ok(file)
    }

    /// When cache `p`'s (at `field`, of `format`) snapshots are shown: one a frame, or at
    /// TIMESTEP * `dt` (LAMMPS dumps, not a sequence).
    fn snapshot_time(
        &self,
        field: &str,
        p: &RawPoints,
        format: CacheFormat,
    ) -> Result<SnapshotTime, String> {
        let snapshots = match (p.snapshots, p.dt) {
            (Some(RawSnapshots::Timestep), Some(dt)) => SnapshotTime::Timestep {
                dt: self.positive(&format!("{field}.dt"), dt.0)?,
            },
            (Some(RawSnapshots::Timestep), None) => {
                return self.err(format_args!(
                    "{field}.snapshots = \"timestep\" places a snapshot at TIMESTEP * dt: give {field}.dt (seconds of shot time per timestep)"
                ));
            }
            (_, Some(_)) => {
                return self.err(format_args!(
                    "{field}.dt is used with snapshots = \"timestep\" only"
                ));
            }
            _ => SnapshotTime::Frames,
        };
        if matches!(snapshots, SnapshotTime::Timestep { .. }) {
            if format != CacheFormat::Lammps {
                return self.err(format_args!(
                    "{field}.snapshots = \"timestep\" reads each snapshot's TIMESTEP, which only LAMMPS dumps hold; this cache's format is {}",
                    format.name()
                ));
            }
            if p.file.contains('#') {
                return self.err(format_args!(
                    "{field}.snapshots = \"timestep\": {field}.file is a sequence ('#', a file per frame); name one file of many snapshots, or a series with '*'"
                ));
            }
        }
        Ok(snapshots)
    }

    /// The looks of cache `p`'s (at `field`) `types`: each type's radius, and its material's
    /// index (from `material`, given the material and where it is).
    fn type_looks(
        &self,
        field: &str,
        p: &RawPoints,
        material: &mut impl FnMut(&MaterialRef, &str) -> Result<u32, String>,
    ) -> Result<Vec<TypeLook>, String> {
        let mut types = Vec::new();
        let Some(t) = &p.types else {
            return Ok(types);
        };
        if t.len() > MAX_TYPES {
            return self.err(format_args!(
                "{field}.types has {} entries, more than {MAX_TYPES}",
                t.len()
            ));
        }
        for (key, look) in t {
            let at = format!("{field}.types.\"{key}\"");
            types.push(TypeLook {
                key: key.clone(),
                radius: match look.radius {
                    Some(r) => Some(self.positive(&format!("{at}.radius"), r.0)?),
                    None => None,
                },
                material: match &look.material {
                    Some(m) => Some(material(m, &at)?),
                    None => None,
                },
            });
        }
        Ok(types)
    }

    /// `color_by` with its `colormap` and `color_range`.
    fn color_by(&self, field: &str, p: &RawPoints) -> Result<Option<ColorBy>, String> {
        let Some(column) = &p.color_by else {
            for (key, given) in [
                ("colormap", p.colormap.is_some()),
                ("color_range", p.color_range.is_some()),
            ] {
                if given {
                    return self.err(format_args!(
                        "{field}.{key} is used with {field}.color_by only (the column to colour by)"
                    ));
                }
            }
            return Ok(None);
        };
        let range = match p.color_range {
            None => None,
            Some(r) => {
                let lo = self.num(&format!("{field}.color_range[0]"), r.0[0])?;
                let hi = self.num(&format!("{field}.color_range[1]"), r.0[1])?;
                if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
                    return self.err(format_args!(
                        "{field}.color_range must run from a smaller to a greater value, got [{lo}, {hi}]"
                    ));
                }
                Some([lo, hi])
            }
        };
        Ok(Some(ColorBy {
            column: column.clone(),
            map: p
                .colormap
                .map_or(raytrace_core::colormap::Colormap::Viridis, |m| m.0),
            range,
        }))
    }
}
