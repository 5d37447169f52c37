//! The scene file: TOML parsed into typed structs, then validated into a [`Scene`].

use std::path::Path;

use crate::error::Error;
use crate::scene::Scene;

/// Parses and validates scene text.
pub fn parse(_text: &str, source: &Path) -> Result<Scene, Error> {
    Err(Error::Scene(format!(
        "{}: scene parsing is not written yet",
        source.display()
    )))
}
