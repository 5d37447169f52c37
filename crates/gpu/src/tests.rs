//! The GPU's pieces against the CPU's, on the GPU (lavapipe where CI runs: under `CI=true` a
//! missing adapter fails these tests instead of skipping them).

use raytrace_scene::scene_file::SceneFile;
use std::path::Path;
use std::sync::OnceLock;

use super::context::Gpu;
use super::schedule::Pace;
use super::shot::GpuShot;
use raytrace_core::pass::PassSet;
use raytrace_core::passes::SumLayout;
use raytrace_core::points::FramePoints;
use raytrace_core::prepared::PreparedFrame;
use raytrace_core::renderer::{FrameJob, FrameResult, ShotTracer};
use raytrace_core::sampler::{CameraUse, IndependentSampler, Sampler, SamplerKind, SobolSampler};
use raytrace_core::scene::{Device, Scene};

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
        let none = FramePoints::none();
        let prepared = PreparedFrame::new(&scene, shot.statics(), &none, 3);
        let mut frame = shot
            .upload_frame(&prepared, &SumLayout::new(PassSet::EMPTY))
            .unwrap();
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

/// A scene on the GPU from its text.
fn on_gpu(text: &str) -> Scene {
    let mut scene = Scene::parse(text, Path::new("gpu.toml")).unwrap();
    scene.render.device = Device::Gpu;
    scene
}

/// Frame `frame` of `scene` rendered on `gpu`, with `pace` as the device's pace to begin with.
fn render(gpu: &Gpu, scene: &Scene, frame: u32, pace: Option<Pace>) -> FrameResult {
    let shot = GpuShot::new(gpu, scene).unwrap();
    if let Some(pace) = pace {
        shot.set_pace(pace);
    }
    FrameJob::new(scene, frame)
        .sample(&shot)
        .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_pixel_of_65536_samples_keeps_the_precision_of_the_cpus_film() {
    // A uniform background and nothing else: every sample of the pixel is the background's
    // f32, so the mean of 65,536 of them is that value. The device sums them compensated in
    // one round; a plain f32 sum drifts by parts in ten thousand.
    let Some(gpu) = gpu() else { return };
    let scene = on_gpu(
        "[output]\nwidth = 1\nheight = 1\n[render]\nsamples = 65536\n[background]\ncolor = [0.7, 0.3, 0.011]\n",
    );
    let r = render(gpu, &scene, 1, None);
    let p = r.film.pixel(0, 0);
    assert_eq!(p.taken(), 65536);
    let want = glam::DVec3::from([0.7f32, 0.3, 0.011].map(f64::from));
    // The CPU's film, sample by sample: its sum in f64 is exact here, its odd samples' in
    // f32 as the GPU's.
    let mut cpu = raytrace_core::film::Pixel::default();
    (0..65536).for_each(|_| assert!(cpu.add(want)));
    assert_eq!(cpu.mean(), want);
    let d = (p.mean() - want).abs() / want;
    assert!(d.max_element() <= 1e-12, "{} against {want}", p.mean());
    assert_eq!(p.replicate_means().1, cpu.replicate_means().1);
    // What a plain f32 sum would give, far outside the tolerance: the test can fail.
    let plain = (0..65536).fold(0f32, |s, _| s + 0.7) as f64 / 65536.0;
    assert!((plain - want.x).abs() > 1e-6 * want.x, "{plain}");
}

#[test]
fn a_frame_is_the_same_bits_however_its_dispatches_are_cut() {
    // The first dispatches of one render take up to 16 samples an invocation; the other's
    // begin at one an invocation and double: other windows, other dispatches, the same film.
    let Some(gpu) = gpu() else { return };
    let text = "[output]\npath = \"f.exr\"\nwidth = 24\nheight = 16\npasses = [\"depth\", \"normal\"]\n[render]\nsamples = 40\n[[sphere]]\ncenter = [0.0, 0.0, -2.0]\nradius = 0.7\nvelocity = [0.5, 0.0, 0.0]\nmaterial = { type = \"lambertian\", albedo = [0.5, 0.6, 0.7] }\n";
    let scene = on_gpu(text);
    let a = render(gpu, &scene, 1, None);
    let b = render(gpu, &scene, 1, Some(Pace::one_sample_at_first()));
    assert_eq!(a.film, b.film);
    assert!(a.stats.samples == 24 * 16 * 40 && a.stats.rays > a.stats.samples);
}

#[test]
fn paths_take_max_depth_bounces_or_the_device_says_it_cannot() {
    // Inside a closed sphere no path leaves: each takes exactly max_depth bounces. Lavapipe
    // ends an invocation's loops after 65,535 iterations, which used to end such paths after
    // about 3,000 bounces whatever max_depth said: 2,000 bounces fit in one invocation, and
    // 40,000 do not, which a software device refuses with a message (a hardware one traces
    // them).
    let Some(gpu) = gpu() else { return };
    let text = |depth: u32| {
        format!(
            "[output]\nwidth = 2\nheight = 2\n[render]\nsamples = 3\nmax_depth = {depth}\n[camera]\nlook_from = [0.0, 0.0, 0.0]\nlook_at = [0.0, 0.0, -1.0]\n[[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 10.0\nmaterial = {{ type = \"lambertian\", albedo = [0.9, 0.9, 0.9] }}\n"
        )
    };
    let r = render(gpu, &on_gpu(&text(2000)), 1, None);
    assert_eq!(r.stats.samples, 12);
    assert_eq!(r.stats.rays, 12 * 2000);
    let scene = on_gpu(&text(40_000));
    let shot = GpuShot::new(gpu, &scene).unwrap();
    let result = FrameJob::new(&scene, 1).sample(&shot);
    match (gpu.is_software(), result) {
        (true, Err(e)) => {
            let e = e.to_string();
            assert!(e.contains("max_depth") && e.contains("--device cpu"), "{e}");
        }
        (false, Ok(r)) => assert_eq!(r.stats.rays, 12 * 40_000),
        (software, r) => panic!("software {software}: {:?}", r.map(|r| r.stats)),
    }
}

#[test]
fn a_frame_split_over_several_bindings_is_the_same_bits() {
    // A device opened with bindings of 128 KiB: the frame's words (1500 spheres, half of
    // them moving, all in the frame's hierarchy) lie over two pages, and the film
    // is cut into parts (64 x 48 pixels of 19 planes: 228 KiB). The frame is the same bits
    // as on the device opened with the adapter's limits, where everything is in one binding:
    // only where words are read from changed.
    let Some(gpu) = gpu() else { return };
    let binding = 128 << 10;
    let limits = wgpu::Limits {
        max_storage_buffer_binding_size: binding,
        max_buffer_size: binding,
        ..super::context::Adapter::find().unwrap().limits()
    };
    let small = Gpu::open_limited(super::context::Adapter::find().unwrap(), limits).unwrap();
    let pages = small.pages();
    assert_eq!(pages.page_words(), 32768);
    assert!(pages.count() >= 2, "{pages:?}");
    let mut text = String::from(
        "[shot]\nframes = 3\n[output]\npath = \"f_####.exr\"\nwidth = 64\nheight = 48\npasses = [\"depth\", \"normal\"]\n[render]\nsamples = 2\nmax_depth = 4\n[camera]\nlook_from = [0.0, 0.0, 6.0]\nlook_at = [0.0, 0.0, 0.0]\n",
    );
    let mut r = raytrace_core::rng::Pcg32::new(3, 7);
    for i in 0..1500 {
        let c = [0; 3].map(|_| (r.next_f64() - 0.5) * 4.0);
        let material = [
            "lambertian\", albedo = [0.6, 0.5, 0.4]",
            "metal\", albedo = [0.8, 0.8, 0.8], fuzz = 0.1",
        ][i % 2];
        text += &format!(
            "[[sphere]]\ncenter = {c:?}\nradius = 0.08\nmaterial = {{ type = \"{material} }}\n"
        );
        if i % 2 == 0 {
            text += "velocity = [0.0, 0.3, 0.0]\n";
        }
    }
    let scene = on_gpu(&text);
    let shot = GpuShot::new(&small, &scene).unwrap();
    let none = FramePoints::none();
    let prepared = PreparedFrame::new(&scene, shot.statics(), &none, 2);
    let words =
        super::upload::FrameWords::new(&prepared, shot.words(), &SumLayout::new(PassSet::EMPTY));
    let split = pages
        .split(&words.words.0)
        .expect("within the small device's pages");
    assert!(split.len() >= 2, "{} pages", split.len());
    let a = render(gpu, &scene, 2, None);
    let b = render(&small, &scene, 2, None);
    assert_eq!(a.film.pixel(0, 0).taken(), 2);
    assert!(a.film.means() == b.film.means());
    assert!(a.film.variances() == b.film.variances());
}
