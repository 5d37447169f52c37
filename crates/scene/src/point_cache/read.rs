//! A snapshot's values read into columns and checked, value by value: positions, radii and
//! velocities finite (and within the range of 32-bit floats), radii >= 0, colours in range,
//! ids whole numbers, image flags whole numbers, colour values finite. A bad value is an
//! error naming the point (its index in the snapshot, from 0).

use glam::DVec3;

use super::columns::ColumnMap;
use super::table::Rows;
use crate::sim::cell::Cell;
use crate::sim::{ReadError, Snapshot};
use raytrace_core::points::PointCacheDesc;

/// Largest magnitude of a coordinate, radius or velocity: the range of the 32-bit floats
/// frames are stored in, as for the scene file's numbers.
pub(super) const MAX_VALUE: f64 = f32::MAX as f64;

/// Largest magnitude of an id: whole numbers beyond 2^53 are not all exact as the `f64`
/// values ids are read through.
const MAX_ID: f64 = (1u64 << 53) as f64;

/// What to read of a snapshot.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Wanted {
    pub(super) positions: bool,
    pub(super) velocities: bool,
    /// Radii, colours, types.
    pub(super) looks: bool,
    pub(super) ids: bool,
    pub(super) images: bool,
    /// The `color_by` values.
    pub(super) values: bool,
}

/// A snapshot's points as read; a column not read is empty.
#[derive(Debug, Default)]
pub(super) struct Read {
    /// Positions as the file places them (scaled positions made cartesian).
    pub(super) centers: Vec<DVec3>,
    /// LAMMPS image flags.
    pub(super) images: Vec<[i32; 3]>,
    /// Velocities times the cache's `velocity_scale`.
    pub(super) velocities: Vec<DVec3>,
    pub(super) radii: Vec<f64>,
    pub(super) colors: Vec<[f32; 3]>,
    pub(super) ids: Vec<i64>,
    /// The `type` (or `species`) of each point, as its key in `types` is written.
    pub(super) kinds: Vec<u32>,
    /// The labels of `kinds` (the distinct types, in order of appearance).
    pub(super) kind_names: Vec<String>,
    /// The `color_by` values.
    pub(super) values: Vec<f64>,
}

/// The box of a snapshot as cache `desc` takes it: the file's, periodic where the file says,
/// unless `periodic` says otherwise (`false`: nowhere; `true`: along every edge, which needs
/// a box).
pub(super) fn cell_of(snap: &Snapshot, desc: &PointCacheDesc) -> Result<Option<Cell>, ReadError> {
    match (snap.cell, desc.periodic) {
        (None, Some(true)) => Err(ReadError::Bad(
            "periodic = true, and the file gives no box (LAMMPS BOX BOUNDS, XYZ Lattice=)".into(),
        )),
        (Some(c), Some(p)) => Ok(Some(Cell {
            periodic: [p; 3],
            ..c
        })),
        (c, _) => Ok(c),
    }
}

/// A value's check: finite and within the range of 32-bit floats.
fn finite(i: u64, name: &str, x: f64) -> Result<f64, String> {
    if !x.is_finite() {
        Err(format!("point {i}: {name} is {x}, not a finite number"))
    } else if x.abs() > MAX_VALUE {
        Err(format!(
            "point {i}: {name} is {x:e}, beyond the 3.4e38 of 32-bit floats"
        ))
    } else {
        Ok(x)
    }
}

/// Reads `rows` (`count` of them, with `names` the columns' names in messages) with
/// `layout` as `wanted` says; `cell` is the snapshot's box (scaled positions need one).
pub(super) fn read_values(
    rows: &mut Rows,
    count: u64,
    names: &[String],
    layout: &ColumnMap,
    cell: Option<&Cell>,
    desc: &PointCacheDesc,
    want: Wanted,
) -> Result<Read, ReadError> {
    let n = usize::try_from(count).map_err(|_| ReadError::Bad(format!("{count} points")))?;
    let mut columns: Vec<usize> = Vec::new();
    let mut add = |on: bool, ks: &[usize]| -> Option<usize> {
        on.then(|| {
            columns.extend(ks);
            columns.len() - ks.len()
        })
    };
    let position = add(want.positions, &layout.position);
    let images = layout.images.and_then(|k| add(want.images, &k));
    let velocity = layout.velocity.and_then(|k| add(want.velocities, &k));
    let radius = layout
        .radius
        .and_then(|(k, f)| add(want.looks, &[k]).map(|s| (s, f)));
    let color = layout
        .color
        .and_then(|(k, int)| add(want.looks, &k).map(|s| (s, int)));
    let id = layout.id.and_then(|k| add(want.ids, &[k]));
    let kind = layout.kind.and_then(|k| add(want.looks, &[k]));
    let values = (!layout.color_by.is_empty())
        .then(|| add(want.values, &layout.color_by))
        .flatten();
    let value_count = layout.color_by.len();
    let scaled = layout.placement.scaled();
    if scaled && position.is_some() && cell.is_none() {
        return Err(ReadError::Bad(
            "positions are fractions of the box (xs ys zs), and the snapshot gives no box".into(),
        ));
    }
    let believed = rows.believed(count);
    let with = |on: Option<usize>| if on.is_some() { believed } else { 0 };
    let mut out = Read {
        centers: Vec::with_capacity(with(position)),
        images: Vec::with_capacity(with(images)),
        velocities: Vec::with_capacity(with(velocity)),
        radii: Vec::with_capacity(with(radius.map(|r| r.0))),
        colors: Vec::with_capacity(with(color.map(|c| c.0))),
        ids: Vec::with_capacity(with(id)),
        kinds: Vec::with_capacity(with(kind)),
        kind_names: Vec::new(),
        values: Vec::with_capacity(with(values)),
    };
    let name = |k: usize| names[columns[k]].as_str();
    let scale = desc.velocity_scale;
    let mut kind_values: Vec<f64> = Vec::new();
    let labels = rows.read(&columns, |i, v| {
        if let Some(k) = position {
            let p = DVec3::new(
                finite(i, name(k), v[k])?,
                finite(i, name(k + 1), v[k + 1])?,
                finite(i, name(k + 2), v[k + 2])?,
            );
            let p = match cell {
                Some(c) if scaled => c.cartesian(p),
                _ => p,
            };
            out.centers.push(p);
        }
        if let Some(k) = images {
            let mut flags = [0i32; 3];
            for (j, f) in flags.iter_mut().enumerate() {
                let x = v[k + j];
                if x.fract() != 0.0 || !(i32::MIN as f64..=i32::MAX as f64).contains(&x) {
                    return Err(format!(
                        "point {i}: {} is {x}, not a whole number of boxes",
                        name(k + j)
                    ));
                }
                *f = x as i32;
            }
            out.images.push(flags);
        }
        if let Some(k) = velocity {
            let mut u = [0.0; 3];
            for (j, x) in u.iter_mut().enumerate() {
                *x = finite(i, name(k + j), finite(i, name(k + j), v[k + j])? * scale)?;
            }
            out.velocities.push(DVec3::from_array(u));
        }
        if let Some((k, factor)) = radius {
            let r = finite(i, name(k), v[k])? * factor;
            if r < 0.0 {
                return Err(format!(
                    "point {i}: {} is {}; a radius must be >= 0",
                    name(k),
                    v[k]
                ));
            }
            out.radii.push(r);
        }
        if let Some((k, integer)) = color {
            let mut c = [0f32; 3];
            for j in 0..3 {
                let x = v[k + j];
                let (scaled, range) = if integer {
                    (x / 255.0, "0 to 255")
                } else {
                    (x, "0 to 1")
                };
                if !(0.0..=1.0).contains(&scaled) {
                    return Err(format!(
                        "point {i}: {} is {x}, outside {range}",
                        name(k + j)
                    ));
                }
                c[j] = scaled as f32;
            }
            out.colors.push(c);
        }
        if let Some(k) = id {
            let x = v[k];
            if x.fract() != 0.0 || !x.is_finite() {
                return Err(format!("point {i}: id is {x}, not a whole number"));
            }
            if x.abs() > MAX_ID {
                return Err(format!(
                    "point {i}: id is {x:e}, beyond the 2^53 that ids are told apart to"
                ));
            }
            out.ids.push(x as i64);
        }
        if let Some(k) = kind {
            kind_values.push(v[k]);
        }
        if let Some(k) = values {
            let x = if value_count == 1 {
                v[k]
            } else {
                v[k..k + value_count]
                    .iter()
                    .map(|x| x * x)
                    .sum::<f64>()
                    .sqrt()
            };
            if !x.is_finite() {
                return Err(format!(
                    "point {i}: {} is {x}, not a finite number (it is coloured by)",
                    name(k)
                ));
            }
            out.values.push(x);
        }
        Ok(())
    })?;
    if kind.is_some() {
        (out.kinds, out.kind_names) = kinds_of(&kind_values, &labels);
    }
    if believed < n {
        // Columns grown as lines were read hold no more than their points.
        out.centers.shrink_to_fit();
        out.images.shrink_to_fit();
        out.velocities.shrink_to_fit();
        out.radii.shrink_to_fit();
        out.colors.shrink_to_fit();
        out.ids.shrink_to_fit();
        out.values.shrink_to_fit();
    }
    Ok(out)
}

/// Each point's type as an index into the distinct types' names: text types (an XYZ
/// species) by their label, numbers as written in a scene file's keys (`1`, `2.5`).
fn kinds_of(values: &[f64], labels: &[String]) -> (Vec<u32>, Vec<String>) {
    if !labels.is_empty() {
        return (values.iter().map(|&v| v as u32).collect(), labels.to_vec());
    }
    let mut names: Vec<String> = Vec::new();
    let mut seen: std::collections::HashMap<u64, u32> = std::collections::HashMap::new();
    let kinds = values
        .iter()
        .map(|&v| {
            *seen.entry(v.to_bits()).or_insert_with(|| {
                names.push(if v.fract() == 0.0 && v.abs() < 1e15 {
                    format!("{}", v as i64)
                } else {
                    format!("{v}")
                });
                (names.len() - 1) as u32
            })
        })
        .collect();
    (kinds, names)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn types_are_named_as_scene_files_write_them() {
        let (k, n) = kinds_of(&[1.0, 2.0, 1.0, 2.5], &[]);
        assert_eq!(k, [0, 1, 0, 2]);
        assert_eq!(n, ["1", "2", "2.5"]);
        let labels = ["Ar".to_string(), "Ne".to_string()];
        let (k, n) = kinds_of(&[1.0, 0.0], &labels);
        assert_eq!((k, n), (vec![1, 0], labels.to_vec()));
    }
}
