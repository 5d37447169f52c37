//! A perceptual difference: NVIDIA's FLIP (Andersson et al., "FLIP: A Difference Evaluator
//! for Alternating Images", HPG 2020) through the `nv-flip` crate, the bindings to NVIDIA's own
//! implementation that wgpu's image tests use.
//!
//! FLIP here is its LDR form: both images are 8-bit sRGB as a viewer would see them (what a
//! PNG frame holds), compared at the crate's default 67 pixels per degree (a 0.7 m viewing
//! distance from a 24-inch 4K screen). The mean over the pixels of the error map, from 0
//! (identical) to 1, is the single figure the paper's authors recommend.

/// The mean FLIP error of `test` against `reference`, both `width` x `height` 8-bit sRGB
/// images, RGB interleaved, row-major, top row first.
pub(crate) fn mean_flip(width: u32, height: u32, reference: &[u8], test: &[u8]) -> f64 {
    let size = width as usize * height as usize * 3;
    assert!(
        reference.len() == size && test.len() == size,
        "images of different sizes"
    );
    let reference = nv_flip::FlipImageRgb8::with_data(width, height, reference);
    let test = nv_flip::FlipImageRgb8::with_data(width, height, test);
    let map = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    nv_flip::FlipPool::from_image(&map).mean() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 32x24 image of smooth gradients, with noise of amplitude `noise` (in 8-bit steps)
    /// from a fixed PCG32 stream.
    fn image(noise: f64) -> Vec<u8> {
        let mut rng = raytrace_core::rng::Pcg32::new(3, 1);
        (0..32 * 24 * 3)
            .map(|i| {
                let base = 40.0 + (i % 96) as f64 + (i / 96) as f64 * 2.0;
                let n = (2.0 * rng.next_f64() - 1.0) * noise;
                (base + n).round().clamp(0.0, 255.0) as u8
            })
            .collect()
    }

    #[test]
    fn flip_is_zero_for_equal_images_and_grows_with_the_difference() {
        let reference = image(0.0);
        assert_eq!(mean_flip(32, 24, &reference, &reference), 0.0);
        let errors: Vec<f64> = [2.0, 8.0, 32.0]
            .iter()
            .map(|&n| mean_flip(32, 24, &reference, &image(n)))
            .collect();
        assert!(
            errors[0] > 0.0 && errors[0] < errors[1] && errors[1] < errors[2],
            "{errors:?}"
        );
        assert!(errors[2] < 1.0, "{errors:?}");
        // Black against white is as far apart as it gets.
        let (black, white) = (vec![0u8; 32 * 24 * 3], vec![255u8; 32 * 24 * 3]);
        assert!(mean_flip(32, 24, &black, &white) > 0.9);
    }

    #[test]
    fn the_smallest_images_are_measured() {
        for (w, h) in [(1, 1), (1, 7), (5, 1)] {
            let n = (w * h * 3) as usize;
            let e = mean_flip(w, h, &vec![10; n], &vec![200; n]);
            assert!(e.is_finite() && e > 0.0, "{w}x{h}: {e}");
        }
    }
}
