//! A simulation's box: an origin and three edge vectors (orthogonal or triclinic), each
//! direction periodic or not. What periodic boxes need: fractional coordinates, the shift of
//! a point into the box, the nearest image of a displacement.
//!
//! LAMMPS's triclinic box (docs: Howto triclinic): edges `a = (xhi - xlo, 0, 0)`,
//! `b = (xy, yhi - ylo, 0)`, `c = (xz, yz, zhi - zlo)`; a dump's `BOX BOUNDS` holds the
//! bounding box of that parallelepiped, from which the edges are found back
//! ([`Cell::from_lammps`]).

use glam::{DMat3, DVec3};

/// A box: `origin + u a + v b + w c` for fractional `u, v, w` in `[0, 1)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cell {
    pub origin: DVec3,
    /// The edge vectors, as the matrix's columns.
    pub edges: DMat3,
    /// Whether each direction (of `a`, `b`, `c`) is periodic.
    pub periodic: [bool; 3],
}

impl Cell {
    /// The box of a LAMMPS dump: the three `BOX BOUNDS` lines as numbers (`lo hi` or, for a
    /// triclinic box, `lo hi tilt` with tilts `xy`, `xz`, `yz`) and the boundary flags
    /// (`pp` is periodic). An error is the bound line at fault (0 to 2) and what is wrong:
    /// non-finite numbers, bounds whose upper is less than their lower.
    pub(crate) fn from_lammps(
        bounds: [[f64; 3]; 3],
        triclinic: bool,
        periodic: [bool; 3],
    ) -> Result<Cell, (usize, String)> {
        for (k, b) in bounds.iter().enumerate() {
            let n = if triclinic { 3 } else { 2 };
            if let Some(x) = b[..n].iter().find(|x| !x.is_finite()) {
                return Err((k, format!("box bound {x} is not a finite number")));
            }
        }
        let (xy, xz, yz) = if triclinic {
            (bounds[0][2], bounds[1][2], bounds[2][2])
        } else {
            (0.0, 0.0, 0.0)
        };
        // The bounding box's lower x is xlo + min(0, xy, xz, xy + xz); its upper,
        // xhi + max(0, xy, xz, xy + xz); y's, ylo + min(0, yz) and yhi + max(0, yz).
        let xlo = bounds[0][0] - [0.0, xy, xz, xy + xz].into_iter().fold(0.0, f64::min);
        let xhi = bounds[0][1] - [0.0, xy, xz, xy + xz].into_iter().fold(0.0, f64::max);
        let ylo = bounds[1][0] - yz.min(0.0);
        let yhi = bounds[1][1] - yz.max(0.0);
        let (zlo, zhi) = (bounds[2][0], bounds[2][1]);
        // Equal bounds are a flat box, refused only where it is periodic ([`Cell::spans_volume`]).
        for (k, (name, lo, hi)) in [("x", xlo, xhi), ("y", ylo, yhi), ("z", zlo, zhi)]
            .into_iter()
            .enumerate()
        {
            if hi < lo || !(hi - lo).is_finite() {
                return Err((
                    k,
                    format!(
                        "the box's {name} bounds are {lo} to {hi}: the upper must not be less than the lower"
                    ),
                ));
            }
        }
        Cell::new(
            DVec3::new(xlo, ylo, zlo),
            DMat3::from_cols(
                DVec3::new(xhi - xlo, 0.0, 0.0),
                DVec3::new(xy, yhi - ylo, 0.0),
                DVec3::new(xz, yz, zhi - zlo),
            ),
            periodic,
        )
        .map_err(|m| (0, m))
    }

    /// A box from its origin and edges; an error when the edges are not finite or span no
    /// volume.
    pub(crate) fn new(origin: DVec3, edges: DMat3, periodic: [bool; 3]) -> Result<Cell, String> {
        if !origin.is_finite() || !edges.is_finite() {
            return Err("the box holds a number that is not finite".into());
        }
        Ok(Cell {
            origin,
            edges,
            periodic,
        })
    }

    /// Whether the edges span a volume, as a periodic box needs (wrapping takes fractional
    /// coordinates through the edges' inverse); a box no direction of which is periodic is
    /// not used as a box, and may be flat.
    pub(crate) fn spans_volume(&self) -> bool {
        let volume = self.edges.determinant();
        let e = &self.edges;
        let scale = e.x_axis.length() * e.y_axis.length() * e.z_axis.length();
        // Edges within 1e-12 of lying in a plane have no usable inverse.
        volume.is_finite() && volume.abs() > 1e-12 * scale
    }

    /// Whether any direction is periodic.
    pub(crate) fn any_periodic(&self) -> bool {
        self.periodic.iter().any(|&p| p)
    }

    /// `p`'s fractional coordinates.
    pub(crate) fn fractional(&self, p: DVec3) -> DVec3 {
        self.edges.inverse() * (p - self.origin)
    }

    /// The point at fractional coordinates `f`.
    pub(crate) fn cartesian(&self, f: DVec3) -> DVec3 {
        self.origin + self.edges * f
    }

    /// The vector of whole box edges `n` (`n.x a + n.y b + n.z c`).
    pub(crate) fn shift(&self, n: DVec3) -> DVec3 {
        self.edges * n
    }

    /// The whole numbers of edges, along periodic directions, that bring `p` into the box:
    /// `-floor(u)` for each periodic fractional coordinate `u`, zero for the others.
    pub(crate) fn edges_into_box(&self, p: DVec3) -> DVec3 {
        let f = self.fractional(p);
        DVec3::from_array(std::array::from_fn(|k| {
            if self.periodic[k] { -f[k].floor() } else { 0.0 }
        }))
    }

    /// The displacement `d` less the whole edges that make it shortest in fractional terms
    /// along periodic directions: the nearest image's displacement (minimum image convention,
    /// exact for displacements under half a box).
    pub(crate) fn nearest_image(&self, d: DVec3) -> DVec3 {
        let f = self.edges.inverse() * d;
        let n = DVec3::from_array(std::array::from_fn(|k| {
            if self.periodic[k] { -f[k].round() } else { 0.0 }
        }));
        if n == DVec3::ZERO {
            d
        } else {
            d + self.shift(n)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triclinic_box_is_found_back_from_its_bounding_box() {
        // xlo 0, xhi 10, ylo 0, yhi 8, zlo 0, zhi 6, xy 2, xz -1, yz 0.5: the bounding box
        // is x from -1 to 12, y from 0 to 8.5 (the LAMMPS docs' formulas).
        let c = Cell::from_lammps(
            [[-1.0, 12.0, 2.0], [0.0, 8.5, -1.0], [0.0, 6.0, 0.5]],
            true,
            [true; 3],
        )
        .unwrap();
        assert_eq!(c.origin, DVec3::ZERO);
        assert_eq!(c.edges.x_axis, DVec3::new(10.0, 0.0, 0.0));
        assert_eq!(c.edges.y_axis, DVec3::new(2.0, 8.0, 0.0));
        assert_eq!(c.edges.z_axis, DVec3::new(-1.0, 0.5, 6.0));
        let p = DVec3::new(3.0, 2.0, 1.0);
        assert!((c.cartesian(c.fractional(p)) - p).length() < 1e-12);
        // A point one c beyond the top comes back by -c.
        let q = p + c.edges.z_axis;
        assert_eq!(c.edges_into_box(q), DVec3::new(0.0, 0.0, -1.0));
        // The nearest image of a displacement of 0.9 box along b is -0.1 b.
        let d = c.edges.y_axis * 0.9;
        assert!((c.nearest_image(d) + c.edges.y_axis * 0.1).length() < 1e-12);
    }

    #[test]
    fn inverted_non_finite_and_flat_boxes_are_refused() {
        let flags = [true; 3];
        let e = Cell::from_lammps(
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
            false,
            flags,
        );
        let (line, m) = e.unwrap_err();
        assert_eq!(line, 0);
        assert!(m.contains("x bounds are 1 to 0: the upper must not be less"));
        let e = Cell::from_lammps(
            [[0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [3.0, 1.0, 0.0]],
            false,
            flags,
        );
        assert_eq!(e.unwrap_err().0, 2);
        let e = Cell::from_lammps(
            [[0.0, f64::NAN, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
            false,
            flags,
        );
        let (line, m) = e.unwrap_err();
        assert_eq!(
            (line, m.as_str()),
            (0, "box bound NaN is not a finite number")
        );
        // A flat box is a box, which spans no volume (refused where it is periodic).
        let flat = DMat3::from_cols(DVec3::X, DVec3::X * 2.0, DVec3::Z);
        assert!(!Cell::new(DVec3::ZERO, flat, flags).unwrap().spans_volume());
        let zero = Cell::from_lammps(
            [[5.0, 5.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
            false,
            [false; 3],
        );
        assert!(!zero.unwrap().spans_volume());
        let cube = DMat3::from_diagonal(DVec3::splat(2.0));
        assert!(Cell::new(DVec3::ZERO, cube, flags).unwrap().spans_volume());
    }

    #[test]
    fn only_periodic_directions_wrap() {
        let c = Cell::new(
            DVec3::ZERO,
            DMat3::from_diagonal(DVec3::splat(2.0)),
            [true, false, true],
        )
        .unwrap();
        assert_eq!(
            c.edges_into_box(DVec3::new(-0.5, -0.5, 4.5)),
            DVec3::new(1.0, 0.0, -2.0)
        );
        assert_eq!(
            c.nearest_image(DVec3::new(1.5, 1.5, -1.5)),
            DVec3::new(-0.5, 1.5, 0.5)
        );
    }
}
