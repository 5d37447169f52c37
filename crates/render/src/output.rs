//! A rendered frame to its file: the one step every command takes from a finished
//! [`FrameResult`] to an EXR or PNG file. The frame's image (its colour and its passes'
//! channels) is encoded as it is; the file's attributes come from the scene, the frame's own
//! interval and its figures.

use std::path::Path;

use raytrace_core::error::Error;
use raytrace_core::format::Format;
use raytrace_core::renderer::{Budget, FrameResult};
use raytrace_core::scene::Scene;
use raytrace_core::shutter::ShutterCurve;
use raytrace_io::{self as io, FrameInfo};

/// Writes `result`, a frame of `scene` rendered under `budget`, to `path` in `format`
/// atomically, with its passes and attributes: the frame's interval, samples, seed, sampler,
/// shutter; its estimated relative error when known; the budget's threshold and limit; the
/// fewest and mean samples when pixels took different counts. Returns the number of pixels
/// written as black because their means were not finite as `f32` (recorded as
/// `nonFinitePixels`).
pub fn write_frame(
    path: &Path,
    format: Format,
    scene: &Scene,
    result: &FrameResult,
    budget: &Budget,
) -> Result<u64, Error> {
    let st = &result.stats;
    let mut info = frame_info(scene, result, st.samples_per_pixel);
    if st.relative_error.is_finite() {
        info.extra
            .push(("estimatedRelativeError".to_string(), st.relative_error));
    }
    if let Some(d) = &result.denoised {
        info.denoiser = Some(format!(
            "{DENOISER}, quality {}; written: the raw and denoised frames blended per pixel by their estimated errors",
            d.quality
        ));
        info.extra
            .push(("denoisedShare".to_string(), d.denoised_share));
        if let Some(h) = d.history_share {
            info.extra.push(("historyShare".to_string(), h));
        }
        if st.noisy_relative_error.is_finite() {
            info.extra
                .push(("noisyRelativeError".to_string(), st.noisy_relative_error));
        }
    }
    if let Some(t) = budget.noise_threshold {
        info.extra.push(("noiseThreshold".to_string(), t));
    }
    if let Some(t) = budget.time_limit {
        info.extra.push(("timeLimit".to_string(), t));
    }
    if st.min_samples_per_pixel != st.samples_per_pixel {
        info.extra
            .push(("minSamples".to_string(), st.min_samples_per_pixel as f64));
        info.extra
            .push(("meanSamples".to_string(), st.mean_samples_per_pixel));
    }
    // A pixel of the film that is not finite as an `f32` (NaN, infinite, or a mean beyond
    // `f32::MAX`) was written black in the image.
    let non_finite = result.film.non_finite();
    if non_finite > 0 {
        info.extra
            .push(("nonFinitePixels".to_string(), non_finite as f64));
    }
    io::write_image(path, format, &result.image, &info)?;
    Ok(non_finite)
}

/// `result`, a frame of `scene`, as the 8-bit sRGB PNG that [`write_frame`] writes to a
/// `.png` path (the same pixels), in memory.
pub fn frame_png(scene: &Scene, result: &FrameResult) -> Result<Vec<u8>, Error> {
    let mut png = Vec::new();
    io::encode_png(&mut png, &result.image).map_err(|e| Error::Output {
        path: scene.source.clone(),
        message: format!("PNG encoder: {e}"),
    })?;
    Ok(png)
}

/// How a denoised frame's file names its denoiser (the `denoiser` attribute).
pub const DENOISER: &str =
    "Intel Open Image Denoise 2.5 RT filter, HDR, colour only, each replicate";

/// The attributes of `result`, a frame of `scene`, rendered with `samples` per pixel.
fn frame_info(scene: &Scene, result: &FrameResult, samples: u32) -> FrameInfo {
    FrameInfo {
        frame: result.frame,
        fps: scene.shot.fps,
        shutter_open: result.interval.open,
        shutter_close: result.interval.close,
        samples,
        seed: scene.render.seed,
        sampler: scene.render.sampler.name().to_string(),
        rolling_shutter_readout: scene.shot.rolling.map(|r| r.readout),
        shutter_curve: (scene.shot.curve != ShutterCurve::Box).then(|| scene.shot.curve.describe()),
        denoiser: None,
        extra: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use raytrace_scene::scene_file::SceneFile;

    use super::*;
    use raytrace_core::pass::PassSet;
    use raytrace_core::passes::SumLayout;
    use raytrace_core::renderer::FrameStats;

    #[test]
    fn pixels_beyond_f32_are_written_finite_and_counted() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.exr");
        let scene = Scene::parse("", Path::new("empty.toml")).unwrap();
        // Finite means in f64 that no f32 holds.
        let film = raytrace_core::film::Film::from_fn(3, 2, |x, y| match (x, y) {
            (0, 0) => DVec3::splat(0.5),
            (1, 0) => DVec3::new(1e39, 0.0, 0.0),
            (2, 1) => DVec3::new(0.0, -1e300, 1.0),
            _ => DVec3::ZERO,
        });
        let result = FrameResult {
            frame: 1,
            interval: scene.shot.interval(1),
            image: film.colour(),
            film,
            layout: SumLayout::new(PassSet::EMPTY),
            denoised: None,
            stats: FrameStats::default(),
        };
        let written = write_frame(&path, Format::Exr, &scene, &result, &Budget::default());
        assert_eq!(written.unwrap(), 2);
        let read = io::read_exr_colour(&path).unwrap();
        assert_eq!((read.width(), read.height()), (3, 2));
        let pixels = read.interleaved(raytrace_core::image::COLOUR).unwrap();
        assert!(pixels.iter().all(|p| p.is_finite()));
        assert_eq!(pixels[..6], [0.5, 0.5, 0.5, 0.0, 0.0, 0.0]);
        let image = ::exr::prelude::read_all_data_from_file(&path).unwrap();
        let count = image.layer_data[0]
            .attributes
            .other
            .get(&::exr::meta::attribute::Text::from("nonFinitePixels"))
            .cloned();
        assert_eq!(
            count,
            Some(::exr::meta::attribute::AttributeValue::F64(2.0))
        );
    }
}
