//! Values given on the command line in place of a scene file's.

use raytrace_core::pass::Pass;
use raytrace_core::sampler::SamplerKind;
use raytrace_core::scene::Device;
use raytrace_core::scene::{DenoiseDevice, DenoiseQuality};

/// Values given on the command line in place of the scene file's. They are written into the
/// file's raw values before validation, so the one validator checks them with the same rules
/// and messages (which name the flag: `--width must be in 1..=65536, got 0`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overrides {
    /// `--output`: replaces `[output] path`.
    pub output: Option<String>,
    /// `--width`: replaces `[output] width`.
    pub width: Option<u32>,
    /// `--height`: replaces `[output] height`.
    pub height: Option<u32>,
    /// `--samples`: replaces `[render] samples`.
    pub samples: Option<u32>,
    /// `--seed`: replaces `[render] seed`.
    pub seed: Option<u64>,
    /// `--sampler`: replaces `[render] sampler`.
    pub sampler: Option<SamplerKind>,
    /// `--clip`: replaces `[output] clip`.
    pub clip: Option<String>,
    /// `--passes`: replaces `[output] passes` (in the order given, duplicates included, so
    /// the validator names them).
    pub passes: Option<Vec<Pass>>,
    /// `--denoise`: replaces `[output] denoise`.
    pub denoise: Option<bool>,
    /// `--denoise-quality`: replaces `[output] denoise_quality`.
    pub denoise_quality: Option<DenoiseQuality>,
    /// `--temporal`: a denoised shot kept from flickering (needs denoising).
    pub temporal: Option<bool>,
    /// `--denoise-device`: where the denoiser runs (no scene key: a machine's choice, not
    /// the shot's).
    pub denoise_device: Option<DenoiseDevice>,
    /// `--device`: replaces `[render] device`.
    pub device: Option<Device>,
}
