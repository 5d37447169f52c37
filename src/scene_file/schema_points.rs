//! The `[[points]]` table of the scene file's format (the rest is in [`super::schema`]): a
//! point cache, whose points are spheres.

use serde::{Deserialize, de};

use super::schema::{F, Keyword, MaterialRef};

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawPoints {
    pub(super) file: String,
    pub(super) material: MaterialRef,
    pub(super) radius: Option<F>,
    pub(super) motion: Option<RawPointMotion>,
}

#[derive(Clone, Copy)]
pub(super) enum RawPointMotion {
    Velocity,
    Interpolate,
    None,
}

impl Keyword for RawPointMotion {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("velocity", Self::Velocity),
        ("interpolate", Self::Interpolate),
        ("none", Self::None),
    ];
}

impl<'de> Deserialize<'de> for RawPointMotion {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Self::deserialize_keyword(d)
    }
}
