//! The denoiser: Intel Open Image Denoise's `RT` filter on the device `--denoise-device` picks
//! ([`crate::device`]: the GPU that traces, or the CPU), through the `oidn` crate (vendored:
//! vendor/README.md). On a GPU device a run uploads the image and reads the result back (the
//! `oidn` crate's copies); the rest of finishing stays on the host.
//!
//! The filter reads three channels of an image (linear HDR radiance) and gives them back
//! denoised (OIDN takes them interleaved, a pixel after another). It takes the colour alone: guides (the first hit's albedo and normal), prefiltered as OIDN recommends for
//! noisy guides, were measured on every shipped scene against colour-only filtering and did
//! not pay for their cost (docs/denoising.md, "Measured and not kept"). A filter is made once
//! for an image size and quality ([`Denoiser::filter`]) and run on every image of a shot.
//!
//! Determinism: OIDN's documentation promises no bit-identical output, only the same quality
//! on every device type with possibly small numerical differences between them. Its own
//! `oidnDenoise` tool (2.5.1) checks repeated runs for the same output hash and reports a
//! mismatch as "non-deterministic output". The tests check that repeated runs, a second
//! device and 1, 2 and 3 device threads (`OIDN_NUM_THREADS`) give the same bytes on the CPU
//! device.

use std::fmt;

use glam::Vec3;
use raytrace_core::image::{Image, Rgb};
use raytrace_core::scene::{DenoiseDevice, DenoiseQuality};

use crate::device::TracingGpu;

/// The largest width and height OIDN accepts (its `ImageDesc` refuses larger sides as
/// "image size is too large").
pub const MAX_SIDE: usize = 65536;

/// What can go wrong when denoising.
#[derive(Debug, Clone, PartialEq)]
pub enum DenoiseError {
    /// The library could not be loaded: where it was looked for and how to provide it
    /// ([`super::library::load`]).
    Missing(String),
    /// OIDN could not make a CPU device: the library or its CPU device module could not be
    /// loaded, or the CPU is not supported (OIDN needs SSE4.1 on x86-64).
    Unavailable(String),
    /// An image side beyond [`MAX_SIDE`], or no pixels at all.
    Size { width: usize, height: usize },
    /// An image or guide whose length is not three values for each of `width * height`
    /// pixels.
    Length {
        what: &'static str,
        len: usize,
        expected: usize,
    },
    /// OIDN reported an error while filtering.
    Filter(String),
    /// `--denoise-device gpu`, and OIDN has no device for the GPU: why.
    NoGpu(String),
}

impl fmt::Display for DenoiseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DenoiseError::Missing(m) => write!(f, "{m}"),
            DenoiseError::Unavailable(m) => write!(
                f,
                "Intel Open Image Denoise (libOpenImageDenoise 2.5) could not start a CPU \
                 device: {m}. It needs its CPU device module \
                 (libOpenImageDenoise_device_cpu.so) and oneTBB (libtbb.so.12) beside \
                 libOpenImageDenoise, and a CPU with SSE4.1. The build provides them in the \
                 project's .oidn folder (from pkg-config or the pyoidn 2.5.1 wheel): rebuild to \
                 restore it, or install OIDN 2.5 (https://github.com/RenderKit/oidn/releases) \
                 and set OIDN_DIR to it before building"
            ),
            DenoiseError::Size { width, height } => write!(
                f,
                "cannot denoise a {width}x{height} image: Intel Open Image Denoise takes \
                 1 to {MAX_SIDE} pixels a side"
            ),
            DenoiseError::Length {
                what,
                len,
                expected,
            } => write!(
                f,
                "the {what} image holds {len} values, not {expected} (RGB for each pixel)"
            ),
            DenoiseError::Filter(m) => write!(f, "Intel Open Image Denoise failed: {m}"),
            DenoiseError::NoGpu(m) => write!(
                f,
                "--denoise-device gpu: Intel Open Image Denoise has no device for the GPU: {m}. \
                 It drives NVIDIA GPUs through CUDA and AMD ones through HIP (its device \
                 modules beside libOpenImageDenoise, with the GPU's driver); use \
                 --denoise-device auto or cpu to denoise on the CPU"
            ),
        }
    }
}

impl std::error::Error for DenoiseError {}

impl From<DenoiseError> for raytrace_core::error::Error {
    fn from(e: DenoiseError) -> Self {
        raytrace_core::error::Error::Resource(Box::new(e))
    }
}

/// An OIDN device, made once for a run and used for every frame.
pub struct Denoiser {
    device: oidn::Device,
    /// `cpu`, or `cuda (ADAPTER NAME)` and the like.
    name: String,
    note: Option<String>,
}

impl Denoiser {
    /// Starts the OIDN device `choice` asks for, for a run that traces on `traced_on` (none:
    /// the CPU): see [`crate::device`]. OIDN's CPU device uses every core unless
    /// `OIDN_NUM_THREADS` says otherwise.
    pub fn new(
        choice: DenoiseDevice,
        traced_on: Option<&TracingGpu>,
    ) -> Result<Denoiser, DenoiseError> {
        super::library::load().map_err(DenoiseError::Missing)?;
        let opened = crate::device::open(choice, traced_on)?;
        Ok(Denoiser {
            device: opened.device,
            name: opened.name,
            note: opened.note,
        })
    }

    /// The device, as `--stats` names it: `cpu`, or `cuda (NVIDIA H100 80GB HBM3)`.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Why the run denoises on the CPU though it traces on a GPU (`auto` without an OIDN
    /// device for it): one line for standard error.
    pub fn note(&self) -> Option<&str> {
        self.note.as_deref()
    }

    /// A colour-only `RT` filter for HDR images of `width` x `height` at `quality`, made once
    /// and run on every image of that size ([`Filter::run`]): OIDN builds its network and
    /// scratch memory when a filter is first run, not again while its size stays.
    pub fn filter(
        &self,
        width: usize,
        height: usize,
        quality: DenoiseQuality,
    ) -> Result<Filter<'_>, DenoiseError> {
        let len = check_size(width, height)?;
        let mut filter = oidn::RayTracing::try_new(&self.device)
            .map_err(|e| DenoiseError::Filter(describe(&e)))?;
        filter
            .image_dimensions(width, height)
            .hdr(true)
            .filter_quality(oidn_quality(quality));
        Ok(Filter { filter, len })
    }
}

/// A filter of one image size and quality ([`Denoiser::filter`]).
pub struct Filter<'d> {
    filter: oidn::RayTracing<'d>,
    /// The values of an image: three a pixel.
    len: usize,
}

/// OIDN's own scratch memory for a `width` x `height` filter at `quality` (its CPU device,
/// OIDN 2.5.1), made when the filter first runs and kept while it lives (a shot's): about 355
/// bytes a pixel at `fast` and 620 at `balanced` and `high`, up to about 1.5 and 2.5 GiB,
/// beyond which OIDN denoises the image in tiles. The pixels are those of the image padded to
/// multiples of [`OIDN_ALIGNMENT`] a side, as OIDN's network works on them: a 1x65536 frame
/// holds sixteen times its own pixels' scratch (355 MiB where 65536 pixels in a square take
/// 22). Measured by the peak resident memory of denoising images of 480x270 to 3840x2160 and
/// 1x65536, less the images' own ([`Filter::run_bytes`]):
/// `cargo test --release -p raytrace-denoise --lib -- --ignored --nocapture scratch_memory`
/// (which checks these figures).
pub fn oidn_scratch(width: u64, height: u64, quality: DenoiseQuality) -> u64 {
    let (per_pixel, most): (u64, u64) = match quality {
        DenoiseQuality::Fast => (355, 1_520 << 20),
        DenoiseQuality::Balanced | DenoiseQuality::High => (620, 2_590 << 20),
    };
    let padded = width.next_multiple_of(OIDN_ALIGNMENT) * height.next_multiple_of(OIDN_ALIGNMENT);
    (padded * per_pixel).min(most)
}

/// The side multiple OIDN pads an image to: its U-Net pools four times, halving the image each
/// time, so a side must divide by 16 (measured: a 1x65536 image takes the scratch of
/// 16x65536).
const OIDN_ALIGNMENT: u64 = 16;

impl Filter<'_> {
    /// The bytes a run of a filter of `pixels` pixels holds beyond OIDN's scratch memory
    /// ([`oidn_scratch`]): the image packed for OIDN, the `oidn` crate's copies of it and of
    /// OIDN's output, the output and the image made of it (12 bytes a pixel each).
    pub fn run_bytes(pixels: u64) -> u64 {
        5 * Image::bytes_for(pixels, 3)
    }

    /// The channels `names` of `image` (linear HDR radiance) denoised: an image of those
    /// channels. A pixel with a value that is not finite is denoised as black (OIDN takes
    /// finite values only).
    pub fn run(&self, image: &Image, names: Rgb) -> Result<Image, DenoiseError> {
        let planes = image.rgb(names).ok_or(DenoiseError::Length {
            what: "colour",
            len: 0,
            expected: self.len,
        })?;
        let colour: Vec<f32> = (0..image.pixels())
            .flat_map(|i| {
                let c = planes.at(i);
                if c.is_finite() { c } else { Vec3::ZERO }.to_array()
            })
            .collect();
        if colour.len() != self.len {
            return Err(DenoiseError::Length {
                what: "colour",
                len: colour.len(),
                expected: self.len,
            });
        }
        let mut out = vec![0.0f32; self.len];
        self.filter
            .filter(&colour, &mut out)
            .map_err(|e| DenoiseError::Filter(describe(&e)))?;
        drop(colour);
        Ok(Image::from_interleaved(
            image.width(),
            image.height(),
            names,
            &out,
        ))
    }
}

/// OIDN's name for `quality`.
fn oidn_quality(quality: DenoiseQuality) -> oidn::Quality {
    match quality {
        DenoiseQuality::Fast => oidn::Quality::Fast,
        DenoiseQuality::Balanced => oidn::Quality::Balanced,
        DenoiseQuality::High => oidn::Quality::High,
    }
}

/// The number of `f32` values of a `width` x `height` RGB image, or the error for a size OIDN
/// refuses.
fn check_size(width: usize, height: usize) -> Result<usize, DenoiseError> {
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(DenoiseError::Size { width, height });
    }
    Ok(3 * width * height)
}

/// OIDN's error kind and message.
pub(crate) fn describe(e: &oidn::Error) -> String {
    let message = e.message();
    if message.is_empty() {
        e.kind().as_str().to_string()
    } else {
        format!("{} ({})", message, e.kind().as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic;
    use raytrace_core::image::COLOUR;

    /// A small noisy frame's full image.
    fn noisy() -> (usize, usize, Image) {
        let f = synthetic::frame(64, 48, synthetic::edges, 0.5, 11);
        (f.width, f.height, f.full())
    }

    fn denoised() -> Image {
        let (w, h, color) = noisy();
        let denoiser = Denoiser::new(DenoiseDevice::Cpu, None).unwrap();
        let filter = denoiser.filter(w, h, DenoiseQuality::Fast).unwrap();
        filter.run(&color, COLOUR).unwrap()
    }

    /// FNV-1a over the colour's bits.
    fn hash(image: &Image) -> u64 {
        let values = image.interleaved(COLOUR).unwrap();
        values.iter().fold(0xcbf2_9ce4_8422_2325, |h, v| {
            (h ^ v.to_bits() as u64).wrapping_mul(0x0100_0000_01b3)
        })
    }

    #[test]
    fn denoising_brings_the_image_closer_to_the_truth_at_every_quality() {
        let f = synthetic::frame(64, 48, synthetic::edges, 0.5, 11);
        let denoiser = Denoiser::new(DenoiseDevice::Cpu, None).unwrap();
        let before = raytrace_core::metrics::rel_mse(&f.full(), &f.truth());
        for q in DenoiseQuality::ALL {
            let filter = denoiser.filter(64, 48, q).unwrap();
            let out = filter.run(&f.full(), COLOUR).unwrap();
            let after = raytrace_core::metrics::rel_mse(&out, &f.truth());
            assert!(after < before / 4.0, "{q}: {after} vs {before}");
        }
    }

    /// The process's peak and current resident memory (Linux), in bytes.
    fn resident() -> (u64, u64) {
        let status = std::fs::read_to_string("/proc/self/status").unwrap();
        let kib = |key: &str| -> u64 {
            let line = status.lines().find(|l| l.starts_with(key)).unwrap();
            line.split_whitespace()
                .nth(1)
                .unwrap()
                .parse::<u64>()
                .unwrap()
                * 1024
        };
        (kib("VmHWM:"), kib("VmRSS:"))
    }

    /// Checks [`oidn_scratch`]: each size and quality denoised in a process of its own (this
    /// test run again, with `OIDN_SCRATCH_SIZE` set), whose peak beyond its resident memory
    /// before the filter is made must be the scratch and a run's images
    /// ([`Filter::run_bytes`]), within 10%.
    /// About 3 GB at the largest.
    #[test]
    #[ignore = "calibration of oidn_scratch: up to 3 GB; see oidn_scratch's notes"]
    fn scratch_memory() {
        if let Ok(size) = std::env::var("OIDN_SCRATCH_SIZE") {
            let [w, h, q]: [&str; 3] = size.split(' ').collect::<Vec<_>>().try_into().unwrap();
            let (w, h): (u32, u32) = (w.parse().unwrap(), h.parse().unwrap());
            let quality = DenoiseQuality::from_name(q).unwrap();
            let image = Image::from_interleaved(w, h, COLOUR, &vec![0.5; 3 * (w * h) as usize]);
            let denoiser = Denoiser::new(DenoiseDevice::Cpu, None).unwrap();
            let before = resident().1;
            let filter = denoiser.filter(w as usize, h as usize, quality).unwrap();
            let out = filter.run(&image, COLOUR).unwrap();
            println!("peak beyond {}", resident().0 - before);
            drop(out);
            return;
        }
        for size in [
            "480 270 fast",
            "1920 1080 fast",
            "3840 2160 fast",
            "1920 1080 balanced",
            "3840 2160 high",
            "1 65536 fast",
        ] {
            let out = std::process::Command::new(std::env::current_exe().unwrap())
                .args(["--exact", "denoiser::tests::scratch_memory"])
                .args(["--ignored", "--nocapture", "--test-threads", "1"])
                .env("OIDN_SCRATCH_SIZE", size)
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&out.stdout);
            let peak: u64 = text
                .lines()
                .find_map(|l| l.split("peak beyond ").nth(1))
                .and_then(|n| n.trim().parse().ok())
                .unwrap_or_else(|| panic!("{size}: {text}"));
            let [w, h, q]: [&str; 3] = size.split(' ').collect::<Vec<_>>().try_into().unwrap();
            let (w, h) = (w.parse::<u64>().unwrap(), h.parse::<u64>().unwrap());
            let quality = DenoiseQuality::from_name(q).unwrap();
            let model = oidn_scratch(w, h, quality) + Filter::run_bytes(w * h);
            println!("{size}: peak {} MiB, model {} MiB", peak >> 20, model >> 20);
            assert!(
                (peak as f64 / model as f64 - 1.0).abs() < 0.1,
                "{size}: peak {peak}, model {model}"
            );
        }
    }

    #[test]
    fn a_filter_runs_again_and_again_with_the_same_bytes() {
        let (w, h, color) = noisy();
        let denoiser = Denoiser::new(DenoiseDevice::Cpu, None).unwrap();
        let filter = denoiser.filter(w, h, DenoiseQuality::Fast).unwrap();
        let once = filter.run(&color, COLOUR).unwrap();
        // Another image between two runs of the same one.
        let grey = Image::from_interleaved(w as u32, h as u32, COLOUR, &vec![0.25; 3 * w * h]);
        let other = filter.run(&grey, COLOUR).unwrap();
        assert_ne!(hash(&once), hash(&other));
        assert_eq!(hash(&once), hash(&filter.run(&color, COLOUR).unwrap()));
        // A second device, a second filter.
        let second = Denoiser::new(DenoiseDevice::Cpu, None).unwrap();
        let again = second.filter(w, h, DenoiseQuality::Fast).unwrap();
        assert_eq!(hash(&once), hash(&again.run(&color, COLOUR).unwrap()));
    }

    #[test]
    fn balanced_is_high_on_the_cpu_and_fast_is_not() {
        // What the quality's documentation says of OIDN's CPU device.
        let (w, h, color) = noisy();
        let denoiser = Denoiser::new(DenoiseDevice::Cpu, None).unwrap();
        let run = |q| {
            hash(
                &denoiser
                    .filter(w, h, q)
                    .unwrap()
                    .run(&color, COLOUR)
                    .unwrap(),
            )
        };
        assert_eq!(run(DenoiseQuality::Balanced), run(DenoiseQuality::High));
        assert_ne!(run(DenoiseQuality::Fast), run(DenoiseQuality::High));
    }

    /// Prints the hash of [`denoised`] for `the_thread_count_does_not_change_the_bytes`, which
    /// runs it in a child process with `OIDN_NUM_THREADS` set (the device reads it when made).
    #[test]
    #[ignore = "run in a child process by the_thread_count_does_not_change_the_bytes"]
    fn print_the_denoised_hash() {
        println!("denoised hash {:016x}", hash(&denoised()));
    }

    #[test]
    fn the_thread_count_does_not_change_the_bytes() {
        let here = format!("{:016x}", hash(&denoised()));
        for threads in ["1", "2", "3"] {
            let out = std::process::Command::new(std::env::current_exe().unwrap())
                .args(["--exact", "denoiser::tests::print_the_denoised_hash"])
                .args(["--ignored", "--nocapture", "--test-threads", "1"])
                .env("OIDN_NUM_THREADS", threads)
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&out.stdout);
            let line = text
                .lines()
                // The harness prints the test's name on the same line.
                .find_map(|l| l.split("denoised hash ").nth(1))
                .unwrap_or_else(|| {
                    let err = String::from_utf8_lossy(&out.stderr);
                    panic!("no hash from the child: {text} {err}")
                });
            assert_eq!(line, here, "OIDN_NUM_THREADS={threads}");
        }
    }

    #[test]
    fn sizes_beyond_what_oidn_takes_are_refused() {
        let denoiser = Denoiser::new(DenoiseDevice::Cpu, None).unwrap();
        let n = MAX_SIDE + 1;
        let refused = denoiser
            .filter(n, 1, DenoiseQuality::Fast)
            .err()
            .expect("refused");
        assert_eq!(
            refused,
            DenoiseError::Size {
                width: n,
                height: 1
            }
        );
        assert!(refused.to_string().contains("1 to 65536 pixels a side"));
        assert!(matches!(
            denoiser.filter(0, 1, DenoiseQuality::Fast),
            Err(DenoiseError::Size { .. })
        ));
        // OIDN itself draws the line at the same place: one side of 65536 passes, 65537 not.
        let device = oidn::Device::cpu().unwrap();
        let color = vec![0.5f32; 3 * n];
        let run = |w: usize| {
            let mut out = vec![0.0f32; 3 * w];
            oidn::RayTracing::try_new(&device)
                .unwrap()
                .image_dimensions(w, 1)
                .hdr(true)
                .filter_quality(oidn::Quality::Fast)
                .filter(&color[..3 * w], &mut out)
        };
        assert!(run(MAX_SIDE).is_ok());
        let e = run(MAX_SIDE + 1).unwrap_err();
        assert!(e.message().contains("too large"), "{e}");
        // An image of another size than the filter's.
        let filter = denoiser.filter(1, 2, DenoiseQuality::Fast).unwrap();
        let one = Image::from_interleaved(1, 1, COLOUR, &color[..3]);
        assert!(matches!(
            filter.run(&one, COLOUR),
            Err(DenoiseError::Length { .. })
        ));
    }
}
