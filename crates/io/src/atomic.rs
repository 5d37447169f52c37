//! Atomic file writing: every file the renderer writes (frames, CSV, plots, generated scenes)
//! goes to a hidden temporary file beside its target, is flushed to disk and then renamed
//! over the target, so a reader (or a crashed render) never sees a partial file: the target
//! holds either the previous complete file or the new complete file.
//!
//! Temporary files are named `.{file name}.{host}.{pid}.{16 hex digits}.tmp`. A write that
//! fails removes its temporary file and the folders it created. A process that is stopped by
//! a signal removes those of the write in flight ([`stop_writing`]); one that is killed
//! outright can leave one behind, which [`remove_stale_temp_files`] cleans up later.

use std::ffi::{OsStr, OsString};
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, OnceLock, PoisonError};
use std::time::Duration;

use raytrace_core::error::{Error, elide_path};

/// Writes `bytes` to `path` atomically: through a temporary file beside it, renamed into
/// place, so readers never see a partial file. Parent folders are created as needed.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    write_with(path, |writer| {
        writer.write_all(bytes).map_err(|e| Error::io(path, e))
    })
}

/// Creates `path`'s folder, has `write` fill a new temporary file beside `path`, syncs it and
/// renames it into place. On any failure the temporary file is removed, and so are the
/// folders this call created.
pub fn write_with(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), Error>,
) -> Result<(), Error> {
    let (dir, pending, file) = start(path)?;
    let mut writer = BufWriter::new(file);
    write(&mut writer)?;
    let file = writer
        .into_inner()
        .map_err(|e| Error::io(path, e.into_error()))?;
    file.sync_all().map_err(|e| Error::io(path, e))?;
    drop(file);
    commit(pending, &dir, path)
}

/// [`write_with`] for a writer that is another program: creates `path`'s folder and an
/// empty temporary file beside `path`, hands `write` the open file (to pass to the program),
/// then syncs the file and renames it into place. On any failure, or a stop
/// ([`stop_writing`]), the temporary file and the folders this call created are removed.
pub(crate) fn write_with_temp_file(
    path: &Path,
    write: impl FnOnce(File) -> Result<(), Error>,
) -> Result<(), Error> {
    let (dir, pending, file) = start(path)?;
    let temp = pending.temp.clone().expect("a temporary file");
    write(file)?;
    File::open(&temp)
        .and_then(|f| f.sync_all())
        .map_err(|e| Error::io(path, e))?;
    commit(pending, &dir, path)
}

/// The start of an atomic write of `path`: its folder (created, if need be), the pending
/// write (which removes what it created if dropped before [`commit`]) and the new temporary
/// file.
fn start(path: &Path) -> Result<(PathBuf, Pending, File), Error> {
    let (dir, file_name) = split_target(path)?;
    let mut pending = Pending::default();
    create_folders(&dir, &mut pending).map_err(|e| Error::io(path, e))?;
    let file = pending
        .create_temp(&dir, file_name)
        .map_err(|e| Error::io(path, e))?;
    Ok((dir, pending, file))
}

/// The end of an atomic write: the synced temporary file renamed to `path`, and the rename
/// made durable.
fn commit(pending: Pending, dir: &Path, path: &Path) -> Result<(), Error> {
    pending.rename_to(path).map_err(|e| Error::io(path, e))?;
    sync_dir(dir);
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

/// The longest path the system takes, in bytes (Linux's `PATH_MAX` less its final zero).
const MAX_PATH_BYTES: usize = 4095;

/// The longest file or folder name, in bytes (`NAME_MAX` of nearly every file system).
const MAX_NAME_BYTES: usize = 255;

/// Why `path` cannot be written by [`write_with`], found before a command starts work: the
/// path, one of its names, or its temporary file's name or path is longer than the system
/// allows; or no file can be made where it goes (a missing or read-only mount, a folder of
/// someone else's, a file where a folder must be): see `probe_folder`, which leaves the disk
/// as it was.
pub fn check_target(path: &Path) -> Result<(), String> {
    let shown = elide_path(path);
    let bytes = path.as_os_str().len();
    if let Some(long) = path
        .components()
        .map(|c| c.as_os_str())
        .find(|c| c.len() > MAX_NAME_BYTES)
    {
        return Err(format!(
            "{shown}: the name \"{}\" is {} bytes long; file and folder names are limited to \
             {MAX_NAME_BYTES} bytes",
            raytrace_core::error::elide(&long.to_string_lossy()),
            long.len()
        ));
    }
    let Ok((dir, file_name)) = split_target(path) else {
        return Err(format!("{shown}: not a file path (it has no file name)"));
    };
    let temp = temp_name(file_name, host_name(), u32::MAX, u64::MAX);
    let extra = temp.len() - file_name.len();
    if temp.len() > MAX_NAME_BYTES {
        return Err(format!(
            "{shown}: the file name is {} bytes long; it can be at most {} bytes, as its \
             temporary file's name adds {extra} to it and names are limited to {MAX_NAME_BYTES}",
            file_name.len(),
            MAX_NAME_BYTES - extra
        ));
    }
    if bytes.max(dir.join(&temp).as_os_str().len()) > MAX_PATH_BYTES {
        return Err(format!(
            "{shown}: the path is {bytes} bytes long; with its temporary file's name it must \
             stay within {MAX_PATH_BYTES} bytes"
        ));
    }
    probe_folder(&dir, file_name).map_err(|e| format!("{shown} cannot be written: {e}"))
}

/// Whether a write of `file_name` into `dir` can start: the nearest folder of `dir` that
/// exists (`dir` itself, or the one its missing folders will be made in) is a folder, and a
/// temporary file made in it is removed at once. No folder is made: chunks of a farm starting
/// together into a new folder must not remove one another's (a folder made by a check and
/// removed again could vanish under another process's write).
fn probe_folder(dir: &Path, file_name: &OsStr) -> io::Result<()> {
    let existing = dir
        .ancestors()
        .map(|a| match a.as_os_str().is_empty() {
            true => Path::new("."),
            false => a,
        })
        .find(|a| fs::metadata(a).is_ok())
        .unwrap_or(Path::new("."));
    if !existing.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::NotADirectory,
            format!("{} is not a folder", elide_path(existing)),
        ));
    }
    Pending::default()
        .create_temp(existing, file_name)
        .map(drop)
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

/// The temporary files and created folders of this process's writes in flight, and whether
/// the process has stopped writing (see [`stop_writing`]).
struct InFlight {
    temps: Vec<PathBuf>,
    folders: Vec<PathBuf>,
}

static IN_FLIGHT: Mutex<InFlight> = Mutex::new(InFlight {
    temps: Vec::new(),
    folders: Vec::new(),
});

/// Files this process has renamed into place.
static FILES_WRITTEN: AtomicU64 = AtomicU64::new(0);

fn in_flight() -> MutexGuard<'static, InFlight> {
    IN_FLIGHT.lock().unwrap_or_else(PoisonError::into_inner)
}

/// How many files this process has written (renamed into place) so far.
pub fn files_written() -> u64 {
    FILES_WRITTEN.load(Ordering::SeqCst)
}

/// Holds every write of this process back, for good: see [`stop_writing`].
pub struct WritesStopped {
    _held: MutexGuard<'static, InFlight>,
    /// Files written (renamed into place) before the stop.
    pub files_written: u64,
}

/// For a process about to exit on a signal: removes the temporary files of the writes in
/// flight and the folders they created (those still empty), and blocks every write from here
/// on (a write that has not renamed its file yet never will), for as long as the returned
/// value lives. A file already renamed into place is complete and stays.
pub fn stop_writing() -> WritesStopped {
    let mut held = in_flight();
    for temp in held.temps.drain(..) {
        let _ = fs::remove_file(temp);
    }
    for folder in held.folders.drain(..).rev() {
        let _ = fs::remove_dir(folder);
    }
    WritesStopped {
        _held: held,
        files_written: files_written(),
    }
}

/// What one write has put on disk so far: the folders it created and its temporary file. On
/// drop (a failure) they are removed again, and forgotten by the in-flight list.
#[derive(Default)]
struct Pending {
    temp: Option<PathBuf>,
    folders: Vec<PathBuf>,
}

impl Pending {
    /// Creates a new, empty temporary file for the target `file_name` in `dir`.
    fn create_temp(&mut self, dir: &Path, file_name: &OsStr) -> io::Result<File> {
        let mut attempts = 0;
        loop {
            let path = dir.join(temp_name(
                file_name,
                host_name(),
                std::process::id(),
                random_u64(),
            ));
            // Created and listed in one step, so a stop never misses it.
            let mut flight = in_flight();
            match OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(file) => {
                    flight.temps.push(path.clone());
                    self.temp = Some(path);
                    return Ok(file);
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && attempts < 16 => {
                    attempts += 1
                }
                Err(e) => return Err(e),
            }
        }
    }

    /// Renames the temporary file to `target`; the write is done and nothing is removed.
    fn rename_to(mut self, target: &Path) -> io::Result<()> {
        let temp = self.temp.take().expect("a temporary file");
        let mut flight = in_flight();
        if let Err(e) = fs::rename(&temp, target) {
            self.temp = Some(temp);
            return Err(e);
        }
        FILES_WRITTEN.fetch_add(1, Ordering::SeqCst);
        flight.temps.retain(|t| *t != temp);
        flight.folders.retain(|f| !self.folders.contains(f));
        self.folders.clear();
        Ok(())
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if self.temp.is_none() && self.folders.is_empty() {
            return;
        }
        let mut flight = in_flight();
        if let Some(temp) = self.temp.take() {
            let _ = fs::remove_file(&temp);
            flight.temps.retain(|t| *t != temp);
        }
        for folder in self.folders.drain(..).rev() {
            // Only if still empty: another process may have written into it meanwhile.
            let _ = fs::remove_dir(&folder);
            flight.folders.retain(|f| *f != folder);
        }
    }
}

/// Creates `dir` and its missing parents, noting each folder created in `pending` (and the
/// in-flight list) so that a failed or stopped write removes them again.
fn create_folders(dir: &Path, pending: &mut Pending) -> io::Result<()> {
    if dir.is_dir() {
        return Ok(());
    }
    let missing: Vec<&Path> = dir
        .ancestors()
        .take_while(|a| !a.as_os_str().is_empty() && !a.is_dir())
        .collect();
    for folder in missing.into_iter().rev() {
        let mut flight = in_flight();
        match fs::create_dir(folder) {
            Ok(()) => {
                flight.folders.push(folder.to_path_buf());
                pending.folders.push(folder.to_path_buf());
            }
            // Another process made it meanwhile: not ours to remove.
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists && folder.is_dir() => {}
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {
                return Err(io::Error::new(
                    io::ErrorKind::NotADirectory,
                    format!("{} is not a folder", elide_path(folder)),
                ));
            }
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// This machine's name as it appears in temporary file names: letters, digits and `-` (any
/// other character becomes `-`), at most 63 of them; `None` where it cannot be read.
pub(crate) fn host_name() -> Option<&'static str> {
    static HOST: OnceLock<Option<String>> = OnceLock::new();
    HOST.get_or_init(|| {
        let raw = ["/proc/sys/kernel/hostname", "/etc/hostname"]
            .iter()
            .find_map(|p| fs::read_to_string(p).ok())?;
        let name: String = raw
            .trim()
            .chars()
            .take(63)
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
            .collect();
        (!name.is_empty()).then_some(name)
    })
    .as_deref()
}

/// `.{file_name}.{host}.{pid}.{random as 16 lowercase hex digits}.tmp`, or without the host
/// (`.{file_name}.{pid}.{random}.tmp`, as files of earlier versions are named) when it is
/// unknown.
pub(super) fn temp_name(file_name: &OsStr, host: Option<&str>, pid: u32, random: u64) -> OsString {
    let mut name = OsString::from(".");
    name.push(file_name);
    if let Some(host) = host {
        name.push(format!(".{host}"));
    }
    name.push(format!(".{pid}.{random:016x}.tmp"));
    name
}

/// The writer of a temporary file, as its name tells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Writer<'a> {
    /// The machine, when the name records it.
    pub(super) host: Option<&'a str>,
    pub(super) pid: u32,
}

/// If `name` is a temporary file name of ours for the target `file_name`, who wrote it.
pub(super) fn parse_temp_name<'a>(name: &'a OsStr, file_name: &OsStr) -> Option<Writer<'a>> {
    let name = name.as_encoded_bytes();
    let target = file_name.as_encoded_bytes();
    let rest = name
        .strip_prefix(b".")?
        .strip_prefix(target)?
        .strip_prefix(b".")?
        .strip_suffix(b".tmp")?;
    let mut fields = rest.rsplitn(3, |&b| b == b'.');
    let (random, pid, host) = (fields.next()?, fields.next()?, fields.next());
    let random_ok = random.len() == 16
        && random
            .iter()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(b));
    if pid.is_empty() || pid.len() > 10 || !pid.iter().all(u8::is_ascii_digit) || !random_ok {
        return None;
    }
    let host = match host {
        None => None,
        Some(h) if !h.is_empty() && h.len() <= 63 => {
            if !h.iter().all(|b| b.is_ascii_alphanumeric() || *b == b'-') {
                return None;
            }
            Some(std::str::from_utf8(h).ok()?)
        }
        Some(_) => return None,
    };
    let pid = std::str::from_utf8(pid).ok()?.parse().ok()?;
    Some(Writer { host, pid })
}

/// 64 unpredictable-enough bits for temporary file names, without an extra dependency:
/// std's randomly keyed hasher over a process-wide counter and the clock.
fn random_u64() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u64(COUNTER.fetch_add(1, Ordering::Relaxed));
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH);
    h.write_u128(now.map_or(0, |d| d.as_nanos()));
    h.finish()
}

/// Whether process `pid` of this machine may still be running. Only answers "no" when it can
/// tell for sure (Linux with `/proc` mounted); everywhere else every process counts as alive.
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
/// target are candidates. Of those, a file written on this machine (its name records this
/// machine's name) is removed as soon as its writing process is gone (Linux: no
/// `/proc/{pid}`). A file of another machine, or of an earlier version whose names record no
/// machine, is removed once it was last modified at least `min_age` ago (and, for the latter,
/// its pid is not running here): a pid means nothing on another machine, so the age is what
/// protects a file another machine is still writing into a shared folder. Pass a `min_age`
/// longer than any frame takes to write (minutes).
///
/// A missing folder, or a path through a regular file, is not an error here: there is
/// nothing to clean, and the write that follows reports it with the frame's path.
pub fn remove_stale_temp_files(target: &Path, min_age: Duration) -> Result<Vec<PathBuf>, Error> {
    let (dir, file_name) = split_target(target)?;
    let entries = match fs::read_dir(&dir) {
        Ok(entries) => entries,
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::NotFound | io::ErrorKind::NotADirectory
            ) =>
        {
            return Ok(Vec::new());
        }
        Err(e) => return Err(Error::io(&dir, e)),
    };
    let here = host_name();
    let mut removed = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(&dir, e))?;
        let name = entry.file_name();
        let Some(writer) = parse_temp_name(&name, file_name) else {
            continue;
        };
        // (whether the pid is meaningful here, whether the file must be old)
        let (pid_known, needs_age) = match writer.host {
            Some(host) if Some(host) == here => (true, false),
            Some(_) => (false, true),
            None => (true, true),
        };
        if pid_known && process_may_be_alive(writer.pid) {
            continue;
        }
        let path = entry.path();
        let Ok(meta) = fs::symlink_metadata(&path) else {
            continue;
        };
        if !meta.file_type().is_file() {
            continue;
        }
        if needs_age && !min_age.is_zero() {
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
