//! Provides Intel Open Image Denoise (OIDN) 2.5, which the `oidn` crate (patched in
//! vendor/oidn) loads at run time when a frame is denoised, and tells the binaries where it
//! was provided.
//!
//! Nothing links the library: a binary runs without it, and finds it when it denoises
//! (`src/denoise/library.rs`): beside itself (its folder, `lib`, `../lib`), then in the
//! folder this script names in `RAYTRACE_OIDN_BUILD_LIB`, compiled in.
//! `.cargo/config.toml` points `OIDN_DIR` at the project's ignored `.oidn/` folder (unless the
//! environment names another one), and this script fills it once:
//!
//! 1. a system OIDN 2.5 or later 2.x that pkg-config finds: its front library is copied into
//!    `.oidn/lib` (as a record that the system has it), and the binaries load it from the
//!    system's folder;
//! 2. otherwise the official OIDN 2.5.1 Linux x86-64 binaries that PyPI's `pyoidn` 2.5.1 wheel
//!    carries, fetched with `python3 -m pip download` (its SHA-256 pinned below) and unpacked
//!    with Python's `zipfile`: the library, its core, its CPU, CUDA and HIP device modules
//!    and oneTBB.
//!
//! A stamp file records what was provided; a later build that finds it does nothing.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, SystemTime};

/// The wheel that carries the official OIDN 2.5.1 binaries, and its SHA-256 (from PyPI).
const WHEEL_REQUIREMENT: &str = "pyoidn==2.5.1";
const WHEEL_PLATFORM: &str = "manylinux2014_x86_64";
const WHEEL_SHA256: &str = "32ad13368f8de1ef63001942ad05b02a00cd732d1206d97f352d3a3f606d823e";
/// The files taken from the wheel's `pyoidn/oidn/lib/`: the library, its core, oneTBB, and
/// the device modules raytrace uses: the CPU's, and for `--denoise-device` the CUDA (NVIDIA)
/// and HIP (AMD) ones, 3.4 and 12.8 MB, which load only where their GPU's driver is installed
/// (OIDN skips a module whose driver library is missing). The SYCL module (Intel GPUs) is
/// left out: it needs 30 MB more of the wheel's runtime (`libsycl`, the Unified Runtime
/// loader and its Level Zero adapters). The libraries find each other through their own
/// `$ORIGIN/../lib` rpath in a folder named `lib` (and in any folder once the `oidn` crate has
/// loaded oneTBB and the core first); OIDN loads device modules from its own folder.
const WHEEL_LIBRARIES: [&str; 6] = [
    "libOpenImageDenoise.so.2.5.1",
    "libOpenImageDenoise_core.so.2.5.1",
    "libOpenImageDenoise_device_cpu.so.2.5.1",
    "libOpenImageDenoise_device_cuda.so.2.5.1",
    "libOpenImageDenoise_device_hip.so.2.5.1",
    "libtbb.so.12",
];
/// The version the stamp records for the wheel route, with the modules taken; a change of it
/// provides anew.
const STAMP_WHEEL: &str = "pyoidn 2.5.1 sha256:32ad13368f8de1ef63001942ad05b02a00cd732d1206d97f352d3a3f606d823e cpu cuda hip\n";
const STAMP: &str = "PROVIDED";

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=OIDN_DIR");
    if std::env::var_os("DOCS_RS").is_some() {
        return;
    }
    // The workspace's root, two folders above this crate's: `.oidn/` lies there, beside the
    // README that names it.
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let root = manifest.join("../..");
    let default_dir = fs::canonicalize(&root).unwrap_or(root).join(".oidn");
    let dir = match std::env::var_os("OIDN_DIR").filter(|d| !d.is_empty()) {
        Some(d) => PathBuf::from(d),
        None => default_dir.clone(),
    };
    let lib = dir.join("lib");
    println!("cargo::rerun-if-changed={}", dir.join(STAMP).display());

    let runtime_dir = if same_path(&dir, &default_dir) {
        match provide(&dir) {
            Ok(runtime_dir) => runtime_dir,
            Err(message) => fail(&message),
        }
    } else if lib.join("libOpenImageDenoise.so").exists() {
        // A folder the user named: an unpacked OIDN release, used as it is.
        lib.clone()
    } else {
        fail(&format!(
            "OIDN_DIR={} has no lib/libOpenImageDenoise.so; point it at an unpacked Open Image \
             Denoise 2.5 release, or unset it to let the build provide one in {}",
            dir.display(),
            default_dir.display()
        ));
    };
    // The folder the binaries look in last before the system's search path: found wherever
    // the binary runs on this machine (`cargo install`'s copy, say).
    println!(
        "cargo::rustc-env=RAYTRACE_OIDN_BUILD_LIB={}",
        runtime_dir.display()
    );
}

/// Stops the build with `message` and how to provide the library.
fn fail(message: &str) -> ! {
    println!("cargo::error=Open Image Denoise (OIDN) 2.5 is needed: {message}");
    println!(
        "cargo::error=Provide it in one of three ways: install OIDN 2.5 so that `pkg-config \
         OpenImageDenoise` finds it; or make `python3 -m pip` able to reach PyPI (Debian: \
         apt-get install python3-pip) and build again; or set OIDN_DIR to an unpacked OIDN 2.5 \
         release (https://github.com/RenderKit/oidn/releases)"
    );
    // Cargo fails the build on `cargo::error`; exiting 0 keeps its report to these lines.
    std::process::exit(0);
}

fn same_path(a: &Path, b: &Path) -> bool {
    let canon = |p: &Path| fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    canon(a) == canon(b)
}

/// Fills `dir` (unless its stamp says it is filled) and returns the folder the binaries load
/// the library from.
fn provide(dir: &Path) -> Result<PathBuf, String> {
    if let Some(runtime_dir) = fs::read_to_string(dir.join(STAMP))
        .ok()
        .and_then(|stamp| still_provided(&stamp, dir))
    {
        return Ok(runtime_dir);
    }
    let parent = dir.parent().ok_or("OIDN_DIR has no parent folder")?;
    let staging = parent.join(format!(".oidn-staging-{}", std::process::id()));
    let _ = fs::remove_dir_all(&staging);
    fs::create_dir_all(staging.join("lib")).map_err(|e| format!("{}: {e}", staging.display()))?;
    let provided = match system_library() {
        Some(libdir) => link_system(&staging, &libdir),
        None => unpack_wheel(&staging),
    };
    let stamp = match provided {
        Ok(stamp) => stamp,
        Err(e) => {
            let _ = fs::remove_dir_all(&staging);
            return Err(e);
        }
    };
    fs::write(staging.join(STAMP), &stamp).map_err(|e| e.to_string())?;
    // Atomic: a build that stops half-way leaves no half-filled folder behind.
    let _ = fs::remove_dir_all(dir);
    if let Err(e) = fs::rename(&staging, dir) {
        let _ = fs::remove_dir_all(&staging);
        // Another build (e.g. clippy's) may have filled it at the same time.
        return fs::read_to_string(dir.join(STAMP))
            .ok()
            .and_then(|s| still_provided(&s, dir))
            .ok_or(format!("moving the library into {}: {e}", dir.display()));
    }
    age(dir).map_err(|e| format!("setting file times in {}: {e}", dir.display()))?;
    still_provided(&stamp, dir).ok_or(format!("{} is incomplete", dir.display()))
}

/// The runtime folder if the stamp's provision is still in place.
fn still_provided(stamp: &str, dir: &Path) -> Option<PathBuf> {
    let lib = dir.join("lib");
    if stamp == STAMP_WHEEL {
        let complete = WHEEL_LIBRARIES.iter().all(|f| lib.join(f).is_file())
            && lib.join("libOpenImageDenoise.so").exists();
        return complete.then_some(lib);
    }
    // "system <libdir>": the system library is still there.
    let libdir = PathBuf::from(stamp.strip_prefix("system ")?.trim_end());
    lib.join("libOpenImageDenoise.so")
        .exists()
        .then_some(libdir)
}

/// The folder of a system OIDN 2.5 or later 2.x that pkg-config finds.
fn system_library() -> Option<PathBuf> {
    let found = pkg_config::Config::new()
        .atleast_version("2.5")
        .cargo_metadata(false)
        .env_metadata(false)
        .probe("OpenImageDenoise")
        .ok()?;
    if !found.version.starts_with("2.") {
        return None;
    }
    found
        .link_paths
        .into_iter()
        .find(|p| p.join("libOpenImageDenoise.so").exists())
}

fn link_system(staging: &Path, libdir: &Path) -> Result<String, String> {
    // A copy of the small front library, which the stamp's check finds (the binaries load
    // the system's, from `libdir`); a copy, as in `unpack_wheel`.
    fs::copy(
        libdir.join("libOpenImageDenoise.so"),
        staging.join("lib/libOpenImageDenoise.so"),
    )
    .map_err(|e| format!("copying the system library: {e}"))?;
    Ok(format!("system {}\n", libdir.display()))
}

/// Downloads the pinned wheel with pip and unpacks its libraries into `staging/lib`.
fn unpack_wheel(staging: &Path) -> Result<String, String> {
    if !(cfg!(target_os = "linux") && cfg!(target_arch = "x86_64")) {
        return Err(
            "no system OIDN found by pkg-config, and the PyPI wheel this build can \
                    fetch is for Linux x86-64 only"
                .into(),
        );
    }
    let download = staging.join("download");
    fs::create_dir_all(&download).map_err(|e| e.to_string())?;
    // --require-hashes makes pip check the wheel against the pinned digest.
    let requirements = download.join("requirements.txt");
    fs::write(
        &requirements,
        format!("{WHEEL_REQUIREMENT} --hash=sha256:{WHEEL_SHA256}\n"),
    )
    .map_err(|e| e.to_string())?;
    eprintln!("fetching {WHEEL_REQUIREMENT} from PyPI for Open Image Denoise");
    let pip = Command::new("python3")
        .args(["-m", "pip", "download", "--no-deps", "--only-binary=:all:"])
        .args(["--platform", WHEEL_PLATFORM, "--require-hashes", "-r"])
        .arg(&requirements)
        .arg("-d")
        .arg(&download)
        .output()
        .map_err(|e| format!("no system OIDN found by pkg-config, and python3 cannot run: {e}"))?;
    if !pip.status.success() {
        return Err(format!(
            "no system OIDN found by pkg-config, and `python3 -m pip download \
             {WHEEL_REQUIREMENT}` failed: {}",
            String::from_utf8_lossy(&pip.stderr).trim()
        ));
    }
    let wheel = fs::read_dir(&download)
        .map_err(|e| e.to_string())?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.extension().is_some_and(|x| x == "whl"))
        .ok_or("pip reported success but left no wheel")?;
    // A wheel is a zip file; Python (there for pip) unpacks the members named.
    const UNZIP: &str = "import os, sys, zipfile\n\
        wheel, lib = sys.argv[1], sys.argv[2]\n\
        with zipfile.ZipFile(wheel) as z:\n\
        \x20   for name in sys.argv[3:]:\n\
        \x20       target = os.path.join(lib, name)\n\
        \x20       with z.open('pyoidn/oidn/lib/' + name) as src, open(target, 'wb') as dst:\n\
        \x20           dst.write(src.read())\n\
        \x20       os.chmod(target, 0o755)\n";
    let unzip = Command::new("python3")
        .args(["-c", UNZIP])
        .arg(&wheel)
        .arg(staging.join("lib"))
        .args(WHEEL_LIBRARIES)
        .output()
        .map_err(|e| format!("unpacking {}: {e}", wheel.display()))?;
    if !unzip.status.success() {
        return Err(format!(
            "unpacking {}: {}",
            wheel.display(),
            String::from_utf8_lossy(&unzip.stderr).trim()
        ));
    }
    fs::remove_dir_all(&download).map_err(|e| e.to_string())?;
    // The front library under its soname (.so.2), which the binaries load, and its
    // development name (.so), which an unpacked release holds: copies (124 KB) rather than
    // symbolic links, whose own times `age` cannot set.
    for name in ["libOpenImageDenoise.so", "libOpenImageDenoise.so.2"] {
        let lib = staging.join("lib");
        fs::copy(lib.join("libOpenImageDenoise.so.2.5.1"), lib.join(name))
            .map_err(|e| e.to_string())?;
    }
    Ok(STAMP_WHEEL.to_string())
}

/// Sets the modification time of the folder and everything in it to a fixed past instant.
///
/// This script asks cargo to rerun it when the stamp changes, and writes the stamp while it
/// runs: dated "now", the stamp would read as changed at the next build, which would run the
/// script and rebuild the package once more. Dated in the past it reads as unchanged, so the
/// second build does nothing.
fn age(dir: &Path) -> std::io::Result<()> {
    let past = SystemTime::UNIX_EPOCH + Duration::from_secs(1_000_000_000);
    let mut stack = vec![dir.to_path_buf()];
    let mut dirs = Vec::new();
    while let Some(d) = stack.pop() {
        for entry in fs::read_dir(&d)? {
            let path = entry?.path();
            let kind = fs::symlink_metadata(&path)?.file_type();
            if kind.is_dir() {
                stack.push(path);
            } else if kind.is_file() {
                fs::File::options()
                    .write(true)
                    .open(&path)?
                    .set_modified(past)?;
            }
        }
        dirs.push(d);
    }
    // Folders last (setting a file's time does not touch its folder's, but creating did).
    for d in dirs.iter().rev() {
        fs::File::open(d)?.set_modified(past)?;
    }
    Ok(())
}
