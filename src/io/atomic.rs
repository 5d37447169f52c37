//! Atomic file writing: every file the renderer writes (frames, CSV, plots, generated scenes)
//! goes to a hidden temporary file beside its target, is flushed to disk and then renamed
//! over the target, so a reader (or a crashed render) never sees a partial file: the target
//! holds either the previous complete file or the new complete file.
//!
//! Temporary files are named `.{file name}.{pid}.{16 hex digits}.tmp`; a run that is killed
//! mid-write can leave one behind, which [`remove_stale_temp_files`] cleans up later.

use std::ffi::{OsStr, OsString};
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::error::Error;

/// Writes `bytes` to `path` atomically: through a temporary file beside it, renamed into
/// place, so readers never see a partial file. Parent folders are created as needed.
pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    write_with(path, |writer| {
        writer.write_all(bytes).map_err(|e| Error::io(path, e))
    })
}

/// Creates `path`'s folder, has `write` fill a new temporary file beside `path`, syncs it and
/// renames it into place. The temporary file is removed on any failure.
pub(crate) fn write_with(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), Error>,
) -> Result<(), Error> {
    let (dir, file_name) = split_target(path)?;
    fs::create_dir_all(&dir).map_err(|e| Error::io(path, e))?;

    let (mut temp, file) = TempFile::create(&dir, file_name).map_err(|e| Error::io(path, e))?;
    let mut writer = BufWriter::new(file);
    write(&mut writer)?;
    let file = writer
        .into_inner()
        .map_err(|e| Error::io(path, e.into_error()))?;
    file.sync_all().map_err(|e| Error::io(path, e))?;
    drop(file);
    fs::rename(&temp.path, path).map_err(|e| Error::io(path, e))?;
    temp.armed = false;
    sync_dir(&dir);
    Ok(())
}

/// The folder (`.` for a bare file name) and file name of a target path.
pub(super) fn split_target(path: &Path) -> Result<(PathBuf, &OsStr), Error> {
    let Some(file_name) = path.file_name() else {
        return Err(Error::Output {
            path: path.to_path_buf(),
            message: "not a file path (it has no file name)".to_string(),
        });
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok((dir, file_name))
}

/// Makes a rename in `dir` durable. Best effort: some file systems refuse to sync folders.
fn sync_dir(dir: &Path) {
    #[cfg(unix)]
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dir;
}

/// A temporary file that is removed when dropped, unless disarmed after the final rename.
struct TempFile {
    path: PathBuf,
    armed: bool,
}

impl TempFile {
    /// Creates a new, empty temporary file for the target `file_name` in `dir`.
    fn create(dir: &Path, file_name: &OsStr) -> io::Result<(TempFile, File)> {
        let mut attempts = 0;
        loop {
            let path = dir.join(temp_name(file_name, std::process::id(), random_u64()));
            match OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(file) => return Ok((TempFile { path, armed: true }, file)),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && attempts < 16 => {
                    attempts += 1
                }
                Err(e) => return Err(e),
            }
        }
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if self.armed {
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// `.{file_name}.{pid}.{random as 16 lowercase hex digits}.tmp`
pub(super) fn temp_name(file_name: &OsStr, pid: u32, random: u64) -> OsString {
    let mut name = OsString::from(".");
    name.push(file_name);
    name.push(format!(".{pid}.{random:016x}.tmp"));
    name
}

/// If `name` is a temporary file name of ours for the target `file_name`, the pid in it.
pub(super) fn parse_temp_name(name: &OsStr, file_name: &OsStr) -> Option<u32> {
    let name = name.as_encoded_bytes();
    let target = file_name.as_encoded_bytes();
    let rest = name
        .strip_prefix(b".")?
        .strip_prefix(target)?
        .strip_prefix(b".")?;
    let rest = rest.strip_suffix(b".tmp")?;
    let dot = rest.iter().position(|&b| b == b'.')?;
    let (pid, random) = (&rest[..dot], &rest[dot + 1..]);
    let random_ok = random.len() == 16
        && random
            .iter()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(b));
    if pid.is_empty() || pid.len() > 10 || !pid.iter().all(u8::is_ascii_digit) || !random_ok {
        return None;
    }
    std::str::from_utf8(pid).ok()?.parse().ok()
}

/// 64 unpredictable-enough bits for temporary file names, without an extra dependency:
/// std's randomly keyed hasher over a process-wide counter and the clock.
fn random_u64() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u64(COUNTER.fetch_add(1, Ordering::Relaxed));
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH);
    h.write_u128(now.map_or(0, |d| d.as_nanos()));
    h.finish()
}

/// Whether process `pid` may still be running. Only answers "no" when it can tell for sure
/// (Linux with `/proc` mounted); everywhere else every process counts as alive.
fn process_may_be_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    if cfg!(target_os = "linux") && Path::new("/proc/self").exists() {
        return Path::new("/proc").join(pid.to_string()).exists();
    }
    true
}

/// Removes temporary files that an interrupted earlier run left behind while writing
/// `target`, and returns their paths.
///
/// Only regular files named exactly as [`write_with`] names its temporary files for this
/// target are candidates, and of those only the ones whose writing process is known to be
/// gone (Linux: no `/proc/{pid}`; elsewhere nothing is ever removed) and that were last
/// modified at least `min_age` ago. Pids are only meaningful on this machine: when several
/// machines write into a shared folder, pass a `min_age` longer than any frame takes to
/// write (minutes), so a file another machine is still writing is never taken for stale.
///
/// A missing folder is not an error.
pub(crate) fn remove_stale_temp_files(
    target: &Path,
    min_age: Duration,
) -> Result<Vec<PathBuf>, Error> {
    let (dir, file_name) = split_target(target)?;
    let entries = match fs::read_dir(&dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::io(&dir, e)),
    };
    let mut removed = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(&dir, e))?;
        let Some(pid) = parse_temp_name(&entry.file_name(), file_name) else {
            continue;
        };
        if process_may_be_alive(pid) {
            continue;
        }
        let path = entry.path();
        let Ok(meta) = fs::symlink_metadata(&path) else {
            continue;
        };
        if !meta.file_type().is_file() {
            continue;
        }
        if !min_age.is_zero() {
            let age = meta.modified().ok().and_then(|m| m.elapsed().ok());
            if age.is_none_or(|age| age < min_age) {
                continue;
            }
        }
        match fs::remove_file(&path) {
            Ok(()) => removed.push(path),
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => return Err(Error::io(&path, e)),
        }
    }
    Ok(removed)
}
