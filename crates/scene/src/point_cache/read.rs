//! A snapshot's values read into columns and checked, value by value: positions, radii and
//! velocities finite (and within the range of 32-bit floats), radii >= 0, colours in range,
//! ids whole numbers, image flags whole numbers, colour values finite. A bad value is an
//! error naming the point (its index in the snapshot, from 0).

use std::slice::IterMut;

use glam::DVec3;

use super::columns::ColumnMap;
use super::table::Rows;
use crate::sim::cell::Cell;
use crate::sim::{ReadError, Snapshot};
use raytrace_core::pages::{self, room};
use raytrace_core::points::PointCacheDesc;

/// Largest magnitude of a coordinate, radius or velocity: the range of the 32-bit floats
/// frames are stored in, as for the scene file's numbers.
pub(super) const MAX_VALUE: f64 = f32::MAX as f64;

/// The magnitude ids stay below: 2^53. Every whole number below it is exact as the `f64`
/// values ids are read through, and 2^53 itself is not told apart, as 2^53 + 1 reads as it.
const ID_BOUND: f64 = (1u64 << 53) as f64;

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
/// a box). A periodic box must span a volume; a box periodic nowhere is not used, and may be
/// flat (a LAMMPS `ff` box `5 5`, an XYZ zero `Lattice=` with `pbc="F F F"`).
pub(super) fn cell_of(snap: &Snapshot, desc: &PointCacheDesc) -> Result<Option<Cell>, ReadError> {
    let cell = match (snap.cell.as_deref().copied(), desc.periodic) {
        (None, Some(true)) => {
            return Err(ReadError::Bad(
                "periodic = true, and the file gives no box (LAMMPS BOX BOUNDS, XYZ Lattice=)"
                    .into(),
            ));
        }
        (Some(c), Some(p)) => Some(Cell {
            periodic: [p; 3],
            ..c
        }),
        (c, _) => c,
    };
    match cell {
        Some(c) if c.any_periodic() && !c.spans_volume() => Err(ReadError::Bad(
            "the box is periodic and its edges span no volume (two are parallel, or one is zero)"
                .into(),
        )),
        c => Ok(c),
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
    let (slots, columns) = Slots::of(layout, want);
    let scaled = layout.placement.scaled();
    if scaled && slots.position.is_some() && cell.is_none() {
        return Err(ReadError::Bad(
            "positions are fractions of the box (xs ys zs), and the snapshot gives no box".into(),
        ));
    }
    let points = Points {
        slots,
        names,
        columns: &columns,
        fractions_of: cell.filter(|_| scaled),
        velocity_scale: desc.velocity_scale,
        value_count: layout.color_by.len(),
    };
    let (mut out, kind_values, labels) = match rows.part_rows(&columns) {
        // Each row's values in their places, the parts on every thread.
        Some(part_rows) => {
            let mut out = Read::filled(&slots, n);
            let mut kind_values = pages::filled(if slots.kind.is_some() { n } else { 0 }, 0.0);
            let parts = Columns::parts(&mut out, &mut kind_values, part_rows as usize, n);
            rows.read_in_parts(&columns, parts, |part, i, v| points.push(i, v, part))?;
            (out, kind_values, Vec::new())
        }
        // Each row's values pushed, in order.
        None => {
            let believed = rows.believed(count);
            let mut out = Read::with_room(&slots, believed);
            let mut kind_values: Vec<f64> = Vec::new();
            let mut grow = Columns::grow(&mut out, &mut kind_values);
            let labels = rows.read(&columns, |i, v| points.push(i, v, &mut grow))?;
            if believed < n {
                out.shrink_to_fit();
            }
            (out, kind_values, labels)
        }
    };
    if slots.kind.is_some() {
        (out.kinds, out.kind_names) = kinds_of(&kind_values, &labels);
    }
    Ok(out)
}

/// The range a colour column's values are written in.
#[derive(Clone, Copy, Debug)]
enum ColorRange {
    /// Fractions, 0 to 1.
    Unit,
    /// Whole numbers 0 to 255 (an integer column).
    Bytes,
}

impl ColorRange {
    /// `x` as a fraction of the range, and the range in words.
    fn fraction(self, x: f64) -> (f64, &'static str) {
        match self {
            ColorRange::Bytes => (x / 255.0, "0 to 255"),
            ColorRange::Unit => (x, "0 to 1"),
        }
    }
}

/// Where each quantity read is among the values a row gives (`None`: not read).
#[derive(Clone, Copy, Debug)]
struct Slots {
    position: Option<usize>,
    images: Option<usize>,
    velocity: Option<usize>,
    /// With the factor radii are multiplied by.
    radius: Option<(usize, f64)>,
    color: Option<(usize, ColorRange)>,
    id: Option<usize>,
    kind: Option<usize>,
    /// The `color_by` column's first component.
    values: Option<usize>,
}

impl Slots {
    /// The slots of what `want` asks for that `layout` has, and the columns to read (in the
    /// slots' order).
    fn of(layout: &ColumnMap, want: Wanted) -> (Slots, Vec<usize>) {
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
        let color = layout.color.and_then(|(k, int)| {
            let range = if int {
                ColorRange::Bytes
            } else {
                ColorRange::Unit
            };
            add(want.looks, &k).map(|s| (s, range))
        });
        let id = layout.id.and_then(|k| add(want.ids, &[k]));
        let kind = layout.kind.and_then(|k| add(want.looks, &[k]));
        let values = (!layout.color_by.is_empty())
            .then(|| add(want.values, &layout.color_by))
            .flatten();
        let slots = Slots {
            position,
            images,
            velocity,
            radius,
            color,
            id,
            kind,
            values,
        };
        (slots, columns)
    }
}

impl Read {
    /// Empty columns, with room for `believed` points in each that `slots` reads.
    fn with_room(slots: &Slots, believed: usize) -> Read {
        let with = |on: Option<usize>| if on.is_some() { believed } else { 0 };
        Read {
            centers: room(with(slots.position)),
            images: room(with(slots.images)),
            velocities: room(with(slots.velocity)),
            radii: room(with(slots.radius.map(|r| r.0))),
            colors: room(with(slots.color.map(|c| c.0))),
            ids: room(with(slots.id)),
            kinds: room(with(slots.kind)),
            kind_names: Vec::new(),
            values: room(with(slots.values)),
        }
    }

    /// Columns of `n` values each that `slots` reads (written in place by parts of the rows:
    /// [`Columns::parts`]), their memory written on every thread.
    fn filled(slots: &Slots, n: usize) -> Read {
        fn column<T: Default + Copy + Send + Sync>(on: Option<usize>, n: usize) -> Vec<T> {
            pages::filled(if on.is_some() { n } else { 0 }, T::default())
        }
        Read {
            centers: column(slots.position, n),
            images: column(slots.images, n),
            velocities: column(slots.velocity, n),
            radii: column(slots.radius.map(|r| r.0), n),
            colors: column(slots.color.map(|c| c.0), n),
            ids: column(slots.id, n),
            kinds: Vec::new(),
            kind_names: Vec::new(),
            values: column(slots.values, n),
        }
    }

    /// Gives back the room of columns grown as lines were read: they hold no more than
    /// their points.
    fn shrink_to_fit(&mut self) {
        self.centers.shrink_to_fit();
        self.images.shrink_to_fit();
        self.velocities.shrink_to_fit();
        self.radii.shrink_to_fit();
        self.colors.shrink_to_fit();
        self.ids.shrink_to_fit();
        self.values.shrink_to_fit();
    }
}

/// A snapshot's rows made points: each quantity read from its slots, checked.
struct Points<'a> {
    slots: Slots,
    /// The file's columns' names, in messages.
    names: &'a [String],
    /// The file's column of each value a row gives.
    columns: &'a [usize],
    /// The box when positions are fractions of it.
    fractions_of: Option<&'a Cell>,
    velocity_scale: f64,
    /// The `color_by` column's number of components.
    value_count: usize,
}

impl Points<'_> {
    /// The name of the column of a row's value `k`.
    fn name(&self, k: usize) -> &str {
        self.names[self.columns[k]].as_str()
    }

    /// Gives point `i` (its row's values `v`) to `out`.
    fn push<M: Mode>(&self, i: u64, v: &[f64], out: &mut Columns<'_, M>) -> Result<(), String> {
        let s = self.slots;
        if let Some(k) = s.position {
            out.centers.put(self.center(i, v, k)?);
        }
        if let Some(k) = s.images {
            out.images.put(self.image_flags(i, v, k)?);
        }
        if let Some(k) = s.velocity {
            out.velocities.put(self.velocity(i, v, k)?);
        }
        if let Some((k, factor)) = s.radius {
            out.radii.put(self.radius(i, v, k, factor)?);
        }
        if let Some((k, range)) = s.color {
            out.colors.put(self.color(i, v, k, range)?);
        }
        if let Some(k) = s.id {
            out.ids.put(whole_id(i, v[k])?);
        }
        if let Some(k) = s.kind {
            out.kinds.put(v[k]);
        }
        if let Some(k) = s.values {
            out.values.put(self.value(i, v, k)?);
        }
        Ok(())
    }

    /// Point `i`'s position (values `k..k + 3`), made cartesian where it is fractions of
    /// the box.
    fn center(&self, i: u64, v: &[f64], k: usize) -> Result<DVec3, String> {
        let p = DVec3::new(
            finite(i, self.name(k), v[k])?,
            finite(i, self.name(k + 1), v[k + 1])?,
            finite(i, self.name(k + 2), v[k + 2])?,
        );
        Ok(match self.fractions_of {
            Some(c) => c.cartesian(p),
            None => p,
        })
    }

    /// Point `i`'s image flags (values `k..k + 3`): whole numbers of boxes.
    fn image_flags(&self, i: u64, v: &[f64], k: usize) -> Result<[i32; 3], String> {
        let mut flags = [0i32; 3];
        for (j, f) in flags.iter_mut().enumerate() {
            let x = v[k + j];
            if x.fract() != 0.0 || !(i32::MIN as f64..=i32::MAX as f64).contains(&x) {
                return Err(format!(
                    "point {i}: {} is {x}, not a whole number of boxes",
                    self.name(k + j)
                ));
            }
            *f = x as i32;
        }
        Ok(flags)
    }

    /// Point `i`'s velocity (values `k..k + 3`) times the cache's `velocity_scale`.
    fn velocity(&self, i: u64, v: &[f64], k: usize) -> Result<DVec3, String> {
        let mut u = [0.0; 3];
        for (j, x) in u.iter_mut().enumerate() {
            let name = self.name(k + j);
            *x = finite(i, name, finite(i, name, v[k + j])? * self.velocity_scale)?;
        }
        Ok(DVec3::from_array(u))
    }

    /// Point `i`'s radius: value `k` times `factor`, at least 0.
    fn radius(&self, i: u64, v: &[f64], k: usize, factor: f64) -> Result<f64, String> {
        let r = finite(i, self.name(k), v[k])? * factor;
        if r < 0.0 {
            return Err(format!(
                "point {i}: {} is {}; a radius must be >= 0",
                self.name(k),
                v[k]
            ));
        }
        Ok(r)
    }

    /// Point `i`'s colour (values `k..k + 3`, written in `range`) as fractions 0 to 1.
    fn color(&self, i: u64, v: &[f64], k: usize, range: ColorRange) -> Result<[f32; 3], String> {
        let mut c = [0f32; 3];
        for j in 0..3 {
            let x = v[k + j];
            let (scaled, words) = range.fraction(x);
            if !(0.0..=1.0).contains(&scaled) {
                return Err(format!(
                    "point {i}: {} is {x}, outside {words}",
                    self.name(k + j)
                ));
            }
            c[j] = scaled as f32;
        }
        Ok(c)
    }

    /// Point `i`'s `color_by` value (from value `k`): the column's, or the length of its
    /// components; finite.
    fn value(&self, i: u64, v: &[f64], k: usize) -> Result<f64, String> {
        let x = if self.value_count == 1 {
            v[k]
        } else {
            v[k..k + self.value_count]
                .iter()
                .map(|x| x * x)
                .sum::<f64>()
                .sqrt()
        };
        if !x.is_finite() {
            return Err(format!(
                "point {i}: {} is {x}, not a finite number (it is coloured by)",
                self.name(k)
            ));
        }
        Ok(x)
    }
}

/// A column a row's value goes to.
trait Put<T> {
    fn put(&mut self, x: T);
}

/// Rows read in order: a value pushed onto its column's end.
impl<T> Put<T> for &mut Vec<T> {
    fn put(&mut self, x: T) {
        self.push(x);
    }
}

/// Rows read in parts: a value written at its row's place in its column.
impl<T> Put<T> for IterMut<'_, T> {
    fn put(&mut self, x: T) {
        *self.next().expect("a place for each row of a part") = x;
    }
}

/// How a read's rows reach their columns: [`Grow`] or [`Place`].
trait Mode {
    type Column<'a, T: 'a>: Put<T>;
}

/// Rows read in order, onto the ends of columns that grow.
struct Grow;

impl Mode for Grow {
    type Column<'a, T: 'a> = &'a mut Vec<T>;
}

/// Rows read in parts, each part's rows at their places in columns as long as the snapshot.
struct Place;

impl Mode for Place {
    type Column<'a, T: 'a> = IterMut<'a, T>;
}

/// Where the quantities of a row go (see [`Slots`]), each quantity read given once a row (a
/// column not read, empty, is given nothing).
struct Columns<'a, M: Mode> {
    centers: M::Column<'a, DVec3>,
    images: M::Column<'a, [i32; 3]>,
    velocities: M::Column<'a, DVec3>,
    radii: M::Column<'a, f64>,
    colors: M::Column<'a, [f32; 3]>,
    ids: M::Column<'a, i64>,
    /// The types' values, as written (made indices into the types after the reading).
    kinds: M::Column<'a, f64>,
    values: M::Column<'a, f64>,
}

impl<'a> Columns<'a, Grow> {
    /// The columns of `read`, and the types' values `kinds`, to push rows onto.
    fn grow(read: &'a mut Read, kinds: &'a mut Vec<f64>) -> Self {
        Columns {
            centers: &mut read.centers,
            images: &mut read.images,
            velocities: &mut read.velocities,
            radii: &mut read.radii,
            colors: &mut read.colors,
            ids: &mut read.ids,
            kinds,
            values: &mut read.values,
        }
    }
}

impl<'a> Columns<'a, Place> {
    /// The parts of `count` rows, `part_rows` each (the last fewer), over the columns of
    /// `read` and the types' values `kinds` (each `count` long, or empty where not read).
    fn parts(
        read: &'a mut Read,
        kinds: &'a mut [f64],
        part_rows: usize,
        count: usize,
    ) -> Vec<Self> {
        let parts = count.div_ceil(part_rows);
        fn split<T>(
            column: &mut [T],
            rows: usize,
            parts: usize,
        ) -> std::vec::IntoIter<IterMut<'_, T>> {
            let mut chunks = column.chunks_mut(rows);
            let places: Vec<IterMut<'_, T>> = (0..parts)
                .map(|_| chunks.next().unwrap_or_default().iter_mut())
                .collect();
            places.into_iter()
        }
        let mut centers = split(&mut read.centers, part_rows, parts);
        let mut images = split(&mut read.images, part_rows, parts);
        let mut velocities = split(&mut read.velocities, part_rows, parts);
        let mut radii = split(&mut read.radii, part_rows, parts);
        let mut colors = split(&mut read.colors, part_rows, parts);
        let mut ids = split(&mut read.ids, part_rows, parts);
        let mut kinds = split(kinds, part_rows, parts);
        let mut values = split(&mut read.values, part_rows, parts);
        let mut next = || {
            Some(Columns {
                centers: centers.next()?,
                images: images.next()?,
                velocities: velocities.next()?,
                radii: radii.next()?,
                colors: colors.next()?,
                ids: ids.next()?,
                kinds: kinds.next()?,
                values: values.next()?,
            })
        };
        std::iter::from_fn(&mut next).take(parts).collect()
    }
}

/// Point `i`'s id `x` as a whole number, told apart from others (below 2^53 in magnitude).
fn whole_id(i: u64, x: f64) -> Result<i64, String> {
    if x.fract() != 0.0 || !x.is_finite() {
        return Err(format!("point {i}: id is {x}, not a whole number"));
    }
    if x.abs() >= ID_BOUND {
        return Err(format!(
            "point {i}: id is {x:e}, not below the 2^53 that ids are told apart to (2^53 + 1 \
             reads as 2^53)"
        ));
    }
    Ok(x as i64)
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
    fn ids_are_told_apart_below_2_to_the_53() {
        let id = |text: &str| whole_id(7, text.parse().unwrap());
        assert_eq!(id("9007199254740991"), Ok((1 << 53) - 1));
        assert_eq!(id("-9007199254740991"), Ok(1 - (1 << 53)));
        // 2^53 + 1 reads as 2^53: neither is told apart from the other, so both are refused,
        // not taken for one id held twice.
        for text in ["9007199254740992", "9007199254740993", "-9007199254740993"] {
            let e = id(text).unwrap_err();
            assert!(
                e.starts_with("point 7: id is ") && e.contains("2^53"),
                "{e}"
            );
        }
        assert!(id("1.5").unwrap_err().contains("not a whole number"));
    }

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
