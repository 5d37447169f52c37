//! The devices a run renders with, opened once from what its scenes need: the one place that
//! decides whether a run needs the GPU and the denoiser ([`Needs`]), opens them before
//! anything is written ([`Devices::open_for`]), and gives each shot its tracer
//! ([`Devices::shot`]) and its finishing ([`Devices::finishing`]).

use crate::finish::Finishing;
use raytrace_core::error::Error;
use raytrace_core::renderer::{CpuShot, ShotTracer};
use raytrace_core::scene::{DenoiseDevice, Device, Scene};
use raytrace_denoise::denoiser::Denoiser;
use raytrace_denoise::device::TracingGpu;
use raytrace_gpu::{Adapter, Gpu, GpuShot, Unsupported, unsupported};
use raytrace_scene::scene_file::Overrides;

/// What a set of scenes needs opened to render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Needs {
    /// A scene traces on the GPU.
    pub gpu: bool,
    /// A scene's frames are denoised.
    pub denoiser: bool,
    /// Where the denoiser runs (`--denoise-device`, the same for every scene of a run).
    pub denoise_device: DenoiseDevice,
}

impl Needs {
    /// What `scenes` need: the rule, written once.
    pub fn of<'a>(scenes: impl IntoIterator<Item = &'a Scene>) -> Needs {
        scenes.into_iter().fold(Needs::default(), |n, s| Needs {
            gpu: n.gpu || s.render.device == Device::Gpu,
            denoiser: n.denoiser || s.output.denoise.is_some(),
            denoise_device: s.output.denoise.map_or(n.denoise_device, |d| d.device),
        })
    }
}

/// The GPU and the denoiser a run has opened (none until a scene needs them). Cheap to clone:
/// the clones share the devices.
#[derive(Clone, Default)]
pub struct Devices {
    gpu: Option<Gpu>,
    denoiser: Option<std::sync::Arc<Denoiser>>,
    /// Whether [`Devices::gpu_startup_once`] has given the GPU's start-up.
    startup_given: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl Devices {
    /// The devices `scenes` need, opened ([`open`](Self::open)).
    pub fn for_scenes<'a>(scenes: impl IntoIterator<Item = &'a Scene>) -> Result<Devices, Error> {
        Devices::opened(Needs::of(scenes))
    }

    /// The devices `needs` says, opened ([`open`](Self::open)).
    pub fn opened(needs: Needs) -> Result<Devices, Error> {
        let mut devices = Devices::default();
        devices.open(needs)?;
        Ok(devices)
    }

    /// Opens what `scenes` need that is not open yet ([`open`](Self::open)).
    pub fn open_for<'a>(
        &mut self,
        scenes: impl IntoIterator<Item = &'a Scene>,
    ) -> Result<(), Error> {
        self.open(Needs::of(scenes))
    }

    /// Opens what `needs` says that is not open yet: the GPU (on a software adapter, a
    /// warning on standard error says so, whatever `--quiet` says: the CPU renders faster
    /// there) and the denoiser, on the GPU the run traces on where `--denoise-device` lets
    /// it and OIDN has a device for it (where `auto` falls back to the CPU, a note on
    /// standard error says why). A device that cannot open is an error, before any frame is
    /// rendered.
    pub fn open(&mut self, needs: Needs) -> Result<(), Error> {
        if needs.gpu && self.gpu.is_none() {
            let gpu = Gpu::new()?;
            if let Some(note) = gpu.software_note() {
                eprintln!("warning: {note}");
            }
            if let Some(note) = gpu.cache_note() {
                eprintln!("note: {note}");
            }
            self.gpu = Some(gpu);
        }
        if needs.denoiser && self.denoiser.is_none() {
            // A software adapter is the CPU: the denoiser's CPU device is the one for it.
            let traced_on = self.gpu.as_ref().filter(|g| !g.is_software()).map(|g| {
                let (name, pci_bus_id) = g.name_and_pci_bus_id();
                TracingGpu { name, pci_bus_id }
            });
            let denoiser = Denoiser::new(needs.denoise_device, traced_on.as_ref())?;
            if let Some(note) = denoiser.note() {
                eprintln!("note: {note}");
            }
            self.denoiser = Some(std::sync::Arc::new(denoiser));
        }
        Ok(())
    }

    /// The denoiser's device as `--stats` names it (`cpu`, `cuda (NVIDIA H100 ...)`), when a
    /// scene opened it.
    pub fn denoiser_name(&self) -> Option<&str> {
        self.denoiser.as_deref().map(Denoiser::name)
    }

    /// The GPU and its start-up, as `--stats` says them once a run (`llvmpipe (...),
    /// start-up 0.180 s (...)`, [`Gpu::startup`]): the first time it is asked for once the
    /// GPU is open, after a shot on it is made (its tracer compiled beside the shot's build);
    /// None after, or without a GPU.
    pub fn gpu_startup_once(&self) -> Option<String> {
        use std::sync::atomic::Ordering;
        let g = self.gpu.as_ref()?;
        let first = !self.startup_given.swap(true, Ordering::Relaxed);
        first.then(|| format!("{}, {}", g.describe(), g.startup()))
    }

    /// `scene`'s shot on the device its `[render] device` names: its still geometry built,
    /// and on the GPU uploaded.
    pub fn shot(&self, scene: &Scene) -> Result<Box<dyn ShotTracer>, Error> {
        match scene.render.device {
            Device::Cpu => Ok(Box::new(CpuShot::new(scene))),
            Device::Gpu => Ok(Box::new(GpuShot::new(opened(&self.gpu)?, scene)?)),
        }
    }

    /// The stages that finish `scene`'s frames (its denoising with the run's denoiser, its
    /// history).
    pub fn finishing(&self, scene: &Scene) -> Result<Finishing<'_>, Error> {
        let denoiser = match scene.output.denoise {
            Some(_) => Some(opened(&self.denoiser)?.as_ref()),
            None => None,
        };
        Finishing::new(scene, denoiser)
    }
}

/// A device [`Devices::open`] opened, or the error of a run that did not open it first.
fn opened<T>(device: &Option<T>) -> Result<&T, Error> {
    device.as_ref().ok_or_else(|| {
        Error::resource("a scene needs a device its run did not open (Devices::open_for)")
    })
}

/// `scene` (validated with `overrides`) itself, or bad input ([`Error::Scene`], exit status
/// 2) when it asks for the GPU and the GPU does not render it ([`unsupported`]: numbers a
/// 32-bit float cannot carry, spheres beyond what the GPU binds): the message names the
/// file, the field or flag that chose the GPU (`shot.toml: --device gpu: ...`,
/// `shot.toml: render.device = "gpu": ...`), what is beyond the GPU's limits and the way out
/// (`--device cpu`). Every command that renders or checks a scene asks this as it validates
/// the scene, before anything else is checked of it; a scene with point caches is asked
/// again once their files are surveyed ([`room_for_points`]).
pub fn supported(scene: Scene, overrides: &Overrides) -> Result<Scene, Error> {
    if scene.render.device != Device::Gpu {
        return Ok(scene);
    }
    match unsupported(&scene) {
        Some(why) => Err(refusal(&scene, overrides, why)),
        None => Ok(scene),
    }
}

/// Nothing, or bad input as [`supported`] says it, when `scene` asks for the GPU and its
/// words with `points` points in a frame (the most a frame of the run holds, from its point
/// caches' survey) could take more than the GPU binds ([`raytrace_gpu::too_large`]).
pub fn room_for_points(scene: &Scene, overrides: &Overrides, points: u64) -> Result<(), Error> {
    if scene.render.device != Device::Gpu || points == 0 {
        return Ok(());
    }
    match raytrace_gpu::too_large(scene, points) {
        Some(why) => Err(refusal(scene, overrides, why)),
        None => Ok(()),
    }
}

/// The error of a scene the GPU does not render, `why`, as [`supported`] words it.
fn refusal(scene: &Scene, overrides: &Overrides, why: Unsupported) -> Error {
    let file = raytrace_core::error::elide_path(&scene.source);
    // The file is named either way: with several scenes, `--device gpu` alone does not say
    // which one the GPU refuses.
    let chosen = if overrides.device.is_some() {
        format!("{file}: --device gpu")
    } else {
        format!("{file}: render.device = \"gpu\"")
    };
    if let Unsupported::TooLarge { .. } = why {
        return Error::Scene(format!(
            "{chosen}: the GPU has not the room for this scene: {why}; render it with --device cpu"
        ));
    }
    Error::Scene(format!(
        "{chosen}: the GPU computes in 32-bit floats and does not render this scene: {why}; render it with --device cpu"
    ))
}

/// The line `check` gives for the GPU: the adapter a render would take, or why there is none
/// (a check opens none).
pub fn adapter_line() -> String {
    match Adapter::find() {
        Ok(a) => match a.software_note() {
            Some(_) => format!(
                "{}, a software device (it runs on the CPU, where --device cpu renders faster)",
                a.describe()
            ),
            None => a.describe(),
        },
        Err(e) => format!("none here, which rendering needs ({e})"),
    }
}

#[cfg(test)]
mod tests {
    use raytrace_scene::scene_file::SceneFile;
    use std::path::Path;

    use super::*;

    #[test]
    fn a_scene_the_gpu_floats_cannot_carry_is_refused_for_the_gpu_only() {
        // Naming the file's field or the flag that chose the GPU; the CPU takes it.
        let far = "[[sphere]]\ncenter = [1e6, 0.0, 0.0]\nradius = 1e-4\nmaterial = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\n";
        let load = |text: &str, overrides: &Overrides| {
            let scene = Scene::parse_with(text, Path::new("s.toml"), overrides).unwrap();
            supported(scene, overrides)
        };
        let none = Overrides::default();
        assert_eq!(load(far, &none).unwrap().render.device, Device::Cpu);
        let e = load(&format!("[render]\ndevice = \"gpu\"\n{far}"), &none)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("s.toml: render.device = \"gpu\": the GPU computes in 32-bit floats")
                && e.contains("sphere[0].radius 0.0001")
                && e.ends_with("render it with --device cpu"),
            "{e}"
        );
        let gpu = Overrides {
            device: Some(Device::Gpu),
            ..Overrides::default()
        };
        let e = load(far, &gpu).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(e.to_string().starts_with("s.toml: --device gpu: "), "{e}");
    }
}
