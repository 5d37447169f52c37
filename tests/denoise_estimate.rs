//! The denoised frame's stated error against the truth, on every shipped scene: the estimate
//! a denoised frame prints (and records as `estimatedRelativeError`) is within 25 percent of
//! its true relative error at 16 to 1024 samples a pixel.
//!
//! The truth is measured against a reference of 2048 samples with a seed of its own, less the
//! reference's own estimated error: the two renders' noise is independent, so the squared
//! error against the reference is the frame's plus the reference's (as `converge` measures).
//! Frames are rendered at half their width and height, so the whole file takes a few minutes
//! of two cores; docs/convergence.md has the same table at full size.

use std::path::Path;

use glam::DVec3;
use raytrace::analysis::metrics;
use raytrace::denoise::denoiser::Denoiser;
use raytrace::renderer::{Budget, render_frame, render_frame_denoised};
use raytrace::scene::Scene;
use raytrace::scene_file::Overrides;
use raytrace::world::StaticGeometry;

const REFERENCE_SAMPLES: u32 = 2048;
const SAMPLES: [u32; 4] = [16, 64, 256, 1024];

/// The shipped scene `name` at half its width and height, with `samples` and `seed` (`None`:
/// the scene's).
fn scene(name: &str, samples: u32, seed: Option<u64>) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.toml"));
    let full = Scene::load(&path).unwrap();
    let overrides = Overrides {
        width: Some(full.output.width / 2),
        height: Some(full.output.height / 2),
        samples: Some(samples),
        seed,
        ..Overrides::default()
    };
    Scene::load_with(&path, &overrides).unwrap()
}

/// Renders the scene's first frame at each of [`SAMPLES`] denoised, and checks each stated
/// error against the truth.
fn check(name: &str) {
    let reference_scene = scene(name, REFERENCE_SAMPLES, Some(0x5eed_0f_7e5e));
    let statics = StaticGeometry::new(&reference_scene);
    let frame = reference_scene.shot.first_frame;
    let reference = render_frame(
        &reference_scene,
        &statics,
        frame,
        &Budget::default(),
        &|_| {},
    );
    let own = reference.stats.relative_error.powi(2);
    let reference = reference.film.means();
    let denoiser = Denoiser::new().unwrap();
    let mut worst: f64 = 0.0;
    for n in SAMPLES {
        let s = scene(name, n, None);
        let statics = StaticGeometry::new(&s);
        let result =
            render_frame_denoised(&s, &statics, frame, &Budget::default(), &denoiser, &|_| {})
                .unwrap();
        let denoised = result.denoised.as_ref().unwrap();
        let image: Vec<DVec3> = denoised
            .rgb
            .chunks_exact(3)
            .map(|c| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64))
            .collect();
        let truth = (metrics::rel_mse(&image, &reference) - own).max(0.0).sqrt();
        let raw = (metrics::rel_mse(&result.film.means(), &reference) - own)
            .max(0.0)
            .sqrt();
        let estimate = result.stats.relative_error;
        eprintln!(
            "{name} {n:>4} spp: raw {:.3}%, denoised {:.3}%, stated {:.3}% ({:.3})",
            100.0 * raw,
            100.0 * truth,
            100.0 * estimate,
            estimate / truth
        );
        worst = worst.max((estimate / truth - 1.0).abs());
        assert!(
            (estimate / truth - 1.0).abs() < 0.25,
            "{name} at {n} samples: stated {estimate}, true {truth} (reference's own {})",
            own.sqrt()
        );
    }
    eprintln!("{name}: worst |stated / true - 1| = {worst:.3}");
}

#[test]
fn quick() {
    check("quick");
}

#[test]
fn defocus() {
    check("defocus");
}

#[test]
fn orbits() {
    check("orbits");
}

#[test]
fn turntable() {
    check("turntable");
}

#[test]
fn propeller() {
    check("propeller");
}

#[test]
fn bouncing_spheres() {
    check("bouncing_spheres");
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
        "orbits",
        "propeller",
        "quick",
        "turntable",
    ];
    assert_eq!(shipped, checked, "a shipped scene needs its test above");
}
