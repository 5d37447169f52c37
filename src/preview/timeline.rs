//! The shot as the page's timeline draws it: each selected frame's nominal time and whole
//! exposure (`Shot::interval`, the interval `check` lists), the shutter's curve and a rolling
//! shutter's readout (what `check`'s `shutter:` line says, in its words), the views the page
//! can show, the image's size and samples. Sent to the pages as one `shot` event.

use serde_json::json;

use raytrace_core::scene::Scene;
use raytrace_core::shutter::ReadoutDirection;

/// Most frames the timeline lists: a longer selection shows its first this many (narrow it
/// with `--frames`).
pub(crate) const MAX_TIMELINE_FRAMES: usize = 2000;

/// The page's names of the views a frame of `scene` has: `colour`, then the scene's passes.
pub(crate) fn view_names(scene: &Scene) -> Vec<&'static str> {
    std::iter::once("colour")
        .chain(scene.output.passes.iter().map(|p| p.name()))
        .collect()
}

/// The `shot` event's data (JSON) for `scene` (the file `name`), whose run shows `frames`
/// (at most [`MAX_TIMELINE_FRAMES`] of the `total` selected), rendered at `size` (the
/// scene's own, or smaller to fit the pages), as render generation `generation`.
pub(crate) fn shot_json(
    scene: &Scene,
    name: &str,
    frames: &[u32],
    total: u64,
    size: (u32, u32),
    generation: u64,
) -> String {
    let shot = &scene.shot;
    let listed: Vec<_> = frames
        .iter()
        .map(|&f| {
            let i = shot.interval(f);
            json!([f, shot.frame_time(f), i.open, i.close])
        })
        .collect();
    let rolling = shot.rolling.filter(|r| r.readout > 0.0);
    json!({
        "scene": name,
        "generation": generation,
        "fps": shot.fps,
        "frames": listed,
        "total": total,
        "shutter": shot.shutter,
        "exposure": shot.exposure(),
        "readout": rolling.map_or(0.0, |r| r.readout),
        "bottomFirst": rolling.is_some_and(|r| r.direction == ReadoutDirection::BottomToTop),
        "curve": shot.curve.points().iter().map(|&(s, w)| [s, w]).collect::<Vec<_>>(),
        "note": shot.exposure_note(),
        "views": view_names(scene),
        "width": size.0,
        "height": size.1,
        "fullWidth": scene.output.width,
        "fullHeight": scene.output.height,
        "samples": scene.render.samples,
    })
    .to_string()
}

#[cfg(test)]
mod tests {
    use raytrace_scene::scene_file::SceneFile;
    use std::path::Path;

    use super::*;

    #[test]
    fn frames_carry_their_exposure_and_the_curve_and_readout_come_along() {
        let text = "[shot]\nfps = 24.0\nframes = 4\nshutter_angle = 180.0\n\
                    shutter_curve = \"triangle\"\nrolling_shutter = { readout = 0.01 }\n\
                    [output]\nwidth = 8\nheight = 4\npasses = [\"depth\"]\npath = \"f_####.exr\"\n";
        let scene = Scene::parse(text, Path::new("s.toml")).unwrap();
        let v: serde_json::Value =
            serde_json::from_str(&shot_json(&scene, "s.toml", &[2, 3], 4, (8, 4), 7)).unwrap();
        // Frame 2 at 1/24 s; its whole exposure is the 1/48 s shutter plus the readout,
        // centred on it.
        let f = &v["frames"][0];
        assert_eq!(f[0], 2);
        let (t, half) = (1.0 / 24.0, 0.5 * (1.0 / 48.0 + 0.01));
        assert!((f[1].as_f64().unwrap() - t).abs() < 1e-15);
        assert!((f[2].as_f64().unwrap() - (t - half)).abs() < 1e-15);
        assert!((f[3].as_f64().unwrap() - (t + half)).abs() < 1e-15);
        assert_eq!(v["readout"], 0.01);
        assert_eq!(v["curve"], json!([[0.0, 0.0], [0.5, 1.0], [1.0, 0.0]]));
        assert_eq!(v["views"], json!(["colour", "depth"]));
        assert_eq!(v["note"], scene.shot.exposure_note().unwrap());
        assert_eq!(v["generation"], 7);
    }
}
