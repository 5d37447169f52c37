//! Fuzzes `Scene::parse_bytes` with any bytes: it must never panic; a refused input must be a
//! bad-scene error (exit status 2) whose message starts with the file name; an accepted scene
//! must render a tiny frame (first and last) with finite pixels and no sample dropped.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use raytrace_core::Scene;
use raytrace_core::image::COLOUR;
use raytrace_core::renderer::{CpuShot, FrameJob};
use raytrace_scene::scene_file::SceneFile;

fuzz_target!(|data: &[u8]| {
    match Scene::parse_bytes(data, Path::new("fuzz.toml")) {
        Err(e) => {
            assert_eq!(e.exit_code(), 2, "{e}");
            assert!(e.to_string().starts_with("fuzz.toml"), "{e}");
        }
        Ok(mut scene) => {
            scene.output.width = 2;
            scene.output.height = 2;
            scene.render.samples = 1;
            scene.render.max_depth = 4;
            let shot = CpuShot::new(&scene);
            for frame in [scene.shot.first_frame, scene.shot.last_frame()] {
                let r = FrameJob::new(&scene, frame).sample(&shot).expect("a CPU frame");
                assert_eq!(r.stats.non_finite, 0);
                let colour = r.image.rgb(COLOUR).expect("a frame's colour");
                assert!((0..r.image.pixels()).all(|i| colour.at(i).is_finite()));
            }
        }
    }
});
