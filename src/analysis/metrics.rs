//! Image error metrics: against a reference image, and estimated from the samples alone.
//!
//! All are means over every pixel and colour channel, in linear radiance.

use glam::DVec3;

/// The offset in the denominator of the relative error, so that black pixels do not divide
/// by zero (as pbrt-v4's `imgtool diff --metric relmse`).
pub const RELATIVE_EPSILON: f64 = 0.01;

fn mean_over(values: impl Iterator<Item = DVec3>, count: usize) -> f64 {
    let sum: f64 = values.map(|v| v.x + v.y + v.z).sum();
    sum / (3 * count.max(1)) as f64
}

/// The mean squared error of `image` against `reference`.
pub fn mse(image: &[DVec3], reference: &[DVec3]) -> f64 {
    assert_eq!(image.len(), reference.len(), "images of different sizes");
    let diffs = image
        .iter()
        .zip(reference)
        .map(|(v, r)| (*v - *r) * (*v - *r));
    mean_over(diffs, image.len())
}

/// The relative mean squared error, `mean((v - ref)^2 / (ref + 0.01)^2)`.
pub fn rel_mse(image: &[DVec3], reference: &[DVec3]) -> f64 {
    assert_eq!(image.len(), reference.len(), "images of different sizes");
    let terms = image.iter().zip(reference).map(|(v, r)| {
        let d = *v - *r;
        let s = *r + RELATIVE_EPSILON;
        d * d / (s * s)
    });
    mean_over(terms, image.len())
}

/// The mean squared error estimated from each pixel's variance of its mean (no reference):
/// the mean of the variances, since `E[(mean - expected)^2]` is the variance of the mean.
pub fn estimated_mse(variance_of_mean: &[DVec3]) -> f64 {
    mean_over(variance_of_mean.iter().copied(), variance_of_mean.len())
}

/// One pixel's term of [`estimated_rel_mse`]: the variance of its mean over
/// `(mean + 0.01)^2`, averaged over the channels, with the pixel's own mean standing in for
/// the reference (clamped at 0).
pub fn estimated_rel_mse_term(mean: DVec3, variance_of_mean: DVec3) -> f64 {
    let s = mean.max(DVec3::ZERO) + RELATIVE_EPSILON;
    let r = variance_of_mean / (s * s);
    (r.x + r.y + r.z) / 3.0
}

/// The relative mean squared error estimated from each pixel's (mean, variance of its mean):
/// the mean of [`estimated_rel_mse_term`] over the pixels.
pub fn estimated_rel_mse(pixels: impl Iterator<Item = (DVec3, DVec3)>) -> f64 {
    let mut count = 0;
    let sum: f64 = pixels
        .map(|(m, var)| {
            count += 1;
            estimated_rel_mse_term(m, var)
        })
        .sum();
    sum / count.max(1) as f64
}

/// A sequence's flicker, relative: how much its error changes from one frame to the next.
/// The square root of the mean over consecutive frames, pixels and channels of
/// `(e_n - e_(n-1))^2 / (R + 0.01)^2`, where `e_n = X_n - T_n` is frame `n`'s error and `R`
/// the two references' mean. The errors are taken against the `references`, whose own noise
/// (`reference_variances`, each pixel's estimated variance of its mean) is independent from
/// frame to frame and of the sequence's, so it adds both variances to the mean square, which
/// are taken out. An error that stays (a fixed bias, or noise that stays put) does not
/// flicker; independent noise of relative variance `s^2` in every frame flickers by
/// `sqrt(2) s`. Measured at fixed pixels: with a moving camera, an error that moves with the
/// picture counts too. Clamped at 0 before the root.
pub fn flicker(
    frames: &[Vec<DVec3>],
    references: &[Vec<DVec3>],
    reference_variances: &[Vec<DVec3>],
) -> f64 {
    assert!(
        frames.len() == references.len() && references.len() == reference_variances.len(),
        "one reference per frame"
    );
    let mut sum = 0.0;
    let mut count = 0usize;
    for n in 1..frames.len() {
        let (x0, x1) = (&frames[n - 1], &frames[n]);
        let (r0, r1) = (&references[n - 1], &references[n]);
        let (v0, v1) = (&reference_variances[n - 1], &reference_variances[n]);
        for i in 0..x1.len() {
            let de = (x1[i] - r1[i]) - (x0[i] - r0[i]);
            let change = de * de - v0[i] - v1[i];
            let s = (r0[i] + r1[i]) * 0.5 + RELATIVE_EPSILON;
            let t = change / (s * s);
            sum += t.x + t.y + t.z;
            count += 3;
        }
    }
    (sum / count.max(1) as f64).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_of_known_images() {
        let reference = [DVec3::ZERO, DVec3::ONE];
        let image = [DVec3::splat(0.1), DVec3::new(1.0, 1.0, 1.3)];
        // Squared differences: 0.01 x 3, then 0, 0, 0.09: mean 0.12 / 6.
        assert!((mse(&image, &reference) - 0.02).abs() < 1e-15);
        // Relative: 0.01 / 0.0001 x 3 = 300, and 0.09 / 1.0201.
        let expected = (300.0 + 0.09 / 1.0201) / 6.0;
        assert!((rel_mse(&image, &reference) - expected).abs() < 1e-9);
        assert_eq!(mse(&reference, &reference), 0.0);
    }

    #[test]
    fn flicker_sees_independent_noise_and_not_shared_error() {
        // A truth that changes from frame to frame, exact references.
        let truth: Vec<Vec<DVec3>> = (0..4)
            .map(|n| vec![DVec3::splat(1.0 + 0.1 * n as f64); 2])
            .collect();
        let zero = vec![vec![DVec3::ZERO; 2]; 4];
        assert_eq!(flicker(&truth, &truth, &zero), 0.0);
        // A fixed error in every frame: no flicker.
        let biased: Vec<Vec<DVec3>> = truth
            .iter()
            .map(|f| f.iter().map(|v| *v + DVec3::splat(0.05)).collect())
            .collect();
        assert!(flicker(&biased, &truth, &zero) < 1e-9);
        // Errors of +e and -e in alternate frames, on a still truth of 1: the change is 2e,
        // so the flicker is 2e / 1.01.
        let still = vec![vec![DVec3::ONE; 2]; 4];
        let e = 0.03;
        let alternating: Vec<Vec<DVec3>> = (0..4)
            .map(|n| vec![DVec3::splat(if n % 2 == 0 { 1.0 + e } else { 1.0 - e }); 2])
            .collect();
        assert!((flicker(&alternating, &still, &zero) - 2.0 * e / 1.01).abs() < 1e-12);
        // Noisy references whose noise is known is taken out: references off by +-d in
        // alternate frames, each with variance d^2, against a sequence equal to the truth:
        // (2d)^2 - 2 d^2 = 2 d^2 is left; relative to 1.01^2.
        let d = 0.02;
        let noisy: Vec<Vec<DVec3>> = (0..4)
            .map(|n| vec![DVec3::splat(if n % 2 == 0 { 1.0 + d } else { 1.0 - d }); 2])
            .collect();
        let var = vec![vec![DVec3::splat(d * d); 2]; 4];
        let expected = (2.0 * d * d).sqrt() / 1.01;
        assert!((flicker(&still, &noisy, &var) - expected).abs() < 1e-12);
        let exact_var = vec![vec![DVec3::splat(2.0 * d * d); 2]; 4];
        assert!(flicker(&still, &noisy, &exact_var) < 1e-6);
    }

    #[test]
    fn estimates_are_means_of_variances() {
        let var = [DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO];
        assert_eq!(estimated_mse(&var), 1.0);
        let image = [DVec3::splat(0.99), DVec3::ONE];
        let pixels = image.iter().copied().zip(var.iter().copied());
        assert!((estimated_rel_mse(pixels) - 1.0).abs() < 1e-12);
    }
}
