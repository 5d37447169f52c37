//! Scene files: reading and checking them, and writing generated ones. The result is the
//! validated description, [`raytrace_core::scene::Scene`]; nothing downstream re-validates.
//!
//! A scene file goes through these steps, one file each:
//! - [`load`]: the file's bytes (regular files of bounded size only) and text;
//! - [`scan`]: limits that bound the parse's memory, checked before any document is parsed;
//! - [`schema`]: the TOML format as typed serde structs (unknown keys rejected);
//! - [`validate`]: the one validator, from those raw values (with any [`Overrides`] applied to
//!   them first) to a `Scene`, naming the field of any bad value;
//! - [`pieces`]: large files cut at their `[[sphere]]` headers and parsed in parallel;
//!
//! [`schema_curve`] holds the shutter curve's part of the schema, and `validate::points` the
//! `[[points]]` tables' checks.
//!
//! [`report`] words the errors found in the text (`raytrace_core::show` the numbers they quote).
//! [`generate`] writes large random test scenes as scene-file text.
//!
//! This file only declares and re-exports: the children import each other directly.

pub mod generate;
mod load;
mod overrides;
mod pieces;
mod report;
mod scan;
mod schema;
mod schema_curve;
mod validate;

#[cfg(test)]
mod tests;

pub use load::{SceneFile, SceneSource, bytes_for};
pub use overrides::Overrides;
