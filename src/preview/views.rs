//! What the page shows of a rendered frame: its colour, as the PNG a frame file holds (the
//! same pixels as `render` writes), and each of the scene's passes as a picture to look at.
//!
//! The passes' pictures are for the eye only (the frame files keep the values): depth as
//! grey from near (white) to far (dark) over the frame's own range, misses black; normals as
//! `0.5 + 0.5 n`; albedo and the noisy colour sRGB encoded; motion as the forward
//! displacement (`0.5 + u / 2m`, `0.5 + v / 2m`, 0.5, with `m` the frame's largest); variance
//! as grey on a log scale over the frame's range; samples and alpha as grey over [0, most].

use ::image::ImageEncoder;
use ::image::codecs::png::PngEncoder;

use raytrace_core::error::Error;
use raytrace_core::image::Image;
use raytrace_core::pass::Pass;
use raytrace_core::pass::{DEPTH, FORWARD, NORMAL, SAMPLES, VARIANCE};
use raytrace_core::passes::NO_DEPTH;
use raytrace_core::renderer::FrameResult;
use raytrace_core::scene::Scene;
use raytrace_io::linear_to_srgb8;
use raytrace_render::output;

/// One view of a frame: its name (`colour` or a pass's) and its PNG.
pub(crate) struct EncodedView {
    pub(crate) name: &'static str,
    pub(crate) png: Vec<u8>,
}

/// Every view of `result`, a frame of `scene`: the colour first, then the scene's passes.
pub(crate) fn encode_views(scene: &Scene, result: &FrameResult) -> Result<Vec<EncodedView>, Error> {
    let mut views = vec![EncodedView {
        name: "colour",
        png: output::frame_png(scene, result)?,
    }];
    let image = &result.image;
    for pass in scene.output.passes.iter() {
        let rgb = pass_picture(image, pass);
        views.push(EncodedView {
            name: pass.name(),
            png: encode_rgb(&rgb, image.width(), image.height(), scene)?,
        });
    }
    Ok(views)
}

/// 8-bit RGB of a picture as a PNG.
fn encode_rgb(rgb: &[u8], width: u32, height: u32, scene: &Scene) -> Result<Vec<u8>, Error> {
    let mut png = Vec::new();
    PngEncoder::new(&mut png)
        .write_image(rgb, width, height, ::image::ExtendedColorType::Rgb8)
        .map_err(|e| Error::Output {
            path: scene.source.clone(),
            message: format!("PNG encoder: {e}"),
        })?;
    Ok(png)
}

/// The picture of `pass` (whose channels `image` holds), 8-bit RGB, row-major.
fn pass_picture(image: &Image, pass: Pass) -> Vec<u8> {
    let channel = |name: &str| image.floats(name).unwrap_or(&[]);
    let grey = |v: f32| {
        let g = (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        [g, g, g]
    };
    let unit = |v: f32| ((0.5 + 0.5 * v).clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    let n = image.pixels();
    let pixels: Vec<[u8; 3]> = match pass {
        Pass::Alpha => channel("A").iter().map(|&a| grey(a)).collect(),
        Pass::Samples => {
            let s = channel(SAMPLES);
            let most = s.iter().copied().fold(0.0f32, f32::max).max(1.0);
            s.iter().map(|&v| grey(v / most)).collect()
        }
        Pass::Depth => {
            let z = channel(DEPTH);
            let hit = |v: f32| v.is_finite() && v < NO_DEPTH;
            let (near, far) = range(z.iter().copied().filter(|&v| hit(v)));
            z.iter()
                .map(|&v| match hit(v) {
                    true => grey(1.0 - 0.9 * (v - near) / (far - near).max(f32::MIN_POSITIVE)),
                    false => [0, 0, 0],
                })
                .collect()
        }
        Pass::Normal => {
            let [x, y, z] = NORMAL.0.map(channel);
            (0..n)
                .map(|i| [unit(x[i]), unit(y[i]), unit(z[i])])
                .collect()
        }
        Pass::Albedo | Pass::Noisy => {
            let names = pass.channels();
            let (r, g, b) = (channel(names[0]), channel(names[1]), channel(names[2]));
            (0..n)
                .map(|i| [r[i], g[i], b[i]].map(linear_to_srgb8))
                .collect()
        }
        Pass::Motion => {
            let (u, v) = (channel(FORWARD[0]), channel(FORWARD[1]));
            let most = u.iter().chain(v).map(|x| x.abs()).fold(0.0f32, f32::max);
            let scale = if most > 0.0 { 1.0 / most } else { 0.0 };
            (0..n)
                .map(|i| [unit(u[i] * scale), unit(v[i] * scale), 128])
                .collect()
        }
        Pass::Variance => {
            let [r, g, b] = VARIANCE.0.map(channel);
            let log = |i: usize| ((r[i] + g[i] + b[i]) / 3.0).max(1e-12).log10();
            let (low, high) = range((0..n).map(log));
            (0..n)
                .map(|i| grey((log(i) - low) / (high - low).max(f32::MIN_POSITIVE)))
                .collect()
        }
    };
    pixels.into_iter().flatten().collect()
}

/// The least and greatest of finite `values` (0 and 1 when there are none).
fn range(values: impl Iterator<Item = f32>) -> (f32, f32) {
    let (low, high) = values
        .filter(|v| v.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if low <= high { (low, high) } else { (0.0, 1.0) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use raytrace_core::image::{Precision, Values};

    #[test]
    fn depth_runs_from_white_near_to_dark_far_and_misses_are_black() {
        let mut image = Image::new(3, 1);
        image.set(
            DEPTH,
            Precision::Float,
            Values::Float(vec![2.0, 4.0, NO_DEPTH]),
        );
        let rgb = pass_picture(&image, Pass::Depth);
        assert_eq!(&rgb[0..3], &[255, 255, 255]);
        // 1 - 0.9 = 0.1 of white.
        assert_eq!(&rgb[3..6], &[26, 26, 26]);
        assert_eq!(&rgb[6..9], &[0, 0, 0]);
    }

    #[test]
    fn normals_map_minus_one_to_black_and_one_to_white() {
        let mut image = Image::new(1, 1);
        image.set_rgb(NORMAL, [glam::Vec3::new(-1.0, 0.0, 1.0)].into_iter());
        assert_eq!(pass_picture(&image, Pass::Normal), [0, 128, 255]);
    }
}
