//! The GPU's pieces against the CPU's, on the GPU (lavapipe where CI runs: under `CI=true` a
//! missing adapter fails these tests instead of skipping them).

use std::path::Path;
use std::sync::OnceLock;

use super::context::Gpu;
use super::shot::GpuShot;
use crate::pass::PassSet;
use crate::passes::Layout;
use crate::sampler::{CameraUse, IndependentSampler, Sampler, SamplerKind, SobolSampler};
use crate::scene::Scene;

/// The GPU, opened once for the tests; `None` (the test skips) where there is none, except
/// under `CI=true`, where its absence fails the test.
pub(super) fn gpu() -> Option<&'static Gpu> {
    static GPU: OnceLock<Option<Gpu>> = OnceLock::new();
    let gpu = GPU.get_or_init(|| match Gpu::new() {
        Ok(g) => Some(g),
        Err(e) => {
            assert!(
                std::env::var("CI").as_deref() != Ok("true"),
                "CI=true and no GPU: {e}"
            );
            eprintln!("skipped: no GPU ({e})");
            None
        }
    });
    gpu.as_ref()
}

#[test]
fn the_gpu_draws_the_cpu_samplers_numbers() {
    let Some(gpu) = gpu() else { return };
    // Pixels, sample indices (both replicates, a second block of 2^16 points, the last index)
    // and every combination of the camera's uses.
    let mut samples = vec![];
    for (x, y) in [(0, 0), (17, 3), (399, 224), (65535, 1)] {
        for index in (0..40).chain([131_072, 131_073, 4_000_001, u32::MAX]) {
            samples.push([x, y, index, index % 4]);
        }
    }
    for kind in SamplerKind::ALL {
        let text = format!("[shot]\nfirst_frame = 3\n[render]\nseed = 5\nsampler = \"{kind}\"\n");
        let scene = Scene::parse(&text, Path::new("numbers.toml")).unwrap();
        let shot = GpuShot::new(gpu, &scene).unwrap();
        let mut frame = shot.frame(&scene, 3, &Layout::new(PassSet::EMPTY)).unwrap();
        let numbers = frame.numbers(&samples).unwrap();
        let mut cpu: Box<dyn Sampler> = match kind {
            SamplerKind::Independent => Box::new(IndependentSampler::new(5, 3)),
            SamplerKind::Sobol => Box::new(SobolSampler::new(5, 3)),
        };
        for (s, got) in samples.iter().zip(&numbers) {
            cpu.start_sample(s[0], s[1], s[2]);
            let uses = CameraUse {
                lens: s[3] & 1 != 0,
                time: s[3] & 2 != 0,
            };
            let c = cpu.camera(uses);
            let mut want = vec![c.pixel.0, c.pixel.1, c.lens.0, c.lens.1, c.time];
            for _ in 0..4 {
                let b = cpu.next_bounce();
                want.extend([b.uc, b.u.0, b.u.1]);
            }
            for (k, (&w, &g)) in want.iter().zip(got).enumerate() {
                // Sobol points (the camera's and the first bounce's, numbers 0 to 7) are the
                // CPU's f32s exactly; PCG32's 32 random bits (every number of the independent
                // sampler, later bounces of Sobol's) are cut to 24 on the GPU. Unused numbers
                // are 0.5 on both.
                let sobol_point = kind == SamplerKind::Sobol && k < 8;
                let expect = if sobol_point || (k < 5 && w == 0.5) {
                    w
                } else {
                    (w * 16_777_216.0).floor() / 16_777_216.0
                };
                assert_eq!(g as f64, expect, "{kind} sample {s:?} number {k}");
            }
        }
    }
}
