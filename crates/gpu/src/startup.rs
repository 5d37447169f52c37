//! How long a GPU took to start, as `--stats` says it once a run: finding the adapter and
//! opening the device, then creating the tracer's pipelines (from the pipeline cache or not)
//! on their own thread while the shot is built, and how long the run waited for them.

use std::fmt;

use super::disk_cache::CacheUse;

/// A GPU's start-up, timed by [`Gpu::new`](super::Gpu::new) and said by
/// [`Gpu::startup`](super::Gpu::startup).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Startup {
    /// Seconds to find the adapter and open the device and its pipeline cache.
    pub(crate) device_seconds: f64,
    /// Seconds to compile the tracers' shaders and create their pipelines, on their own
    /// threads beside the shot's build.
    pub(crate) pipelines_seconds: f64,
    /// Of those, the seconds the run waited for them (the rest overlapped the shot's build).
    pub(crate) waited_seconds: f64,
    /// Whether the pipelines came from the cache on disk.
    pub(crate) cache: CacheUse,
}

impl fmt::Display for Startup {
    /// `start-up 0.180 s (adapter and device 0.120 s, pipelines 0.292 s beside the shot's
    /// build, 0.060 s of them waited for, cache hit)`: the start-up is what the run paid, the
    /// device and the wait.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "start-up {:.3} s (adapter and device {:.3} s, pipelines {:.3} s beside the shot's build, {:.3} s of them waited for, {})",
            self.device_seconds + self.waited_seconds,
            self.device_seconds,
            self.pipelines_seconds,
            self.waited_seconds,
            self.cache
        )
    }
}
