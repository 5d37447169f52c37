//! The binary moved to another folder, as a farm's shared file system holds it, where the
//! folder the build provided the denoiser's library in does not exist: every command that
//! does not denoise runs without the library; `--denoise` is exit 1 naming the library and
//! how to provide it, and works once the libraries are copied beside the binary.

use crate::common;

use std::path::Path;

use common::moved::{SCENE, copy_libraries, moved_binary, provided_by_the_build, run};
use common::text;

fn ok(binary: &Path, dir: &Path, args: &[&str]) -> String {
    let o = run(binary, dir, args);
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", text(&o));
    text(&o)
}

/// A folder with `bin/raytrace` (moved) and the scene `shot.toml`.
fn farm() -> (tempfile::TempDir, std::path::PathBuf) {
    let d = tempfile::tempdir().unwrap();
    let bin = d.path().join("bin");
    std::fs::create_dir(&bin).unwrap();
    std::fs::write(d.path().join("shot.toml"), SCENE).unwrap();
    let binary = moved_binary(&bin);
    (d, binary)
}

#[test]
fn a_moved_binary_without_the_library_runs_all_but_denoising() {
    let (d, raytrace) = farm();
    let dir = d.path();
    assert!(ok(&raytrace, dir, &["--version"]).starts_with("raytrace "));
    assert!(ok(&raytrace, dir, &["check", "shot.toml"]).contains("shot.toml: ok"));
    ok(&raytrace, dir, &["render", "shot.toml", "--frames", "1"]);
    assert!(dir.join("out/f_0001.exr").is_file());
    let o = run(
        &raytrace,
        dir,
        &["render", "shot.toml", "--frames", "2", "--denoise"],
    );
    let t = text(&o);
    if provided_by_the_build() {
        assert_eq!(o.status.code(), Some(1), "{t}");
        for want in [
            "denoising needs Intel Open Image Denoise 2.5 (libOpenImageDenoise.so.2)",
            "no libOpenImageDenoise.so.2 in ",
            "Copy the libraries of the build's .oidn/lib folder",
        ] {
            assert!(t.contains(want), "{want:?} missing in {t}");
        }
        assert!(!t.contains("panicked"), "{t}");
        assert!(!dir.join("out/f_0002.exr").exists());
    } else {
        // The build took the system's library, which the system's loader finds.
        assert_eq!(o.status.code(), Some(0), "{t}");
    }
}

#[test]
fn a_moved_binary_with_its_libraries_beside_it_denoises() {
    let (d, raytrace) = farm();
    let dir = d.path();
    // Every library beside the binary, in a folder not named `lib`: their own run paths
    // ($ORIGIN/../lib) do not find each other there.
    assert!(copy_libraries(&dir.join("bin"), |_| true) >= 2);
    let t = ok(
        &raytrace,
        dir,
        &["render", "shot.toml", "--frames", "1", "--denoise"],
    );
    assert!(t.contains("denoised"), "{t}");
    assert!(dir.join("out/f_0001.exr").is_file());
    // The same from a lib folder beside bin/ (an install's layout).
    let (d, raytrace) = farm();
    let lib = d.path().join("lib");
    std::fs::create_dir(&lib).unwrap();
    assert!(copy_libraries(&lib, |_| true) >= 2);
    ok(
        &raytrace,
        d.path(),
        &["render", "shot.toml", "--frames", "2", "--denoise"],
    );
    assert!(d.path().join("out/f_0002.exr").is_file());
}
