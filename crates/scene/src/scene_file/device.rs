//! `[render] device`: the names a scene file may write.

use super::schema::Keyword;
use raytrace_core::scene::Device;

impl Keyword for Device {
    const NAMES: &'static [(&'static str, Self)] = &[("cpu", Device::Cpu), ("gpu", Device::Gpu)];
}
