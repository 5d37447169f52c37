//! Denoised frames end to end: what is written (the denoised colour, the `noisy` layer, the
//! attributes, PNG), determinism, bad input, and the denoiser's library missing.

use crate::common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use common::{exr_attribute, exr_bits_and_attributes, exr_channels, exr_number, run, run_ok, text};

fn quick() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/quick.toml")
}

/// Renders frame 1 of scenes/quick.toml at 96x54 with `samples` (0: the scene's) and the extra
/// `args` to `out` (in `dir`).
fn render(dir: &Path, out: &str, samples: u32, args: &[&str]) {
    let scene = quick();
    let samples = samples.to_string();
    let mut all = vec![
        "render",
        scene.to_str().unwrap(),
        "--frames",
        "1",
        "--width",
        "96",
        "--height",
        "54",
        "--quiet",
        "-o",
        out,
    ];
    if samples != "0" {
        all.extend(["--samples", &samples]);
    }
    all.extend_from_slice(args);
    run_ok(dir, &all);
}

/// Renders the scene file `scene` (in `dir`) to `out` with the extra `args`, quietly.
fn render_file(dir: &Path, scene: &str, out: &str, args: &[&str]) {
    let mut all = vec!["render", scene, "--quiet", "-o", out];
    all.extend_from_slice(args);
    run_ok(dir, &all);
}

/// The relative MSE of `image` against `reference` (RGB channels), as `converge` measures it.
fn rel_mse(image: &HashMap<String, Vec<f32>>, reference: &HashMap<String, Vec<f32>>) -> f64 {
    let mut sum = 0.0;
    let mut n = 0.0;
    for c in ["R", "G", "B"] {
        for (x, r) in image[c].iter().zip(&reference[c]) {
            let (x, r) = (*x as f64, *r as f64);
            sum += (x - r) * (x - r) / ((r + 0.01) * (r + 0.01));
            n += 1.0;
        }
    }
    sum / n
}

#[test]
fn a_denoised_frame_is_closer_to_the_truth_and_keeps_the_noisy_colour() {
    let d = tempfile::tempdir().unwrap();
    render(d.path(), "raw_####.exr", 8, &[]);
    render(
        d.path(),
        "dn_####.exr",
        8,
        &["--denoise", "--passes", "noisy"],
    );
    render(d.path(), "ref_####.exr", 1024, &[]);
    let raw = exr_channels(&d.path().join("raw_0001.exr"));
    let dn = exr_channels(&d.path().join("dn_0001.exr"));
    let reference = exr_channels(&d.path().join("ref_0001.exr"));

    // The `noisy` layer is the plain render, bit for bit; the colour is not.
    for c in ["R", "G", "B"] {
        let noisy = &dn[&format!("noisy.{c}")];
        assert!(
            noisy
                .iter()
                .zip(&raw[c])
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        assert_ne!(dn[c], raw[c]);
    }
    let (before, after) = (rel_mse(&raw, &reference), rel_mse(&dn, &reference));
    assert!(after < 0.5 * before, "denoised {after}, noisy {before}");

    let (_, attributes) = exr_bits_and_attributes(&d.path().join("dn_0001.exr"));
    let denoiser = format!("{:?}", exr_attribute(&attributes, "denoiser").unwrap());
    assert!(denoiser.contains("Open Image Denoise"), "{denoiser}");
    let estimated = exr_number(&attributes, "estimatedRelativeError");
    let noisy = exr_number(&attributes, "noisyRelativeError");
    assert!(estimated < noisy, "{estimated} vs {noisy}");
    // A plain frame names no denoiser.
    let (_, plain) = exr_bits_and_attributes(&d.path().join("raw_0001.exr"));
    assert!(exr_attribute(&plain, "denoiser").is_none());
}

/// 8-bit sRGB of a linear value, as the PNG format defines it (IEC 61966-2-1).
fn srgb8(v: f32) -> u8 {
    let x = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    } as f64;
    let e = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0).round() as u8
}

#[test]
fn png_frames_show_the_denoised_colour() {
    let d = tempfile::tempdir().unwrap();
    render(d.path(), "dn_####.exr", 8, &["--denoise"]);
    render(d.path(), "dn_####.png", 8, &["--denoise"]);
    let exr = exr_channels(&d.path().join("dn_0001.exr"));
    let png = image::open(d.path().join("dn_0001.png")).unwrap().to_rgb8();
    let mut worst = 0;
    for (i, p) in png.pixels().enumerate() {
        for (k, c) in ["R", "G", "B"].iter().enumerate() {
            let want = srgb8(exr[*c][i]) as i32;
            worst = worst.max((p.0[k] as i32 - want).abs());
        }
    }
    // Rounding at the boundary between two codes may differ by one between f32 and f64.
    assert!(
        worst <= 1,
        "a PNG pixel differs from the denoised EXR's by {worst} codes"
    );
}

#[test]
fn the_denoised_frame_is_the_same_on_any_thread_count() {
    let d = tempfile::tempdir().unwrap();
    render(
        d.path(),
        "one_####.exr",
        16,
        &["--denoise", "--threads", "1"],
    );
    render(
        d.path(),
        "two_####.exr",
        16,
        &["--denoise", "--threads", "2"],
    );
    let (one, _) = exr_bits_and_attributes(&d.path().join("one_0001.exr"));
    let (two, _) = exr_bits_and_attributes(&d.path().join("two_0001.exr"));
    assert!(one == two, "the denoised frames differ");
}

#[test]
fn under_a_noise_threshold_the_denoised_frame_is_the_same_on_any_thread_count() {
    // Rounds, denoises and the stop depend on the samples alone (the choice of when to
    // denoise counts costs in samples, not seconds): one thread, whose rounds take twice
    // the time of two threads' against the same denoise, writes the same bytes, over several
    // adaptive rounds and denoises.
    let d = tempfile::tempdir().unwrap();
    let threshold = ["--denoise", "--noise-threshold", "0.012"];
    render(
        d.path(),
        "one_####.exr",
        0,
        &[&threshold[..], &["--threads", "1"]].concat(),
    );
    render(
        d.path(),
        "two_####.exr",
        0,
        &[&threshold[..], &["--threads", "2"]].concat(),
    );
    let (one, a) = exr_bits_and_attributes(&d.path().join("one_0001.exr"));
    let (two, _) = exr_bits_and_attributes(&d.path().join("two_0001.exr"));
    assert!(one == two, "the denoised frames differ");
    // Adaptive rounds were taken: the pixels took different counts.
    assert!(exr_number(&a, "meanSamples") > 16.0);
}

#[test]
fn noise_threshold_stops_at_the_denoised_estimate() {
    let d = tempfile::tempdir().unwrap();
    render(
        d.path(),
        "t_####.exr",
        0,
        &["--denoise", "--noise-threshold", "0.03"],
    );
    render(d.path(), "ref_####.exr", 2048, &[]);
    let (_, a) = exr_bits_and_attributes(&d.path().join("t_0001.exr"));
    let estimated = exr_number(&a, "estimatedRelativeError");
    let noisy = exr_number(&a, "noisyRelativeError");
    assert!(estimated <= 0.03, "{estimated}");
    // The raw frame alone would not have stopped here.
    assert!(noisy > 0.03, "{noisy}");
    assert_eq!(exr_number(&a, "noiseThreshold"), 0.03);
    // The denoised frame's true error is near its estimate.
    let frame = exr_channels(&d.path().join("t_0001.exr"));
    let reference = exr_channels(&d.path().join("ref_0001.exr"));
    let truth = rel_mse(&frame, &reference).sqrt();
    assert!(
        (truth / estimated - 1.0).abs() < 0.25,
        "true {truth}, estimated {estimated}"
    );
}

#[test]
fn denoised_rounds_leave_at_the_first_count_only_the_pixels_raw_rounds_leave() {
    // Under a noise threshold the denoised rounds weigh a pixel by what more samples remove
    // of the written error, which is the raw variance's where the denoised frame has no
    // weight. A weight of the whole error once left pixels at 16 samples while others took
    // 8192 (a stale denoise's error times the samples grew without bound where the denoised
    // side held it). The pixels left at the first round's 16 samples must be, nearly all,
    // those raw rounds leave there too (the sky, whose samples all agree), though other
    // pixels reach the cap.
    let d = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/bouncing_spheres_seed7.toml");
    let render = |out: &str, extra: &[&str]| {
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "--width",
            "160",
            "--height",
            "90",
            "--noise-threshold",
            "0.03",
            "--max-samples",
            "256",
            "--passes",
            "samples",
            "--quiet",
            "-o",
            out,
        ];
        args.extend_from_slice(extra);
        run_ok(d.path(), &args);
    };
    render("d.exr", &["--denoise"]);
    render("r.exr", &[]);
    let samples = |name: &str| exr_channels(&d.path().join(name))["samples"].clone();
    let (denoised, raw) = (samples("d.exr"), samples("r.exr"));
    let first = |s: &[f32], i: usize| s[i] <= 16.0;
    let left: Vec<usize> = (0..denoised.len())
        .filter(|&i| first(&denoised, i))
        .collect();
    let also_raw = left.iter().filter(|&&i| first(&raw, i)).count();
    assert!(
        denoised.iter().any(|&n| n >= 256.0),
        "no pixel reached the cap"
    );
    assert!(
        also_raw as f64 >= 0.9 * left.len() as f64,
        "{} pixels left at 16 samples, {also_raw} of them also by raw rounds",
        left.len()
    );
}

#[test]
fn noisy_takes_denoising_and_an_exr_output() {
    let d = tempfile::tempdir().unwrap();
    let scene = quick();
    let scene = scene.to_str().unwrap();
    let o = run(
        d.path(),
        &["render", scene, "--passes", "noisy", "-o", "a_####.exr"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("\"noisy\""), "{}", text(&o));
    let o = run(
        d.path(),
        &[
            "render",
            scene,
            "--denoise",
            "--passes",
            "noisy",
            "-o",
            "a_####.png",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("PNG"), "{}", text(&o));
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
}

#[test]
fn without_the_denoiser_s_cpu_device_denoise_is_exit_1_and_writes_nothing() {
    // The binary moved beside OIDN's front and core libraries but not its CPU device module
    // (nor oneTBB, which only that module needs): the library loads, but OIDN cannot make a
    // CPU device.
    let d = tempfile::tempdir().unwrap();
    let raytrace = common::moved::moved_binary(d.path());
    let copied = common::moved::copy_libraries(d.path(), |name| {
        name.starts_with("libOpenImageDenoise") && !name.contains("device")
    });
    assert!(copied >= 2, "front and core libraries");
    let out = d.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let scene = quick();
    let args = |denoise: bool| {
        let mut a = vec![
            "render".to_string(),
            scene.to_str().unwrap().to_string(),
            "--frames".into(),
            "1".into(),
            "--samples".into(),
            "1".into(),
            "--width".into(),
            "16".into(),
            "--height".into(),
            "9".into(),
            "-o".into(),
            out.join("f_####.exr").to_str().unwrap().to_string(),
        ];
        if denoise {
            a.push("--denoise".into());
        }
        a
    };
    let o = std::process::Command::new(&raytrace)
        .args(args(true))
        .output()
        .unwrap();
    let message = text(&o);
    assert_eq!(o.status.code(), Some(1), "{message}");
    assert!(message.contains("Open Image Denoise"), "{message}");
    assert!(
        message.contains("libOpenImageDenoise_device_cpu"),
        "{message}"
    );
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0);
    // Frames that are not denoised do not need the device.
    let o = std::process::Command::new(&raytrace)
        .args(args(false))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(out.join("f_0001.exr").exists());
}

#[test]
fn a_temporal_frame_is_the_same_alone_in_a_sequence_and_in_a_chunk() {
    let d = tempfile::tempdir().unwrap();
    let scene = quick();
    let scene = scene.to_str().unwrap();
    let common = [
        "render",
        scene,
        "--width",
        "48",
        "--height",
        "27",
        "--samples",
        "4",
        "--denoise",
        "--temporal",
        "--quiet",
    ];
    let run_with = |extra: &[&str]| {
        let mut args = common.to_vec();
        args.extend_from_slice(extra);
        run_ok(d.path(), &args);
    };
    run_with(&["--frames", "1-4", "-o", "seq_####.exr"]);
    run_with(&["--frames", "4", "-o", "alone_####.exr"]);
    assert!(!d.path().join("alone_0003.exr").exists());
    run_with(&[
        "--frames",
        "1-4",
        "--chunk-size",
        "2",
        "--chunk",
        "1",
        "-o",
        "chunk_####.exr",
    ]);
    let bits = |name: &str| exr_bits_and_attributes(&d.path().join(name)).0;
    assert!(bits("seq_0004.exr") == bits("alone_0004.exr"));
    assert!(bits("seq_0003.exr") == bits("chunk_0003.exr"));
    assert!(bits("seq_0004.exr") == bits("chunk_0004.exr"));
}

#[test]
fn on_a_still_shot_temporal_frames_do_not_flicker() {
    // A still shot: every frame's truth is the same image. With --temporal every frame takes
    // the same sample points, so the frames written are the same bytes (no flicker at all),
    // each a plain denoised frame of its samples (no history: no historyShare); with
    // --denoise alone each frame has noise of its own, and frames differ. The stable frames'
    // error against a reference is a denoised frame's: within the spread of plain --denoise's
    // three frames (their largest error times 1.5).
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("still.toml"), common::still_shot(3, 4)).unwrap();
    let render = |out: &str, extra: &[&str]| render_file(d.path(), "still.toml", out, extra);
    render("t_####.exr", &["--denoise", "--temporal"]);
    render("p_####.exr", &["--denoise"]);
    render("r_####.exr", &["--frames", "3", "--samples", "256"]);
    let file = |name: &str| d.path().join(name);
    let bits = |name: &str| exr_bits_and_attributes(&file(name)).0;
    assert!(bits("t_0001.exr") == bits("t_0002.exr"));
    assert!(bits("t_0001.exr") == bits("t_0003.exr"));
    assert!(bits("p_0001.exr") != bits("p_0002.exr"));
    let attributes = exr_bits_and_attributes(&file("t_0003.exr")).1;
    assert!(exr_attribute(&attributes, "historyShare").is_none());
    let reference = exr_channels(&file("r_0003.exr"));
    let error = |name: &str| rel_mse(&exr_channels(&file(name)), &reference);
    let plain = ["p_0001.exr", "p_0002.exr", "p_0003.exr"].map(error);
    let temporal = error("t_0003.exr");
    let worst = plain.iter().cloned().fold(0.0, f64::max);
    assert!(
        temporal < 1.5 * worst,
        "temporal {temporal}, plain {plain:?}"
    );
}

#[test]
fn a_fast_sphere_leaves_no_trail_under_temporal() {
    // A bright sphere crosses the frame, 0.5 units a frame over a grey ground. Where it was
    // in frames 1 and 2 and is no longer in frame 3, frame 3 with --temporal must show the
    // ground: its stable sample points, the same at every pixel in every frame, must not keep
    // the sphere's noise there, nor anything of the earlier frames (a trail). Its error against a reference of frame 3 in that region
    // is held to plain --denoise's, within noise; a trail of the sphere's red would be tens of
    // times it.
    let d = tempfile::tempdir().unwrap();
    std::fs::write(
        d.path().join("fast.toml"),
        "[shot]\nframes = 3\nshutter_angle = 90.0\n[output]\nwidth = 96\nheight = 54\n\
         [render]\nsamples = 16\n\
         [camera]\nlook_from = [0.0, 1.0, 6.0]\nlook_at = [0.0, 0.4, 0.0]\nvfov = 28.0\n\
         [[sphere]]\ncenter = [-1.5, 0.4, 0.0]\nradius = 0.4\nvelocity = [12.0, 0.0, 0.0]\n\
         material = { type = \"lambertian\", albedo = [0.9, 0.1, 0.1] }\n\
         [[sphere]]\ncenter = [0.0, -100.0, 0.0]\nradius = 100.0\n\
         material = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\n",
    )
    .unwrap();
    let render = |out: &str, extra: &[&str]| render_file(d.path(), "fast.toml", out, extra);
    render("t_####.exr", &["--denoise", "--temporal"]);
    render("p_####.exr", &["--frames", "3", "--denoise"]);
    render("r_####.exr", &["--frames", "1,3", "--samples", "1024"]);
    let file = |name: &str| exr_channels(&d.path().join(name));
    let (first, last) = (file("r_0001.exr"), file("r_0003.exr"));
    // The region the sphere left: red in frame 1's reference, ground (grey) in frame 3's.
    let red = |c: &HashMap<String, Vec<f32>>, i: usize| c["R"][i] > 2.0 * c["G"][i] + 0.05;
    let left: Vec<usize> = (0..last["R"].len())
        .filter(|&i| red(&first, i) && !red(&last, i))
        .collect();
    assert!(left.len() > 50, "the sphere left {} pixels", left.len());
    let error = |image: &HashMap<String, Vec<f32>>| {
        let region = |c: &HashMap<String, Vec<f32>>| -> HashMap<String, Vec<f32>> {
            ["R", "G", "B"]
                .iter()
                .map(|k| (k.to_string(), left.iter().map(|&i| c[*k][i]).collect()))
                .collect()
        };
        rel_mse(&region(image), &region(&last))
    };
    let (temporal, plain) = (error(&file("t_0003.exr")), error(&file("p_0003.exr")));
    // A trail: the sphere's red where the ground is, a relative error of order one.
    assert!(
        temporal < 0.01,
        "temporal {temporal} in the region the sphere left"
    );
    assert!(
        temporal < 2.0 * plain + 1e-4,
        "temporal {temporal}, plain {plain} in the region the sphere left"
    );
}

#[test]
fn temporal_takes_denoising() {
    let d = tempfile::tempdir().unwrap();
    let scene = quick();
    let o = run(
        d.path(),
        &[
            "render",
            scene.to_str().unwrap(),
            "--temporal",
            "-o",
            "a_####.exr",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--temporal"), "{}", text(&o));
    assert!(text(&o).contains("--denoise"), "{}", text(&o));
    assert!(text(&o).contains("quick.toml"), "{}", text(&o));
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
}

#[test]
fn a_centred_window_reads_the_frame_after_and_the_frame_before() {
    // A still shot of three frames finished with a centred window (`Carry::Centred`, which
    // `converge --flicker` measures): frame 1 has no frame before it, so what its history
    // takes (`history_share`) is frame 2's, sampled ahead; the history route finishes frame
    // 1 with nothing. Frame 3, the shot's last, has no frame after it and reads frame 2.
    use raytrace_core::renderer::{CpuShot, FrameJob, FrameResult};
    use raytrace_core::scene::{Carry, Scene};
    use raytrace_render::devices::{Devices, Needs};
    use raytrace_scene::scene_file::{Overrides, SceneFile};

    let d = tempfile::tempdir().unwrap();
    let path = d.path().join("still.toml");
    std::fs::write(&path, common::still_shot(3, 8)).unwrap();
    let overrides = Overrides {
        denoise: Some(true),
        ..Overrides::default()
    };
    let devices = Devices::opened(Needs {
        denoiser: true,
        ..Needs::default()
    })
    .unwrap();
    let with = |carry: Carry| {
        let mut s = Scene::load_with(&path, &overrides).unwrap();
        s.output.denoise.as_mut().unwrap().carry = carry;
        s
    };
    let history_share = |r: &FrameResult| r.denoised.unwrap().history_share.unwrap();
    let (centred, before) = (with(Carry::Centred), with(Carry::Written));
    let tracer = CpuShot::new(&centred);

    let mut history = devices.finishing(&before).unwrap();
    assert_eq!(history.ahead(1), None);
    let alone = history.render(FrameJob::new(&before, 1), &tracer).unwrap();
    assert_eq!(history_share(&alone), 0.0);

    let mut f = devices.finishing(&centred).unwrap();
    assert_eq!((f.needs(1), f.ahead(1)), (vec![], Some(2)));
    f.render_ahead(FrameJob::new(&centred, 2), &tracer).unwrap();
    assert_eq!(f.ahead(1), None, "frame 2 is held");
    let first = f.render(FrameJob::new(&centred, 1), &tracer).unwrap();
    assert!(history_share(&first) > 0.1, "{}", history_share(&first));
    // The same samples as the history route's frame 1, combined with frame 2's.
    assert_ne!(first.image, alone.image);
    assert_eq!(first.film.colour(), alone.film.colour());
    f.render_ahead(FrameJob::new(&centred, 3), &tracer).unwrap();
    f.render(FrameJob::new(&centred, 2), &tracer).unwrap();
    assert_eq!(f.ahead(3), None, "the shot's last frame");
    let last = f.render(FrameJob::new(&centred, 3), &tracer).unwrap();
    assert!(history_share(&last) > 0.1, "{}", history_share(&last));
}
