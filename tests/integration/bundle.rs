//! `contrib/bundle.sh`: the bundle for a machine without a Rust toolchain, unpacked in another
//! folder where the build's folder of the denoiser's library does not exist, renders and
//! denoises with the libraries it carries, and holds the device check with its scenes.

use crate::common;

use std::path::Path;
use std::process::Command;

use common::moved::{SCENE, provided_by_the_build, run, without_the_build_folder};
use common::text;

#[test]
fn a_bundle_unpacked_elsewhere_renders_and_denoises_with_its_own_libraries() {
    let d = tempfile::tempdir().unwrap();
    let archive = d.path().join("bundle.tar.xz");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // The fastest compression: the test checks the contents, not the size.
    let o = Command::new("bash")
        .arg(root.join("contrib/bundle.sh"))
        .arg(&archive)
        .arg(env!("CARGO_BIN_EXE_raytrace"))
        .env("XZ_OPT", "-0")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));

    let farm = d.path().join("farm");
    std::fs::create_dir(&farm).unwrap();
    let o = Command::new("tar")
        .arg("-xJf")
        .arg(&archive)
        .arg("-C")
        .arg(&farm)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let entries: Vec<_> = std::fs::read_dir(&farm).unwrap().flatten().collect();
    assert_eq!(entries.len(), 1, "one folder at the top");
    let top = entries[0].path();
    let name = top.file_name().unwrap().to_string_lossy().into_owned();
    let version = env!("CARGO_PKG_VERSION");
    assert!(
        name.starts_with(&format!("raytrace-{version}-")) && name.ends_with("-linux"),
        "{name}"
    );

    // The binary stripped, and blind to the build's folder, as on a machine without it.
    let binary = top.join("bin/raytrace");
    let built = std::fs::metadata(env!("CARGO_BIN_EXE_raytrace"))
        .unwrap()
        .len();
    assert!(std::fs::metadata(&binary).unwrap().len() < built);
    without_the_build_folder(&binary, &binary);
    if provided_by_the_build() {
        for library in [
            "libOpenImageDenoise.so.2",
            "libOpenImageDenoise_core.so.2.5.1",
            "libOpenImageDenoise_device_cpu.so.2.5.1",
            "libtbb.so.12",
        ] {
            assert!(top.join("lib").join(library).is_file(), "{library}");
        }
    }

    let work = d.path().join("work");
    std::fs::create_dir(&work).unwrap();
    std::fs::write(work.join("shot.toml"), SCENE).unwrap();
    let o = run(&binary, &work, &["--version"]);
    assert!(
        text(&o).starts_with(&format!("raytrace {version}")),
        "{}",
        text(&o)
    );
    let o = run(
        &binary,
        &work,
        &["render", "shot.toml", "--denoise", "--stats"],
    );
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("denoiser: cpu"), "{}", text(&o));
    assert!(work.join("out/f_0001.exr").is_file());

    // The device check and the scenes it renders, where it looks for them; where there is a
    // GPU (lavapipe where CI runs), the check itself, at its reduced size, called as the
    // docs say, with paths from the folder the bundle was unpacked in.
    assert!(top.join("contrib/gpu-check.sh").is_file());
    for scene in [
        "bench/bouncing_spheres_seed7.toml",
        "scenes/bouncing_spheres.toml",
    ] {
        let o = run(&binary, &top, &["check", scene]);
        assert!(o.status.success(), "{scene}: {}", text(&o));
    }
    if common::gpu().is_some() {
        let o = Command::new("bash")
            .arg(format!("{name}/contrib/gpu-check.sh"))
            .arg("--quick")
            .arg(format!("{name}/bin/raytrace"))
            .current_dir(&farm)
            .env_remove("OUT")
            .env_remove("LD_LIBRARY_PATH")
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", text(&o));
        assert!(text(&o).contains("== start-up"), "{}", text(&o));
    }
}
