//! Where the denoiser's library, Intel Open Image Denoise, is looked for when a frame is
//! denoised: nothing links it, so every command that does not denoise runs without it, and a
//! binary copied with its libraries to another folder (a farm's shared file system) finds
//! them beside itself.

use std::path::{Path, PathBuf};

/// The folder the build provided the library in (build.rs), if the build said.
pub const BUILD_FOLDER: Option<&str> = option_env!("RAYTRACE_OIDN_BUILD_LIB");

/// The folders searched, in order, for a binary in `exe_dir`: `exe_dir` itself, `lib` in it
/// and `../lib` beside it (an install's `bin/` and `lib/`), as a `$ORIGIN`-relative run path
/// would, then the build's folder (the project's `.oidn/lib`, for the binaries in its
/// `target/` and `cargo install`'s copy). The `oidn` crate tries the system's search path
/// after them. Folders further up are not searched: a binary in `/tmp/x/` would load what
/// anyone put in `/tmp`.
pub fn folders(exe_dir: Option<&Path>) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Some(dir) = exe_dir {
        out.push(dir.to_path_buf());
        out.push(dir.join("lib"));
        if let Some(parent) = dir.parent() {
            out.push(parent.join("lib"));
        }
    }
    out.extend(BUILD_FOLDER.map(PathBuf::from));
    out
}

/// Loads the library (once per process) from the first of [`folders`] of the running binary
/// that holds it, else from the system's search path; an error that names the library,
/// where it was looked for and how to provide it.
pub fn load() -> Result<(), String> {
    let exe = std::env::current_exe().ok();
    let exe_dir = exe.as_deref().and_then(Path::parent);
    oidn::load(&folders(exe_dir)).map(|_| ()).map_err(|e| {
        format!(
            "denoising needs Intel Open Image Denoise 2.5 ({}), which could not be loaded \
             from beside the binary (its folder, lib, ../lib), the build's folder or the system's library path: {}. Copy the libraries of the \
             build's .oidn/lib folder (libOpenImageDenoise.so.2, \
             libOpenImageDenoise_core.so.2.5.1, libOpenImageDenoise_device_cpu.so.2.5.1, \
             libtbb.so.12; libOpenImageDenoise_device_cuda.so.2.5.1 and _hip to denoise on an \
             NVIDIA or AMD GPU) beside the binary, or install OIDN 2.5 \
             (https://github.com/RenderKit/oidn/releases) where the system's loader finds \
             it; frames that are not denoised need none of it",
            oidn::LIBRARY_NAMES[0],
            e.message()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beside_the_binary_first_then_the_build() {
        let got = folders(Some(Path::new("/farm/bin")));
        let mut want: Vec<PathBuf> = ["/farm/bin", "/farm/bin/lib", "/farm/lib"]
            .iter()
            .map(PathBuf::from)
            .collect();
        want.extend(BUILD_FOLDER.map(PathBuf::from));
        assert_eq!(got, want);
        // This test binary, in target/release/deps, finds the build's folder.
        load().unwrap();
        let from = oidn::loaded_from().unwrap();
        assert!(from.is_absolute(), "{}", from.display());
    }
}
