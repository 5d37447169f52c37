//! The stated change of the error between two written frames (`change`) against the truth, on
//! synthetic clips denoised by OIDN: two frames of a known image, still or moving, whose
//! replicates' noise is the same in both frames (stable sample points), related, or new.

use glam::DVec3;

use super::change::{ChangeTerms, mean_change};
use super::denoiser::{Denoiser, Filter};
use super::estimate::{Blend, DenoiseTerms};
use super::synthetic::{self, Frame};
use raytrace_core::image::COLOUR;
use raytrace_core::metrics::estimated_rel_mse_term;
use raytrace_core::replicates::{REPLICATE_A, REPLICATE_B};
use raytrace_core::scene::{DenoiseDevice, DenoiseQuality};

const WIDTH: usize = 128;
const HEIGHT: usize = 96;

/// The frame written from `frame` by `filter`, with its change terms.
fn written(filter: &Filter<'_>, frame: &Frame) -> (Blend, ChangeTerms) {
    let replicates = frame.replicates();
    let da = filter.run(&replicates, REPLICATE_A).unwrap();
    let db = filter.run(&replicates, REPLICATE_B).unwrap();
    let snapshot = DenoiseTerms::new(&replicates, &da, &db);
    let terms = snapshot.written(&replicates);
    (
        Blend::from_written(&terms),
        ChangeTerms::new(&snapshot, &replicates, &terms),
    )
}

/// The true relative mean squared change of the error from `frames[0]`'s written frame to
/// `frames[1]`'s, as `metrics::FlickerSum` measures it (the truth in place of references), and
/// the stated one.
fn true_and_stated(filter: &Filter<'_>, frames: &[Frame; 2]) -> (f64, f64) {
    let (w0, c0) = written(filter, &frames[0]);
    let (w1, c1) = written(filter, &frames[1]);
    let (x0, x1) = (w0.image.rgb(COLOUR).unwrap(), w1.image.rgb(COLOUR).unwrap());
    let n = WIDTH * HEIGHT;
    let truth = (0..n)
        .map(|i| {
            let (t0, t1) = (frames[0].truth[i], frames[1].truth[i]);
            let de = (x1.at_f64(i) - t1) - (x0.at_f64(i) - t0);
            estimated_rel_mse_term((t0 + t1) * 0.5, de * de)
        })
        .sum::<f64>()
        / n as f64;
    (truth, mean_change(&c0, &c1))
}

/// The true and stated flicker (roots of the mean squared change over eight seeds) of clips
/// of `truth_at` (moved `shift` pixels) with `noise` and `correlation`.
fn flicker(
    name: &str,
    truth_at: (fn(usize, usize) -> DVec3, usize),
    noise: f64,
    correlation: f64,
) -> (f64, f64) {
    let denoiser = Denoiser::new(DenoiseDevice::Cpu, None).unwrap();
    let filter = denoiser
        .filter(WIDTH, HEIGHT, DenoiseQuality::default())
        .unwrap();
    let (mut truth, mut stated) = (0.0, 0.0);
    for seed in 0..8 {
        let frames = synthetic::clip(WIDTH, HEIGHT, truth_at, noise, correlation, 300 + seed);
        let (t, s) = true_and_stated(&filter, &frames);
        truth += t / 8.0;
        stated += s / 8.0;
    }
    let (truth, stated) = (truth.sqrt(), stated.max(0.0).sqrt());
    eprintln!(
        "{name}: true flicker {:.4}%, stated {:.4}% ({:.3} of the truth)",
        100.0 * truth,
        100.0 * stated,
        stated / truth
    );
    (truth, stated)
}

/// Checks the stated flicker of clips as [`flicker`] makes them within `bound` of the truth
/// (a fraction of it); returns the true flicker.
fn check(
    name: &str,
    truth_at: (fn(usize, usize) -> DVec3, usize),
    noise: f64,
    correlation: f64,
    bound: f64,
) -> f64 {
    let (truth, stated) = flicker(name, truth_at, noise, correlation);
    assert!(
        (stated / truth - 1.0).abs() < bound,
        "{name}: stated {stated}, true {truth}"
    );
    truth
}

#[test]
fn the_stated_flicker_holds_with_new_samples_and_with_stable_ones() {
    let smooth = (synthetic::smooth as fn(usize, usize) -> DVec3, 0);
    let new = check("smooth, still, new samples", smooth, 0.3, 0.0, 0.1);
    let related = check("smooth, still, related samples", smooth, 0.3, 0.7, 0.1);
    assert!(related < 0.8 * new, "{related} {new}");
    // The same samples in both frames of a still image: the same written frames, no flicker,
    // and none stated (but the `f32` rounding of the terms).
    let (truth, stated) = flicker("smooth, still, stable samples", smooth, 0.3, 1.0);
    assert!(truth == 0.0 && stated < 1e-4, "{truth} {stated}");
}

#[test]
fn the_stated_flicker_holds_where_the_picture_moves() {
    let edges = (synthetic::edges as fn(usize, usize) -> DVec3, 1);
    check("edges, moving, new samples", edges, 0.5, 0.0, 0.25);
    check("edges, moving, stable samples", edges, 0.5, 1.0, 0.25);
    let smooth = (synthetic::smooth as fn(usize, usize) -> DVec3, 2);
    check("smooth, moving, stable samples", smooth, 0.3, 1.0, 0.1);
}
