//! Point caches: the spheres a simulation wrote, as the scene describes a cache
//! ([`PointCacheDesc`]) and as one frame holds its points ([`PointSet`], [`FramePoints`]):
//! columns, one array per attribute, not a record per point.
//!
//! A point is a sphere whose centre moves on a line during the frame: `P + v (t - time)`,
//! with `P` its position at the set's `time` and `v` its velocity (from the cache's velocity
//! attributes, or from its next position in the next frame's file: see `point_cache`). A
//! point is prepared for a frame's interval exactly as a `[[sphere]]` with `velocity` is
//! ([`crate::motion::Motion::prepare`]), so the two render the same bits.
//!
//! The columns keep positions, velocities and radii as `f32` (28 bytes a point rather than
//! 56): the precision of the files that simulations write (PLY `float`, VTK `Float32`), and of
//! a frame's `f32` pixels. A point renders as the sphere with those `f32` values, computed on
//! in `f64` from there as a `[[sphere]]` is.

use glam::{DVec3, Vec3};

use crate::shutter::Interval;

/// How a cache's points move during a frame (`[[points]] motion`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PointMotion {
    /// `P + v (t - t_frame)`, with `v` the file's velocity attributes.
    Velocity,
    /// On the line from this frame's position to the next frame's file's position of the
    /// point with the same `id`; a point without a match moves by its velocity, if the file
    /// has one, or stands still.
    Interpolate,
    /// Every point stands still.
    Still,
}

impl PointMotion {
    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        match self {
            PointMotion::Velocity => "velocity",
            PointMotion::Interpolate => "interpolate",
            PointMotion::Still => "none",
        }
    }
}

/// How a cache's file is read (`[[points]] format`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CacheFormat {
    Ply,
    /// LAMMPS text dumps, gzip or not.
    Lammps,
    /// VTK point data: legacy `.vtk`, XML `.vtu` and `.vtp`.
    Vtk,
    /// Extended XYZ.
    Xyz,
}

impl CacheFormat {
    /// Every format with its name in scene files.
    pub const ALL: [(&'static str, CacheFormat); 4] = [
        ("ply", CacheFormat::Ply),
        ("lammps", CacheFormat::Lammps),
        ("vtk", CacheFormat::Vtk),
        ("xyz", CacheFormat::Xyz),
    ];

    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        CacheFormat::ALL
            .iter()
            .find(|(_, f)| *f == self)
            .map_or("ply", |(n, _)| n)
    }

    /// The format of a file by its extension (a `.gz` after it is looked through): `.ply`,
    /// `.vtk`/`.vtu`/`.vtp`, `.xyz`/`.extxyz`; anything else is a LAMMPS dump.
    pub fn from_name(file: &str) -> CacheFormat {
        let lower = file.to_ascii_lowercase();
        let name = lower.strip_suffix(".gz").unwrap_or(&lower);
        let ext = name.rsplit_once('.').map_or("", |(_, e)| e);
        match ext {
            "ply" => CacheFormat::Ply,
            "vtk" | "vtu" | "vtp" => CacheFormat::Vtk,
            "xyz" | "extxyz" => CacheFormat::Xyz,
            _ => CacheFormat::Lammps,
        }
    }

    /// Whether a file of this format may hold several snapshots.
    pub fn has_snapshots(self) -> bool {
        matches!(self, CacheFormat::Lammps | CacheFormat::Xyz)
    }
}

/// When a file's snapshots are (`[[points]] snapshots`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SnapshotTime {
    /// The n-th snapshot is the shot's n-th frame, at its nominal time.
    Frames,
    /// A snapshot is at `start_time + TIMESTEP * dt` seconds.
    Timestep { dt: f64 },
}

/// Points coloured by a column through a colour map (`color_by`, `colormap`,
/// `color_range`).
#[derive(Clone, Debug, PartialEq)]
pub struct ColorBy {
    /// The column's name (a vector's magnitude where it has several components).
    pub column: String,
    pub map: crate::colormap::Colormap,
    /// The values at the map's ends; `None`: the least and greatest over the shot's
    /// selected frames, found before any frame renders.
    pub range: Option<[f64; 2]>,
}

/// What a `types` entry gives the points of one type (or species).
#[derive(Clone, Debug, PartialEq)]
pub struct TypeLook {
    /// The value of the `type` (or `species`) column, as written (`"1"`, `"Ar"`).
    pub key: String,
    pub radius: Option<f64>,
    /// Index into [`crate::scene::Scene::materials`].
    pub material: Option<u32>,
}

/// A `[[points]]` table, validated: where the cache is and how its points are drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct PointCacheDesc {
    /// The file, or a sequence: each run of `#` is the zero-padded frame number; or a series
    /// of one file a snapshot, a `*` standing for any number (the timestep, as LAMMPS names
    /// them). Relative paths have been joined to the scene file's folder.
    pub file: crate::path_pattern::FramePattern,
    pub format: CacheFormat,
    /// Index into [`crate::scene::Scene::materials`]. With `color_by`, a copy of the table's
    /// material with a white albedo, which the map's colour multiplies.
    pub material: u32,
    /// Radius of points without a radius attribute (> 0); `None`: the cache must have one.
    pub radius: Option<f64>,
    /// `None`: velocity where the cache has velocities, else still.
    pub motion: Option<PointMotion>,
    pub snapshots: SnapshotTime,
    /// Multiplies the file's velocities into units per second of shot time.
    pub velocity_scale: f64,
    /// `None`: periodic as the file says; `Some(false)`: the box is ignored; `Some(true)`:
    /// every direction of the file's box is periodic.
    pub periodic: Option<bool>,
    pub color_by: Option<ColorBy>,
    /// A column holding radii (halved when it is named `diameter`).
    pub radius_by: Option<String>,
    /// Per type (or species): radius and material (materials white with `color_by`).
    pub types: Vec<TypeLook>,
}

impl PointCacheDesc {
    /// Whether the file is a sequence, one file per frame (its name has a `#`).
    pub fn is_sequence(&self) -> bool {
        self.file.contains('#')
    }

    /// Whether the file is a series of one file a snapshot (its name has a `*`).
    pub fn is_series(&self) -> bool {
        self.file.contains('*')
    }
}

/// One frame's points of one cache, as columns.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointSet {
    /// Index into [`crate::scene::Scene::materials`].
    pub material: u32,
    /// The time at which the points are at `centers` (seconds).
    pub time: f64,
    /// Positions at `time`.
    pub centers: Vec<Vec3>,
    /// Velocities, units per second, one per point; empty when no point moves.
    pub velocities: Vec<Vec3>,
    /// Radii, one per point (>= 0); empty when every point has [`PointSet::radius`].
    pub radii: Vec<f32>,
    /// The radius of every point when `radii` is empty.
    pub radius: f32,
    /// Colours multiplying the material's albedo, one per point, each component in [0, 1];
    /// empty when the cache has none.
    pub colors: Vec<[f32; 3]>,
}

/// A point prepared for one frame's interval: its centre at the interval's opening and its
/// velocity (zero when it does not move during the interval).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreparedPoint {
    pub start: DVec3,
    pub velocity: DVec3,
    pub radius: f64,
}

impl PointSet {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.centers.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.centers.is_empty()
    }

    /// The velocity of point `i`.
    #[inline]
    pub fn velocity(&self, i: usize) -> DVec3 {
        self.velocities.get(i).map_or(DVec3::ZERO, |v| v.as_dvec3())
    }

    /// The radius of point `i`.
    #[inline]
    pub(crate) fn radius_of(&self, i: usize) -> f64 {
        f64::from(self.radii.get(i).copied().unwrap_or(self.radius))
    }

    /// The centre of point `i` at time `t`: `P + v (t - time)`.
    #[inline]
    pub fn at(&self, i: usize, t: f64) -> DVec3 {
        self.centers[i].as_dvec3() + self.velocity(i) * (t - self.time)
    }

    /// Point `i` prepared for `interval`, as [`crate::motion::Motion::prepare`] prepares a
    /// sphere with a velocity: fixed at its position at the opening when it does not move
    /// or the interval is an instant, else a line from there.
    #[inline]
    pub fn prepare(&self, i: usize, interval: Interval) -> PreparedPoint {
        let v = self.velocity(i);
        let start = self.at(i, interval.open);
        let moves = !interval.is_instant() && v != DVec3::ZERO;
        PreparedPoint {
            start,
            velocity: if moves { v } else { DVec3::ZERO },
            radius: self.radius_of(i),
        }
    }
}

impl PreparedPoint {}

#[cfg(test)]
impl PreparedPoint {
    /// The point's boxes at the opening and the closing of `interval` (the one it was
    /// prepared for), the same as [`crate::sphere::PreparedSphere::shutter_boxes`] gives a
    /// sphere on the same line.
    pub(crate) fn shutter_boxes(
        &self,
        interval: Interval,
    ) -> (crate::aabb::Aabb, crate::aabb::Aabb) {
        use crate::aabb::Aabb;
        let r = self.radius;
        let open = Aabb::point(self.start).grow(r);
        let close = if self.velocity == DVec3::ZERO {
            open
        } else {
            Aabb::point(self.start + self.velocity * (interval.close - interval.open)).grow(r)
        };
        crate::sphere::pad_for_interpolation(open, close)
    }
}

/// Every cache's points in one frame, in the order of the scene's `[[points]]` tables. A
/// point is numbered over all of them: the first set's first, then on.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FramePoints {
    pub sets: Vec<PointSet>,
}

impl FramePoints {
    /// No points (a scene without point caches).
    pub fn none() -> FramePoints {
        FramePoints::default()
    }

    /// Number of points, over every set.
    pub fn len(&self) -> usize {
        self.sets.iter().map(PointSet::len).sum()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.sets.iter().all(PointSet::is_empty)
    }

    /// The set of point `k` (numbered over every set) and its index there; `None` past the
    /// last point.
    #[inline]
    pub(crate) fn locate(&self, mut k: usize) -> Option<(&PointSet, usize)> {
        for s in &self.sets {
            if k < s.len() {
                return Some((s, k));
            }
            k -= s.len();
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::{FrameMotion, Motion};
    use crate::sphere::SphereDesc;

    /// A point of a set at time 0 is prepared, and boxed, as the sphere with the same centre,
    /// velocity and radius (the point's `f32` values): the same bits, for still and moving
    /// points and instants.
    #[test]
    fn a_point_is_prepared_as_a_sphere_with_its_velocity() {
        let mut rng = crate::rng::Pcg32::new(3, 9);
        let mut r = || (rng.next_f64() * 2.0 - 1.0) as f32;
        for _ in 0..500 {
            let p = Vec3::new(r(), r(), r()) * 100.0;
            let v = if r() > 0.5 {
                Vec3::ZERO
            } else {
                Vec3::new(r(), r(), r()) * 30.0
            };
            let radius = r().abs() + 0.01;
            let set = PointSet {
                centers: vec![p],
                velocities: vec![v],
                radius,
                ..PointSet::default()
            };
            let sphere = SphereDesc {
                motion: Motion::Velocity {
                    origin: p.as_dvec3(),
                    velocity: v.as_dvec3(),
                },
                radius: radius.into(),
                material: 0,
            };
            let open = f64::from(r()) * 10.0;
            for close in [open, open + f64::from(r().abs()) * 0.1] {
                let interval = Interval { open, close };
                let point = set.prepare(0, interval);
                let prepared = sphere.prepare(interval);
                let (start, velocity) = match prepared.motion {
                    FrameMotion::Fixed(c) => (c, DVec3::ZERO),
                    FrameMotion::Linear {
                        start, velocity, ..
                    } => (start, velocity),
                    _ => unreachable!(),
                };
                assert_eq!((point.start, point.velocity), (start, velocity));
                assert_eq!(
                    point.shutter_boxes(interval),
                    prepared.shutter_boxes(interval)
                );
            }
        }
    }

    #[test]
    fn points_are_numbered_over_every_set() {
        let set = |n: usize| PointSet {
            centers: vec![Vec3::ZERO; n],
            ..PointSet::default()
        };
        let points = FramePoints {
            sets: vec![set(2), set(0), set(3)],
        };
        assert_eq!(points.len(), 5);
        let at = |k| points.locate(k).map(|(s, i)| (s.len(), i));
        assert_eq!(at(0), Some((2, 0)));
        assert_eq!(at(1), Some((2, 1)));
        assert_eq!(at(2), Some((3, 0)));
        assert_eq!(at(4), Some((3, 2)));
        assert_eq!(at(5), None);
        assert!(FramePoints::none().is_empty());
    }
}
