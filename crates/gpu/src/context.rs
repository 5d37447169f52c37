//! The GPU itself: finding an adapter through wgpu (Vulkan, Metal or DirectX 12), opening a
//! device, compiling the tracer's compute shader once (on its own thread, beside the shot's
//! build), and the errors a device can give.

use std::fmt;
use std::sync::{Arc, Mutex, OnceLock};
use std::thread::JoinHandle;
use std::time::Instant;

use super::disk_cache::DiskCache;

use super::layout::{
    COUNTER_WORDS, Counting, FRAME_PAGES, FRAME_WORDS, PARAMS_WORDS, SHOT_PAGES, WORKGROUP,
    wgsl_prelude,
};
use super::pages::Pages;
use super::quiet::without_stray_lines;
use super::startup::Startup;

/// The shaders' text, put after the layout's constants: the 64-bit words and samplers, the
/// geometry (motions, spheres, hierarchies), the camera and time, the materials, the tracer.
const SHADERS: &str = concat!(
    include_str!("shaders/words.wgsl"),
    include_str!("shaders/sampler.wgsl"),
    include_str!("shaders/geometry.wgsl"),
    include_str!("shaders/camera.wgsl"),
    include_str!("shaders/material.wgsl"),
    include_str!("shaders/trace.wgsl"),
);

/// The environment variable that makes the device lost after that many dispatches: a fault
/// injected on purpose, for the tests of what a lost device leaves behind.
pub const LOSE_AFTER_VARIABLE: &str = "RAYTRACE_GPU_LOSE_AFTER";

/// The environment variable that caps the storage binding (and buffer) size a device is
/// opened with, in bytes, below the adapter's own: the way the tests run the paths that
/// split a scene's words over several bindings ([`Pages`]) and a film into parts on a device
/// whose real limits a test scene would never reach.
pub const MAX_BINDING_VARIABLE: &str = "RAYTRACE_GPU_MAX_BINDING";

/// What can go wrong with a GPU.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GpuError {
    /// No adapter was found: the message says what was looked for and how to get one.
    NoAdapter(String),
    /// The device was lost (a driver reset, a GPU removed, a fault injected).
    Lost(String),
    /// The device ran out of memory.
    OutOfMemory(String),
    /// Anything else the device or the driver reported.
    Failed(String),
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GpuError::NoAdapter(m) => write!(f, "{m}"),
            GpuError::Lost(m) => write!(f, "the GPU device was lost: {m}"),
            GpuError::OutOfMemory(m) => write!(f, "the GPU ran out of memory: {m}"),
            GpuError::Failed(m) => write!(f, "the GPU failed: {m}"),
        }
    }
}

impl std::error::Error for GpuError {}

impl From<GpuError> for raytrace_core::error::Error {
    fn from(e: GpuError) -> Self {
        raytrace_core::error::Error::Resource(Box::new(e))
    }
}

/// An open GPU device, and once [`Gpu::fitting`] gave it one, the tracer's pipeline. Cheap to
/// clone (wgpu's handles are shared).
#[derive(Clone, Debug)]
pub struct Gpu {
    pub(super) device: wgpu::Device,
    pub(super) queue: wgpu::Queue,
    /// The tracer this handle dispatches ([`Gpu::tracer`]): compiled for [`Tracer::pages`]
    /// pages of words. None on the device [`Gpu::new`] opens, whose tracer is still being
    /// compiled.
    tracer: Option<Arc<Tracer>>,
    /// The tracers begun so far, by their pages less one, shared by the clones
    /// ([`Gpu::begin`], [`Gpu::fitting`]).
    tracers: Arc<Mutex<Vec<Option<Compiling>>>>,
    /// How the shot's and the frame's words may lie over bindings at most.
    pages: Pages,
    counting: Counting,
    /// The pipeline cache the tracers are created with, and its file.
    cache: Arc<DiskCache>,
    /// How long the device and its tracers took, and how long the run waited for them.
    startup: Arc<Mutex<Startup>>,
    adapter: wgpu::Adapter,
    info: wgpu::AdapterInfo,
    /// The first fault the device reported on its own (lost, an error outside any scope).
    fault: Arc<Mutex<Option<GpuError>>>,
    /// Dispatches so far, and after how many the device is lost on purpose.
    dispatches: Arc<Mutex<(u64, Option<u64>)>>,
}

/// The tracer's pipeline compiled for words over some number of pages: each page more is a
/// branch at every read of the words, which lavapipe's compiler pays for in memory (the
/// empty scene's peak: 127 MiB with one page, 214 MiB with four), so a shot takes the
/// fewest pages its words need.
#[derive(Debug)]
pub(super) struct Tracer {
    pub(super) pipeline: wgpu::ComputePipeline,
    /// The sampler's numbers alone, for the tests that compare them with the CPU's.
    #[cfg(test)]
    pub(super) numbers: wgpu::ComputePipeline,
    pub(super) layout: wgpu::BindGroupLayout,
    /// How the shot's and the frame's words lie over its bindings.
    pub(super) pages: Pages,
}

/// A tracer being compiled on its own thread, or compiled (or its compilation's error).
#[derive(Debug)]
enum Compiling {
    /// The thread compiling it, begun at `begun`: it gives the tracer and when it was done.
    Running {
        thread: JoinHandle<(Result<Tracer, GpuError>, Instant)>,
        begun: Instant,
    },
    /// Its thread's result, and when the thread was done with it.
    Done {
        tracer: Result<Arc<Tracer>, GpuError>,
        done: Instant,
    },
}

/// The adapter a render takes: of those wgpu finds on Vulkan, Metal or DirectX 12, the first
/// by kind (a discrete GPU, an integrated one, a virtual one, another, and last a software
/// device such as lavapipe, llvmpipe or WARP, which run on the CPU).
#[derive(Debug)]
pub struct Adapter {
    adapter: wgpu::Adapter,
    info: wgpu::AdapterInfo,
}

impl Adapter {
    /// Finds the adapter. Without one: [`GpuError::NoAdapter`], naming what was looked for and
    /// how to get it.
    pub fn find() -> Result<Adapter, GpuError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::PRIMARY,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapters = without_stray_lines(|| {
            pollster::block_on(instance.enumerate_adapters(wgpu::Backends::PRIMARY))
        });
        let rank = |t: wgpu::DeviceType| match t {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Other => 3,
            wgpu::DeviceType::Cpu => 4,
        };
        // The first of the best kind, in wgpu's order.
        let best = adapters
            .into_iter()
            .map(|adapter| {
                let info = adapter.get_info();
                Adapter { adapter, info }
            })
            .min_by_key(|a| rank(a.info.device_type));
        match best {
            Some(a) => Ok(a),
            None => {
                // wgpu's own account of why there is none.
                let why = without_stray_lines(|| {
                    pollster::block_on(instance.request_adapter(&Default::default()))
                })
                .err()
                .map_or("none listed".to_string(), |e| e.to_string());
                Err(GpuError::NoAdapter(no_adapter(&why)))
            }
        }
    }

    /// The limits a device is opened with on this adapter: the adapter's own (not WebGPU's
    /// floor: Vulkan on NVIDIA binds 4 GiB a storage buffer where WebGPU guarantees 128 MiB),
    /// the binding and buffer sizes capped by [`MAX_BINDING_VARIABLE`] where it is set.
    pub fn limits(&self) -> wgpu::Limits {
        capped(self.adapter.limits())
    }

    /// How a device opened on this adapter lays the shot's and the frame's words over its
    /// bindings, and so how many bytes of each it holds.
    pub fn pages(&self) -> Pages {
        Pages::of(&self.limits())
    }

    /// The adapter, as frame lines and docs name it: `llvmpipe (LLVM 15.0.6, 256 bits)
    /// (vulkan, Mesa 22.3.6 (LLVM 15.0.6))`.
    pub fn describe(&self) -> String {
        let driver = if self.info.driver_info.is_empty() {
            self.info.driver.clone()
        } else {
            self.info.driver_info.clone()
        };
        format!("{} ({}, {driver})", self.info.name, self.info.backend)
    }

    /// Whether the adapter is a software one (a device that runs on the CPU: lavapipe,
    /// llvmpipe, WARP).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// For a software adapter, what the user should know: it runs on the CPU, where the CPU
    /// tracer is faster, and no hardware GPU was found.
    pub fn software_note(&self) -> Option<String> {
        self.is_software().then(|| {
            format!(
                "the GPU device found is a software one, {}: it runs on this machine's CPU, \
                 where --device cpu renders the same image faster. No hardware GPU was found: \
                 is its Vulkan driver installed, and visible here (a container needs the GPU's \
                 graphics capability)?",
                self.describe()
            )
        })
    }
}

impl Gpu {
    /// Opens the adapter [`Adapter::find`] takes and begins compiling the tracer of one page
    /// ([`Gpu::open`]). Without an adapter: [`GpuError::NoAdapter`], naming what was looked
    /// for and how to get it.
    pub fn new() -> Result<Gpu, GpuError> {
        let start = Instant::now();
        let gpu = Gpu::open(Adapter::find()?)?;
        // The adapter's search counts with the device's opening.
        gpu.startup.lock().unwrap().device_seconds = start.elapsed().as_secs_f64();
        Ok(gpu)
    }

    /// Opens a device on `adapter` with its limits ([`Adapter::limits`]) and begins
    /// compiling the tracer of one page on its own thread: the shot is built and uploaded
    /// meanwhile, then waits for it ([`GpuShot::new`](super::GpuShot::new), [`Gpu::fitting`]).
    /// A shader the device refuses is an error there.
    pub fn open(adapter: Adapter) -> Result<Gpu, GpuError> {
        let limits = adapter.limits();
        Gpu::open_limited(adapter, limits)
    }

    /// Opens a device on `adapter` with `limits` (within the adapter's) and begins compiling
    /// the tracer for them ([`Gpu::open`]).
    pub(super) fn open_limited(adapter: Adapter, limits: wgpu::Limits) -> Result<Gpu, GpuError> {
        let start = Instant::now();
        let pages = Pages::of(&limits);
        let Adapter { adapter, info } = adapter;
        let (counting, features) = match adapter.features().contains(wgpu::Features::SUBGROUP) {
            true => (Counting::Subgroups, wgpu::Features::SUBGROUP),
            false => (Counting::Atomics, wgpu::Features::empty()),
        };
        let features = features | DiskCache::features(&adapter);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("raytrace"),
            required_features: features,
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| GpuError::Failed(format!("{} ({}): {e}", info.name, info.backend)))?;
        let fault = watch_faults(&device);
        let cache = DiskCache::open(&device, &info, features);
        let startup = Startup {
            device_seconds: start.elapsed().as_secs_f64(),
            pipelines_seconds: 0.0,
            waited_seconds: 0.0,
            cache: cache.used(),
        };
        let lose_after = std::env::var(LOSE_AFTER_VARIABLE)
            .ok()
            .and_then(|v| v.parse().ok());
        let gpu = Gpu {
            device,
            queue,
            tracer: None,
            tracers: Arc::new(Mutex::new(vec![])),
            pages,
            counting,
            cache: Arc::new(cache),
            startup: Arc::new(Mutex::new(startup)),
            adapter,
            info,
            fault,
            dispatches: Arc::new(Mutex::new((0, lose_after))),
        };
        // Most shots' words fit one page (a binding of 4 GiB on NVIDIA's Vulkan).
        gpu.begin(0);
        Ok(gpu)
    }

    /// The adapter, as [`Adapter::describe`] names it.
    pub fn describe(&self) -> String {
        self.adapter().describe()
    }

    /// How long the device and its tracers took to start, how long the run waited for the
    /// tracers, and whether the pipeline cache served, as `--stats` says it: `start-up
    /// 0.180 s (adapter and device 0.120 s, pipelines 0.292 s beside the shot's build,
    /// 0.060 s of them waited for, cache hit)` ([`Startup`]). Said once a shot is made (its
    /// tracers compiled); tracers still compiling then are waited for here, uncounted.
    pub fn startup(&self) -> String {
        let running = self.tracers.lock().unwrap().len();
        for k in 0..running {
            // Only a compilation's error, which the shot that needs it reports.
            let _ = self.joined(k);
        }
        self.startup.lock().unwrap().to_string()
    }

    /// What the user should know of the pipeline cache: the directory named for it cannot
    /// be made (the shaders are then compiled without one).
    pub fn cache_note(&self) -> Option<&str> {
        self.cache.note()
    }

    /// How the shot's and the frame's words may lie over the device's bindings at most.
    pub fn pages(&self) -> Pages {
        self.pages
    }

    /// The tracer this handle dispatches. Only a handle [`Gpu::fitting`] gave dispatches.
    pub(super) fn tracer(&self) -> &Tracer {
        self.tracer
            .as_deref()
            .expect("a GPU handle dispatches once Gpu::fitting gave it its tracer")
    }

    /// Begins compiling, on its own thread, the tracer for `bytes` of words (the fewest pages
    /// that hold them, [`Pages::holding`]), unless it is begun already: once a device for each
    /// number of pages. The thread saves the pipeline cache when done.
    pub(super) fn begin(&self, bytes: u64) {
        let pages = self.pages.holding(bytes);
        let k = pages.count() as usize - 1;
        let mut tracers = self.tracers.lock().unwrap();
        if tracers.len() <= k {
            tracers.resize_with(k + 1, || None);
        }
        if tracers[k].is_some() {
            return;
        }
        let (device, counting, cache) = (self.device.clone(), self.counting, self.cache.clone());
        let begun = Instant::now();
        let thread = std::thread::Builder::new()
            .name(format!("tracer of {} pages", pages.count()))
            .spawn(move || {
                let tracer = compile(&device, counting, pages, &cache);
                cache.save();
                (tracer, Instant::now())
            });
        tracers[k] = Some(match thread {
            Ok(thread) => Compiling::Running { thread, begun },
            Err(e) => Compiling::Done {
                tracer: Err(GpuError::Failed(format!(
                    "no thread to compile the tracer on: {e}"
                ))),
                done: begun,
            },
        });
    }

    /// This device with the tracer for `bytes` of words (the larger of a shot's and its
    /// frames'), compiled for the fewest pages that hold them ([`Gpu::begin`]): waited for
    /// where its thread is still compiling it, the wait counted in the start-up.
    pub(super) fn fitting(&self, bytes: u64) -> Result<Gpu, GpuError> {
        self.begin(bytes);
        let k = self.pages.holding(bytes).count() as usize - 1;
        let start = Instant::now();
        let (tracer, done) = self.joined(k)?;
        // Until the thread was done, not until this one woke: so the wait is never more than
        // the compilation, which began before it.
        self.startup.lock().unwrap().waited_seconds +=
            done.saturating_duration_since(start).as_secs_f64();
        Ok(Gpu {
            tracer: Some(tracer),
            ..self.clone()
        })
    }

    /// The tracer of slot `k` (begun) and when its thread was done, the thread joined if it
    /// is still running, its seconds from begun to done counted in the start-up.
    fn joined(&self, k: usize) -> Result<(Arc<Tracer>, Instant), GpuError> {
        let mut tracers = self.tracers.lock().unwrap();
        let slot = &mut tracers[k];
        if let Some(Compiling::Running { .. }) = slot {
            let Some(Compiling::Running { thread, begun }) = slot.take() else {
                unreachable!("the slot was running")
            };
            *slot = Some(match thread.join() {
                Ok((tracer, done)) => {
                    self.startup.lock().unwrap().pipelines_seconds +=
                        done.saturating_duration_since(begun).as_secs_f64();
                    Compiling::Done {
                        tracer: tracer.map(Arc::new),
                        done,
                    }
                }
                Err(_) => Compiling::Done {
                    tracer: Err(GpuError::Failed(
                        "the thread compiling the tracer panicked".into(),
                    )),
                    done: Instant::now(),
                },
            });
        }
        match slot {
            Some(Compiling::Done { tracer, done }) => tracer.clone().map(|t| (t, *done)),
            _ => unreachable!("a tracer is begun before it is joined"),
        }
    }

    /// The adapter's name (`NVIDIA H100 80GB HBM3`) and its PCI address as the platform
    /// reports it (`0000:01:00.0`; empty where it gives none): what a denoiser looks for to
    /// run on the same GPU.
    pub fn name_and_pci_bus_id(&self) -> (String, String) {
        (self.info.name.clone(), self.info.device_pci_bus_id.clone())
    }

    /// Whether the adapter is a software one ([`Adapter::is_software`]).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// For a software adapter, what the user should know ([`Adapter::software_note`]).
    pub fn software_note(&self) -> Option<String> {
        self.adapter().software_note()
    }

    fn adapter(&self) -> Adapter {
        Adapter {
            adapter: self.adapter.clone(),
            info: self.info.clone(),
        }
    }

    /// The fault the device reported on its own, if any.
    pub(super) fn fault(&self) -> Option<GpuError> {
        self.fault.lock().map(|f| f.clone()).unwrap_or(None)
    }

    /// Counts a dispatch; loses the device on purpose when [`LOSE_AFTER_VARIABLE`] says so.
    pub(super) fn count_dispatch(&self) {
        let Ok(mut d) = self.dispatches.lock() else {
            return;
        };
        d.0 += 1;
        if d.1.is_some_and(|n| d.0 > n) {
            self.device.destroy();
        }
    }
}

/// Where the first fault `device` reports on its own (lost, an error outside any scope) is
/// kept: its callbacks set to keep it there.
fn watch_faults(device: &wgpu::Device) -> Arc<Mutex<Option<GpuError>>> {
    let fault = Arc::new(Mutex::new(None));
    let lost = fault.clone();
    device.set_device_lost_callback(move |_, message| {
        record(&lost, GpuError::Lost(message));
    });
    let uncaptured = fault.clone();
    device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
        record(&uncaptured, classify(&e));
    }));
    fault
}

/// The tracer's bindings, as `shaders/words.wgsl` and the prelude declare them: the work and
/// the film (2, 3), at a dispatch's offset the parameters (4) and the counters (7), and the
/// pages of the shot's and the frame's words (from [`SHOT_PAGES`] and [`FRAME_PAGES`]), and
/// on a tracer of one page the frame's words again as words ([`FRAME_WORDS`]).
fn bind_group_layout(device: &wgpu::Device, pages: &Pages) -> wgpu::BindGroupLayout {
    let mut entries = vec![
        storage(2, false),
        storage(3, false),
        slot(4, wgpu::BufferBindingType::Uniform, PARAMS_WORDS),
        slot(
            7,
            wgpu::BufferBindingType::Storage { read_only: false },
            COUNTER_WORDS,
        ),
    ];
    for k in 0..pages.count() {
        entries.push(storage(SHOT_PAGES + k, true));
        entries.push(storage(FRAME_PAGES + k, true));
    }
    if pages.count() == 1 {
        entries.push(storage(FRAME_WORDS, true));
    }
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("tracer"),
        entries: &entries,
    })
}

/// `limits` with the binding and buffer sizes capped by [`MAX_BINDING_VARIABLE`] where it is
/// set.
pub(super) fn capped(mut limits: wgpu::Limits) -> wgpu::Limits {
    if let Some(cap) = binding_cap() {
        limits.max_storage_buffer_binding_size = limits.max_storage_buffer_binding_size.min(cap);
        limits.max_buffer_size = limits.max_buffer_size.min(cap);
    }
    limits
}

/// How the adapter a render would take ([`Adapter::find`]) lays words over its bindings,
/// looked up once a process; without an adapter, what every device binds.
pub(super) fn pages_here() -> Pages {
    static PAGES: OnceLock<Pages> = OnceLock::new();
    *PAGES.get_or_init(|| Adapter::find().map_or_else(|_| Pages::guaranteed(), |a| a.pages()))
}

/// The cap [`MAX_BINDING_VARIABLE`] sets, bytes, if any (at least a quad: 16 bytes).
fn binding_cap() -> Option<u64> {
    let cap: u64 = std::env::var(MAX_BINDING_VARIABLE)
        .ok()?
        .trim()
        .parse()
        .ok()?;
    Some(cap.max(16))
}

/// The tracer for words over `pages`, compiled on `device` with `cache`'s pipeline cache:
/// an invalid shader is an error.
fn compile(
    device: &wgpu::Device,
    counting: Counting,
    pages: Pages,
    cache: &DiskCache,
) -> Result<Tracer, GpuError> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("tracer"),
        source: wgpu::ShaderSource::Wgsl(
            format!("{}{SHADERS}", wgsl_prelude(counting, &pages)).into(),
        ),
    });
    let layout = bind_group_layout(device, &pages);
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("tracer"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let entry = |label, function| Entry {
        layout: &pipeline_layout,
        module: &module,
        label,
        function,
        cache: cache.cache(),
    };
    let pipeline = entry_pipeline(device, entry("tracer", "trace"));
    #[cfg(test)]
    let numbers = entry_pipeline(device, entry("numbers", "numbers"));
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(GpuError::Failed(format!("the tracer's shader: {e}")));
    }
    Ok(Tracer {
        pipeline,
        #[cfg(test)]
        numbers,
        layout,
        pages,
    })
}

/// A compute pipeline to create: `module`'s `function`, named `label`.
struct Entry<'a> {
    layout: &'a wgpu::PipelineLayout,
    module: &'a wgpu::ShaderModule,
    label: &'a str,
    function: &'a str,
    cache: Option<&'a wgpu::PipelineCache>,
}

/// The compute pipeline `entry` describes.
fn entry_pipeline(device: &wgpu::Device, entry: Entry<'_>) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry.label),
        layout: Some(entry.layout),
        module: entry.module,
        entry_point: Some(entry.function),
        compilation_options: Default::default(),
        cache: entry.cache,
    })
}

/// Keeps the first fault.
fn record(slot: &Mutex<Option<GpuError>>, e: GpuError) {
    if let Ok(mut f) = slot.lock()
        && f.is_none()
    {
        *f = Some(e);
    }
}

/// A wgpu error as one of ours.
pub(super) fn classify(e: &wgpu::Error) -> GpuError {
    match e {
        wgpu::Error::OutOfMemory { .. } => GpuError::OutOfMemory(e.to_string()),
        _ => GpuError::Failed(e.to_string()),
    }
}

/// The message for no adapter: what was looked for and how to get one.
fn no_adapter(why: &str) -> String {
    format!(
        "no GPU found: wgpu looked for a Vulkan, Metal or DirectX 12 adapter and found none \
         ({why}). Install your GPU's driver with Vulkan support; without a GPU, Mesa's \
         software Vulkan device (lavapipe) serves, on Debian or Ubuntu: `apt-get install \
         mesa-vulkan-drivers`. Or render on the CPU: --device cpu"
    )
}

/// A binding of the compute stage at a dynamic offset (a dispatch's slot), `words` long.
fn slot(binding: u32, ty: wgpu::BufferBindingType, words: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: true,
            min_binding_size: std::num::NonZeroU64::new(4 * words as u64),
        },
        count: None,
    }
}

/// A storage buffer binding of the compute stage.
fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Workgroups for `n` invocations.
pub(super) fn workgroups(n: u32) -> u32 {
    n.div_ceil(WORKGROUP)
}
