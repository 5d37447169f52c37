//! The scene file's format as typed serde structs: what TOML a scene may hold, with unknown
//! keys rejected. Values are checked by [`super::validate`], not here.

use std::collections::BTreeMap;
use std::fmt;

use serde::Deserialize;
use serde::de::{self, MapAccess, Visitor};

pub(super) type V3 = [f64; 3];

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    #[serde(default)]
    pub(super) shot: RawShot,
    #[serde(default)]
    pub(super) output: RawOutput,
    #[serde(default)]
    pub(super) render: RawRender,
    #[serde(default)]
    pub(super) camera: RawCamera,
    pub(super) background: Option<RawBackground>,
    #[serde(default)]
    pub(super) materials: BTreeMap<String, RawMaterial>,
    #[serde(default)]
    pub(super) sphere: Vec<RawSphere>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawShot {
    pub(super) fps: Option<f64>,
    pub(super) frames: Option<Number>,
    pub(super) first_frame: Option<Number>,
    pub(super) start_time: Option<f64>,
    pub(super) shutter: Option<f64>,
    pub(super) shutter_angle: Option<f64>,
    pub(super) shutter_position: Option<RawShutterPosition>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawShutterPosition {
    Start,
    Center,
    End,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawOutput {
    pub(super) path: Option<String>,
    pub(super) width: Option<Number>,
    pub(super) height: Option<Number>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRender {
    pub(super) samples: Option<Number>,
    pub(super) max_depth: Option<Number>,
    pub(super) seed: Option<Number>,
    pub(super) sampler: Option<RawSampler>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawSampler {
    Independent,
    Sobol,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCamera {
    pub(super) look_from: Option<V3>,
    pub(super) look_at: Option<V3>,
    pub(super) up: Option<V3>,
    pub(super) vfov: Option<f64>,
    pub(super) aperture: Option<f64>,
    pub(super) focus_distance: Option<f64>,
    pub(super) orbit: Option<RawCameraOrbit>,
    pub(super) keyframes: Option<Vec<RawCameraKey>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCameraOrbit {
    pub(super) degrees_per_second: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCameraKey {
    pub(super) time: f64,
    pub(super) look_from: Option<V3>,
    pub(super) look_at: Option<V3>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBackground {
    pub(super) color: V3,
}

#[derive(Deserialize, Clone)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub(super) enum RawMaterial {
    Lambertian {
        albedo: V3,
    },
    Metal {
        albedo: V3,
        #[serde(default)]
        fuzz: f64,
    },
    Dielectric {
        ior: f64,
    },
}

/// A number as written in the file, so that a float where an integer belongs can be reported
/// with its field's name.
#[derive(Clone, Copy, Debug)]
pub(super) enum Number {
    Int(i64),
    Float(f64),
}

impl<'de> Deserialize<'de> for Number {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Number;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an integer")
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<Number, E> {
                Ok(Number::Int(x))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<Number, E> {
                Ok(i64::try_from(x).map_or(Number::Float(x as f64), Number::Int))
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<Number, E> {
                Ok(Number::Float(x))
            }
        }
        d.deserialize_any(V)
    }
}

/// A sphere's material: a name from `[materials]` or an inline table.
pub(super) enum MaterialRef {
    Name(String),
    Inline(RawMaterial),
}

impl<'de> Deserialize<'de> for MaterialRef {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = MaterialRef;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a material name or an inline material table")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<MaterialRef, E> {
                Ok(MaterialRef::Name(s.to_string()))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<MaterialRef, A::Error> {
                RawMaterial::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(MaterialRef::Inline)
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSphere {
    pub(super) center: Option<V3>,
    pub(super) radius: f64,
    pub(super) material: MaterialRef,
    pub(super) velocity: Option<V3>,
    pub(super) keyframes: Option<Vec<RawSphereKey>>,
    pub(super) orbit: Option<RawOrbit>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSphereKey {
    pub(super) time: f64,
    pub(super) center: V3,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawOrbit {
    pub(super) pivot: V3,
    pub(super) axis: V3,
    pub(super) degrees_per_second: f64,
}
