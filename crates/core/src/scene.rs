//! The validated description of a shot: everything a render needs, with defaults applied,
//! names resolved and every value checked, command-line overrides included. It is made only by
//! `raytrace_scene::scene_file` (which reads and checks scene files) and read by the core
//! ([`crate::world`], [`crate::renderer`], [`crate::tracer`]), which never sees the file or its
//! reader.

use std::path::PathBuf;

use crate::camera::CameraRig;
use crate::format::Format;
use crate::material::{Background, Material};
use crate::pass::PassSet;
use crate::path_pattern::FramePattern;
use crate::points::PointCacheDesc;
use crate::sampler::SamplerKind;
use crate::shutter::Shot;
use crate::sphere::SphereDesc;

/// Largest image side, in pixels, from a scene file or the command line.
pub const MAX_SIDE: u32 = 65536;

/// Where and how big frames are written.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputSettings {
    /// The output path pattern; runs of `#` become the zero-padded frame number. `{scene}`
    /// has already been replaced by the scene file's name without extension.
    pub path: FramePattern,
    /// The frames' format, from `path`'s extension: [`Format::Exr`] or [`Format::Png`].
    pub format: Format,
    pub width: u32,
    pub height: u32,
    /// `[output] clip` (or `--clip`): a clip to assemble from the frames after rendering
    /// (`.mp4`, `.gif`, `.apng` or `.png`), `{scene}` replaced as in `path`.
    pub clip: Option<String>,
    /// The passes written beside the colour (`[output] passes`, or `--passes`).
    pub passes: PassSet,
    /// `[output] denoise` (or `--denoise`): the colour written is finished by the denoiser,
    /// with these settings; `None`: the raw frame is written.
    pub denoise: Option<DenoiseSettings>,
}

/// How a denoised shot is finished.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DenoiseSettings {
    /// `[output] denoise_quality` (or `--denoise-quality`).
    pub quality: DenoiseQuality,
    /// `--temporal`: keep the denoised sequence from flickering, by sampling every frame
    /// with the same sample points (`sampler::SamplePattern::Stable`).
    pub temporal: bool,
    /// What a frame takes from the frames before it. No option sets it: `converge --flicker`
    /// measures each way as a route of its own beside `--temporal`'s, which none improved at
    /// its cost (docs/denoising.md).
    pub carry: Carry,
    /// `--denoise-device`: where the denoiser runs.
    pub device: DenoiseDevice,
}

/// What a denoised frame takes from the frames beside it, carried to its pixels along the
/// motion vectors ([`DenoiseSettings::carry`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Carry {
    /// Nothing: each frame is denoised alone.
    #[default]
    Nothing,
    /// The two frames before it: their written frames, combined with this one's by estimated
    /// error (`raytrace_denoise::history`).
    Written,
    /// A centred window: the written frames of the frame before it and the frame after it,
    /// combined with this one's as [`Carry::Written`] combines them, so that the frame is
    /// finished once the frame after it is sampled.
    Centred,
    /// The two frames before it: their raw films, pooled with this one's where they agree,
    /// before the denoise (`raytrace_denoise::accumulate`).
    Raw,
}

/// Where the denoiser runs (`--denoise-device`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum DenoiseDevice {
    /// On the GPU that traces the frame when OIDN has a device for it (CUDA, HIP, SYCL,
    /// Metal), else on the CPU, with a note; the default.
    #[default]
    Auto,
    /// On the CPU.
    Cpu,
    /// On a GPU: the one that traces the frame, or with `--device cpu` the first OIDN finds;
    /// without one, an error.
    Gpu,
}

impl DenoiseDevice {
    /// Every choice, as the command line lists them.
    pub const ALL: [DenoiseDevice; 3] =
        [DenoiseDevice::Auto, DenoiseDevice::Cpu, DenoiseDevice::Gpu];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DenoiseDevice::Auto => "auto",
            DenoiseDevice::Cpu => "cpu",
            DenoiseDevice::Gpu => "gpu",
        }
    }

    /// The choice named `name`, if any.
    pub fn from_name(name: &str) -> Option<DenoiseDevice> {
        DenoiseDevice::ALL.into_iter().find(|d| d.name() == name)
    }
}

/// The denoiser's filter qualities, OIDN's (`[output] denoise_quality`, `--denoise-quality`): each slower and
/// closer to the truth than the one before. On OIDN's CPU device `balanced` runs the `high`
/// network (its documentation: balanced "lowers the precision, if possible"; measured: the
/// same bytes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum DenoiseQuality {
    /// OIDN's smaller network: about half the time of `high`; the default (docs/denoising.md
    /// has the measurement that chose it).
    #[default]
    Fast,
    Balanced,
    High,
}

impl DenoiseQuality {
    /// Every quality, fastest first.
    pub const ALL: [DenoiseQuality; 3] = [
        DenoiseQuality::Fast,
        DenoiseQuality::Balanced,
        DenoiseQuality::High,
    ];

    /// The name used in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DenoiseQuality::Fast => "fast",
            DenoiseQuality::Balanced => "balanced",
            DenoiseQuality::High => "high",
        }
    }

    /// The quality named `name`, if any.
    pub fn from_name(name: &str) -> Option<DenoiseQuality> {
        DenoiseQuality::ALL.into_iter().find(|q| q.name() == name)
    }
}

impl std::fmt::Display for DenoiseQuality {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Sampling settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Samples per pixel, >= 1.
    pub samples: u32,
    /// Longest path in bounces; a path that reaches it returns black.
    pub max_depth: u32,
    pub seed: u64,
    /// How samples are placed (`[render] sampler`).
    pub sampler: SamplerKind,
    /// Where the frames' paths are traced (`[render] device`, or `--device`).
    pub device: Device,
}

/// Where a frame's paths are traced: the same integrand, time model and film either way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Device {
    /// The CPU's worker threads, in `f64` (`crate::renderer`).
    #[default]
    Cpu,
    /// A GPU through wgpu's compute shaders, in `f32` (`raytrace_gpu`).
    Gpu,
}

impl Device {
    /// Every device, in the order they are listed to users.
    pub const ALL: [Device; 2] = [Device::Cpu, Device::Gpu];

    /// The name used in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Device::Cpu => "cpu",
            Device::Gpu => "gpu",
        }
    }
}

impl std::fmt::Display for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Device {
    type Err = String;
    fn from_str(s: &str) -> Result<Device, String> {
        Device::ALL
            .into_iter()
            .find(|d| d.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown device \"{}\" (expected one of: cpu, gpu)",
                    crate::error::elide(s)
                )
            })
    }
}

/// A validated scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The file the scene was read from (used in messages and for the default output path).
    pub source: PathBuf,
    pub shot: Shot,
    pub output: OutputSettings,
    pub render: RenderSettings,
    pub camera: CameraRig,
    pub background: Background,
    /// `[background] transparent`: camera rays that miss every sphere add black, so the
    /// colour is premultiplied by the alpha pass.
    pub transparent: bool,
    /// Every material used by a sphere; spheres refer to them by index.
    pub materials: Vec<Material>,
    pub spheres: Vec<SphereDesc>,
    /// The `[[points]]` tables: point caches whose points are spheres too, read per frame.
    pub points: Vec<PointCacheDesc>,
}
