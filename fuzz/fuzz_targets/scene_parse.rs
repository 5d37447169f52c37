//! Fuzzes `Scene::parse_bytes` with any bytes: it must never panic; a refused input must be a
//! bad-scene error (exit status 2) whose message starts with the file name; an accepted scene
//! must render a tiny frame (first and last) with finite pixels and no sample dropped.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use raytrace_scene::scene_file::SceneFile;
use raytrace_core::Scene;
use raytrace_core::renderer::{Budget, render_frame};
use raytrace_core::world::StaticGeometry;

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
            let statics = StaticGeometry::new(&scene);
            for frame in [scene.shot.first_frame, scene.shot.last_frame()] {
                let r = render_frame(&scene, &statics, frame, &Budget::default(), &|_| {});
                assert_eq!(r.stats.dropped, 0);
                assert!(r.film.pixels().iter().all(|p| p.is_finite()));
            }
        }
    }
});
