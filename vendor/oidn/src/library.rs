//! Open Image Denoise loaded at run time (with `libloading`), not linked: a program built with
//! this crate starts, and runs everything that does not denoise, where the library is absent
//! or has moved. The library is loaded once, by [`load`] from the folders its caller names
//! (then the system's search path), or by the first device made ([`crate::Device`]) from the
//! system's search path alone; it stays loaded until the process ends.
//!
//! A folder's companions are loaded first, by their full paths: oneTBB and OIDN's core
//! library, which the front library and the CPU device module name by their sonames and find
//! through their own run path (`$ORIGIN/../lib`), which holds only in a folder named `lib`.
//! Once loaded, a library satisfies every later request for its soname, so a folder of any
//! name works (a binary's own folder, say). OIDN then loads its device modules from its core
//! library's folder itself.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use libloading::Library;

use crate::{Error, ErrorKind};

/// The front library's names: its soname, which the system's loader finds, then the name
/// an unpacked release also holds.
#[cfg(target_os = "macos")]
pub const LIBRARY_NAMES: [&str; 2] = ["libOpenImageDenoise.2.dylib", "libOpenImageDenoise.dylib"];
#[cfg(windows)]
pub const LIBRARY_NAMES: [&str; 1] = ["OpenImageDenoise.dll"];
#[cfg(not(any(target_os = "macos", windows)))]
pub const LIBRARY_NAMES: [&str; 2] = ["libOpenImageDenoise.so.2", "libOpenImageDenoise.so"];

/// How the companions' file names start, in the order they are loaded: oneTBB, then OIDN's
/// core library (the CPU device module needs both, the front library the core).
#[cfg(target_os = "macos")]
const COMPANIONS: [&str; 2] = ["libtbb.12", "libOpenImageDenoise_core."];
#[cfg(windows)]
const COMPANIONS: [&str; 0] = [];
#[cfg(not(any(target_os = "macos", windows)))]
const COMPANIONS: [&str; 2] = ["libtbb.so.12", "libOpenImageDenoise_core.so."];

/// The library as loaded: its functions, where it came from, and the handles that keep it
/// and its companions loaded.
struct Loaded {
    functions: crate::sys::Functions,
    from: PathBuf,
    _libraries: Vec<Library>,
}

static LOADED: OnceLock<Loaded> = OnceLock::new();
static LOADING: Mutex<()> = Mutex::new(());

/// Loads Open Image Denoise from the first of `folders` that holds its front library
/// ([`LIBRARY_NAMES`]), else through the system's search path (`LD_LIBRARY_PATH`, the
/// loader's cache). Returns the file it was loaded from (the name alone for the system's
/// search). Does nothing but return it when the library is already loaded.
///
/// The error, of kind [`ErrorKind::LibraryNotLoaded`], says for each folder that holds the
/// library why it did not load, which folders do not hold it, and what the system's search
/// said.
pub fn load(folders: &[PathBuf]) -> Result<&'static Path, Error> {
    if let Some(l) = LOADED.get() {
        return Ok(&l.from);
    }
    let _one_at_a_time = LOADING.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(l) = LOADED.get() {
        return Ok(&l.from);
    }
    let mut failed = Vec::new();
    let mut without = Vec::new();
    for folder in folders {
        let Some(front) = LIBRARY_NAMES.iter().map(|n| folder.join(n)).find(|p| p.is_file())
        else {
            without.push(folder.display().to_string());
            continue;
        };
        match load_from(folder, &front) {
            Ok(loaded) => return Ok(&LOADED.get_or_init(|| loaded).from),
            Err(why) => failed.push(format!("{}: {why}", front.display())),
        }
    }
    match load_file(Path::new(LIBRARY_NAMES[0]), Vec::new()) {
        Ok(loaded) => return Ok(&LOADED.get_or_init(|| loaded).from),
        Err(why) => failed.push(format!("the system's library path: {why}")),
    }
    let mut message = String::new();
    if !without.is_empty() {
        message = format!("no {} in {}; ", LIBRARY_NAMES[0], without.join(", "));
    }
    message += &failed.join("; ");
    Err(Error::new(ErrorKind::LibraryNotLoaded, message))
}

/// Where the library was loaded from, if it is.
pub fn loaded_from() -> Option<&'static Path> {
    LOADED.get().map(|l| l.from.as_path())
}

/// The library's functions, loaded through the system's search path if nothing loaded it
/// before.
///
/// # Panics
/// If it is not loaded and cannot be: every safe way in ([`crate::Device`]'s constructors)
/// loads it first and reports the failure; only a call into [`crate::sys`] before any can
/// get here without it.
pub(crate) fn functions() -> &'static crate::sys::Functions {
    match LOADED.get() {
        Some(l) => &l.functions,
        None => match load(&[]) {
            Ok(_) => &LOADED.get().expect("loaded").functions,
            Err(e) => panic!("Open Image Denoise is not loaded: {e}"),
        },
    }
}

/// Loads the library for a device's construction: from the system's search path, unless
/// [`load`] has loaded it already.
pub(crate) fn ensure_loaded() -> Result<(), Error> {
    load(&[]).map(|_| ())
}

/// Loads `folder`'s companions, then its front library `front`.
fn load_from(folder: &Path, front: &Path) -> Result<Loaded, String> {
    let mut libraries = Vec::new();
    let entries: Vec<PathBuf> = std::fs::read_dir(folder)
        .map_err(|e| format!("{}: {e}", folder.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    for start in COMPANIONS {
        // The newest version where a folder holds several.
        let companion = entries
            .iter()
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with(start))
            })
            .max();
        if let Some(path) = companion {
            // SAFETY: loading a library runs its initialisers; these are OIDN's own
            // companions, as the front library would load them.
            let library = unsafe { Library::new(path) }
                .map_err(|e| format!("loading {}: {e}", path.display()))?;
            libraries.push(library);
        }
    }
    load_file(front, libraries)
}

/// Loads the front library `path` (a bare name: through the system's search path) and
/// resolves its functions; `libraries` are companions loaded before it, kept loaded with it.
fn load_file(path: &Path, mut libraries: Vec<Library>) -> Result<Loaded, String> {
    // SAFETY: loading OIDN runs its initialisers, which have no preconditions.
    let library = unsafe { Library::new(path) }.map_err(|e| e.to_string())?;
    // SAFETY: the signatures are bindgen's, from the headers of the OIDN 2.5 this crate
    // binds; the library stays loaded (in `LOADED`) for as long as the pointers are used.
    let functions = unsafe { crate::sys::Functions::resolve(&library) }
        .map_err(|name| format!("{} lacks {name} (an OIDN older than 2.5?)", path.display()))?;
    libraries.push(library);
    Ok(Loaded {
        functions,
        from: path.to_path_buf(),
        _libraries: libraries,
    })
}

/// Declares OIDN's functions as bindgen wrote them: the table of their pointers
/// (`Functions`), its resolution from a loaded library, and for each an `unsafe fn` of the
/// same name and signature that calls through the table ([`functions`]).
macro_rules! declare_functions {
    ($(pub fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)?;)*) => {
        /// The library's functions, resolved once it is loaded.
        #[allow(non_snake_case)]
        pub(crate) struct Functions {
            $($name: unsafe extern "C" fn($($ty),*) $(-> $ret)?,)*
        }

        impl Functions {
            /// Every function of `library`, or the name of the first it lacks.
            ///
            /// # Safety
            /// `library` must be Open Image Denoise 2.x, whose functions have these
            /// signatures, and stay loaded while the pointers are used.
            pub(crate) unsafe fn resolve(
                library: &libloading::Library,
            ) -> Result<Functions, &'static str> {
                Ok(Functions {
                    $($name: unsafe {
                        *library
                            .get::<unsafe extern "C" fn($($ty),*) $(-> $ret)?>(
                                concat!(stringify!($name), "\0").as_bytes(),
                            )
                            .map_err(|_| stringify!($name))?
                    },)*
                })
            }
        }

        $(
            /// OIDN's function of this name (see its documentation), called through the
            /// library loaded at run time.
            ///
            /// # Safety
            /// As OIDN's C API requires of its arguments.
            #[allow(non_snake_case, clippy::too_many_arguments)]
            pub unsafe fn $name($($arg: $ty),*) $(-> $ret)? {
                unsafe { (crate::library::functions().$name)($($arg),*) }
            }
        )*
    };
}
pub(crate) use declare_functions;
