//! Which columns of a snapshot a cache reads, by the names each format writes them under:
//!
//! | meaning | PLY | LAMMPS | extended XYZ | VTK (point data arrays) |
//! | --- | --- | --- | --- | --- |
//! | position | `x y z` | `x y z`, `xs ys zs`, `xu yu zu`, `xsu ysu zsu` | `pos` | the points |
//! | image flags | | `ix iy iz` | | |
//! | velocity | `vx vy vz`, `velocity_x ...` | `vx vy vz` | `velo`, `vel` | `velocity`, `velocities`, `vel`, `velo`, `v` |
//! | radius | `radius`, `pscale` | `radius`, `diameter` (halved) | `radius` | `radius`, `diameter` (halved) |
//! | colour | `red green blue`, `r g b` | | | |
//! | identity | `id` | `id` | `id` | `id` |
//! | type | `type` | `type` | `species` | `type` |
//!
//! VTK names are matched without regard to case. `radius_by` and `color_by` name any column
//! (a quantity of several components, an XYZ `velo` or a VTK vector, gives its length).

use crate::sim::{Column, ColumnKind};
use raytrace_core::points::{CacheFormat, PointCacheDesc, PointMotion};

/// How a snapshot's positions are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Placement {
    /// Where the point is (LAMMPS `x`, wrapped into the box).
    Plain,
    /// Fractions of the box's edges (LAMMPS `xs`).
    Scaled,
    /// Where the point is, not wrapped (LAMMPS `xu`): continuous from snapshot to snapshot.
    Unwrapped,
    /// Fractions of the box's edges, not wrapped (LAMMPS `xsu`).
    ScaledUnwrapped,
}

impl Placement {
    /// Whether positions are fractions of the box.
    pub(super) fn scaled(self) -> bool {
        matches!(self, Placement::Scaled | Placement::ScaledUnwrapped)
    }

    /// Whether positions run on across the box's faces.
    pub(super) fn unwrapped(self) -> bool {
        matches!(self, Placement::Unwrapped | Placement::ScaledUnwrapped)
    }
}

/// Where a cache's attributes are among a snapshot's columns.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct ColumnMap {
    pub(super) position: [usize; 3],
    pub(super) placement: Placement,
    pub(super) images: Option<[usize; 3]>,
    pub(super) velocity: Option<[usize; 3]>,
    /// The radius column and the factor its values are multiplied by (0.5 for a diameter).
    pub(super) radius: Option<(usize, f64)>,
    /// Colour columns and whether they are integers (0 to 255).
    pub(super) color: Option<([usize; 3], bool)>,
    pub(super) id: Option<usize>,
    /// The `type` (or `species`) column, when `types` is given.
    pub(super) kind: Option<usize>,
    /// The `color_by` column's components.
    pub(super) color_by: Vec<usize>,
}

/// The index of `name`'s component `component`, matching names exactly or, for VTK, without
/// regard to case.
fn find(columns: &[Column], format: CacheFormat, name: &str, component: u8) -> Option<usize> {
    columns.iter().position(|c| {
        let same = match format {
            CacheFormat::Vtk => c.name.eq_ignore_ascii_case(name),
            _ => c.name == name,
        };
        same && c.component == component
    })
}

/// The first group of `groups` whose columns are all present; a group partly present is an
/// error. A group is names of one-component columns, or one name of a three-component
/// quantity.
fn group(
    columns: &[Column],
    format: CacheFormat,
    groups: &[&[&str]],
) -> Result<Option<([usize; 3], usize)>, String> {
    for (g, names) in groups.iter().enumerate() {
        let found: Vec<Option<usize>> = match names {
            [one] => (0..3).map(|k| find(columns, format, one, k)).collect(),
            _ => names.iter().map(|n| find(columns, format, n, 0)).collect(),
        };
        if let [Some(a), Some(b), Some(c)] = found[..] {
            return Ok(Some(([a, b, c], g)));
        }
        if names.len() == 3
            && let Some(k) = found.iter().position(Option::is_some)
        {
            let missing: Vec<&str> = names
                .iter()
                .zip(&found)
                .filter(|(_, f)| f.is_none())
                .map(|(n, _)| *n)
                .collect();
            return Err(format!(
                "{} has {} but not {}",
                holder(format),
                names[k],
                missing.join(", ")
            ));
        }
    }
    Ok(None)
}

/// What holds the columns, in messages.
fn holder(format: CacheFormat) -> &'static str {
    match format {
        CacheFormat::Ply => "the vertex element",
        _ => "the file",
    }
}

/// The first of `names` present as a one-component column.
fn single(columns: &[Column], format: CacheFormat, names: &[&str]) -> Option<(usize, usize)> {
    names.iter().enumerate().find_map(|(g, n)| {
        let k = find(columns, format, n, 0)?;
        (columns[k].components == 1).then_some((k, g))
    })
}

/// Every component of the column named `name` (exactly, or without case for VTK).
fn quantity(columns: &[Column], format: CacheFormat, name: &str) -> Vec<usize> {
    let first = find(columns, format, name, 0);
    match first {
        None => Vec::new(),
        Some(k) => (0..columns[k].components)
            .filter_map(|c| find(columns, format, name, c))
            .collect(),
    }
}

/// The attributes of a snapshot with `columns` that cache `desc` needs.
pub(super) fn map_columns(columns: &[Column], desc: &PointCacheDesc) -> Result<ColumnMap, String> {
    let f = desc.format;
    let (position, placement) = position_columns(columns, f)?;
    let images = match f {
        CacheFormat::Lammps => group(columns, f, &[&["ix", "iy", "iz"]])?.map(|g| g.0),
        _ => None,
    };
    let velocities = velocity_names(f);
    let velocity = group(columns, f, velocities)?.map(|g| g.0);
    let radius = radius_column(columns, desc)?;
    let every_type_sized = !desc.types.is_empty() && desc.types.iter().all(|t| t.radius.is_some());
    if radius.is_none() && desc.radius.is_none() && !every_type_sized {
        return Err(
            "no radius column (radius, pscale or diameter), and the [[points]] table gives no radius"
                .into(),
        );
    }
    let color = match f {
        CacheFormat::Ply => group(columns, f, &[&["red", "green", "blue"], &["r", "g", "b"]])?
            .map(|(k, _)| (k, k.iter().any(|&i| columns[i].kind == ColumnKind::Integer))),
        _ => None,
    };
    let id = single(columns, f, &["id"]).map(|g| g.0);
    let kind = kind_column(columns, desc)?;
    let color_by = match &desc.color_by {
        None => Vec::new(),
        Some(c) => {
            let q = quantity(columns, f, &c.column);
            if q.is_empty() {
                return Err(format!(
                    "color_by names the column {}, which the file does not have",
                    c.column
                ));
            }
            q
        }
    };
    if desc.motion == Some(PointMotion::Velocity) && velocity.is_none() {
        let names: Vec<String> = velocities.iter().map(|g| g.join(" ")).collect();
        return Err(format!(
            "motion = \"velocity\", but {} has no velocity columns ({})",
            holder(f),
            names.join(", or ")
        ));
    }
    if desc.motion == Some(PointMotion::Interpolate) && id.is_none() {
        return Err(format!(
            "motion = \"interpolate\" matches points by id, and {} has no id column",
            holder(f)
        ));
    }
    let layout = ColumnMap {
        position,
        placement,
        images,
        velocity,
        radius,
        color,
        id,
        kind,
        color_by,
    };
    layout.check_numbers(columns)?;
    Ok(layout)
}

/// The position columns of `format` and how they place the points; an error when there are
/// none.
fn position_columns(
    columns: &[Column],
    format: CacheFormat,
) -> Result<([usize; 3], Placement), String> {
    let positions: &[&[&str]] = match format {
        CacheFormat::Ply => &[&["x", "y", "z"]],
        CacheFormat::Lammps => &[
            &["x", "y", "z"],
            &["xs", "ys", "zs"],
            &["xu", "yu", "zu"],
            &["xsu", "ysu", "zsu"],
        ],
        CacheFormat::Xyz => &[&["pos"]],
        CacheFormat::Vtk => &[&[crate::sim::vtk::POINTS]],
    };
    let Some((position, p)) = group(columns, format, positions)? else {
        let names: Vec<String> = positions.iter().map(|g| g.join(" ")).collect();
        return Err(format!(
            "no position columns: {} (the points' positions)",
            names.join(", or ")
        ));
    };
    // In the order of the groups of names above.
    let placement = [
        Placement::Plain,
        Placement::Scaled,
        Placement::Unwrapped,
        Placement::ScaledUnwrapped,
    ][p];
    Ok((position, placement))
}

/// The groups of names `format` writes velocities under, in the order they are looked for.
fn velocity_names(format: CacheFormat) -> &'static [&'static [&'static str]] {
    match format {
        CacheFormat::Ply => &[
            &["vx", "vy", "vz"],
            &["velocity_x", "velocity_y", "velocity_z"],
        ],
        CacheFormat::Lammps => &[&["vx", "vy", "vz"]],
        CacheFormat::Xyz => &[&["velo"], &["vel"]],
        CacheFormat::Vtk => &[&["velocity"], &["velocities"], &["vel"], &["velo"], &["v"]],
    }
}

/// The radius column of cache `desc` and the factor its values are multiplied by (0.5 for
/// a diameter): `radius_by`'s (an error when the file lacks it), else the first of the
/// format's names present.
fn radius_column(
    columns: &[Column],
    desc: &PointCacheDesc,
) -> Result<Option<(usize, f64)>, String> {
    let f = desc.format;
    Ok(match &desc.radius_by {
        Some(name) => {
            let Some(k) = find(columns, f, name, 0).filter(|&k| columns[k].components == 1) else {
                return Err(format!(
                    "radius_by names the column {name}, which the file does not have (as one number a point)"
                ));
            };
            Some((k, if name == "diameter" { 0.5 } else { 1.0 }))
        }
        None => {
            let names: &[&str] = match f {
                CacheFormat::Ply => &["radius", "pscale"],
                CacheFormat::Xyz => &["radius"],
                CacheFormat::Lammps | CacheFormat::Vtk => &["radius", "diameter"],
            };
            single(columns, f, names).map(|(k, _)| {
                let diameter = columns[k].name.eq_ignore_ascii_case("diameter");
                (k, if diameter { 0.5 } else { 1.0 })
            })
        }
    })
}

/// The `type` (XYZ: `species`) column, where cache `desc` gives looks per type (an error
/// when the file has none).
fn kind_column(columns: &[Column], desc: &PointCacheDesc) -> Result<Option<usize>, String> {
    if desc.types.is_empty() {
        return Ok(None);
    }
    let f = desc.format;
    let name = if f == CacheFormat::Xyz {
        "species"
    } else {
        "type"
    };
    match single(columns, f, &[name]) {
        Some((k, _)) => Ok(Some(k)),
        None => Err(format!(
            "types gives looks per {name}, and the file has no {name} column"
        )),
    }
}

impl ColumnMap {
    /// Every column the layout reads.
    pub(super) fn used(&self) -> Vec<usize> {
        let mut v: Vec<usize> = self.position.to_vec();
        v.extend(self.images.iter().flatten());
        v.extend(self.velocity.iter().flatten());
        v.extend(self.radius.iter().map(|r| r.0));
        v.extend(self.color.iter().flat_map(|c| c.0));
        v.extend(self.id);
        v.extend(self.kind);
        v.extend(&self.color_by);
        v
    }

    /// Checks that every column the layout reads is a single number, or text for the type.
    fn check_numbers(&self, columns: &[Column]) -> Result<(), String> {
        for k in self.used() {
            let c = &columns[k];
            let text_type = Some(k) == self.kind && c.kind == ColumnKind::Text;
            if c.kind == ColumnKind::List || (c.kind == ColumnKind::Text && !text_type) {
                return Err(format!(
                    "property {} is {}; a single number was expected",
                    c.label(),
                    if c.kind == ColumnKind::List {
                        "a list"
                    } else {
                        "text"
                    }
                ));
            }
        }
        Ok(())
    }

    /// A cache's motion with this layout: its own, or velocity where the file has
    /// velocities, else still.
    pub(super) fn motion(&self, desc: &PointCacheDesc) -> PointMotion {
        desc.motion.unwrap_or(if self.velocity.is_some() {
            PointMotion::Velocity
        } else {
            PointMotion::Still
        })
    }
}
