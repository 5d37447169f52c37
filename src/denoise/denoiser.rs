//! The denoiser: Intel Open Image Denoise's `RT` filter on its CPU device, through the `oidn`
//! crate.
//!
//! Images are interleaved RGB `f32`, row-major, linear HDR radiance; the guides are the
//! first hit's albedo (in [0, 1]) and shading normal (in [-1, 1]), averaged over the pixel's
//! samples like the colour.
//!
//! The guides are noisy (anti-aliasing, motion and defocus blur average several surfaces), so
//! they are denoised first, each alone by an `RT` filter of its own, and the colour is then
//! denoised with the cleaned guides and `cleanAux` set: OIDN's recommendation for final frames
//! with noisy guides (its documentation, "Denoising with prefiltering"). Without prefiltering
//! the filter has to treat the guides' noise as detail to keep, and leaves more of the colour's
//! noise in. The `oidn` crate 2.5.1 is patched for both steps (vendor/README.md).
//!
//! Determinism: OIDN's documentation promises no bit-identical output, only the same quality
//! on every device type with possibly small numerical differences between them. Its own
//! `oidnDenoise` tool (2.5.1) checks repeated runs for the same output hash and reports a
//! mismatch as "non-deterministic output". The tests check that repeated calls and runs with
//! 1, 2 and 3 device threads (`OIDN_NUM_THREADS`) give the same bytes on the CPU device.

use std::fmt;

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
        }
    }
}

impl std::error::Error for DenoiseError {}

/// The guide images of a frame: interleaved RGB `f32`, row-major, the frame's size.
#[derive(Clone, Copy, Debug)]
pub struct Guides<'a> {
    /// The first hit's albedo, in [0, 1].
    pub albedo: &'a [f32],
    /// The first hit's shading normal, in [-1, 1] (need not be unit length).
    pub normal: &'a [f32],
}

/// An OIDN CPU device, made once and used for every frame.
pub struct Denoiser {
    device: oidn::Device,
}

impl Denoiser {
    /// Starts OIDN's CPU device (it uses every core unless `OIDN_NUM_THREADS` says
    /// otherwise).
    pub fn new() -> Result<Denoiser, DenoiseError> {
        super::library::load().map_err(DenoiseError::Missing)?;
        let device = oidn::Device::cpu().map_err(|e| DenoiseError::Unavailable(describe(&e)))?;
        Ok(Denoiser { device })
    }

    /// Denoises each of `colors` (HDR, `width` x `height`) with the same guides, through one
    /// filter, after denoising the guides ([`prefilter`](Self::prefilter)). Returns the
    /// denoised images in the same order.
    pub fn denoise_all(
        &self,
        width: usize,
        height: usize,
        colors: &[&[f32]],
        guides: Guides<'_>,
    ) -> Result<Vec<Vec<f32>>, DenoiseError> {
        let (albedo, normal) = self.prefilter(width, height, guides)?;
        let clean = Guides {
            albedo: &albedo,
            normal: &normal,
        };
        self.denoise_with_clean_guides(width, height, colors, clean)
    }

    /// Denoises each of `colors` (HDR, `width` x `height`) with guides already denoised
    /// ([`prefilter`](Self::prefilter), or averages of prefiltered guides), through one filter
    /// with `cleanAux` set. Returns the denoised images in the same order.
    pub fn denoise_with_clean_guides(
        &self,
        width: usize,
        height: usize,
        colors: &[&[f32]],
        guides: Guides<'_>,
    ) -> Result<Vec<Vec<f32>>, DenoiseError> {
        let expected = check_lengths(width, height, colors, guides)?;
        let mut filter = oidn::RayTracing::try_new(&self.device)
            .map_err(|e| DenoiseError::Filter(describe(&e)))?;
        let buffer = |values: &[f32]| {
            self.device
                .create_buffer(values)
                .map_err(|e| DenoiseError::Filter(describe(&e)))
        };
        filter
            .image_dimensions(width, height)
            .albedo_normal_buffer(buffer(guides.albedo)?, buffer(guides.normal)?)
            .map_err(|e| DenoiseError::Filter(describe(&e)))?
            .hdr(true)
            .clean_aux(true);
        colors
            .iter()
            .map(|color| {
                let mut out = vec![0.0f32; expected];
                filter
                    .filter(color, &mut out)
                    .map_err(|e| DenoiseError::Filter(describe(&e)))?;
                Ok(out)
            })
            .collect()
    }

    /// The guides denoised, each alone by an `RT` filter (OIDN's prefiltering of noisy
    /// guides): `(albedo, normal)`, interleaved RGB like the inputs.
    pub fn prefilter(
        &self,
        width: usize,
        height: usize,
        guides: Guides<'_>,
    ) -> Result<(Vec<f32>, Vec<f32>), DenoiseError> {
        check_lengths(width, height, &[], guides)?;
        let run = |kind, input: &[f32]| {
            let mut out = vec![0.0f32; input.len()];
            oidn::prefilter_auxiliary(
                &self.device,
                kind,
                width,
                height,
                oidn::Quality::Default,
                input,
                &mut out,
            )
            .map_err(|e| DenoiseError::Filter(describe(&e)))?;
            Ok(out)
        };
        Ok((
            run(oidn::AuxiliaryImage::Albedo, guides.albedo)?,
            run(oidn::AuxiliaryImage::Normal, guides.normal)?,
        ))
    }

    /// Denoises one HDR image (`width` x `height`) with its guides.
    pub fn denoise(
        &self,
        width: usize,
        height: usize,
        color: &[f32],
        guides: Guides<'_>,
    ) -> Result<Vec<f32>, DenoiseError> {
        let mut all = self.denoise_all(width, height, &[color], guides)?;
        Ok(all.remove(0))
    }
}

/// The number of `f32` values of a `width` x `height` RGB image, or the error for a size OIDN
/// refuses or an image (`colors`, `guides`) of another length.
fn check_lengths(
    width: usize,
    height: usize,
    colors: &[&[f32]],
    guides: Guides<'_>,
) -> Result<usize, DenoiseError> {
    let expected = check_size(width, height)?;
    for (what, values) in [("albedo", guides.albedo), ("normal", guides.normal)]
        .into_iter()
        .chain(colors.iter().map(|c| ("colour", *c)))
    {
        if values.len() != expected {
            return Err(DenoiseError::Length {
                what,
                len: values.len(),
                expected,
            });
        }
    }
    Ok(expected)
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
fn describe(e: &oidn::Error) -> String {
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
    use crate::denoise::synthetic::{self, to_f32};

    /// A small noisy frame's full image and guides, interleaved.
    fn noisy() -> (usize, usize, Vec<f32>, Vec<f32>, Vec<f32>) {
        let f = synthetic::frame(64, 48, synthetic::edges, 0.5, true, 11);
        (f.width, f.height, to_f32(&f.full()), f.albedo, f.normal)
    }

    fn denoised() -> Vec<f32> {
        let (w, h, color, albedo, normal) = noisy();
        let guides = Guides {
            albedo: &albedo,
            normal: &normal,
        };
        Denoiser::new()
            .unwrap()
            .denoise(w, h, &color, guides)
            .unwrap()
    }

    /// FNV-1a over the values' bits.
    fn hash(values: &[f32]) -> u64 {
        values.iter().fold(0xcbf2_9ce4_8422_2325, |h, v| {
            (h ^ v.to_bits() as u64).wrapping_mul(0x0100_0000_01b3)
        })
    }

    #[test]
    fn denoising_brings_the_image_closer_to_the_truth() {
        let f = synthetic::frame(64, 48, synthetic::edges, 0.5, true, 11);
        let out = synthetic::from_f32(&denoised());
        let before = crate::analysis::metrics::rel_mse(&f.full(), &f.truth);
        let after = crate::analysis::metrics::rel_mse(&out, &f.truth);
        assert!(after < before / 4.0, "{after} vs {before}");
    }

    #[test]
    fn repeated_calls_give_the_same_bytes() {
        let (w, h, color, albedo, normal) = noisy();
        let guides = Guides {
            albedo: &albedo,
            normal: &normal,
        };
        let denoiser = Denoiser::new().unwrap();
        let once = denoiser.denoise(w, h, &color, guides).unwrap();
        let all = denoiser
            .denoise_all(w, h, &[&color, &color, &color], guides)
            .unwrap();
        for again in &all {
            assert_eq!(hash(&once), hash(again));
        }
        // A second device too.
        let other = Denoiser::new().unwrap();
        assert_eq!(
            hash(&once),
            hash(&other.denoise(w, h, &color, guides).unwrap())
        );
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
                .args([
                    "--exact",
                    "denoise::denoiser::tests::print_the_denoised_hash",
                ])
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
        let denoiser = Denoiser::new().unwrap();
        let n = MAX_SIDE + 1;
        let (color, aux) = (vec![0.5f32; 3 * n], vec![0.5f32; 3 * n]);
        let guides = Guides {
            albedo: &aux,
            normal: &aux,
        };
        let refused = denoiser.denoise(n, 1, &color, guides).unwrap_err();
        assert_eq!(
            refused,
            DenoiseError::Size {
                width: n,
                height: 1
            }
        );
        assert!(refused.to_string().contains("1 to 65536 pixels a side"));
        // OIDN itself draws the line at the same place: one side of 65536 passes, 65537 not.
        let device = oidn::Device::cpu().unwrap();
        let run = |w: usize| {
            let mut out = vec![0.0f32; 3 * w];
            oidn::RayTracing::try_new(&device)
                .unwrap()
                .image_dimensions(w, 1)
                .hdr(true)
                .filter(&color[..3 * w], &mut out)
        };
        assert!(run(MAX_SIDE).is_ok());
        let e = run(MAX_SIDE + 1).unwrap_err();
        assert!(e.message().contains("too large"), "{e}");
        let short = &color[..3];
        assert!(matches!(
            denoiser.denoise(
                1,
                2,
                short,
                Guides {
                    albedo: short,
                    normal: short
                }
            ),
            Err(DenoiseError::Length { .. })
        ));
        assert!(matches!(
            denoiser.denoise(
                0,
                1,
                &[],
                Guides {
                    albedo: &[],
                    normal: &[]
                }
            ),
            Err(DenoiseError::Size { .. })
        ));
    }

    #[test]
    fn clean_aux_reaches_the_filter() {
        // OIDN ignores parameters it does not know: if `cleanAux` did not reach it (as with
        // the unpatched crate, which passed `clean_aux`), both runs would give the same bytes.
        let (w, h, color, albedo, normal) = noisy();
        let device = Denoiser::new().unwrap().device;
        let run = |clean: bool| {
            let mut out = vec![0.0f32; color.len()];
            oidn::RayTracing::try_new(&device)
                .unwrap()
                .image_dimensions(w, h)
                .albedo_normal(&albedo, &normal)
                .hdr(true)
                .clean_aux(clean)
                .filter(&color, &mut out)
                .unwrap();
            hash(&out)
        };
        assert_ne!(run(true), run(false));
    }

    #[test]
    fn prefiltering_brings_the_guides_closer_to_their_truth() {
        // The synthetic frame's guides are clean; noise is added to them here, as
        // anti-aliasing and blur leave in a path tracer's.
        let f = synthetic::frame(64, 48, synthetic::edges, 0.5, true, 11);
        let mut rng = crate::rng::Pcg32::new(5, 3);
        let mut noisy = |truth: &[f32], lo: f32| -> Vec<f32> {
            truth
                .iter()
                .map(|t| (t + 0.2 * (2.0 * rng.next_f64() as f32 - 1.0)).clamp(lo, 1.0))
                .collect()
        };
        let (albedo, normal) = (noisy(&f.albedo, 0.0), noisy(&f.normal, -1.0));
        let guides = Guides {
            albedo: &albedo,
            normal: &normal,
        };
        let denoiser = Denoiser::new().unwrap();
        let (clean_albedo, clean_normal) = denoiser.prefilter(f.width, f.height, guides).unwrap();
        let error = |a: &[f32], b: &[f32]| {
            a.iter()
                .zip(b)
                .map(|(a, b)| ((a - b) as f64).powi(2))
                .sum::<f64>()
        };
        for (name, noisy, filtered, truth) in [
            ("albedo", &albedo, &clean_albedo, &f.albedo),
            ("normal", &normal, &clean_normal, &f.normal),
        ] {
            let (before, after) = (error(noisy, truth), error(filtered, truth));
            assert!(after < before / 4.0, "{name}: {after} vs {before}");
        }
    }
}
