//! Simulation output as the tools write it, read as numbers for the caller's columns: LAMMPS
//! text dumps (`lammps`), extended XYZ (`xyz`), VTK point data (`vtk`, legacy and XML), each
//! a list of snapshots with named columns ([`Snapshot`], [`Column`]), and their periodic
//! boxes (`cell`). `text` reads plain and gzip text line by line with positions, so a
//! file's snapshots are indexed once and each read again from where it starts.
//!
//! What the columns mean (positions, velocities, radii) is the point cache's business
//! (`point_cache`); here a column is a name, a component and the kind of its values.

pub(crate) mod cell;
pub(crate) mod lammps;
mod read_error;
mod snapshot;
pub(crate) mod text;
pub(crate) mod vtk;
mod vtk_data;
mod vtk_legacy;
mod vtk_xml;
pub(crate) mod xyz;

pub(crate) use read_error::ReadError;
pub(crate) use snapshot::ColumnKind;
pub(crate) use snapshot::{Column, Snapshot};
