//! Which OIDN device denoises a run's frames (`--denoise-device`): the GPU that traces them
//! when OIDN has a device for it, else the CPU ([`open`]).
//!
//! OIDN picks a physical device by an identifier a graphics API reports; wgpu's adapter
//! information gives the PCI address on Vulkan (`device_pci_bus_id`, from
//! `VK_EXT_pci_bus_info`: `domain:bus:device.function`, hexadecimal), which OIDN takes
//! (`oidnNewDeviceByPCIAddress`), so the filter runs on the very GPU that holds the film. OIDN
//! drives a GPU through a device module of its own release (CUDA, HIP, SYCL, Metal), beside
//! the library: a module missing, or a GPU it has none for, is a fallback to the CPU device
//! under `auto`, with a note, and an error under `gpu`.

use raytrace_core::scene::DenoiseDevice;

use crate::denoiser::{DenoiseError, describe};

/// The GPU a run traces on, as the denoiser looks for it: its name and its PCI address as
/// wgpu reports it (empty where the platform gives none).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TracingGpu {
    /// The adapter's name (`NVIDIA H100 80GB HBM3`).
    pub name: String,
    /// `domain:bus:device.function`, hexadecimal (`0000:01:00.0`), or empty.
    pub pci_bus_id: String,
}

/// An OIDN device opened for a run, with the words `--stats` names it by.
pub(crate) struct Opened {
    pub(crate) device: oidn::Device,
    /// `cpu`, or the device's kind and the GPU's name: `cuda (NVIDIA H100 80GB HBM3)`.
    pub(crate) name: String,
    /// Why `auto` fell back to the CPU, for one line on standard error.
    pub(crate) note: Option<String>,
}

/// The OIDN device `choice` asks for, for a run that traces on `traced_on` (none: the CPU).
pub(crate) fn open(
    choice: DenoiseDevice,
    traced_on: Option<&TracingGpu>,
) -> Result<Opened, DenoiseError> {
    let cpu = |note| -> Result<Opened, DenoiseError> {
        let device = oidn::Device::cpu().map_err(|e| DenoiseError::Unavailable(describe(&e)))?;
        Ok(Opened {
            device,
            name: "cpu".to_string(),
            note,
        })
    };
    match (choice, traced_on) {
        (DenoiseDevice::Cpu, _) | (DenoiseDevice::Auto, None) => cpu(None),
        (DenoiseDevice::Auto, Some(gpu)) => match on_gpu(Some(gpu)) {
            Ok(opened) => Ok(opened),
            Err(why) => cpu(Some(format!(
                "denoising on the CPU: Intel Open Image Denoise has no device for {} ({why})",
                gpu.name
            ))),
        },
        (DenoiseDevice::Gpu, gpu) => on_gpu(gpu).map_err(DenoiseError::NoGpu),
    }
}

/// An OIDN device on `gpu` (by its PCI address), or with none the first GPU OIDN finds; why
/// not, otherwise.
fn on_gpu(gpu: Option<&TracingGpu>) -> Result<Opened, String> {
    let device = match gpu {
        Some(g) => {
            let Some((domain, bus, dev, function)) = pci_address(&g.pci_bus_id) else {
                return Err(format!(
                    "the adapter reports no PCI address{}",
                    if g.pci_bus_id.is_empty() {
                        String::new()
                    } else {
                        format!(" OIDN can use (\"{}\")", g.pci_bus_id)
                    }
                ));
            };
            oidn::Device::by_pci_address(domain, bus, dev, function)
        }
        None => oidn::Device::new(),
    }
    .map_err(|e| describe(&e))?;
    let kind = gpu_kind(device.device_type()).ok_or_else(|| {
        "no GPU device module of Intel Open Image Denoise found one (it found only the CPU)"
            .to_string()
    })?;
    let name = match gpu {
        Some(g) => format!("{kind} ({})", g.name),
        None => kind.to_string(),
    };
    Ok(Opened {
        device,
        name,
        note: None,
    })
}

/// The word for an OIDN GPU device's type, or `None` for the CPU.
fn gpu_kind(device_type: oidn::sys::OIDNDeviceType) -> Option<&'static str> {
    use oidn::sys::{
        OIDNDeviceType_OIDN_DEVICE_TYPE_CUDA as CUDA, OIDNDeviceType_OIDN_DEVICE_TYPE_HIP as HIP,
        OIDNDeviceType_OIDN_DEVICE_TYPE_METAL as METAL,
        OIDNDeviceType_OIDN_DEVICE_TYPE_SYCL as SYCL,
    };
    [
        (CUDA, "cuda"),
        (HIP, "hip"),
        (SYCL, "sycl"),
        (METAL, "metal"),
    ]
    .into_iter()
    .find(|(t, _)| *t == device_type)
    .map(|(_, word)| word)
}

/// A PCI address `domain:bus:device.function` in hexadecimal (`0000:c1:00.0`) as numbers,
/// or `None` where `text` is not one.
fn pci_address(text: &str) -> Option<(i32, i32, i32, i32)> {
    let (domain, rest) = text.split_once(':')?;
    let (bus, rest) = rest.split_once(':')?;
    let (device, function) = rest.split_once('.')?;
    let hex = |s: &str| i32::from_str_radix(s, 16).ok().filter(|v| *v >= 0);
    Some((hex(domain)?, hex(bus)?, hex(device)?, hex(function)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pci_addresses_read_as_wgpu_writes_them() {
        assert_eq!(pci_address("0000:01:00.0"), Some((0, 1, 0, 0)));
        assert_eq!(pci_address("0001:c1:1f.7"), Some((1, 0xc1, 0x1f, 7)));
        for bad in ["", "01:00.0", "0000:01:00", "0000:zz:00.0", "0000:01:-1.0"] {
            assert_eq!(pci_address(bad), None, "{bad}");
        }
    }

    #[test]
    fn the_cpu_is_the_cpu_and_auto_without_a_gpu_takes_it() {
        crate::library::load().unwrap();
        for choice in [DenoiseDevice::Cpu, DenoiseDevice::Auto] {
            let opened = open(choice, None).unwrap();
            assert_eq!(opened.name, "cpu");
            assert_eq!(opened.note, None);
            assert_eq!(
                opened.device.device_type(),
                oidn::sys::OIDNDeviceType_OIDN_DEVICE_TYPE_CPU
            );
        }
    }

    #[test]
    fn auto_falls_back_to_the_cpu_with_a_note_where_oidn_has_no_device_for_the_gpu() {
        // A GPU OIDN cannot have: no PCI address, and an address no machine has.
        crate::library::load().unwrap();
        for pci in ["", "ffff:ff:1f.7"] {
            let gpu = TracingGpu {
                name: "Some GPU".to_string(),
                pci_bus_id: pci.to_string(),
            };
            let opened = open(DenoiseDevice::Auto, Some(&gpu)).unwrap();
            assert_eq!(opened.name, "cpu");
            let note = opened.note.unwrap();
            assert!(
                note.starts_with(
                    "denoising on the CPU: Intel Open Image Denoise has no device for Some GPU ("
                ),
                "{note}"
            );
            // `gpu` asks for one: an error, naming why.
            let e = open(DenoiseDevice::Gpu, Some(&gpu)).err().unwrap();
            assert!(matches!(e, DenoiseError::NoGpu(_)), "{e}");
            assert!(e.to_string().contains("--denoise-device"), "{e}");
        }
    }
}
