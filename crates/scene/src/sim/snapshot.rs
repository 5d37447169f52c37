//! A snapshot's columns (a name, a component, the kind of its values) and a text file's
//! snapshot as its header says.

use std::sync::Arc;

use super::text::Position;

/// What a column's values are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ColumnKind {
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
    pub(crate) fn expected(self) -> &'static str {
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
pub(crate) struct Column {
    pub name: String,
    /// Which component (from 0) of the quantity's `components`.
    pub component: u8,
    pub components: u8,
    pub kind: ColumnKind,
}

impl Column {
    /// A column of one number, as a LAMMPS dump's.
    pub(crate) fn scalar(name: &str) -> Column {
        Column {
            name: name.to_string(),
            component: 0,
            components: 1,
            kind: ColumnKind::Real,
        }
    }

    /// The column's name in messages: `pos[1]` for a component, else the name.
    pub(crate) fn label(&self) -> String {
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
pub(crate) struct Snapshot {
    /// The line its header begins on.
    pub line: u64,
    /// Where its first row is.
    pub rows: Position,
    pub count: u64,
    pub timestep: Option<i64>,
    /// Shared between consecutive snapshots with the same box (a file of a million
    /// snapshots holds its index, not a million boxes).
    pub cell: Option<Arc<super::cell::Cell>>,
    /// Shared between consecutive snapshots with the same columns.
    pub columns: Arc<[Column]>,
}
