//! `[render] device`: the names a scene file may write, and the refusal of a scene the device
//! it names cannot render (the GPU path's limits, `crate::gpu::unsupported`), worded with the
//! field or flag that chose the device.

use serde::{Deserialize, Deserializer};

use super::overrides::Overrides;
use super::schema::Keyword;
use super::show::{show, show_approx};
use crate::error::Error;
use crate::gpu::{
    CAMERA_FRACTION, MAX_BUFFER_BYTES, MAX_COORDINATE, MAX_SWEEP_DEGREES, MIN_PIXEL_ANGLE,
    MIN_RADIUS, MIN_RADIUS_FRACTION, Unsupported,
};
use crate::scene::{Device, Scene};

impl Keyword for Device {
    const NAMES: &'static [(&'static str, Self)] = &[("cpu", Device::Cpu), ("gpu", Device::Gpu)];
}

impl<'de> Deserialize<'de> for Device {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        <Device as Keyword>::deserialize_keyword(d)
    }
}

/// `scene` itself, or bad input ([`Error::Scene`], exit status 2) when it asks for the GPU
/// and the GPU path does not render it: the message names the file, the field or flag that
/// chose the GPU (`shot.toml: --device gpu: ...`, `shot.toml: render.device = "gpu": ...`), what
/// is beyond the GPU's limits and the way out (`--device cpu`).
pub(super) fn check(scene: Scene, overrides: &Overrides) -> Result<Scene, Error> {
    if scene.render.device != Device::Gpu {
        return Ok(scene);
    }
    let Some(why) = crate::gpu::unsupported(&scene) else {
        return Ok(scene);
    };
    let file = crate::error::elide_path(&scene.source);
    // The file is named either way: with several scenes, `--device gpu` alone does not say
    // which one the GPU refuses.
    let chosen = if overrides.device.is_some() {
        format!("{file}: --device gpu")
    } else {
        format!("{file}: render.device = \"gpu\"")
    };
    if let Unsupported::PointCaches { tables } = why {
        let tables = match tables {
            1 => "a [[points]] table".to_string(),
            n => format!("{n} [[points]] tables"),
        };
        return Err(Error::Scene(format!(
            "{chosen}: the GPU does not render point caches, and this scene has {tables}; render it with --device cpu"
        )));
    }
    Err(Error::Scene(format!(
        "{chosen}: the GPU computes in 32-bit floats and does not render this scene: {}; render it with --device cpu",
        describe(&why)
    )))
}

/// What is beyond the GPU's limits, in words.
fn describe(why: &Unsupported) -> String {
    match why {
        Unsupported::PointCaches { .. } => "its point caches".to_string(),
        Unsupported::Far { what, value } => format!(
            "{what} reaches a coordinate of {}, beyond the {} the GPU takes",
            show_approx(*value),
            show(MAX_COORDINATE)
        ),
        Unsupported::Tiny { sphere, radius } => format!(
            "sphere[{sphere}].radius is {}, below the {} the GPU takes",
            show(*radius),
            show(MIN_RADIUS)
        ),
        Unsupported::Small {
            sphere,
            radius,
            coordinate,
        } => format!(
            "sphere[{sphere}].radius {} is less than {} of its largest coordinate {}, so a 32-bit float would place its surface to worse than 1/2048 of its radius (the GPU takes a radius of at least {})",
            show(*radius),
            show_approx(MIN_RADIUS_FRACTION),
            show_approx(*coordinate),
            show_approx(MIN_RADIUS_FRACTION * coordinate)
        ),
        Unsupported::FarCamera {
            coordinate,
            footprint,
        } => format!(
            "the camera reaches a coordinate of {}, where a 32-bit float resolves it to more than 1/64 of a pixel's footprint at the focus distance ({}; the GPU takes a footprint of at least {} of the coordinate)",
            show_approx(*coordinate),
            show_approx(*footprint),
            show_approx(CAMERA_FRACTION)
        ),
        Unsupported::NarrowView { pixel_angle } => format!(
            "camera.vfov gives pixels {} radians wide, less than the {} the GPU's 32-bit directions resolve to 1/64",
            show_approx(*pixel_angle),
            show_approx(MIN_PIXEL_ANGLE)
        ),
        Unsupported::FastOrbit { what, sweep } => format!(
            "{what} sweeps {} degrees over a frame's exposure and a frame period on each side, more than the {} the GPU takes",
            show_approx(*sweep),
            show(MAX_SWEEP_DEGREES)
        ),
        Unsupported::TooLarge { bytes } => format!(
            "its spheres could need {} MiB in one GPU buffer, more than the {} MiB every GPU offers",
            bytes.div_ceil(1 << 20),
            MAX_BUFFER_BYTES >> 20
        ),
    }
}
