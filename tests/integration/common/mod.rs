//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub(crate) mod doc_blocks;
pub(crate) mod hostile;
pub(crate) mod moved;
pub(crate) mod shape;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use glam::DVec3;
use raytrace_core::film::Film;
use raytrace_core::renderer::{Budget, CpuShot, FrameJob};
use raytrace_core::scene::Scene;
use raytrace_scene::scene_file::SceneFile;

/// Parses a scene from TOML text, panicking with the error message if it is invalid.
pub(crate) fn scene(toml: &str) -> Scene {
    Scene::parse(toml, Path::new("test.toml")).unwrap_or_else(|e| panic!("{e}\n{toml}"))
}

/// Renders frame `frame` of `scene` with its own settings.
pub(crate) fn render(scene: &Scene, frame: u32) -> Film {
    let statics = CpuShot::new(scene);
    FrameJob::new(scene, frame).sample(&statics).unwrap().film
}

/// Renders with a given seed and sample count.
pub(crate) fn render_with(scene: &Scene, frame: u32, samples: u32, seed: u64) -> Film {
    let mut scene = scene.clone();
    scene.render.samples = samples;
    scene.render.seed = seed;
    render(&scene, frame)
}

/// The GPU (wgpu's adapter: Mesa's lavapipe where CI runs), opened once per test binary.
/// `None` where there is none, and the GPU test returns, except under `CI=true`, where a
/// missing adapter fails the test instead (`.ci/run` installs lavapipe).
pub(crate) fn gpu() -> Option<&'static raytrace_gpu::Gpu> {
    static GPU: std::sync::OnceLock<Option<raytrace_gpu::Gpu>> = std::sync::OnceLock::new();
    GPU.get_or_init(|| match raytrace_gpu::Gpu::new() {
        Ok(g) => Some(g),
        Err(e) => {
            assert!(
                std::env::var("CI").as_deref() != Ok("true"),
                "CI=true and no GPU: {e}"
            );
            eprintln!("skipped: no GPU ({e})");
            None
        }
    })
    .as_ref()
}

/// Renders frame `frame` of `scene` (whatever its `[render] device`) on `gpu`.
pub(crate) fn render_gpu_frame(
    gpu: &raytrace_gpu::Gpu,
    scene: &Scene,
    frame: u32,
    budget: &Budget,
) -> raytrace_core::renderer::FrameResult {
    let mut scene = scene.clone();
    scene.render.device = raytrace_core::scene::Device::Gpu;
    let shot = raytrace_gpu::GpuShot::new(gpu, &scene).unwrap();
    FrameJob::new(&scene, frame)
        .budget(*budget)
        .sample(&shot)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Renders frame `frame` of `scene` on `gpu`, its film.
pub(crate) fn render_gpu(gpu: &raytrace_gpu::Gpu, scene: &Scene, frame: u32) -> Film {
    render_gpu_frame(gpu, scene, frame, &Budget::default()).film
}

/// Means over square blocks of `block` x `block` pixels (partial blocks dropped).
pub(crate) fn block_means(film: &Film, block: u32) -> Vec<DVec3> {
    let mut out = Vec::new();
    for by in 0..film.height / block {
        for bx in 0..film.width / block {
            let mut sum = DVec3::ZERO;
            for y in 0..block {
                for x in 0..block {
                    sum += film.get(bx * block + x, by * block + y);
                }
            }
            out.push(sum / (block * block) as f64);
        }
    }
    out
}

/// The image's mean.
pub(crate) fn mean(film: &Film) -> DVec3 {
    film.means().iter().copied().sum::<DVec3>() / film.means().len() as f64
}

/// Formats a float for TOML so that it parses back to the same bits.
pub(crate) fn f(x: f64) -> String {
    format!("{x:?}")
}

/// A TOML array of a vector, exact.
pub(crate) fn v(p: DVec3) -> String {
    format!("[{}, {}, {}]", f(p.x), f(p.y), f(p.z))
}

/// Runs the `raytrace` binary in `dir` with `args`, whatever its status.
pub(crate) fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raytrace"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run raytrace")
}

/// Runs the `raytrace` binary in `dir` with `args` under a limit of `memory_kib` KiB of
/// address space (`ulimit -v`, so an allocation proportional to a hostile count fails) and no
/// standard input; panics if it runs longer than `seconds`.
pub(crate) fn run_limited(dir: &Path, args: &[&str], seconds: u64, memory_kib: u64) -> Output {
    let mut cmd = Command::new("sh");
    cmd.arg("-c")
        .arg(format!("ulimit -v {memory_kib} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_raytrace"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = cmd.spawn().expect("run raytrace");
    let start = Instant::now();
    let shown: Vec<String> = args.iter().map(|a| shorten(a)).collect();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(seconds) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("raytrace {shown:?} took more than {seconds} s");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let o = child.wait_with_output().unwrap();
    println!(
        "{shown:?}: {} in {:.2} s",
        o.status,
        start.elapsed().as_secs_f64()
    );
    o
}

/// An argument as messages quote it: a long one cut, with its length.
pub(crate) fn shorten(a: &str) -> String {
    if a.len() > 60 {
        format!("{}… ({} bytes)", &a[..40], a.len())
    } else {
        a.to_string()
    }
}

/// What a run printed: its standard output, then its standard error.
pub(crate) fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Runs the `raytrace` binary in `dir` and asserts that it succeeds.
pub(crate) fn run_ok(dir: &Path, args: &[&str]) -> Output {
    let o = run(dir, args);
    assert!(o.status.success(), "{args:?}: {}", text(&o));
    o
}

/// Runs the `raytrace` binary in `dir`, asserts that it succeeds and returns its standard
/// output.
pub(crate) fn ok(dir: &Path, args: &[&str]) -> String {
    String::from_utf8_lossy(&run_ok(dir, args).stdout).into_owned()
}

/// An EXR frame's float channels by name.
pub(crate) fn exr_channels(path: &Path) -> std::collections::HashMap<String, Vec<f32>> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let mut out = std::collections::HashMap::new();
    for c in &layer.channel_data.list {
        if let exr::image::FlatSamples::F32(v) = &c.sample_data {
            out.insert(c.name.to_string(), v.clone());
        }
    }
    out
}

/// Checks a frame rendered under a budget with the `samples` pass (`adaptive`'s channels)
/// against plain renders: for each sample count a pixel took, `plain(n)` renders the frame
/// with exactly `n` samples and returns its channels, and every pixel that took `n` samples
/// must have the same colour bits. Returns the distinct counts, smallest first.
pub(crate) fn matches_plain_renders(
    adaptive: &std::collections::HashMap<String, Vec<f32>>,
    mut plain: impl FnMut(u32) -> std::collections::HashMap<String, Vec<f32>>,
) -> Vec<u32> {
    let counts: Vec<u32> = adaptive["samples"].iter().map(|&c| c as u32).collect();
    let mut distinct = counts.clone();
    distinct.sort_unstable();
    distinct.dedup();
    for &n in &distinct {
        let plain = plain(n);
        for c in ["R", "G", "B"] {
            for (i, &count) in counts.iter().enumerate() {
                if count == n {
                    assert_eq!(
                        plain[c][i].to_bits(),
                        adaptive[c][i].to_bits(),
                        "pixel {i} ({n} samples), channel {c}"
                    );
                }
            }
        }
    }
    distinct
}

/// The pixels (as bits, every float channel in turn) and the attributes of an EXR frame.
pub(crate) fn exr_bits_and_attributes(
    path: &Path,
) -> (Vec<u32>, exr::meta::header::LayerAttributes) {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let mut bits = Vec::new();
    for c in &layer.channel_data.list {
        if let exr::image::FlatSamples::F32(v) = &c.sample_data {
            bits.extend(v.iter().map(|x| x.to_bits()));
        }
    }
    (bits, layer.attributes.clone())
}

/// The custom attribute `name` of an EXR frame's attributes `a`, if it has it.
pub(crate) fn exr_attribute(
    a: &exr::meta::header::LayerAttributes,
    name: &str,
) -> Option<exr::meta::attribute::AttributeValue> {
    a.other
        .get(&exr::meta::attribute::Text::from(name))
        .cloned()
}

/// The numeric (int or double) custom attribute `name` of `a`, as an `f64`; panics if it is
/// missing or not a number.
pub(crate) fn exr_number(a: &exr::meta::header::LayerAttributes, name: &str) -> f64 {
    use exr::meta::attribute::AttributeValue;
    match exr_attribute(a, name) {
        Some(AttributeValue::F64(x)) => x,
        Some(AttributeValue::I32(x)) => x as f64,
        other => panic!("{name}: {other:?}"),
    }
}

/// A frame's channels by name, each as bits.
pub(crate) type Bits = std::collections::HashMap<String, Vec<u32>>;

/// Renders frames `frames` of the scene file `scene` in `dir` to EXR (`NAME_####.exr`
/// beside it); each frame's channels as bits.
pub(crate) fn render_bits(
    dir: &Path,
    scene: &str,
    frames: std::ops::RangeInclusive<u32>,
) -> Vec<Bits> {
    let name = scene.trim_end_matches(".toml");
    let out = format!("{name}_####.exr");
    let spec = format!("{}-{}", frames.start(), frames.end());
    ok(
        dir,
        &[
            "render",
            scene,
            "-q",
            "--threads",
            "2",
            "-o",
            &out,
            "--frames",
            &spec,
        ],
    );
    frames
        .map(|frame| {
            exr_channels(&dir.join(format!("{name}_{frame:04}.exr")))
                .into_iter()
                .map(|(c, v)| (c, v.iter().map(|x| x.to_bits()).collect()))
                .collect()
        })
        .collect()
}

/// Asserts two renders have the same channels, each the same bits, and that something was
/// hit (the colour is not one value everywhere).
pub(crate) fn assert_same_bits(a: &[Bits], b: &[Bits]) {
    assert_eq!(a.len(), b.len());
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        let mut names: Vec<&String> = x.keys().collect();
        names.sort();
        assert_eq!(names.len(), y.len(), "frame {k}: channels");
        for c in names {
            let differ = x[c].iter().zip(&y[c]).filter(|(p, q)| p != q).count();
            assert_eq!(differ, 0, "frame {k}: {differ} pixels of {c} differ");
        }
        let r = &x["R"];
        assert!(r.iter().any(|v| *v != r[0]), "frame {k}: a blank image");
    }
}

/// Whether LAMMPS's `lmp` runs (`.ci/run` installs Debian's `lammps`); without it a test that
/// needs it is skipped with a note, except under CI=true, where it fails.
pub(crate) fn have_lammps() -> bool {
    if Command::new("lmp")
        .arg("-h")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return true;
    }
    let msg = "LAMMPS's lmp is needed (Debian: apt-get install lammps)";
    if std::env::var("CI").as_deref() == Ok("true") {
        panic!("CI=true but {msg}");
    }
    eprintln!("skipped: {msg}");
    false
}

/// Runs LAMMPS's `lmp` on the input script `input` in `dir` (its dumps are written there, as
/// the script names them), with no log or screen output; panics with its messages if it fails.
pub(crate) fn run_lammps(input: &Path, dir: &Path) {
    let o = Command::new("lmp")
        .arg("-in")
        .arg(input)
        .args(["-log", "none", "-screen", "none"])
        .current_dir(dir)
        .output()
        .expect("run lmp");
    assert!(
        o.status.success(),
        "lmp: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The MiB figure that follows `label` in `t`, as `check` and `--stats` print it (`about 12.3
/// MiB`, `peak memory 12.3 MiB`): its first occurrence.
pub(crate) fn mib_after(t: &str, label: &str) -> f64 {
    let at = t
        .find(label)
        .unwrap_or_else(|| panic!("no {label:?} in {t}"));
    let rest = &t[at + label.len()..];
    let number = rest.split_whitespace().next().unwrap();
    assert!(rest.trim_start()[number.len()..].starts_with(" MiB"), "{t}");
    number.parse().unwrap()
}

/// The peak resident memory of process `pid` in KiB (`VmHWM` in /proc), while it runs.
pub(crate) fn peak_kib(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

/// The shipped scene `name` (`scenes/NAME.toml`) as a test renders it: the shipped file, or
/// for a scene with a point cache a copy in `dir/scenes/` beside its cache, made as the
/// scene's notes say: the fountain's first `frames` files, the LAMMPS run's dump
/// (`examples/lammps/gas.in`, run from the folder above `scenes/`; see [`have_lammps`]).
pub(crate) fn shipped_beside_its_cache(name: &str, dir: &Path, frames: u32) -> PathBuf {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.toml"));
    let scene = dir.join("scenes").join(format!("{name}.toml"));
    match name {
        "fountain" => {
            std::fs::create_dir_all(dir.join("scenes")).unwrap();
            std::fs::copy(&shipped, &scene).unwrap();
            let o = Command::new(env!("CARGO_BIN_EXE_raytrace"))
                .args(["generate", "-o", "scenes/caches/fountain_####.ply"])
                .args(["--frames", &frames.to_string(), "--points", "4000"])
                .current_dir(dir)
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            scene
        }
        "lammps_gas" => {
            std::fs::create_dir_all(dir.join("scenes/caches")).unwrap();
            std::fs::copy(&shipped, &scene).unwrap();
            let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/lammps/gas.in");
            run_lammps(&input, dir);
            scene
        }
        _ => shipped,
    }
}

/// A still shot of `frames` frames at 48x27 and `samples` samples: a sphere on a ground,
/// nothing moving, the camera still (every frame's truth is the same image).
pub(crate) fn still_shot(frames: u32, samples: u32) -> String {
    format!(
        "[shot]\nframes = {frames}\n[output]\nwidth = 48\nheight = 27\n[render]\nsamples = {samples}\n\
         [camera]\nlook_from = [0.0, 1.0, 5.0]\nlook_at = [0.0, 0.5, 0.0]\n\
         [[sphere]]\ncenter = [0.0, 0.5, 0.0]\nradius = 0.5\n\
         material = {{ type = \"lambertian\", albedo = [0.5, 0.4, 0.3] }}\n\
         [[sphere]]\ncenter = [0.0, -100.0, 0.0]\nradius = 100.0\n\
         material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\n"
    )
}
