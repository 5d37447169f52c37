//! Pictures of every pass of one frame, for docs/scene-format.md.
//!
//! ```sh
//! cargo run --release --example pass_images -- SCENE FRAME OUT_DIR
//! ```
//! Renders frame FRAME of SCENE with its own settings and every pass, and writes 8-bit sRGB
//! PNGs to OUT_DIR: `colour.png`, `alpha.png`, `depth.png` (1 / Z, scaled to the nearest
//! hit), `normal.png` (0.5 + 0.5 N), `albedo.png`, `motion.png` (`forward`: 0.5 + u / s in red,
//! 0.5 + v / s in green, s the largest displacement) and `variance.png` (the log of the
//! variance's mean over R, G, B, in whole decades over the 6 below its largest). Every value is
//! taken as display-referred and written without the sRGB curve.

use std::path::Path;
use std::process::ExitCode;

use raytrace_core::format::Format;
use raytrace_core::image::{COLOUR, Image};
use raytrace_core::pass::Pass;
use raytrace_core::renderer::{CpuShot, FrameJob};
use raytrace_core::scene::Scene;
use raytrace_io::{FrameInfo, write_image};
use raytrace_scene::scene_file::Overrides;
use raytrace_scene::scene_file::SceneFile;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 3 {
        eprintln!("usage: pass_images SCENE FRAME OUT_DIR");
        return ExitCode::from(2);
    }
    // Every pass, requested as `--passes` would (through the validator); the passes need an
    // EXR output, which is never written here.
    let every_pass = Overrides {
        output: Some("passes_####.exr".to_string()),
        passes: Some(Pass::ALL.to_vec()),
        ..Overrides::default()
    };
    let scene = match Scene::load_with(Path::new(&args[0]), &every_pass) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let Ok(frame) = args[1].parse::<u32>() else {
        eprintln!("not a frame number: {}", args[1]);
        return ExitCode::from(2);
    };
    let statics = CpuShot::new(&scene);
    let result = FrameJob::new(&scene, frame).sample(&statics).unwrap();
    let p = &result.image;
    let out = Path::new(&args[2]);
    let (w, h) = (p.width(), p.height());
    let info = FrameInfo {
        frame,
        fps: scene.shot.fps,
        shutter_open: 0.0,
        shutter_close: 0.0,
        samples: scene.render.samples,
        seed: scene.render.seed,
        sampler: scene.render.sampler.name().to_string(),
        rolling_shutter_readout: None,
        shutter_curve: None,
        denoiser: None,
        extra: Vec::new(),
    };
    // The encoder applies the sRGB curve to linear values; these pictures are display values,
    // so undo it here.
    let linear = |v: f64| -> f32 {
        let v = v.clamp(0.0, 1.0);
        if v <= 0.04045 {
            (v / 12.92) as f32
        } else {
            ((v + 0.055) / 1.055).powf(2.4) as f32
        }
    };
    let write = |name: &str, rgb: Vec<f32>| {
        let picture = Image::from_interleaved(w, h, COLOUR, &rgb);
        write_image(&out.join(name), Format::Png, &picture, &info).expect("writes the picture");
    };
    write("colour.png", p.interleaved(COLOUR).expect("a colour"));
    let ch = |name: &str| channel(p, name);
    let grey = |values: Vec<f64>| values.iter().flat_map(|&v| [linear(v); 3]).collect();
    let rgb = |r: Vec<f64>, g: Vec<f64>, b: Vec<f64>| -> Vec<f32> {
        (0..r.len())
            .flat_map(|i| [linear(r[i]), linear(g[i]), linear(b[i])])
            .collect()
    };
    write("alpha.png", grey(ch("A")));
    let z = ch("Z");
    let nearest = z.iter().copied().fold(f64::INFINITY, f64::min);
    write("depth.png", grey(z.iter().map(|&z| nearest / z).collect()));
    let half = |v: Vec<f64>| v.iter().map(|x| 0.5 + 0.5 * x).collect::<Vec<_>>();
    write(
        "normal.png",
        rgb(half(ch("N.X")), half(ch("N.Y")), half(ch("N.Z"))),
    );
    write(
        "albedo.png",
        rgb(ch("albedo.R"), ch("albedo.G"), ch("albedo.B")),
    );
    let (u, v) = (ch("forward.u"), ch("forward.v"));
    let s = u.iter().chain(&v).fold(1e-9, |m: f64, x| m.max(x.abs()));
    let scaled = |c: &[f64]| c.iter().map(|x| 0.5 + 0.5 * x / s).collect::<Vec<_>>();
    write(
        "motion.png",
        rgb(scaled(&u), scaled(&v), vec![0.5; u.len()]),
    );
    let (vr, vg, vb) = (ch("variance.R"), ch("variance.G"), ch("variance.B"));
    let var: Vec<f64> = (0..u.len())
        .map(|i| ((vr[i] + vg[i] + vb[i]) / 3.0).max(1e-30).log10())
        .collect();
    let top = var.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    // In steps of a decade: the noise within one says nothing and costs bytes.
    let step = |l: f64| 1.0 + (l - top).floor() / 6.0;
    write("variance.png", grey(var.iter().map(|&l| step(l)).collect()));
    ExitCode::SUCCESS
}

/// The values of channel `name` as f64.
fn channel(p: &Image, name: &str) -> Vec<f64> {
    p.floats(name)
        .expect("a channel of the passes")
        .iter()
        .map(|&v| v as f64)
        .collect()
}
