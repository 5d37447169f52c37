//! How a snapshot's points move during a frame, and where they are drawn in a periodic box:
//! velocities towards the same id's position in the next snapshot (through the box's faces
//! by the image flags or unwrapped positions where the file has them, else by the nearest
//! image), and a point whose path crosses a periodic face drawn on each side of it.

use glam::DVec3;
use rayon::prelude::*;

use super::read::{MAX_VALUE, Read};
use crate::sim::cell::Cell;
use raytrace_core::points::{PointCacheDesc, PointMotion};
use raytrace_core::show::show_approx;
use raytrace_core::shutter::Interval;

/// Most whole boxes a point may cross along one edge during a frame's shutter: beyond it the
/// path would be drawn as more than two images of a streak.
const MAX_CROSSINGS: f64 = 1.0;

/// `ids` with their indices, sorted; an error names an id held twice.
pub(super) fn sorted_ids(ids: &[i64]) -> Result<Vec<(i64, u32)>, String> {
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
}

/// How the displacement from a point to its next position crosses a periodic box.
#[derive(Clone, Copy, Debug)]
pub(super) enum Crossing<'a> {
    /// No box, or positions that run on across its faces (unwrapped): as written.
    Direct,
    /// Wrapped positions with image flags: the flags' difference in whole boxes is added.
    Images(&'a Cell),
    /// Wrapped positions without flags: the nearest image.
    Nearest(&'a Cell),
}

/// The velocities of `own`'s points moving to the position of the point with the same id in
/// `next` (`next_ids` sorted, from [`sorted_ids`]) `dt` seconds on; a point without one
/// keeps its velocity (still if there are none).
pub(super) fn interpolate(
    own: &Read,
    next: &Read,
    next_ids: &[(i64, u32)],
    dt: f64,
    crossing: Crossing,
) -> Result<Vec<DVec3>, String> {
    let mut out: Vec<DVec3> = vec![DVec3::ZERO; own.centers.len()];
    out.par_iter_mut().enumerate().try_for_each(|(i, v)| {
        *v = match next_ids.binary_search_by_key(&own.ids[i], |e| e.0) {
            Ok(k) => {
                let j = next_ids[k].1 as usize;
                let (p, q) = (own.centers[i], next.centers[j]);
                let d = match crossing {
                    Crossing::Direct => q - p,
                    Crossing::Images(cell) => {
                        let (a, b) = (own.images[i], next.images[j]);
                        let n = DVec3::from_array(std::array::from_fn(|k| (b[k] - a[k]) as f64));
                        q - p + cell.shift(n)
                    }
                    Crossing::Nearest(cell) => cell.nearest_image(q - p),
                };
                // As a keyframed sphere's velocity between its keys.
                let u = d / dt;
                if !u.is_finite() || u.abs().max_element() > MAX_VALUE {
                    return Err(format!(
                        "point {i} (id {}) moves from {p} to {q} in {dt} s: its velocity is out of range",
                        own.ids[i]
                    ));
                }
                u
            }
            Err(_) => own.velocities.get(i).copied().unwrap_or(DVec3::ZERO),
        };
        Ok(())
    })?;
    Ok(out)
}

/// Checks that points moving at `velocities` travel at most [`MAX_CROSSINGS`] box edges
/// along each periodic edge of `cell` in one frame's `exposure` (seconds), so that each
/// path is drawn in at most two images of the box whatever its start: the one rule `check`
/// and `render` hold a snapshot's velocities (the file's, or those towards the next
/// snapshot) to. An error names the first point that travels further.
pub(super) fn paths_within_box(
    velocities: &[DVec3],
    exposure: f64,
    cell: &Cell,
) -> Result<(), String> {
    if !cell.any_periodic() || exposure == 0.0 {
        return Ok(());
    }
    let inverse = cell.edges.inverse();
    let too_far = |v: &DVec3| {
        let f = inverse * (*v * exposure);
        (0..3)
            // NaN is too far too.
            .find(|&k| cell.periodic[k] && (f[k].abs() > MAX_CROSSINGS || f[k].is_nan()))
            .map(|k| (k, f[k].abs()))
    };
    match velocities
        .par_iter()
        .enumerate()
        .find_first(|(_, v)| too_far(v).is_some())
    {
        None => Ok(()),
        Some((i, v)) => {
            let (k, edges) = too_far(v).expect("found");
            let [x, y, z] = v.to_array().map(show_approx);
            Err(format!(
                "point {i} moves {} box edges along edge {} in a frame's exposure of {} s (velocity {x}, {y}, {z}): a point may move at most one box edge a frame in a periodic box",
                show_approx(edges),
                ["a", "b", "c"][k],
                show_approx(exposure)
            ))
        }
    }
}

/// Holds the file's velocities of a snapshot (`read`, in box `cell`) to [`paths_within_box`]
/// where cache `desc` moves its points by them (any motion but `still`).
pub(super) fn file_velocities_within_box(
    read: &Read,
    cell: Option<&Cell>,
    desc: &PointCacheDesc,
    exposure: f64,
) -> Result<(), String> {
    match cell {
        Some(cell) if desc.motion != Some(PointMotion::Still) => {
            paths_within_box(&read.velocities, exposure, cell)
        }
        _ => Ok(()),
    }
}

/// Points (by index) with a shift.
pub(super) type Shifts = Vec<(usize, DVec3)>;

/// Where each point of a periodic box is drawn during `interval`: its path over the interval
/// is moved by whole box edges (along periodic directions) so that it starts inside the box,
/// and for each periodic face the path crosses, a copy shifted by the edge through that face
/// is drawn too (the part of the path beyond the face, seen entering through the opposite
/// one; with two faces crossed, the copy across both as well). Returns, per point, its shift
/// (`None` where it starts in the box) and the shifts of its copies; points are at `time`
/// at `centers`, moving by `velocities` (empty: still).
pub(super) fn images(
    centers: &[DVec3],
    velocities: &[DVec3],
    time: f64,
    interval: Interval,
    cell: &Cell,
) -> Result<(Shifts, Shifts), String> {
    let mut moved = Vec::new();
    let mut copies = Vec::new();
    let inverse = cell.edges.inverse();
    for (i, &p) in centers.iter().enumerate() {
        let v = velocities.get(i).copied().unwrap_or(DVec3::ZERO);
        let start = p + v * (interval.open - time);
        let end = p + v * (interval.close - time);
        let n = cell.edges_into_box(start);
        let shift = if n == DVec3::ZERO {
            DVec3::ZERO
        } else {
            cell.shift(n)
        };
        if shift != DVec3::ZERO {
            moved.push((i, shift));
        }
        if v == DVec3::ZERO {
            continue;
        }
        // The fractional coordinates of the path's end, from a start in [0, 1).
        let f = inverse * (end + shift - cell.origin);
        let mut cross = [0.0f64; 3];
        for k in 0..3 {
            if !cell.periodic[k] {
                continue;
            }
            let out = f[k].floor();
            if out.abs() > MAX_CROSSINGS {
                return Err(format!(
                    "point {i} crosses {} boxes along edge {} in one frame: its motion during the shutter is longer than the periodic box",
                    show_approx(out.abs()),
                    ["a", "b", "c"][k]
                ));
            }
            cross[k] = out;
        }
        // Every non-empty set of crossed faces: a copy shifted back through them.
        for mask in 1..8u8 {
            let n = DVec3::from_array(std::array::from_fn(|k| {
                if mask & (1 << k) != 0 { -cross[k] } else { 0.0 }
            }));
            let used = (0..3).all(|k| mask & (1 << k) == 0 || cross[k] != 0.0);
            if used {
                copies.push((i, shift + cell.shift(n)));
            }
        }
    }
    Ok((moved, copies))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat3;

    fn cube(periodic: [bool; 3]) -> Cell {
        Cell::new(
            DVec3::ZERO,
            DMat3::from_diagonal(DVec3::splat(10.0)),
            periodic,
        )
        .unwrap()
    }

    #[test]
    fn a_path_across_a_face_is_drawn_on_both_sides() {
        let cell = cube([true; 3]);
        let interval = Interval {
            open: 0.0,
            close: 1.0,
        };
        // Starts at x = 9.5 moving +1 a second: crosses x = 10; a copy 10 back.
        let (moved, copies) = images(
            &[DVec3::new(9.5, 5.0, 5.0)],
            &[DVec3::new(1.0, 0.0, 0.0)],
            0.0,
            interval,
            &cell,
        )
        .unwrap();
        assert!(moved.is_empty());
        assert_eq!(copies, vec![(0, DVec3::new(-10.0, 0.0, 0.0))]);
        // Starts outside (x = -0.5 at the opening, written at time 1 as 0.5 moving +1):
        // moved by +10, then crosses x = 10 on the way: a copy at -10 from there.
        let (moved, copies) = images(
            &[DVec3::new(0.5, 5.0, 5.0)],
            &[DVec3::new(1.0, 0.0, 0.0)],
            1.0,
            interval,
            &cell,
        )
        .unwrap();
        assert_eq!(moved, vec![(0, DVec3::new(10.0, 0.0, 0.0))]);
        assert_eq!(copies, vec![(0, DVec3::ZERO)]);
        // Through a corner: three copies (x, y, and both).
        let (_, copies) = images(
            &[DVec3::new(9.5, 0.5, 5.0)],
            &[DVec3::new(1.0, -1.0, 0.0)],
            0.0,
            interval,
            &cell,
        )
        .unwrap();
        let shifts: Vec<DVec3> = copies.iter().map(|c| c.1).collect();
        assert_eq!(
            shifts,
            [
                DVec3::new(-10.0, 0.0, 0.0),
                DVec3::new(0.0, 10.0, 0.0),
                DVec3::new(-10.0, 10.0, 0.0)
            ]
        );
        // Not periodic along x: no copy.
        let (_, copies) = images(
            &[DVec3::new(9.5, 5.0, 5.0)],
            &[DVec3::new(1.0, 0.0, 0.0)],
            0.0,
            interval,
            &cube([false, true, true]),
        )
        .unwrap();
        assert!(copies.is_empty());
        // Faster than a box a frame: refused.
        let e = images(
            &[DVec3::splat(5.0)],
            &[DVec3::new(16.0, 0.0, 0.0)],
            0.0,
            interval,
            &cell,
        );
        assert!(e.unwrap_err().contains("crosses 2 boxes along edge a"));
    }

    /// A path longer than one box edge in an exposure is refused whatever its start, in
    /// short numbers; one edge exactly, or any speed along an edge that is not periodic, is
    /// not.
    #[test]
    fn a_path_longer_than_a_box_edge_is_refused() {
        let cell = cube([true, true, false]);
        let ok = [DVec3::new(20.0, -20.0, 1e30)];
        assert_eq!(paths_within_box(&ok, 0.5, &cell), Ok(()));
        let fast = [DVec3::ZERO, DVec3::new(0.0, 1e30, 0.0)];
        assert_eq!(
            paths_within_box(&fast, 0.5, &cell).unwrap_err(),
            "point 1 moves 5e28 box edges along edge b in a frame's exposure of 0.5 s (velocity 0, 1e30, 0): a point may move at most one box edge a frame in a periodic box"
        );
        assert!(paths_within_box(&[DVec3::new(f64::NAN, 0.0, 0.0)], 0.5, &cell).is_err());
        assert_eq!(paths_within_box(&fast, 0.0, &cell), Ok(()));
        assert_eq!(paths_within_box(&fast, 0.5, &cube([false; 3])), Ok(()));
    }

    #[test]
    fn interpolation_follows_flags_or_the_nearest_image() {
        let cell = cube([true; 3]);
        let read = |x: f64, image: i32| Read {
            centers: vec![DVec3::new(x, 5.0, 5.0)],
            images: vec![[image, 0, 0]],
            ids: vec![7],
            ..Read::default()
        };
        let (a, b) = (read(9.8, 0), read(0.2, 1));
        let ids = sorted_ids(&b.ids).unwrap();
        let v = |c| interpolate(&a, &b, &ids, 0.5, c).unwrap()[0];
        assert!((v(Crossing::Images(&cell)) - DVec3::new(0.8, 0.0, 0.0)).length() < 1e-12);
        assert!((v(Crossing::Nearest(&cell)) - DVec3::new(0.8, 0.0, 0.0)).length() < 1e-12);
        assert!((v(Crossing::Direct) - DVec3::new(-19.2, 0.0, 0.0)).length() < 1e-12);
        // A whole box of motion shows only in the flags.
        let c = read(0.2, 2);
        let ids = sorted_ids(&c.ids).unwrap();
        let w = interpolate(&a, &c, &ids, 0.5, Crossing::Images(&cell)).unwrap()[0];
        assert!((w - DVec3::new(20.8, 0.0, 0.0)).length() < 1e-12);
        assert!(
            sorted_ids(&[3, 1, 3])
                .unwrap_err()
                .contains("id 3 is held by two points")
        );
    }
}
