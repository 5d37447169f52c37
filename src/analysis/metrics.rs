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
    fn estimates_are_means_of_variances() {
        let var = [DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO];
        assert_eq!(estimated_mse(&var), 1.0);
        let image = [DVec3::splat(0.99), DVec3::ONE];
        let pixels = image.iter().copied().zip(var.iter().copied());
        assert!((estimated_rel_mse(pixels) - 1.0).abs() < 1e-12);
    }
}
