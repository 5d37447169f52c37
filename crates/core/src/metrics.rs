//! Image error metrics: against a reference image, and estimated from the samples alone.
//!
//! All are means over every pixel and colour channel of images' colours ([`COLOUR`]), in
//! linear radiance.

use glam::DVec3;

use crate::image::{COLOUR, Image, RgbPlanes};
use crate::pass::VARIANCE;

/// The offset in the denominator of the relative error, so that black pixels do not divide
/// by zero (as pbrt-v4's `imgtool diff --metric relmse`).
pub(crate) const RELATIVE_EPSILON: f64 = 0.01;

fn mean_over(values: impl Iterator<Item = DVec3>, count: usize) -> f64 {
    let sum: f64 = values.map(|v| v.x + v.y + v.z).sum();
    sum / (3 * count.max(1)) as f64
}

/// The colour of `image` ([`COLOUR`]), read a pixel at a time.
fn colour(image: &Image) -> RgbPlanes<'_> {
    image.rgb(COLOUR).expect("an image with a colour")
}

/// The colours of images of one size, pixel by pixel.
fn pixels<const N: usize>(images: [&Image; N]) -> impl Iterator<Item = [DVec3; N]> + '_ {
    let n = images[0].pixels();
    assert!(
        images.iter().all(|i| i.pixels() == n),
        "images of different sizes"
    );
    let planes = images.map(colour);
    (0..n).map(move |i| planes.map(|p| p.at_f64(i)))
}

/// The mean squared error of `image` against `reference` (their colours).
pub fn mse(image: &Image, reference: &Image) -> f64 {
    let diffs = pixels([image, reference]).map(|[v, r]| (v - r) * (v - r));
    mean_over(diffs, image.pixels())
}

/// The relative mean squared error, `mean((v - ref)^2 / (ref + 0.01)^2)`.
pub fn rel_mse(image: &Image, reference: &Image) -> f64 {
    let terms = pixels([image, reference]).map(|[v, r]| {
        let d = v - r;
        let s = r + RELATIVE_EPSILON;
        d * d / (s * s)
    });
    mean_over(terms, image.pixels())
}

/// The mean squared error of `image` against the truth, estimated from two references `a`
/// and `b` of the same frame whose noise is independent of each other and of the image's:
/// `mean((x - a)(x - b))`. With `a = t + e_a`, `b = t + e_b`, `x = t + e`,
/// `(x - a)(x - b) = e^2 - e (e_a + e_b) + e_a e_b`, whose expectation over the references'
/// noise is `e^2` whatever its size: unbiased for the true MSE, where `mean((x - a)^2)` is
/// high by the reference's own variance. One frame's value may be negative when the image is
/// much closer to the truth than the references are (its expectation is not).
pub fn cross_mse(image: &Image, a: &Image, b: &Image) -> f64 {
    let terms = pixels([image, a, b]).map(|[x, a, b]| (x - a) * (x - b));
    mean_over(terms, image.pixels())
}

/// The relative mean squared error of `image` against the truth, estimated as [`cross_mse`]
/// is: `mean((x - a)(x - b) / (m + 0.01)^2)`, with `m = (a + b) / 2` (clamped at 0) standing
/// in for the truth in the denominator.
///
/// The denominator is the best estimate of the truth the two references give; it depends on
/// their noise, so the estimate is unbiased only to first order. Expanding `1 / (t' + d)^2`
/// (`t' = t + 0.01`) in the references' mean noise `d` (variance `s^2 / 2` for references of
/// variance `s^2` each), a pixel's expectation is `e^2 / t'^2 (1 + 1.5 r) + 1.5 r^2`, with
/// `r = s^2 / t'^2` the references' relative variance, plus `2 E[e] s^2 / t'^3` for an image
/// that is biased (denoised). For references of 1% relative noise a pixel, `r = 1e-4`: the
/// error is 0.015% of the measured value plus 1.5e-8, where the plain
/// `mean((x - a)^2 / (a + 0.01)^2)` is high by `r` itself. (Another denominator from the two
/// references, such as `(a + 0.01)(b + 0.01)`, has terms of the same order; one from a third
/// reference removes the `r^2` term but not the bias of `1 / c^2`, for a third render.)
pub fn cross_rel_mse(image: &Image, a: &Image, b: &Image) -> f64 {
    let terms = pixels([image, a, b]).map(|[x, a, b]| {
        let s = ((a + b) * 0.5).max(DVec3::ZERO) + RELATIVE_EPSILON;
        (x - a) * (x - b) / (s * s)
    });
    mean_over(terms, image.pixels())
}

/// The mean squared error estimated from each pixel's variance of its mean ([`VARIANCE`] of
/// `image`: a film's replicates, a frame with the variance pass), with no reference: the
/// mean of the variances, since `E[(mean - expected)^2]` is the variance of the mean.
pub fn estimated_mse(image: &Image) -> f64 {
    let variance = image.rgb(VARIANCE).expect("an image with a variance");
    mean_over(
        (0..image.pixels()).map(|i| variance.at_f64(i)),
        image.pixels(),
    )
}

/// One pixel's estimated relative squared error: the variance of its mean over
/// `(mean + 0.01)^2`, averaged over the channels, with the pixel's own mean standing in for
/// the reference (clamped at 0).
pub fn estimated_rel_mse_term(mean: DVec3, variance_of_mean: DVec3) -> f64 {
    let s = mean.max(DVec3::ZERO) + RELATIVE_EPSILON;
    let r = variance_of_mean / (s * s);
    (r.x + r.y + r.z) / 3.0
}

/// A sequence's flicker, relative: how much its error changes from one frame to the next.
/// The square root of the mean over consecutive frames, pixels and channels of
/// `(e_n - e_(n-1))^2 / (R + 0.01)^2`, where `e_n = X_n - T_n` is frame `n`'s error and `R`
/// the two references' mean. The errors are taken against the references, whose own noise
/// (each pixel's estimated variance of its mean) is independent from frame to frame and of
/// the sequence's, so it adds both variances to the mean square, which are taken out. An
/// error that stays (a fixed bias, or noise that stays put) does not flicker; independent
/// noise of relative variance `s^2` in every frame flickers by `sqrt(2) s`. Measured at fixed
/// pixels: with a moving camera, an error that moves with the picture counts too. Clamped at
/// 0 before the root. Summed one pair of consecutive frames at a time ([`FlickerSum::add`]),
/// so that a sequence of any length is measured holding two frames.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlickerSum {
    sum: f64,
    count: usize,
}

/// A frame of a sequence as flicker reads it: its colour, its reference's colour, and the
/// reference's per-pixel variances of its mean ([`VARIANCE`]; a film's replicates image).
pub type FlickerFrame<'a> = (&'a Image, &'a Image, &'a Image);

/// A reference's variances of its pixels' means.
fn variances(image: &Image) -> RgbPlanes<'_> {
    image.rgb(VARIANCE).expect("a reference's variances")
}

impl FlickerSum {
    /// Adds the change from frame `(x0, r0, v0)` to the next, `(x1, r1, v1)`.
    pub fn add(&mut self, (x0, r0, v0): FlickerFrame<'_>, (x1, r1, v1): FlickerFrame<'_>) {
        let (v0, v1) = (variances(v0), variances(v1));
        for (i, [x0, r0, x1, r1]) in pixels([x0, r0, x1, r1]).enumerate() {
            let de = (x1 - r1) - (x0 - r0);
            let change = de * de - v0.at_f64(i) - v1.at_f64(i);
            let s = (r0 + r1) * 0.5 + RELATIVE_EPSILON;
            let t = change / (s * s);
            self.sum += t.x + t.y + t.z;
            self.count += 3;
        }
    }

    /// The flicker of the pairs added.
    pub fn flicker(&self) -> f64 {
        (self.sum / self.count.max(1) as f64).max(0.0).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::{Precision, Values};

    /// A one-row image whose colour is `values` (rounded to `f32`, as images hold them).
    fn image(values: &[DVec3]) -> Image {
        let mut image = Image::new(values.len() as u32, 1);
        image.set_rgb(COLOUR, values.iter().map(|v| v.as_vec3()));
        image
    }

    /// A one-row image of the variances `values`.
    fn variances(values: &[DVec3]) -> Image {
        let mut image = Image::new(values.len() as u32, 1);
        image.set_rgb(VARIANCE, values.iter().map(|v| v.as_vec3()));
        image
    }

    /// The flicker of a sequence: `frames` against `references` of variances `vars`.
    fn flicker(frames: &[Vec<DVec3>], references: &[Vec<DVec3>], vars: &[Vec<DVec3>]) -> f64 {
        let (x, r, v): (Vec<Image>, Vec<Image>, Vec<Image>) = (
            frames.iter().map(|f| image(f)).collect(),
            references.iter().map(|f| image(f)).collect(),
            vars.iter().map(|f| variances(f)).collect(),
        );
        let mut sum = FlickerSum::default();
        for n in 1..x.len() {
            sum.add((&x[n - 1], &r[n - 1], &v[n - 1]), (&x[n], &r[n], &v[n]));
        }
        sum.flicker()
    }

    #[test]
    fn errors_of_known_images() {
        let reference = image(&[DVec3::ZERO, DVec3::ONE]);
        let x = image(&[DVec3::splat(0.25), DVec3::new(1.0, 1.0, 1.5)]);
        // Squared differences: 0.0625 x 3, then 0, 0, 0.25: mean 0.4375 / 6.
        assert_eq!(mse(&x, &reference), 0.4375 / 6.0);
        // Relative: 0.0625 / 0.0001 x 3, and 0.25 / 1.0201.
        let expected = (3.0 * 0.0625 / 0.0001 + 0.25 / 1.0201) / 6.0;
        assert!((rel_mse(&x, &reference) / expected - 1.0).abs() < 1e-12);
        assert_eq!(mse(&reference, &reference), 0.0);
        // Images of different sizes are not compared.
        let wider = image(&[DVec3::ZERO; 3]);
        assert!(std::panic::catch_unwind(|| mse(&wider, &reference)).is_err());
    }

    #[test]
    fn flicker_sees_independent_noise_and_not_shared_error() {
        // A truth that changes from frame to frame, exact references.
        let truth: Vec<Vec<DVec3>> = (0..4)
            .map(|n| vec![DVec3::splat(1.0 + 0.125 * n as f64); 2])
            .collect();
        let zero = vec![vec![DVec3::ZERO; 2]; 4];
        assert_eq!(flicker(&truth, &truth, &zero), 0.0);
        // A fixed error in every frame: no flicker.
        let biased: Vec<Vec<DVec3>> = truth
            .iter()
            .map(|f| f.iter().map(|v| *v + DVec3::splat(0.0625)).collect())
            .collect();
        assert!(flicker(&biased, &truth, &zero) < 1e-9);
        // Errors of +e and -e in alternate frames, on a still truth of 1: the change is 2e,
        // so the flicker is 2e / 1.01.
        let still = vec![vec![DVec3::ONE; 2]; 4];
        let e = 0.03125;
        let alternating: Vec<Vec<DVec3>> = (0..4)
            .map(|n| vec![DVec3::splat(if n % 2 == 0 { 1.0 + e } else { 1.0 - e }); 2])
            .collect();
        assert!((flicker(&alternating, &still, &zero) - 2.0 * e / 1.01).abs() < 1e-12);
        // Noisy references whose noise is known is taken out: references off by +-d in
        // alternate frames, each with variance d^2, against a sequence equal to the truth:
        // (2d)^2 - 2 d^2 = 2 d^2 is left; relative to 1.01^2.
        let d = 0.015625;
        let noisy: Vec<Vec<DVec3>> = (0..4)
            .map(|n| vec![DVec3::splat(if n % 2 == 0 { 1.0 + d } else { 1.0 - d }); 2])
            .collect();
        let var = vec![vec![DVec3::splat(d * d); 2]; 4];
        let expected = (2.0 * d * d).sqrt() / 1.01;
        assert!((flicker(&still, &noisy, &var) - expected).abs() < 1e-12);
        let exact_var = vec![vec![DVec3::splat(2.0 * d * d); 2]; 4];
        assert!(flicker(&still, &noisy, &exact_var) < 1e-6);
    }

    /// Triples of (image, reference a, reference b) around a known truth, with independent
    /// noise of the given standard deviations (uniform noise from PCG32).
    fn noisy(truth: &[DVec3], sigma: (f64, f64), seed: u64) -> [Image; 3] {
        let mut rng = crate::rng::Pcg32::new(seed, 7);
        // A uniform number in [-1, 1) has variance 1/3.
        let mut noise = |s: f64| {
            let mut u = || (2.0 * rng.next_f64() - 1.0) * s * 3f64.sqrt();
            DVec3::new(u(), u(), u())
        };
        let x: Vec<DVec3> = truth.iter().map(|t| *t + noise(sigma.0)).collect();
        let a: Vec<DVec3> = truth.iter().map(|t| *t + noise(sigma.1)).collect();
        let b: Vec<DVec3> = truth.iter().map(|t| *t + noise(sigma.1)).collect();
        [image(&x), image(&a), image(&b)]
    }

    #[test]
    fn cross_estimates_are_unbiased_where_the_plain_error_is_not() {
        // Pixels of several brightnesses; references with half the image's noise, whose
        // variance makes the plain error 25% high.
        let values: Vec<DVec3> = (0..64)
            .map(|i| DVec3::new(0.5, 1.0, 2.0) * (1.0 + i as f64 / 16.0))
            .collect();
        let truth = image(&values);
        let (sigma, sigma_ref) = (0.1, 0.05);
        let (mut cross, mut plain, mut exact) = (0.0, 0.0, 0.0);
        let (mut cross_rel, mut exact_rel) = (0.0, 0.0);
        let trials = 2000;
        for seed in 0..trials {
            let [x, a, b] = noisy(&values, (sigma, sigma_ref), seed);
            cross += cross_mse(&x, &a, &b);
            plain += mse(&x, &a);
            exact += mse(&x, &truth);
            cross_rel += cross_rel_mse(&x, &a, &b);
            exact_rel += rel_mse(&x, &truth);
        }
        let n = trials as f64;
        let (cross, plain, exact) = (cross / n, plain / n, exact / n);
        // The true MSE is sigma^2; the plain one adds the reference's variance.
        assert!((exact / (sigma * sigma) - 1.0).abs() < 0.01, "{exact}");
        assert!(
            (cross / exact - 1.0).abs() < 0.02,
            "{cross} against {exact}"
        );
        let expected_plain = sigma * sigma + sigma_ref * sigma_ref;
        assert!((plain / expected_plain - 1.0).abs() < 0.02, "{plain}");
        // Relative: unbiased but for the references' relative variance r (at most
        // 0.05^2 / 0.51^2 = 0.0096 here): 1.5 r = 1.4% on the darkest pixels, less on average.
        let ratio = cross_rel / exact_rel;
        assert!((ratio - 1.0).abs() < 0.02, "{ratio}");
        // With exact references, the cross-estimate is the true error, bit for bit.
        let [x, _, _] = noisy(&values, (sigma, sigma_ref), 1);
        assert_eq!(cross_mse(&x, &truth, &truth), mse(&x, &truth));
        assert_eq!(cross_rel_mse(&x, &truth, &truth), rel_mse(&x, &truth));
    }

    #[test]
    fn estimates_are_means_of_variances() {
        let var = variances(&[DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO]);
        assert_eq!(estimated_mse(&var), 1.0);
        assert!((estimated_rel_mse_term(DVec3::splat(0.99), DVec3::ONE) - 1.0).abs() < 1e-12);
        // A count channel is not a variance.
        let mut counts = Image::new(1, 1);
        counts.set("variance.R", Precision::Float, Values::Count(vec![1]));
        assert!(std::panic::catch_unwind(|| estimated_mse(&counts)).is_err());
    }
}
