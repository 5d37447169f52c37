//! The tracer's pipeline cache on disk, where the adapter has one (wgpu's
//! `Features::PIPELINE_CACHE`: Vulkan): read before the pipelines are created, so that a
//! second run skips the driver's compilation, and written back after them.
//!
//! The file is `DIR/tracer-KEY.bin`, KEY being `wgpu::util::pipeline_cache_key` (the backend,
//! the vendor and the device), so another adapter never reads it; DIR is
//! [`CACHE_VARIABLE`] where set, else `$XDG_CACHE_HOME/raytrace`, else `$HOME/.cache/raytrace`.
//! A file that is missing, corrupt or foreign changes nothing but the time: wgpu checks its
//! header and the driver its own (`fallback: true`), and a cache wgpu refuses is replaced by an
//! empty one. A directory that cannot be made or written means no cache, never a failure.

use std::fmt;
use std::path::{Path, PathBuf};

/// The environment variable naming the directory of the pipeline cache, instead of
/// `$XDG_CACHE_HOME/raytrace` or `$HOME/.cache/raytrace`.
pub const CACHE_VARIABLE: &str = "RAYTRACE_GPU_CACHE";

/// How the tracer's pipelines were created, as `--stats` says it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CacheUse {
    /// From a cache file the device took.
    Hit,
    /// With a cache, but nothing usable in it yet (no file, or one wgpu refused).
    Cold,
    /// Without a cache: the adapter has none, or there is no directory for it.
    Off,
}

impl fmt::Display for CacheUse {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CacheUse::Hit => "cache hit",
            CacheUse::Cold => "cold",
            CacheUse::Off => "no cache",
        })
    }
}

/// A device's pipeline cache and the file it is kept in.
#[derive(Debug)]
pub(super) struct DiskCache {
    cache: Option<wgpu::PipelineCache>,
    file: Option<PathBuf>,
    used: CacheUse,
    note: Option<String>,
}

impl DiskCache {
    /// The features to ask of `adapter` for a cache: `PIPELINE_CACHE` where it has it.
    pub(super) fn features(adapter: &wgpu::Adapter) -> wgpu::Features {
        adapter.features() & wgpu::Features::PIPELINE_CACHE
    }

    /// No cache.
    pub(super) fn off() -> DiskCache {
        DiskCache {
            cache: None,
            file: None,
            used: CacheUse::Off,
            note: None,
        }
    }

    /// The cache of `device` (opened on the adapter `info` describes, with `features`), from
    /// its file where there is one.
    pub(super) fn open(
        device: &wgpu::Device,
        info: &wgpu::AdapterInfo,
        features: wgpu::Features,
    ) -> DiskCache {
        let Some(key) = wgpu::util::pipeline_cache_key(info)
            .filter(|_| features.contains(wgpu::Features::PIPELINE_CACHE))
        else {
            return DiskCache::off();
        };
        let Some((dir, named)) = directory() else {
            return DiskCache::off();
        };
        if let Err(e) = std::fs::create_dir_all(&dir) {
            // Said only where the directory was named: a home without a cache is no news.
            let note = named.then(|| unusable(&dir, &e));
            return DiskCache {
                note,
                ..DiskCache::off()
            };
        }
        let file = dir.join(format!("tracer-{key}.bin"));
        let data = std::fs::read(&file).ok().filter(|d| !d.is_empty());
        let Some(empty) = created(device, None) else {
            return DiskCache::off();
        };
        let loaded = data.as_deref().and_then(|d| created(device, Some(d)));
        let (cache, used) = match (loaded, &data) {
            (Some(c), Some(d)) if took(&c, d, &empty) => (c, CacheUse::Hit),
            (Some(c), _) => (c, CacheUse::Cold),
            // No data, or data wgpu refused (made for another device): start empty.
            (None, _) => (empty, CacheUse::Cold),
        };
        DiskCache {
            cache: Some(cache),
            file: Some(file),
            used,
            note: None,
        }
    }

    /// The cache to create pipelines with, if any.
    pub(super) fn cache(&self) -> Option<&wgpu::PipelineCache> {
        self.cache.as_ref()
    }

    /// How the pipelines were created.
    pub(super) fn used(&self) -> CacheUse {
        self.used
    }

    /// What the user should know: the cache directory named cannot be used.
    pub(super) fn note(&self) -> Option<&str> {
        self.note.as_deref()
    }

    /// Writes the cache's data to its file, atomically (a temporary file beside it, then a
    /// rename), so that a reader never sees half of it. A failure only costs the next run
    /// its cache. One save at a time in a process: the threads compiling tracers
    /// (`Gpu::begin`) would otherwise write the same temporary file.
    pub(super) fn save(&self) {
        static SAVING: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let (Some(cache), Some(file)) = (&self.cache, &self.file) else {
            return;
        };
        let _one = SAVING.lock();
        let Some(data) = cache.get_data() else {
            return;
        };
        let temporary = file.with_extension(format!("tmp{}", std::process::id()));
        if std::fs::write(&temporary, &data).is_err() || std::fs::rename(&temporary, file).is_err()
        {
            let _ = std::fs::remove_file(&temporary);
        }
    }
}

/// The cache's directory: [`CACHE_VARIABLE`], else `$XDG_CACHE_HOME/raytrace`, else
/// `$HOME/.cache/raytrace` (the XDG base directory specification's default); none without
/// any of them. With it, whether the variable named it.
fn directory() -> Option<(PathBuf, bool)> {
    let set = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
    if let Some(dir) = set(CACHE_VARIABLE) {
        return Some((PathBuf::from(dir), true));
    }
    let dir = match set("XDG_CACHE_HOME") {
        Some(dir) => Path::new(&dir).join("raytrace"),
        None => Path::new(&set("HOME")?).join(".cache").join("raytrace"),
    };
    Some((dir, false))
}

/// Whether `cache`, created from `data`, took it and it holds pipelines: wgpu and the
/// driver drop data they refuse (`fallback`) without saying so, and a cache that dropped it
/// holds what `empty` holds (headers), where one that took it holds it all. A driver that
/// keeps no pipelines in the cache (lavapipe in Mesa 22.3) never writes more than headers.
fn took(cache: &wgpu::PipelineCache, data: &[u8], empty: &wgpu::PipelineCache) -> bool {
    let size = |c: &wgpu::PipelineCache| c.get_data().map_or(0, |d| d.len());
    data.len() > size(empty) && size(cache) >= data.len()
}

/// A pipeline cache on `device` from `data`, or `None` where wgpu refuses the data (a
/// header for another device: a validation error even with `fallback`).
#[allow(unsafe_code)]
fn created(device: &wgpu::Device, data: Option<&[u8]>) -> Option<wgpu::PipelineCache> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    // SAFETY: wgpu asks for data from `get_data` of a cache with the same key; the file is
    // named by that key and written only from `get_data`. Data that is not (a corrupt or
    // foreign file) is checked anyway: wgpu's header (magic, versions, adapter, length) and
    // then the driver's (Vulkan requires drivers to validate a pipeline cache's header),
    // with `fallback` making an empty cache of data they refuse.
    let cache = unsafe {
        device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
            label: Some("tracer"),
            data,
            fallback: true,
        })
    };
    match pollster::block_on(scope.pop()) {
        None => Some(cache),
        Some(_) => None,
    }
}

/// The note for a cache directory that cannot be made.
fn unusable(dir: &Path, e: &std::io::Error) -> String {
    format!(
        "the GPU's pipeline cache directory {} cannot be made ({e}): the shaders are compiled \
         without a cache; set {CACHE_VARIABLE} to a writable directory",
        dir.display()
    )
}
