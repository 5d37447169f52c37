//! VTK point data (placeholder while the reader is written).

use std::path::Path;
use std::sync::Arc;

use super::{Column, ReadError};

/// The name the points' positions go by among a VTK file's columns.
pub const POINTS: &str = "Points";

/// A VTK file's points and point data.
pub struct VtkFile {
    columns: Arc<[Column]>,
    count: u64,
}

impl VtkFile {
    /// Opens and reads `path`.
    pub fn open(_path: &Path) -> Result<VtkFile, ReadError> {
        Err(ReadError::Bad("VTK files are not read yet".into()))
    }

    /// The columns: the points' three, then each point data array's.
    pub fn columns(&self) -> Arc<[Column]> {
        self.columns.clone()
    }

    /// The number of points.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Reads every point's values of columns `wanted`.
    pub fn read_rows(
        &self,
        _wanted: &[usize],
        _row: impl FnMut(u64, &[f64]) -> Result<(), String>,
    ) -> Result<(), ReadError> {
        Ok(())
    }
}
