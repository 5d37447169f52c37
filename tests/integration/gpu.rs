//! The GPU tracer (`--device gpu`) against the CPU's, on the GPU (Mesa's lavapipe where CI
//! runs; under `CI=true` a missing adapter fails these tests instead of skipping them).
//!
//! Two renders of a frame made independently (different seeds) differ by their noise alone
//! when both render the same image: their difference, pixel by pixel, has mean zero and the
//! variance the films estimate from their two replicates. Every shipped scene is held to
//! that, and the books' scene through the binary as a user renders it. With the same seed the
//! GPU draws the CPU's sampler numbers (crates/gpu/src/tests.rs), so its camera rays and first hits
//! are the CPU's up to `f32` rounding: the passes are compared pixel by pixel.

use crate::common;

use std::path::Path;
use std::process::Command;

use common::{exr_bits_and_attributes, exr_channels, exr_number, gpu, render, render_gpu, text};
use raytrace_core::film::Film;
use raytrace_core::renderer::{Budget, CpuShot, FrameJob, FrameResult};
use raytrace_core::scene::Scene;
use raytrace_scene::scene_file::SceneFile;

/// How two independent renders of a frame agree.
#[derive(Debug)]
struct Agreement {
    /// Per channel, the mean difference over the frame in its standard errors.
    z: [f64; 3],
    /// The squared differences over their expectation (the sum of the two films' estimated
    /// variances), over every pixel and channel: 1 within noise.
    ratio: f64,
    /// Over blocks of 8 x 8 pixels and each channel: the largest |z| of a block's mean
    /// difference, and the mean of z^2 (1 within noise).
    block_z: f64,
    block_chi: f64,
}

impl Agreement {
    /// Within noise: each channel's frame mean within 5 standard errors, the error variance
    /// within [0.7, 1.5] of its expectation, no 8 x 8 block beyond 6 standard errors and the
    /// blocks' mean z^2 below 2. The bounds leave room for Monte Carlo's heavy tails (rare
    /// bright paths): two CPU renders of `propeller.toml` with different seeds reach a block
    /// at 5.6 and a mean z^2 of 1.8, and the frame ratios of every shipped scene lie within
    /// 0.94 to 1.27.
    fn within_noise(&self) -> bool {
        self.z.iter().all(|z| z.abs() <= 5.0)
            && (0.7..=1.5).contains(&self.ratio)
            && self.block_z <= 6.0
            && self.block_chi <= 2.0
    }
}

/// The agreement of `a` and `b`, the means and estimated variances of the means of the same
/// frame's pixels, row-major, `width` a row, rendered independently. A pixel's expected
/// squared difference is the sum of its two variances plus `(2^-20 m)^2` for `m` its mean,
/// for the `f32` rounding of a sample on the GPU (a pixel that never varies, under a uniform
/// background, has no noise to hide it).
fn agreement(
    a: (&[[f64; 3]], &[[f64; 3]]),
    b: (&[[f64; 3]], &[[f64; 3]]),
    width: usize,
) -> Agreement {
    let ((ma, va), (mb, vb)) = (a, b);
    assert_eq!(ma.len(), mb.len());
    let expect = |i: usize, c: usize| {
        let m = (ma[i][c] + mb[i][c]).abs() * 0.5 / 1_048_576.0;
        va[i][c] + vb[i][c] + m * m
    };
    let mut z = [0.0; 3];
    let (mut d2, mut e2) = (0.0, 0.0);
    for (c, zc) in z.iter_mut().enumerate() {
        let (mut d, mut e) = (0.0, 0.0);
        for i in 0..ma.len() {
            let diff = ma[i][c] - mb[i][c];
            d += diff;
            e += expect(i, c);
            d2 += diff * diff;
        }
        e2 += e;
        *zc = if e > 0.0 { d / e.sqrt() } else { 0.0 };
    }
    let height = ma.len() / width;
    let (mut block_z, mut chi, mut blocks) = (0.0f64, 0.0, 0);
    for by in 0..height / 8 {
        for bx in 0..width / 8 {
            for c in 0..3 {
                let (mut d, mut e) = (0.0, 0.0);
                for y in by * 8..by * 8 + 8 {
                    for x in bx * 8..bx * 8 + 8 {
                        let i = y * width + x;
                        d += ma[i][c] - mb[i][c];
                        e += expect(i, c);
                    }
                }
                // A block that never varies (a channel that is 0 everywhere) must agree.
                let zb = if e > 0.0 {
                    d / e.sqrt()
                } else {
                    d.abs() * f64::INFINITY
                };
                let zb = if zb.is_nan() { 0.0 } else { zb };
                block_z = block_z.max(zb.abs());
                chi += zb * zb;
                blocks += 1;
            }
        }
    }
    Agreement {
        z,
        ratio: d2 / e2,
        block_z,
        block_chi: chi / blocks as f64,
    }
}

/// A film's means and estimated variances of the means, row-major.
fn moments(f: &Film) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    (f.means().iter().map(|m| m.to_array()).collect(), {
        let variances = f.variances();
        let planes = variances.rgb(raytrace_core::pass::VARIANCE).unwrap();
        (0..variances.pixels())
            .map(|i| planes.at_f64(i).to_array())
            .collect()
    })
}

fn films_agree(a: &Film, b: &Film) -> Agreement {
    let (ma, va) = moments(a);
    let (mb, vb) = moments(b);
    agreement((&ma, &va), (&mb, &vb), a.width as usize)
}

/// The shipped scene `name` at `width` x `height` pixels and `samples` samples, seed `seed`.
fn shipped(name: &str, width: u32, height: u32, samples: u32, seed: u64) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    let mut s = Scene::load(&path).unwrap();
    s.output.width = width;
    s.output.height = height;
    s.render.samples = samples;
    s.render.seed = seed;
    s
}

#[test]
fn every_shipped_scene_agrees_with_the_cpu_within_noise() {
    let Some(gpu) = gpu() else { return };
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 6, "{names:?}");
    for name in &names {
        // A frame in the middle of the shot, where things move; independent seeds.
        let cpu = shipped(name, 48, 32, 64, 1);
        let frame = cpu.shot.first_frame + cpu.shot.frames / 2;
        if !cpu.points.is_empty() {
            // Its points are read from its cache's files: rendered through the binary, beside
            // a cache made as the scene's notes say.
            let stem = name.trim_end_matches(".toml");
            if stem == "lammps_gas" && !common::have_lammps() {
                continue;
            }
            let dir = tempfile::tempdir().unwrap();
            let scene = common::shipped_beside_its_cache(stem, dir.path(), frame);
            let frames = frame.to_string();
            let more = ["--frames", frames.as_str()];
            let scene = scene.to_str().unwrap();
            let agreement = binary_agreement(dir.path(), scene, ("48", "32"), "64", &more, &[]);
            println!("[gpu] {name} frame {frame}: {agreement:?}");
            assert!(agreement.within_noise(), "{name}: {agreement:?}");
            continue;
        }
        let a = render(&cpu, frame);
        let b = render_gpu(gpu, &shipped(name, 48, 32, 64, 2), frame);
        let agreement = films_agree(&b, &a);
        println!("[gpu] {name} frame {frame}: {agreement:?}");
        assert!(agreement.within_noise(), "{name}: {agreement:?}");
    }
}

/// Runs the `raytrace` binary in `dir` with `args`, the environment changed by `env` (a
/// variable set, or removed with `None`).
fn raytrace(dir: &Path, args: &[&str], env: &[(&str, Option<&str>)]) -> std::process::Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_raytrace"));
    c.args(args).current_dir(dir);
    for (k, v) in env {
        match v {
            Some(v) => c.env(k, v),
            None => c.env_remove(k),
        };
    }
    c.output().expect("run raytrace")
}

/// `scene` rendered in `dir` at `width`x`height` and `samples` with its variance pass and
/// the arguments `more` (`--frames 7`), on the CPU with seed 1 and on the GPU with seed 2,
/// under `env`: each run's output and its frame's path, the CPU's first.
fn cpu_and_gpu_frames(
    dir: &Path,
    scene: &str,
    (width, height): (&str, &str),
    samples: &str,
    more: &[&str],
    env: &[(&str, Option<&str>)],
) -> Vec<(std::process::Output, std::path::PathBuf)> {
    [("cpu", "1"), ("gpu", "2")]
        .into_iter()
        .map(|(device, seed)| {
            let out = format!("{device}.exr");
            let args = [
                "render",
                scene,
                "--device",
                device,
                "--width",
                width,
                "--height",
                height,
                "--samples",
                samples,
                "--seed",
                seed,
                "--passes",
                "variance",
                "--output",
                &out,
            ];
            let args: Vec<&str> = args.iter().chain(more).copied().collect();
            (raytrace(dir, &args, env), dir.join(&out))
        })
        .collect()
}

/// A frame's colour and estimated variance from an EXR with the variance pass, row-major.
fn exr_moments(path: &Path) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let ch = exr_channels(path);
    let pick = |names: [&str; 3]| -> Vec<[f64; 3]> {
        (0..ch[names[0]].len())
            .map(|i| names.map(|n| ch[n][i] as f64))
            .collect()
    };
    (
        pick(["R", "G", "B"]),
        pick(["variance.R", "variance.G", "variance.B"]),
    )
}

/// How the GPU's frame of `scene` agrees with the CPU's, both rendered in `dir` through the
/// binary as [`cpu_and_gpu_frames`] renders them (each run must succeed).
fn binary_agreement(
    dir: &Path,
    scene: &str,
    (width, height): (&str, &str),
    samples: &str,
    more: &[&str],
    env: &[(&str, Option<&str>)],
) -> Agreement {
    let runs = cpu_and_gpu_frames(dir, scene, (width, height), samples, more, env);
    for (o, _) in &runs {
        assert!(o.status.success(), "{scene}: {}", text(o));
    }
    files_agreement(&runs[0].1, &runs[1].1, width.parse().unwrap())
}

/// How the GPU's frame file `gpu` agrees with the CPU's, `cpu` (each `width` pixels wide, with
/// its variance pass).
fn files_agreement(cpu: &Path, gpu: &Path, width: usize) -> Agreement {
    let (mc, vc) = exr_moments(cpu);
    let (mg, vg) = exr_moments(gpu);
    agreement((&mg, &vg), (&mc, &vc), width)
}

#[test]
fn the_books_scene_renders_through_the_binary_and_agrees_with_the_cpu() {
    // `raytrace render scenes/bouncing_spheres.toml --device gpu`, smaller, with its
    // variance pass, against the CPU with another seed; with XDG_RUNTIME_DIR unset, where
    // Mesa's device selection prints a stray line that must not reach raytrace's output.
    if gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bouncing_spheres.toml");
    let scene = scene.to_str().unwrap();
    let mut files = vec![];
    let runs = cpu_and_gpu_frames(
        dir.path(),
        scene,
        ("64", "40"),
        "48",
        &[],
        &[("XDG_RUNTIME_DIR", None)],
    );
    for (o, file) in runs {
        let all = text(&o);
        assert!(o.status.success(), "{all}");
        assert!(!all.contains("XDG_RUNTIME_DIR"), "{all}");
        // The frame line, as on the CPU.
        assert!(
            all.contains("frame 0: ") && all.contains("M samples/s"),
            "{all}"
        );
        files.push(file);
    }
    let a = files_agreement(&files[0], &files[1], 64);
    println!("[gpu] bouncing_spheres.toml through the binary: {a:?}");
    assert!(a.within_noise(), "{a:?}");
    // The same attributes, but the seed.
    let (_, ca) = exr_bits_and_attributes(&files[0]);
    let (_, ga) = exr_bits_and_attributes(&files[1]);
    for name in ["frame", "samples", "shutterOpen", "shutterClose"] {
        assert_eq!(exr_number(&ca, name), exr_number(&ga, name), "{name}");
    }
}

#[test]
fn a_scene_beyond_one_binding_renders_over_several_and_agrees_with_the_cpu() {
    // 3000 spheres, half of them moving, every one in the frame's words (about 0.4 MiB),
    // with the device's bindings capped at 256 KiB (RAYTRACE_GPU_MAX_BINDING): the frame's
    // words lie over two bindings, and the frame agrees with the CPU's within noise. Capped
    // at 64 KiB, the device's bindings hold less than the scene could need: check and
    // render refuse it, exit 2, naming the need and what the device binds.
    if gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let o = raytrace(
        dir.path(),
        &[
            "generate",
            "--spheres",
            "3000",
            "--moving",
            "0.5",
            "--seed",
            "3",
            "-o",
            "big.toml",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", text(&o));
    // Paths of at most 4 bounces: seconds on lavapipe.
    let scene = dir.path().join("big.toml");
    let toml = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(&scene, toml.replace("max_depth = 50", "max_depth = 4")).unwrap();
    refused_within_64_kib(dir.path(), "big.toml", "its spheres could need ");
    assert!(!dir.path().join("renders").exists());
    let size = ("48", "32");
    let a = binary_agreement(dir.path(), "big.toml", size, "32", &[], &capped("262144"));
    println!("[gpu] 3000 spheres over bindings of 256 KiB: {a:?}");
    assert!(a.within_noise(), "{a:?}");
}

/// The environment that caps the GPU's storage bindings at `bytes`.
fn capped(bytes: &'static str) -> [(&'static str, Option<&'static str>); 1] {
    [(raytrace_gpu::MAX_BINDING_VARIABLE, Some(bytes))]
}

/// Checks that `check`, `render`, `converge` and `converge --flicker` (of frames 1-2) of
/// `scene` (in `dir`) with the GPU's bindings capped at 64 KiB refuse it with exit 2, saying
/// it `needs` more than the bindings hold.
fn refused_within_64_kib(dir: &Path, scene: &str, needs: &str) {
    for command in [
        &["check"][..],
        &["render"],
        &["converge"],
        &["converge", "--flicker", "1-2"],
    ] {
        let args = [&command[..1], &[scene], &command[1..], &["--device", "gpu"]].concat();
        let o = raytrace(dir, &args, &capped("65536"));
        let all = text(&o);
        assert_eq!(o.status.code(), Some(2), "{all}");
        let said =
            format!("{scene}: --device gpu: the GPU has not the room for this scene: {needs}");
        assert!(
            all.contains(&said)
                && all.contains(" KiB in one of the GPU's two buffers of words, more than the ")
                && all.contains(" bindings of 64.0 KiB; the adapter binds at most 64.0 KiB a storage buffer); render it with --device cpu"),
            "{all}"
        );
    }
}

#[test]
fn a_gpu_frame_is_the_same_bytes_on_rerun() {
    // Each run is summed in a fixed order, and runs are added in sample order, so a frame
    // is the same bytes however its batches were cut, on the same device and driver: with
    // every pass and the adaptive rounds of a noise threshold.
    if gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/quick.toml");
    let mut bytes = vec![];
    for run in ["a", "b"] {
        let out = format!("{run}_####.exr");
        let args = [
            "render",
            scene.to_str().unwrap(),
            "--device",
            "gpu",
            "--frames",
            "2",
            "--width",
            "40",
            "--height",
            "24",
            "--noise-threshold",
            "0.015",
            "--max-samples",
            "128",
            "--passes",
            "alpha,depth,normal,albedo,motion,variance,samples",
            "--output",
            &out,
        ];
        let o = raytrace(dir.path(), &args, &[]);
        assert!(o.status.success(), "{}", text(&o));
        bytes.push(std::fs::read(dir.path().join(format!("{run}_0002.exr"))).unwrap());
    }
    assert!(bytes[0] == bytes[1], "two runs wrote different bytes");
    // The rounds were adaptive: pixels took different counts.
    let ch = exr_channels(&dir.path().join("a_0002.exr"));
    let (lo, hi) = ch["samples"]
        .iter()
        .fold((f32::MAX, 0.0f32), |(l, h), &s| (l.min(s), h.max(s)));
    assert!(lo >= 16.0 && hi > lo, "{lo} {hi}");
}

/// A scene with everything that moves: a keyframed camera with a lens, and spheres moving
/// with a velocity, along keys and on an orbit, over a ground, with every pass.
const MOVING: &str = r#"
[shot]
fps = 24.0
frames = 3
shutter_angle = 270.0
[output]
path = "t.exr"
width = 48
height = 32
passes = ["alpha", "depth", "normal", "albedo", "motion"]
[render]
samples = 16
max_depth = 8
seed = 7
[camera]
look_from = [0.0, 1.0, 6.0]
look_at = [0.0, 0.5, 0.0]
vfov = 40.0
aperture = 0.1
keyframes = [{ time = 0.0 }, { time = 1.0, look_from = [2.0, 1.5, 6.0] }]
[materials]
grey = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
red = { type = "lambertian", albedo = [0.8, 0.2, 0.1] }
steel = { type = "metal", albedo = [0.8, 0.8, 0.9], fuzz = 0.2 }
glass = { type = "dielectric", ior = 1.5 }
[[sphere]]
center = [0.0, -100.0, 0.0]
radius = 100.0
material = "grey"
[[sphere]]
center = [-1.5, 0.5, 0.0]
radius = 0.5
material = "red"
velocity = [3.0, 1.0, 0.0]
[[sphere]]
radius = 0.4
material = "steel"
keyframes = [{ time = 0.0, center = [0.5, 0.4, 1.0] }, { time = 0.05, center = [1.0, 0.9, 1.0] }, { time = 0.2, center = [1.5, 0.4, 0.5] }]
[[sphere]]
center = [0.0, 0.6, -1.0]
radius = 0.6
material = "glass"
orbit = { pivot = [0.0, 0.6, -2.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 400.0 }
"#;

#[test]
fn passes_are_the_cpus_with_the_same_seed() {
    // With the same seed the GPU's camera rays are the CPU's to f32 rounding, at the same
    // times, so every pass (alpha, depth, normal, albedo, motion) is the CPU's pixel for
    // pixel, up to a sample whose first hit rounding decides (a ray grazing a silhouette).
    let Some(gpu) = gpu() else { return };
    let scene = common::scene(MOVING);
    let statics = CpuShot::new(&scene);
    for frame in [1, 2] {
        let cpu: FrameResult = FrameJob::new(&scene, frame).sample(&statics).unwrap();
        let g = common::render_gpu_frame(gpu, &scene, frame, &Budget::default());
        let (cpu, g) = (cpu.image, g.image);
        // The passes' channels: those beside the colour.
        let passes = |i: &raytrace_core::image::Image| i.channels()[3..].to_vec();
        for (c, d) in passes(&cpu).iter().zip(&passes(&g)) {
            assert_eq!(c.name, d.name);
            // Motion vectors in pixels, depths relative to the depth, the rest absolute.
            let close = |a: f32, b: f32| {
                let tol = match c.name {
                    "Z" => 1e-4 * a.abs(),
                    n if n.starts_with("forward") || n.starts_with("backward") => 1e-3,
                    _ => 1e-4,
                };
                (a - b).abs() <= tol
            };
            let (cv, dv) = (c.floats().unwrap(), d.floats().unwrap());
            let differ = cv.iter().zip(dv).filter(|(a, b)| !close(**a, **b)).count();
            let most = cv
                .iter()
                .zip(dv)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            println!(
                "[gpu] frame {frame} {}: {differ} of {} pixels differ, largest difference {most:e}",
                c.name,
                cv.len()
            );
            assert!(
                differ * 100 <= cv.len(),
                "{}: {differ} pixels differ",
                c.name
            );
        }
    }
}

#[test]
fn budgets_take_adaptive_rounds_and_each_pixel_is_its_plain_render() {
    // Under a noise threshold the GPU's rounds are the CPU's code: every pixel to 16 samples,
    // then each doubling by its own estimated error. A pixel that stopped at n samples is the
    // same pixel rendered with exactly n, to the f32 rounding of its runs' sums (runs are cut
    // where rounds end).
    let Some(gpu) = gpu() else { return };
    let mut scene = common::scene(MOVING);
    scene.output.passes = Default::default();
    let budget = Budget {
        noise_threshold: Some(0.01),
        max_samples: Some(256),
        ..Budget::default()
    };
    let r = common::render_gpu_frame(gpu, &scene, 2, &budget);
    let st = &r.stats;
    println!("[gpu] budget: {st:?}");
    assert!(
        st.relative_error <= 0.01 || st.samples_per_pixel == 256,
        "{st:?}"
    );
    assert!(st.min_samples_per_pixel >= 16 && st.samples_per_pixel > st.min_samples_per_pixel);
    assert!(st.rounds > 5, "{st:?}");
    let film = &r.film;
    let mut counts: Vec<u32> = film.all_pixels().iter().map(|p| p.taken()).collect();
    counts.sort_unstable();
    counts.dedup();
    for n in counts {
        let mut plain = scene.clone();
        plain.render.samples = n;
        let p = render_gpu(gpu, &plain, 2);
        for y in 0..film.height {
            for x in 0..film.width {
                if film.pixel(x, y).taken() != n {
                    continue;
                }
                let (a, b) = (film.get(x, y), p.get(x, y));
                let d = (a - b).abs().max_element();
                assert!(
                    d <= 2e-6 * a.abs().max_element() + 1e-7,
                    "({x}, {y}), {n} samples: {a} {b}"
                );
            }
        }
    }
}

#[test]
#[cfg(target_os = "linux")]
fn without_an_adapter_the_gpu_is_refused_with_what_was_looked_for_and_nothing_written() {
    // No Vulkan driver to be found: exit 1 before anything is written, naming what was
    // looked for and how to get it. Needs no GPU.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        "[output]\npath = \"f_####.png\"\nwidth = 8\nheight = 8\n",
    )
    .unwrap();
    let none = Some("/nonexistent/icd.json");
    let env = [("VK_ICD_FILENAMES", none), ("VK_DRIVER_FILES", none)];
    let o = raytrace(dir.path(), &["render", "s.toml", "--device", "gpu"], &env);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    for words in [
        "no GPU found",
        "Vulkan",
        "mesa-vulkan-drivers",
        "--device cpu",
    ] {
        assert!(all.contains(words), "{words}: {all}");
    }
    let files: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(files.len(), 1, "{files:?}");
    // The same scene on the CPU renders.
    let o = raytrace(
        dir.path(),
        &["render", "s.toml", "--device", "cpu", "--quiet"],
        &env,
    );
    assert!(o.status.success() && dir.path().join("f_0001.png").exists());
}

#[test]
fn a_lost_device_ends_the_run_with_the_finished_frames_kept() {
    // The device is lost (destroyed on purpose) at the first batch of frame 2: the run ends
    // with exit 1 naming the frame, frame 1 stays whole, nothing else is written, no
    // temporary file is left.
    if gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = "[shot]\nframes = 3\n[output]\npath = \"f_####.png\"\nwidth = 24\nheight = 16\n[render]\nsamples = 8\n[[sphere]]\ncenter = [0.0, 0.0, -2.0]\nradius = 0.5\nmaterial = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\nvelocity = [1.0, 0.0, 0.0]\n";
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    let env = [(raytrace_gpu::LOSE_AFTER_VARIABLE, Some("1"))];
    let o = raytrace(dir.path(), &["render", "s.toml", "--device", "gpu"], &env);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(all.contains("frame 2: the GPU device was lost"), "{all}");
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["f_0001.png", "s.toml"]);
    let png = image::open(dir.path().join("f_0001.png")).unwrap();
    assert_eq!((png.width(), png.height()), (24, 16));
}

#[test]
fn scenes_beyond_the_gpus_floats_are_refused_by_check_and_render() {
    // A sphere of radius 1e-4 a million units from the origin: f32 places its surface to
    // 0.06, more than its radius. `check` and `render` refuse it for the GPU (exit 2, the
    // field named, nothing written); the CPU renders it. Needs no GPU.
    let dir = tempfile::tempdir().unwrap();
    let far = "[output]\npath = \"f_####.png\"\nwidth = 8\nheight = 8\n[render]\ndevice = \"gpu\"\n[camera]\nlook_from = [1000000.0, 0.0, 0.001]\nlook_at = [1000000.0, 0.0, 0.0]\n[[sphere]]\ncenter = [1000000.0, 0.0, 0.0]\nradius = 0.0001\nmaterial = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\n";
    std::fs::write(dir.path().join("far.toml"), far).unwrap();
    for command in ["check", "render"] {
        let o = raytrace(dir.path(), &[command, "far.toml"], &[]);
        let all = text(&o);
        assert_eq!(o.status.code(), Some(2), "{all}");
        for words in [
            "far.toml: render.device = \"gpu\"",
            "sphere[0].radius",
            "--device cpu",
        ] {
            assert!(all.contains(words), "{words}: {all}");
        }
    }
    let o = raytrace(dir.path(), &["render", "far.toml", "--device", "gpu"], &[]);
    assert!(text(&o).contains("--device gpu: "), "{}", text(&o));
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    let o = raytrace(dir.path(), &["check", "far.toml", "--device", "cpu"], &[]);
    assert!(o.status.success(), "{}", text(&o));
    // A scene the GPU takes: `check` says so, with no GPU needed.
    let ok = "[render]\ndevice = \"gpu\"\n";
    std::fs::write(dir.path().join("ok.toml"), ok).unwrap();
    let o = raytrace(dir.path(), &["check", "ok.toml"], &[]);
    assert!(
        o.status.success() && text(&o).contains("device: gpu"),
        "{}",
        text(&o)
    );
}

#[test]
fn chunks_clips_and_time_limits_work_on_the_gpu() {
    if gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = "[shot]\nframes = 3\n[output]\npath = \"f_####.png\"\nwidth = 24\nheight = 16\n[render]\nsamples = 4\ndevice = \"gpu\"\n[[sphere]]\ncenter = [0.0, 0.0, -2.0]\nradius = 0.5\nmaterial = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\nvelocity = [1.0, 0.0, 0.0]\n";
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    // A farm's chunk: the second of two-frame chunks is frame 3 alone.
    let o = raytrace(
        dir.path(),
        &["render", "s.toml", "--chunk-size", "2", "--chunk", "1"],
        &[],
    );
    assert!(o.status.success(), "{}", text(&o));
    assert!(dir.path().join("f_0003.png").exists() && !dir.path().join("f_0001.png").exists());
    // The whole shot and its clip.
    let o = raytrace(dir.path(), &["render", "s.toml", "--clip", "c.gif"], &[]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(dir.path().join("c.gif").exists());
    // A time limit: rounds until the next would pass it.
    let args = [
        "render",
        "s.toml",
        "--frames",
        "1",
        "--time-limit",
        "2",
        "--output",
        "t.exr",
    ];
    let o = raytrace(dir.path(), &args, &[]);
    assert!(o.status.success(), "{}", text(&o));
    let (_, a) = exr_bits_and_attributes(&dir.path().join("t.exr"));
    assert_eq!(exr_number(&a, "timeLimit"), 2.0);
    assert!(exr_number(&a, "samples") >= 16.0);
}

#[test]
fn denoising_and_a_transparent_background_work_on_the_gpu() {
    // A denoised frame on the GPU: finished as on the CPU (the raw and denoised frames
    // blended), with an estimate of the CPU's within noise. With a transparent background,
    // camera rays that miss add nothing.
    let Some(gpu) = gpu() else { return };
    let mut scene = common::scene(MOVING);
    scene.transparent = true;
    scene.output.passes = [raytrace_core::pass::Pass::Alpha].into_iter().collect();
    scene.output.denoise = Some(raytrace_core::scene::DenoiseSettings::default());
    let devices = raytrace_render::devices::Devices::for_scenes([&scene]).unwrap();
    let finished = |scene: &Scene, gpu: Option<&raytrace_gpu::Gpu>| {
        let shot: Box<dyn raytrace_core::renderer::ShotTracer> = match gpu {
            Some(gpu) => Box::new(raytrace_gpu::GpuShot::new(gpu, scene).unwrap()),
            None => Box::new(CpuShot::new(scene)),
        };
        let mut finishing = devices.finishing(scene).unwrap();
        let raw = FrameJob::new(scene, 2).sample(shot.as_ref()).unwrap();
        finishing.finish(raw).unwrap()
    };
    let cpu = finished(&scene, None);
    let mut on_gpu = scene.clone();
    on_gpu.render.device = raytrace_core::scene::Device::Gpu;
    let g = finished(&on_gpu, Some(gpu));
    let d = g.denoised.as_ref().expect("denoised");
    let written = g.image.interleaved(raytrace_core::image::COLOUR).unwrap();
    assert!(d.relative_error.is_finite() && written.iter().all(|c| c.is_finite()));
    // The same estimate as the CPU's frame, within its noise.
    let ratio = g.stats.relative_error / cpu.stats.relative_error;
    assert!(
        (0.7..1.4).contains(&ratio),
        "{:?}\n{:?}",
        g.stats,
        cpu.stats
    );
    // Transparent: a pixel no camera ray hit (alpha 0) is black.
    let alpha = g.image.floats("A").unwrap();
    let means = g.film.means();
    let empty: Vec<usize> = (0..alpha.len()).filter(|&i| alpha[i] == 0.0).collect();
    assert!(!empty.is_empty());
    assert!(empty.iter().all(|&i| means[i] == glam::DVec3::ZERO));
}

#[test]
fn the_denoiser_runs_on_the_gpu_that_traces_or_says_why_not() {
    // `--stats` names the denoiser's device. On a software adapter (lavapipe) that is the
    // CPU, with no note; on a hardware GPU, OIDN's device for it (`cuda (NAME)`) or the CPU
    // with a note saying why. `--denoise-device cpu` is the CPU; `--denoise-device gpu`
    // without an OIDN device for the GPU is exit 1, naming the flag, and nothing written.
    let Some(gpu) = gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let quick = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/quick.toml");
    let run = |out: &str, extra: &[&str]| {
        let mut args = vec![
            "render",
            quick.to_str().unwrap(),
            "--frames",
            "1",
            "--width",
            "48",
            "--height",
            "27",
            "--samples",
            "4",
            "--denoise",
            "--device",
            "gpu",
            "--stats",
            "-o",
            out,
        ];
        args.extend_from_slice(extra);
        raytrace(dir.path(), &args, &[])
    };
    let auto = run("auto.exr", &[]);
    assert!(
        auto.status.success(),
        "{}",
        String::from_utf8_lossy(&auto.stderr)
    );
    let (out, err) = (
        String::from_utf8_lossy(&auto.stdout),
        String::from_utf8_lossy(&auto.stderr),
    );
    let named = |words: &str| named_in(&out, words);
    if gpu.is_software() {
        assert!(named("cpu") && !err.contains("note: "), "{out}\n{err}");
    } else {
        let on_gpu = ["cuda (", "hip (", "sycl (", "metal ("]
            .iter()
            .any(|k| out.contains(&format!("denoiser: {k}")));
        let fell_back = named("cpu")
            && err
                .contains("note: denoising on the CPU: Intel Open Image Denoise has no device for");
        assert!(on_gpu != fell_back, "{out}\n{err}");
    }
    let cpu = run("cpu.exr", &["--denoise-device", "cpu"]);
    assert!(cpu.status.success() && named_in(&String::from_utf8_lossy(&cpu.stdout), "cpu"));
    let asked = run("gpu.exr", &["--denoise-device", "gpu"]);
    if gpu.is_software() {
        assert_eq!(asked.status.code(), Some(1));
        let err = String::from_utf8_lossy(&asked.stderr);
        assert!(
            err.contains(
                "--denoise-device gpu: Intel Open Image Denoise has no device for the GPU"
            ),
            "{err}"
        );
        assert!(!dir.path().join("gpu.exr").exists());
    }
}

/// Whether a `--stats` output names the denoiser `words`.
fn named_in(out: &str, words: &str) -> bool {
    out.contains(&format!(", denoiser: {words})"))
}

#[test]
fn point_caches_split_over_bindings_and_are_refused_only_beyond_them() {
    // 2900 moving points of a PLY cache. With the device's bindings capped at 128 KiB
    // (RAYTRACE_GPU_MAX_BINDING), the frame's words take two of them: the records alone are
    // 90.6 KiB, and a hierarchy of leaves of at most four points has 725 entries at least
    // (45.3 KiB), while the words could need 2900 times 176 bytes (498.4 KiB: a record, a
    // look, two entries a point), within four bindings. The shot's tracer is compiled for
    // one page (no spheres), the frame's for two; it agrees with the CPU within noise.
    // Capped at 64 KiB, the points could need more than the device binds: check and render
    // refuse the scene, exit 2, naming the need, the points and what the device binds.
    if gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let n = 2900;
    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nproperty float vx\nproperty float vy\nproperty float vz\nproperty float radius\nend_header\n"
    );
    for i in 0..n {
        let (x, y) = ((i % 58) as f64 / 57.0 - 0.5, (i / 58) as f64 / 49.0 - 0.5);
        let z = -3.0 - 0.3 * ((i * 7) % 11) as f64 / 10.0;
        let r = 0.02 + 0.01 * (i % 3) as f64;
        ply += &format!(
            "{} {} {z} {} 0 0 {r}\n",
            2.4 * x,
            1.6 * y,
            (i % 5) as f64 * 0.2
        );
    }
    std::fs::write(dir.path().join("p.ply"), ply).unwrap();
    // Two frames, for the flicker's refusal; one for the agreement.
    let scene = "[shot]\nframes = 2\nshutter_angle = 180.0\n[output]\npath = \"f_####.exr\"\n[render]\nmax_depth = 4\n[materials]\nwater = { type = \"lambertian\", albedo = [0.7, 0.6, 0.5] }\n[[points]]\nfile = \"p.ply\"\nmaterial = \"water\"\n";
    std::fs::write(dir.path().join("pts.toml"), scene).unwrap();
    refused_within_64_kib(
        dir.path(),
        "pts.toml",
        "its spheres and the 2900 points of its largest frame could need ",
    );
    // Nothing written: the scene and the cache.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    std::fs::write(
        dir.path().join("pts.toml"),
        scene.replace("frames = 2\n", ""),
    )
    .unwrap();
    let a = binary_agreement(
        dir.path(),
        "pts.toml",
        ("48", "32"),
        "64",
        &[],
        &capped("131072"),
    );
    println!("[gpu] 2900 points over bindings of 128 KiB: {a:?}");
    assert!(a.within_noise(), "{a:?}");
}

#[test]
fn simulation_formats_agree_with_the_cpu_within_noise() {
    // The simulations' files of tests/integration/simulations.rs: five moving points of
    // several radii as extended XYZ and legacy VTK, and as a LAMMPS dump coloured through a
    // colour map by a column, with a type of its own radius and material (a fuzzy metal).
    if gpu().is_none() {
        return;
    }
    use crate::simulations;
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let (c, v, r) = simulations::points();
    simulations::write(dir, "p.xyz", &simulations::xyz_text(&c, &v, &r));
    simulations::write(dir, "p.vtk", &simulations::vtk_legacy_ascii(&c, &v, &r));
    let values = [0.0, 1.0, 2.5, 3.0, 4.0];
    let dump = simulations::lammps_snapshot(0, &c, &v, &r, &values, "ff ff ff");
    simulations::write(dir, "p.lammpstrj", &dump);
    let coloured = "color_by = \"c_val\"\ncolormap = \"viridis\"\ncolor_range = [0.0, 4.0]\ntypes = { \"2\" = { radius = 0.9, material = \"shiny\" } }\n";
    for (file, more) in [("p.xyz", ""), ("p.vtk", ""), ("p.lammpstrj", coloured)] {
        let name = format!("{file}.toml");
        let points = format!("file = \"{file}\"\n{more}");
        simulations::write(dir, &name, &simulations::scene(2, &points));
        let more = ["--frames", "1"];
        let a = binary_agreement(dir, &name, ("48", "32"), "64", &more, &[]);
        println!("[gpu] {file}: {a:?}");
        assert!(a.within_noise(), "{file}: {a:?}");
    }
}

#[test]
fn the_adapter_is_named_and_a_software_one_is_said() {
    // `check --device gpu` names the adapter a render would take; `render --device gpu` says
    // on standard error, with the word `software`, that a software device (lavapipe, where
    // CI runs) is slower than `--device cpu`, and says nothing of it on a hardware GPU;
    // `--stats` names the adapter and gives the host's share and the bytes read back.
    let Some(gpu) = gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let scene = "[output]\npath = \"f_####.png\"\nwidth = 16\nheight = 8\n[render]\nsamples = 4\n";
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    let o = raytrace(dir.path(), &["check", "s.toml", "--device", "gpu"], &[]);
    let all = text(&o);
    assert!(o.status.success(), "{all}");
    let named = format!("device: gpu, adapter: {}", gpu.describe());
    assert!(all.contains(&named), "{named}: {all}");
    assert_eq!(
        all.contains("a software device"),
        gpu.is_software(),
        "{all}"
    );
    let args = ["render", "s.toml", "--device", "gpu", "--stats"];
    let o = raytrace(dir.path(), &args, &[]);
    let (all, err) = (text(&o), String::from_utf8_lossy(&o.stderr).into_owned());
    assert!(o.status.success(), "{all}");
    let said = err.contains("software") && err.contains("--device cpu");
    assert_eq!(said, gpu.is_software(), "{err}");
    assert!(all.contains(&format!("gpu: {}", gpu.describe())), "{all}");
    for words in ["host ", "% (", "ns a sample), read back "] {
        assert!(all.contains(words), "{words}: {all}");
    }
    // The warning is given under --quiet too: a slow render is explained.
    let o = raytrace(
        dir.path(),
        &["render", "s.toml", "--device", "gpu", "--quiet"],
        &[],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.contains("software"), gpu.is_software(), "{err}");
}
