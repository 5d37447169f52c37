//! The `raytrace` binary as a farm would run it: copied to another folder, on a machine
//! where the folder the build provided the denoiser's library in does not exist.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A small two-frame shot for a moved binary to render (`out/f_####.exr`).
pub(crate) const SCENE: &str = "[shot]\nframes = 2\n[output]\npath = \"out/f_####.exr\"\nwidth = 16\n\
    height = 9\n[render]\nsamples = 2\n[camera]\nlook_from = [0.0, 0.0, 3.0]\n\
    [[sphere]]\ncenter = [0.0, 0.0, -1.0]\nradius = 0.5\n\
    material = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\n";

/// Runs `binary` in `dir` with nothing from the environment pointing at a library.
pub(crate) fn run(binary: &Path, dir: &Path, args: &[&str]) -> Output {
    Command::new(binary)
        .args(args)
        .current_dir(dir)
        .env_remove("LD_LIBRARY_PATH")
        .output()
        .unwrap()
}

/// The folder the build provided Intel Open Image Denoise in (the denoise crate's build.rs).
pub(crate) const BUILD_FOLDER: &str = match raytrace_denoise::library::BUILD_FOLDER {
    Some(folder) => folder,
    None => panic!("the build names the folder it provided the library in"),
};

/// Whether that folder is the project's own `.oidn/lib` (the library fetched for the build),
/// rather than a system folder, where the system's loader finds it anyway.
pub(crate) fn provided_by_the_build() -> bool {
    Path::new(BUILD_FOLDER).ends_with(".oidn/lib")
}

/// Copies the binary to `dir/raytrace` as [`without_the_build_folder`] writes it. Returns
/// the copy.
pub(crate) fn moved_binary(dir: &Path) -> PathBuf {
    let copy = dir.join("raytrace");
    without_the_build_folder(Path::new(env!("CARGO_BIN_EXE_raytrace")), &copy);
    copy
}

/// Writes `binary` to `copy` (the same path rewrites it) with the build's folder, compiled
/// into it, replaced by a path of the same length that does not exist (`/xxx…`): what a copy
/// on a machine without that folder sees.
pub(crate) fn without_the_build_folder(binary: &Path, copy: &Path) {
    let mut bytes = std::fs::read(binary).unwrap();
    let from = BUILD_FOLDER.as_bytes();
    let to: Vec<u8> = std::iter::once(b'/')
        .chain(std::iter::repeat_n(b'x', from.len() - 1))
        .collect();
    assert!(!Path::new(std::str::from_utf8(&to).unwrap()).exists());
    let mut found = 0;
    let mut i = 0;
    while let Some(k) = bytes[i..].windows(from.len()).position(|w| w == from) {
        bytes[i + k..i + k + from.len()].copy_from_slice(&to);
        i += k + from.len();
        found += 1;
    }
    assert!(found > 0, "{BUILD_FOLDER} is not in the binary");
    std::fs::write(copy, bytes).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(copy, std::fs::Permissions::from_mode(0o755)).unwrap();
}

/// Copies the build's OIDN libraries whose names `keep` accepts into `dir`; returns how
/// many.
pub(crate) fn copy_libraries(dir: &Path, keep: impl Fn(&str) -> bool) -> usize {
    let mut copied = 0;
    for entry in std::fs::read_dir(BUILD_FOLDER).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let ours = name.starts_with("libOpenImageDenoise") || name.starts_with("libtbb");
        if ours && keep(&name) && path.is_file() {
            std::fs::copy(&path, dir.join(&name)).unwrap();
            copied += 1;
        }
    }
    copied
}
