//! Simulation output as the tools write it, read as numbers for the caller's columns: LAMMPS
//! text dumps (`lammps`), extended XYZ (`xyz`), VTK point data (`vtk`, legacy and XML), each
//! a list of snapshots with named columns ([`Snapshot`], [`Column`]), and their periodic
//! boxes (`cell`). `text` reads plain and gzip text line by line with positions, so a
//! file's snapshots are indexed once and each read again from where it starts.
//!
//! What the columns mean (positions, velocities, radii) is the point cache's business
//! (`point_cache`); here a column is a name, a component and the kind of its values.

pub mod cell;
pub mod lammps;
pub mod text;
pub mod vtk;
mod vtk_legacy;
mod vtk_xml;
pub mod xyz;

use std::sync::Arc;

use text::Position;

/// A reading's error: bad input (a message naming the line and what is wrong), or the
/// system's.
#[derive(Debug)]
pub enum ReadError {
    Bad(String),
    Io(std::io::Error),
}

impl From<std::io::Error> for ReadError {
    fn from(e: std::io::Error) -> Self {
        ReadError::Io(e)
    }
}

/// What a column's values are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColumnKind {
    Real,
    Integer,
    /// `T` or `F`, read as 1 or 0.
    Logical,
    /// Words (an XYZ species), read as the index of each word's first appearance.
    Text,
    /// A PLY list property, which is not one number.
    List,
}

impl ColumnKind {
    /// What a value of this kind must be, for messages.
    pub fn expected(self) -> &'static str {
        match self {
            ColumnKind::Real => "a number",
            ColumnKind::Integer => "a whole number",
            ColumnKind::Logical => "T or F",
            ColumnKind::Text => "a word",
            ColumnKind::List => "a single number",
        }
    }
}

/// A column of a snapshot: one component of a named quantity.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Column {
    pub name: String,
    /// Which component (from 0) of the quantity's `components`.
    pub component: u8,
    pub components: u8,
    pub kind: ColumnKind,
}

impl Column {
    /// A column of one number, as a LAMMPS dump's.
    pub fn scalar(name: &str) -> Column {
        Column {
            name: name.to_string(),
            component: 0,
            components: 1,
            kind: ColumnKind::Real,
        }
    }

    /// The column's name in messages: `pos[1]` for a component, else the name.
    pub fn label(&self) -> String {
        if self.components > 1 {
            format!("{}[{}]", self.name, self.component)
        } else {
            self.name.clone()
        }
    }
}

/// A snapshot of a text file, as its header says: where it starts and where its rows begin,
/// how many there are, its timestep and box where the file gives them, its columns.
#[derive(Clone, Debug)]
pub struct Snapshot {
    /// The line its header begins on.
    pub line: u64,
    /// Where its first row is.
    pub rows: Position,
    pub count: u64,
    pub timestep: Option<i64>,
    pub cell: Option<cell::Cell>,
    /// Shared between consecutive snapshots with the same columns.
    pub columns: Arc<[Column]>,
}
