//! Point caches read for a frame: the files a frame needs, their points read from PLY
//! ([`crate::ply`]) into the columns of a [`PointSet`] and checked, and their motion during the
//! frame (the file's velocities, or the line to the same `id`'s position in the next frame's
//! file). `check` and `render` survey every file of the frames they will render before
//! anything renders ([`survey_frame`]); a frame's points are read when it renders
//! ([`read_frame`]).
//!
//! Attribute names (element `vertex`): position `x`, `y`, `z` (required); radius `radius` or
//! `pscale`; velocity `vx`, `vy`, `vz` or `velocity_x`, `velocity_y`, `velocity_z`; colour
//! `red`, `green`, `blue` or `r`, `g`, `b` (an integer type on the 0 to 255 scale, a float
//! type from 0 to 1); identity `id`.
//!
//! Time: a sequence's file for frame `n` holds the points at frame `n`'s nominal time; a
//! single file (no `#`) holds them at time 0 for every frame.

use std::path::{Path, PathBuf};

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{Error, elide_path};
use crate::ply::{PlyError, PlyFile};
use crate::points::{FramePoints, PointCacheDesc, PointMotion, PointSet};
use crate::scene::Scene;

/// Most spheres and points a frame may hold: what one hierarchy indexes (2^28 primitives).
pub const MAX_FRAME_SPHERES: u64 = 1 << 28;

/// Largest magnitude of a coordinate, radius or velocity: the range of the 32-bit floats
/// frames are stored in, as for the scene file's numbers.
const MAX_VALUE: f64 = f32::MAX as f64;

/// The file of cache `desc` for `frame`: its sequence's, or its single file.
pub fn frame_file(desc: &PointCacheDesc, frame: u32) -> PathBuf {
    if desc.is_sequence() {
        crate::path_pattern::frame_path(&desc.file, frame)
    } else {
        PathBuf::from(&desc.file)
    }
}

/// Where a cache's attributes are among its vertex element's properties.
#[derive(Clone, Debug)]
struct Layout {
    /// The vertex element's index and count.
    element: usize,
    count: u64,
    position: [usize; 3],
    radius: Option<(usize, &'static str)>,
    velocity: Option<[usize; 3]>,
    /// The properties and whether they are integers (0 to 255).
    color: Option<([usize; 3], [&'static str; 3], bool)>,
    id: Option<usize>,
}

/// A group of properties found: their indices and names.
type Group<const N: usize> = ([usize; N], [&'static str; N]);

/// The first group of `names` whose properties are all present; a group partly present is an
/// error. `None` when none is there.
fn group<const N: usize>(
    e: &crate::ply::Element,
    groups: &[[&'static str; N]],
) -> Result<Option<Group<N>>, String> {
    for names in groups {
        let found: Vec<Option<usize>> = names.iter().map(|n| e.property(n)).collect();
        if found.iter().all(Option::is_some) {
            let mut at = [0; N];
            for (a, f) in at.iter_mut().zip(&found) {
                *a = f.expect("present");
            }
            return Ok(Some((at, *names)));
        }
        if let Some(k) = found.iter().position(Option::is_some) {
            let missing: Vec<&str> = names
                .iter()
                .zip(&found)
                .filter(|(_, f)| f.is_none())
                .map(|(n, _)| *n)
                .collect();
            return Err(format!(
                "the vertex element has {} but not {}",
                names[k],
                missing.join(", ")
            ));
        }
    }
    Ok(None)
}

/// The attributes of `file`'s vertex element that cache `desc` needs.
fn layout(file: &PlyFile, desc: &PointCacheDesc) -> Result<Layout, String> {
    let header = file.header();
    let Some((element, e)) = header.element("vertex") else {
        return Err("no vertex element: a point cache's points are its vertices".into());
    };
    let Some((position, _)) = group(e, &[["x", "y", "z"]])? else {
        return Err("the vertex element has no x, y, z properties (the points' positions)".into());
    };
    let radius = group(e, &[["radius"], ["pscale"]])?.map(|(p, n)| (p[0], n[0]));
    if radius.is_none() && desc.radius.is_none() {
        return Err(
            "no radius or pscale property, and the [[points]] table gives no radius".into(),
        );
    }
    let velocity = group(
        e,
        &[
            ["vx", "vy", "vz"],
            ["velocity_x", "velocity_y", "velocity_z"],
        ],
    )?
    .map(|v| v.0);
    let color = group(e, &[["red", "green", "blue"], ["r", "g", "b"]])?.map(|(p, n)| {
        let integer = p.iter().any(|&k| match e.properties[k].kind {
            crate::ply::Kind::Scalar(s) => s.is_integer(),
            crate::ply::Kind::List { .. } => false,
        });
        (p, n, integer)
    });
    let id = e.property("id");
    if desc.motion == Some(PointMotion::Velocity) && velocity.is_none() {
        return Err("motion = \"velocity\", but the vertex element has no vx, vy, vz (or velocity_x, velocity_y, velocity_z) properties".into());
    }
    if desc.motion == Some(PointMotion::Interpolate) && id.is_none() {
        return Err(
            "motion = \"interpolate\" matches points by id, and the vertex element has no id property"
                .into(),
        );
    }
    // Every property read must be a number, not a list.
    let used = position
        .iter()
        .chain(radius.iter().map(|r| &r.0))
        .chain(velocity.iter().flatten())
        .chain(color.iter().flat_map(|c| c.0.iter()))
        .chain(id.iter());
    for &k in used {
        let p = &e.properties[k];
        if let crate::ply::Kind::List { .. } = p.kind {
            return Err(format!(
                "property {} is a list; a single number was expected",
                p.name
            ));
        }
    }
    Ok(Layout {
        element,
        count: e.count,
        position,
        radius,
        velocity,
        color,
        id,
    })
}

/// A cache's motion in a file with this layout: its own, or velocity where the file has
/// velocities, else still.
fn motion_of(desc: &PointCacheDesc, layout: &Layout) -> PointMotion {
    desc.motion.unwrap_or(if layout.velocity.is_some() {
        PointMotion::Velocity
    } else {
        PointMotion::Still
    })
}

/// A message about cache `index` of `scene` in `frame`'s file `path`.
fn about(scene: &Scene, index: usize, frame: u32, path: &Path, what: &str) -> String {
    format!(
        "{}: points[{index}]: frame {frame}: {}: {what}",
        elide_path(&scene.source),
        elide_path(path)
    )
}

/// Opens `path` and finds its layout, with errors worded for `scene`.
fn open(scene: &Scene, index: usize, frame: u32, path: &Path) -> Result<(PlyFile, Layout), Error> {
    let desc = &scene.points[index];
    let file = PlyFile::open(path).map_err(|e| error(scene, index, frame, path, e))?;
    let layout =
        layout(&file, desc).map_err(|m| Error::Scene(about(scene, index, frame, path, &m)))?;
    if layout.count > MAX_FRAME_SPHERES {
        let m = format!(
            "{} points, more than the {MAX_FRAME_SPHERES} a frame can hold",
            layout.count
        );
        return Err(Error::Scene(about(scene, index, frame, path, &m)));
    }
    Ok((file, layout))
}

fn error(scene: &Scene, index: usize, frame: u32, path: &Path, e: PlyError) -> Error {
    match e {
        PlyError::Bad(m) => Error::Scene(about(scene, index, frame, path, &m)),
        PlyError::Io(source) => Error::io(path, source),
    }
}

/// The next frame's file of an interpolated sequence, when frame `frame` needs it: when the
/// next frame is one of the shot's, or its file exists (past the shot's end, the points of
/// the last frame move by their velocity, as at the end of a simulation).
fn next_file(scene: &Scene, desc: &PointCacheDesc, frame: u32) -> Option<(u32, PathBuf)> {
    if desc.motion != Some(PointMotion::Interpolate) {
        return None;
    }
    let next = frame.checked_add(1)?;
    let path = frame_file(desc, next);
    (scene.shot.contains_frame(next) || path.exists()).then_some((next, path))
}

/// Checks, before anything renders, every file frame `frame` of `scene` reads (its own of
/// each cache, and with `interpolate` the next frame's): each is a regular PLY file whose
/// header has the attributes the cache needs and whose size holds its points. Returns the
/// frame's number of points. The values themselves are checked as a frame is read
/// ([`read_frame`]).
pub fn survey_frame(scene: &Scene, frame: u32) -> Result<u64, Error> {
    let mut total = 0;
    for (index, desc) in scene.points.iter().enumerate() {
        let path = frame_file(desc, frame);
        let (_, layout) = open(scene, index, frame, &path)?;
        total += layout.count;
        if let Some((next, path)) = next_file(scene, desc, frame) {
            open(scene, index, next, &path)?;
        }
    }
    check_total(scene, frame, total)?;
    Ok(total)
}

/// A frame may hold at most [`MAX_FRAME_SPHERES`] spheres and points.
fn check_total(scene: &Scene, frame: u32, points: u64) -> Result<(), Error> {
    let all = points + scene.spheres.len() as u64;
    if all > MAX_FRAME_SPHERES {
        return Err(Error::Scene(format!(
            "{}: frame {frame} holds {points} points and {} spheres, more than the {MAX_FRAME_SPHERES} a frame can hold",
            elide_path(&scene.source),
            scene.spheres.len()
        )));
    }
    Ok(())
}

/// Reads frame `frame`'s points of every cache of `scene`, checked: positions, radii and
/// velocities finite (and within the range of 32-bit floats), radii >= 0, colours in range,
/// ids whole numbers found once in a file. A bad value is an error naming the frame, the
/// file and the point's index.
pub fn read_frame(scene: &Scene, frame: u32) -> Result<FramePoints, Error> {
    let mut sets = Vec::with_capacity(scene.points.len());
    let mut total = 0;
    for index in 0..scene.points.len() {
        let set = read_set(scene, index, frame)?;
        total += set.len() as u64;
        check_total(scene, frame, total)?;
        sets.push(set);
    }
    Ok(FramePoints { sets })
}

/// One file's points, as read.
struct Read {
    centers: Vec<DVec3>,
    velocities: Vec<DVec3>,
    radii: Vec<f64>,
    colors: Vec<[f32; 3]>,
    ids: Vec<i64>,
}

/// Reads cache `index`'s points in `frame`.
fn read_set(scene: &Scene, index: usize, frame: u32) -> Result<PointSet, Error> {
    let desc = &scene.points[index];
    let path = frame_file(desc, frame);
    let (file, layout) = open(scene, index, frame, &path)?;
    check_total(scene, frame, layout.count)?;
    let motion = motion_of(desc, &layout);
    let interpolated = motion == PointMotion::Interpolate;
    let read = read_points(
        file,
        &layout,
        motion != PointMotion::Still,
        true,
        interpolated,
    )
    .map_err(|e| error(scene, index, frame, &path, e))?;
    let time = if desc.is_sequence() {
        scene.shot.frame_time(frame)
    } else {
        0.0
    };
    let mut velocities = read.velocities;
    if motion == PointMotion::Interpolate
        && let Some((next, next_path)) = next_file(scene, desc, frame)
    {
        let (next_ply, next_layout) = open(scene, index, next, &next_path)?;
        let later = read_points(next_ply, &next_layout, false, false, true)
            .map_err(|e| error(scene, index, next, &next_path, e))?;
        let dt = scene.shot.frame_time(next) - time;
        velocities = interpolate(&read.centers, &read.ids, velocities, &later, dt).map_err(
            |(which, m)| {
                let (f, p) = if which {
                    (next, &next_path)
                } else {
                    (frame, &path)
                };
                Error::Scene(about(scene, index, f, p, &m))
            },
        )?;
    }
    // A set where nothing moves keeps no velocities.
    if velocities.iter().all(|v| *v == DVec3::ZERO) {
        velocities = Vec::new();
    }
    Ok(PointSet {
        material: desc.material,
        time,
        centers: read.centers,
        velocities,
        radii: read.radii,
        radius: desc.radius.unwrap_or(0.0),
        colors: read.colors,
    })
}

/// The velocities of points `centers` (with `ids`) moving to the position of the point with
/// the same id in `later`, `dt` seconds on; a point without one keeps its velocity in
/// `velocities` (still if there are none). Errors: `(true, ..)` about the later file,
/// `(false, ..)` about this one.
fn interpolate(
    centers: &[DVec3],
    ids: &[i64],
    velocities: Vec<DVec3>,
    later: &Read,
    dt: f64,
) -> Result<Vec<DVec3>, (bool, String)> {
    let sorted = |ids: &[i64]| -> Result<Vec<(i64, u32)>, String> {
        let mut s: Vec<(i64, u32)> = ids
            .iter()
            .enumerate()
            .map(|(k, &id)| (id, k as u32))
            .collect();
        s.par_sort_unstable();
        match s.windows(2).find(|w| w[0].0 == w[1].0) {
            Some(w) => Err(format!(
                "id {} is held by two points ({} and {}): ids must be unique to match points",
                w[0].0, w[0].1, w[1].1
            )),
            None => Ok(s),
        }
    };
    sorted(ids).map_err(|m| (false, m))?;
    let next = sorted(&later.ids).map_err(|m| (true, m))?;
    let mut out: Vec<DVec3> = vec![DVec3::ZERO; centers.len()];
    out.par_iter_mut().enumerate().try_for_each(|(i, v)| {
        *v = match next.binary_search_by_key(&ids[i], |e| e.0) {
            Ok(k) => {
                let q = later.centers[next[k].1 as usize];
                // As a keyframed sphere's velocity between its keys.
                let u = (q - centers[i]) / dt;
                if !u.is_finite() || u.abs().max_element() > MAX_VALUE {
                    return Err((
                        false,
                        format!(
                            "point {i} (id {}) moves from {} to {} in {dt} s: its velocity is out of range",
                            ids[i], centers[i], q
                        ),
                    ));
                }
                u
            }
            Err(_) => velocities.get(i).copied().unwrap_or(DVec3::ZERO),
        };
        Ok(())
    })?;
    Ok(out)
}

/// Reads the points of an open file with `layout`: positions, and velocities when `moving`,
/// radii and colours when `all`, ids when `ids` (where there are), checking every value.
fn read_points(
    file: PlyFile,
    layout: &Layout,
    moving: bool,
    all: bool,
    ids: bool,
) -> Result<Read, PlyError> {
    let n = layout.count as usize;
    let mut wanted: Vec<usize> = layout.position.to_vec();
    let mut names: Vec<&str> = vec!["x", "y", "z"];
    let velocity = layout.velocity.filter(|_| moving).map(|v| {
        wanted.extend(v);
        names.extend(["vx", "vy", "vz"]);
        wanted.len() - 3
    });
    let radius = layout.radius.filter(|_| all).map(|(k, name)| {
        wanted.push(k);
        names.push(name);
        wanted.len() - 1
    });
    let color = layout.color.filter(|_| all).map(|(k, n, integer)| {
        wanted.extend(k);
        names.extend(n);
        (wanted.len() - 3, integer)
    });
    let id = layout.id.filter(|_| ids).map(|k| {
        wanted.push(k);
        wanted.len() - 1
    });
    let with = |on: bool| if on { n } else { 0 };
    let mut read = Read {
        centers: Vec::with_capacity(n),
        velocities: Vec::with_capacity(with(velocity.is_some())),
        radii: Vec::with_capacity(with(radius.is_some())),
        colors: Vec::with_capacity(with(color.is_some())),
        ids: Vec::with_capacity(with(id.is_some())),
    };
    let element = layout.element;
    file.read_rows(element, &wanted, |i, v| {
        let finite = |k: usize, name: &str| -> Result<f64, String> {
            let x = v[k];
            if !x.is_finite() {
                Err(format!("point {i}: {name} is {x}, not a finite number"))
            } else if x.abs() > MAX_VALUE {
                Err(format!(
                    "point {i}: {name} is {x:e}, beyond the 3.4e38 of 32-bit floats"
                ))
            } else {
                Ok(x)
            }
        };
        read.centers.push(DVec3::new(
            finite(0, names[0])?,
            finite(1, names[1])?,
            finite(2, names[2])?,
        ));
        if let Some(k) = velocity {
            read.velocities.push(DVec3::new(
                finite(k, names[k])?,
                finite(k + 1, names[k + 1])?,
                finite(k + 2, names[k + 2])?,
            ));
        }
        if let Some(k) = radius {
            let r = finite(k, names[k])?;
            if r < 0.0 {
                return Err(format!(
                    "point {i}: {} is {r}; a radius must be >= 0",
                    names[k]
                ));
            }
            read.radii.push(r);
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
                        names[k + j]
                    ));
                }
                c[j] = scaled as f32;
            }
            read.colors.push(c);
        }
        if let Some(k) = id {
            read.ids
                .push(crate::points::point_id(v[k]).map_err(|m| format!("point {i}: {m}"))?);
        }
        Ok(())
    })?;
    Ok(read)
}

/// The figures `check` reports of one frame's points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameSurvey {
    /// Points in the frame, over every cache.
    pub points: u64,
    /// Of them, those that move during the frame's interval.
    pub moving: u64,
}

/// Reads and checks frame `frame`'s points ([`read_frame`]) and counts them.
pub fn check_frame(scene: &Scene, frame: u32) -> Result<FrameSurvey, Error> {
    survey_frame(scene, frame)?;
    let points = read_frame(scene, frame)?;
    let interval = scene.shot.interval(frame);
    let moving = points
        .sets
        .iter()
        .map(|s| {
            (0..s.len())
                .filter(|&i| s.prepare(i, interval).velocity != DVec3::ZERO)
                .count() as u64
        })
        .sum();
    Ok(FrameSurvey {
        points: points.len() as u64,
        moving,
    })
}
