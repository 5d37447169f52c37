//! The scene file's format as typed serde structs: what TOML a scene may hold, with unknown
//! keys rejected. Values are checked by [`super::validate`], not here.
//!
//! Every type a message can name says what it expects in the words of the format ("a number",
//! "a table", "an array of 3 numbers", the allowed keywords), so no serde or Rust type name
//! reaches a message (see [`super::report`], which also adds the field path).

use std::collections::BTreeMap;
use std::fmt;

use serde::Deserialize;
use serde::de::{self, IgnoredAny, MapAccess, SeqAccess, Visitor};

pub(super) use super::schema_curve::RawCurve;

/// A number field: any TOML integer or float. Range checks are the validator's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct F(pub(super) f64);

impl<'de> Deserialize<'de> for F {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = F;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number")
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<F, E> {
                Ok(F(x as f64))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<F, E> {
                Ok(F(x as f64))
            }
            fn visit_i128<E: de::Error>(self, x: i128) -> Result<F, E> {
                Ok(F(x as f64))
            }
            fn visit_u128<E: de::Error>(self, x: u128) -> Result<F, E> {
                Ok(F(x as f64))
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<F, E> {
                Ok(F(x))
            }
        }
        d.deserialize_any(V)
    }
}

/// A 3-vector or colour: an array of exactly 3 numbers (`V3<2>`: a pair, such as a range).
/// Any other length is refused from the array's length alone, before any element is read, so
/// a long array costs no more than its parse (the scan before the parse refuses very long
/// arrays; see [`super::scan`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct V3<const N: usize = 3>(pub(super) [f64; N]);

impl<'de, const N: usize> Deserialize<'de> for V3<N> {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<const N: usize>;
        impl<'de, const N: usize> Visitor<'de> for V<N> {
            type Value = V3<N>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "an array of {N} numbers")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<V3<N>, A::Error> {
                let wrong =
                    |n: usize| de::Error::custom(format_args!("expected {N} numbers, found {n}"));
                if let Some(n) = seq.size_hint()
                    && n != N
                {
                    return Err(wrong(n));
                }
                let mut v = [0.0; N];
                for (i, x) in v.iter_mut().enumerate() {
                    match seq.next_element::<F>()? {
                        Some(f) => *x = f.0,
                        None => return Err(wrong(i)),
                    }
                }
                // Without a size hint: count the rest without keeping it.
                let mut n = N;
                while seq.next_element::<IgnoredAny>()?.is_some() {
                    n += 1;
                }
                if n != N {
                    return Err(wrong(n));
                }
                Ok(V3(v))
            }
        }
        d.deserialize_seq(V::<N>)
    }
}

/// A keyword value: one of a fixed set of strings.
pub(super) trait Keyword: Sized + Copy + 'static {
    const NAMES: &'static [(&'static str, Self)];

    /// `one of "a", "b", "c"`.
    fn expected() -> String {
        let names: Vec<String> = Self::NAMES
            .iter()
            .map(|(n, _)| format!("\"{n}\""))
            .collect();
        format!("one of {}", names.join(", "))
    }

    fn deserialize_keyword<'de, D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<T>(std::marker::PhantomData<T>);
        impl<T: Keyword> Visitor<'_> for V<T> {
            type Value = T;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(&T::expected())
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<T, E> {
                T::NAMES
                    .iter()
                    .find(|(n, _)| *n == s)
                    .map(|(_, k)| *k)
                    .ok_or_else(|| {
                        E::custom(format_args!("expected {}, found {s:?}", T::expected()))
                    })
            }
        }
        d.deserialize_any(V(std::marker::PhantomData))
    }
}

/// A keyword of the description's own (a device, a denoise quality, a cache format, a colour
/// map) as a scene file names it: read by its [`Keyword`] names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Named<T>(pub(super) T);

impl<'de, T: Keyword> Deserialize<'de> for Named<T> {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        T::deserialize_keyword(d).map(Named)
    }
}

macro_rules! keyword {
    ($t:ty) => {
        impl<'de> Deserialize<'de> for $t {
            fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                <$t as Keyword>::deserialize_keyword(d)
            }
        }
    };
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields, expecting = "a table")]
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
    #[serde(default)]
    pub(super) points: Vec<RawPoints>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawShot {
    pub(super) fps: Option<F>,
    pub(super) frames: Option<Number>,
    pub(super) first_frame: Option<Number>,
    pub(super) start_time: Option<F>,
    pub(super) shutter: Option<F>,
    pub(super) shutter_angle: Option<F>,
    pub(super) shutter_position: Option<RawShutterPosition>,
    pub(super) shutter_curve: Option<RawCurve>,
    pub(super) rolling_shutter: Option<RawRollingShutter>,
}

#[derive(Clone, Copy)]
pub(super) enum RawShutterPosition {
    Start,
    Center,
    End,
}

impl Keyword for RawShutterPosition {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("start", Self::Start),
        ("center", Self::Center),
        ("end", Self::End),
    ];
}
keyword!(RawShutterPosition);

/// A rolling shutter as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawRollingShutter {
    pub(super) readout: F,
    pub(super) direction: Option<RawReadoutDirection>,
}

#[derive(Clone, Copy)]
pub(super) enum RawReadoutDirection {
    TopToBottom,
    BottomToTop,
}

impl Keyword for RawReadoutDirection {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("top-to-bottom", Self::TopToBottom),
        ("bottom-to-top", Self::BottomToTop),
    ];
}
keyword!(RawReadoutDirection);

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawOutput {
    pub(super) path: Option<String>,
    pub(super) width: Option<Number>,
    pub(super) height: Option<Number>,
    pub(super) clip: Option<String>,
    pub(super) passes: Option<Vec<RawPass>>,
    pub(super) denoise: Option<bool>,
    pub(super) denoise_quality: Option<Named<raytrace_core::scene::DenoiseQuality>>,
}

impl Keyword for raytrace_core::scene::Device {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("cpu", raytrace_core::scene::Device::Cpu),
        ("gpu", raytrace_core::scene::Device::Gpu),
    ];
}

impl Keyword for raytrace_core::scene::DenoiseQuality {
    const NAMES: &'static [(&'static str, Self)] = {
        use raytrace_core::scene::DenoiseQuality;
        &[
            ("fast", DenoiseQuality::Fast),
            ("balanced", DenoiseQuality::Balanced),
            ("high", DenoiseQuality::High),
        ]
    };
}

/// A pass name of `[output] passes`.
#[derive(Clone, Copy)]
pub(super) struct RawPass(pub(super) raytrace_core::pass::Pass);

impl Keyword for RawPass {
    const NAMES: &'static [(&'static str, Self)] = {
        use raytrace_core::pass::Pass;
        &[
            ("alpha", RawPass(Pass::Alpha)),
            ("depth", RawPass(Pass::Depth)),
            ("normal", RawPass(Pass::Normal)),
            ("albedo", RawPass(Pass::Albedo)),
            ("motion", RawPass(Pass::Motion)),
            ("variance", RawPass(Pass::Variance)),
            ("samples", RawPass(Pass::Samples)),
            ("noisy", RawPass(Pass::Noisy)),
        ]
    };
}
keyword!(RawPass);

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawRender {
    pub(super) samples: Option<Number>,
    pub(super) max_depth: Option<Number>,
    pub(super) seed: Option<Number>,
    pub(super) sampler: Option<RawSampler>,
    pub(super) device: Option<Named<raytrace_core::scene::Device>>,
}

#[derive(Clone, Copy)]
pub(super) enum RawSampler {
    Independent,
    Sobol,
}

impl Keyword for RawSampler {
    const NAMES: &'static [(&'static str, Self)] =
        &[("sobol", Self::Sobol), ("independent", Self::Independent)];
}
keyword!(RawSampler);

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawCamera {
    pub(super) look_from: Option<V3>,
    pub(super) look_at: Option<V3>,
    pub(super) up: Option<V3>,
    pub(super) vfov: Option<F>,
    pub(super) aperture: Option<F>,
    pub(super) focus_distance: Option<F>,
    pub(super) orbit: Option<RawCameraOrbit>,
    pub(super) keyframes: Option<Vec<RawCameraKey>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawCameraOrbit {
    pub(super) degrees_per_second: F,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawCameraKey {
    pub(super) time: F,
    pub(super) look_from: Option<V3>,
    pub(super) look_at: Option<V3>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawBackground {
    pub(super) color: Option<V3>,
    pub(super) transparent: Option<bool>,
}

/// A material as written: `type` and the keys of that type.
#[derive(Clone)]
pub(super) enum RawMaterial {
    Lambertian { albedo: V3 },
    Metal { albedo: V3, fuzz: F },
    Dielectric { ior: F },
}

#[derive(Clone, Copy)]
enum MaterialType {
    Lambertian,
    Metal,
    Dielectric,
}

impl Keyword for MaterialType {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("lambertian", Self::Lambertian),
        ("metal", Self::Metal),
        ("dielectric", Self::Dielectric),
    ];
}
keyword!(MaterialType);

/// The keys a material table may hold (the type decides which it needs).
#[derive(Clone, Copy, PartialEq)]
enum MaterialKey {
    Type,
    Albedo,
    Fuzz,
    Ior,
}

impl MaterialKey {
    const ALL: [MaterialKey; 4] = [
        MaterialKey::Type,
        MaterialKey::Albedo,
        MaterialKey::Fuzz,
        MaterialKey::Ior,
    ];

    fn name(self) -> &'static str {
        match self {
            MaterialKey::Type => "type",
            MaterialKey::Albedo => "albedo",
            MaterialKey::Fuzz => "fuzz",
            MaterialKey::Ior => "ior",
        }
    }
}

impl<'de> Deserialize<'de> for MaterialKey {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = MaterialKey;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a material key")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<MaterialKey, E> {
                MaterialKey::ALL
                    .into_iter()
                    .find(|k| k.name() == s)
                    .ok_or_else(|| {
                        E::custom(format_args!(
                            "unknown key `{s}`, expected one of type, albedo, fuzz, ior"
                        ))
                    })
            }
        }
        d.deserialize_identifier(V)
    }
}

/// Reads a material table key by key, with no buffering, so an error in a value is reported
/// at that value (with its path), not at the whole table.
struct MaterialVisitor;

impl<'de> Visitor<'de> for MaterialVisitor {
    type Value = RawMaterial;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a material table")
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<RawMaterial, A::Error> {
        let (mut ty, mut albedo, mut fuzz, mut ior) = (None, None, None, None);
        let mut keys = Vec::new();
        while let Some(key) = map.next_key::<MaterialKey>()? {
            keys.push(key);
            match key {
                MaterialKey::Type => ty = Some(map.next_value::<MaterialType>()?),
                MaterialKey::Albedo => albedo = Some(map.next_value::<V3>()?),
                MaterialKey::Fuzz => fuzz = Some(map.next_value::<F>()?),
                MaterialKey::Ior => ior = Some(map.next_value::<F>()?),
            }
        }
        let Some(ty) = ty else {
            return Err(de::Error::custom(format_args!(
                "missing key `type` ({})",
                MaterialType::expected()
            )));
        };
        let (name, allowed): (&str, &[MaterialKey]) = match ty {
            MaterialType::Lambertian => ("a lambertian", &[MaterialKey::Type, MaterialKey::Albedo]),
            MaterialType::Metal => (
                "a metal",
                &[MaterialKey::Type, MaterialKey::Albedo, MaterialKey::Fuzz],
            ),
            MaterialType::Dielectric => ("a dielectric", &[MaterialKey::Type, MaterialKey::Ior]),
        };
        if let Some(k) = keys.iter().find(|k| !allowed.contains(k)) {
            let allowed: Vec<&str> = allowed.iter().map(|k| k.name()).collect();
            return Err(de::Error::custom(format_args!(
                "unknown key `{}` for {name} material, expected one of {}",
                k.name(),
                allowed.join(", ")
            )));
        }
        let missing = |k: &str| {
            de::Error::custom(format_args!("missing key `{k}` ({name} material needs it)"))
        };
        Ok(match ty {
            MaterialType::Lambertian => RawMaterial::Lambertian {
                albedo: albedo.ok_or_else(|| missing("albedo"))?,
            },
            MaterialType::Metal => RawMaterial::Metal {
                albedo: albedo.ok_or_else(|| missing("albedo"))?,
                fuzz: fuzz.unwrap_or(F(0.0)),
            },
            MaterialType::Dielectric => RawMaterial::Dielectric {
                ior: ior.ok_or_else(|| missing("ior"))?,
            },
        })
    }
}

impl<'de> Deserialize<'de> for RawMaterial {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_map(MaterialVisitor)
    }
}

/// An integer field as written, so that a float where an integer belongs can be reported
/// with its field's name, and a large integer is shown exactly.
#[derive(Clone, Copy, Debug)]
pub(super) enum Number {
    /// Any TOML integer up to 2^127 - 1.
    Int(i128),
    /// An integer beyond `i128` (TOML allows none; the parser reads up to `u128`).
    Huge(u128),
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
                Ok(Number::Int(x.into()))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<Number, E> {
                Ok(Number::Int(x.into()))
            }
            fn visit_i128<E: de::Error>(self, x: i128) -> Result<Number, E> {
                Ok(Number::Int(x))
            }
            fn visit_u128<E: de::Error>(self, x: u128) -> Result<Number, E> {
                Ok(i128::try_from(x).map_or(Number::Huge(x), Number::Int))
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
                MaterialVisitor.visit_map(map).map(MaterialRef::Inline)
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawSphere {
    pub(super) center: Option<V3>,
    pub(super) radius: F,
    pub(super) material: MaterialRef,
    pub(super) velocity: Option<V3>,
    pub(super) keyframes: Option<Vec<RawSphereKey>>,
    pub(super) orbit: Option<RawOrbit>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawSphereKey {
    pub(super) time: F,
    pub(super) center: V3,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawOrbit {
    pub(super) pivot: V3,
    pub(super) axis: V3,
    pub(super) degrees_per_second: F,
}

/// A `[[points]]` table: a point cache, whose points are spheres.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawPoints {
    pub(super) file: String,
    pub(super) material: MaterialRef,
    pub(super) radius: Option<F>,
    pub(super) motion: Option<RawPointMotion>,
    pub(super) format: Option<Named<raytrace_core::points::CacheFormat>>,
    pub(super) snapshots: Option<RawSnapshots>,
    pub(super) dt: Option<F>,
    pub(super) velocity_scale: Option<F>,
    pub(super) periodic: Option<bool>,
    pub(super) color_by: Option<String>,
    pub(super) colormap: Option<Named<raytrace_core::colormap::Colormap>>,
    pub(super) color_range: Option<V3<2>>,
    pub(super) radius_by: Option<String>,
    pub(super) types: Option<BTreeMap<String, RawTypeLook>>,
}

/// A `types` entry of a `[[points]]` table.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table")]
pub(super) struct RawTypeLook {
    pub(super) radius: Option<F>,
    pub(super) material: Option<MaterialRef>,
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

keyword!(RawPointMotion);

/// `[[points]] format`: the names are the description's own.
impl Keyword for raytrace_core::points::CacheFormat {
    const NAMES: &'static [(&'static str, Self)] = &raytrace_core::points::CacheFormat::ALL;
}

/// `[[points]] snapshots`.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum RawSnapshots {
    Frames,
    Timestep,
}

impl Keyword for RawSnapshots {
    const NAMES: &'static [(&'static str, Self)] =
        &[("frames", Self::Frames), ("timestep", Self::Timestep)];
}

keyword!(RawSnapshots);

/// `[[points]] colormap`: the names are the map's own.
impl Keyword for raytrace_core::colormap::Colormap {
    const NAMES: &'static [(&'static str, Self)] = &raytrace_core::colormap::Colormap::ALL;
}
