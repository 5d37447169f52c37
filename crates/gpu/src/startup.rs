//! How long a GPU took to start, as `--stats` says it once a run: finding the adapter and
//! opening the device, then creating the tracer's pipelines (from the pipeline cache or not).

use std::fmt;

use super::disk_cache::CacheUse;

/// A GPU's start-up, timed by [`Gpu::new`](super::Gpu::new) and said by
/// [`Gpu::startup`](super::Gpu::startup).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Startup {
    /// Seconds to find the adapter and open the device.
    pub(crate) device_seconds: f64,
    /// Seconds to compile the tracer's shader and create its pipelines.
    pub(crate) pipelines_seconds: f64,
    /// Whether the pipelines came from the cache on disk.
    pub(crate) cache: CacheUse,
}

impl fmt::Display for Startup {
    /// `start-up 0.412 s (adapter and device 0.120 s, pipelines 0.292 s, cache hit)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "start-up {:.3} s (adapter and device {:.3} s, pipelines {:.3} s, {})",
            self.device_seconds + self.pipelines_seconds,
            self.device_seconds,
            self.pipelines_seconds,
            self.cache
        )
    }
}
