//! Watching the scene file and its point caches: any change to one of them (written in
//! place, replaced by a rename as editors save, created or removed) tells the board, and the
//! worker reads the shot again. Folders are watched, not files, so a file replaced by a
//! rename is still seen; reading a file (the worker's own reads) is not a change.

use std::collections::{BTreeSet, HashSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use notify::{EventKind, RecursiveMode, Watcher};

use super::board::Board;
use raytrace_core::error::Error;

/// The files watched and the watcher of their folders.
pub(crate) struct Watch {
    watcher: notify::RecommendedWatcher,
    folders: BTreeSet<PathBuf>,
    files: Arc<Mutex<HashSet<PathBuf>>>,
}

impl Watch {
    /// A watcher that tells `board` when a watched file changes (none yet: see [`Watch::set`]).
    pub(crate) fn new(board: Arc<Board>) -> Result<Watch, Error> {
        let files: Arc<Mutex<HashSet<PathBuf>>> = Arc::default();
        let seen = Arc::clone(&files);
        let watcher = notify::recommended_watcher(move |event: notify::Result<notify::Event>| {
            let relevant = match event {
                Ok(e) if matches!(e.kind, EventKind::Access(_)) => false,
                Ok(e) => {
                    let files = seen.lock().unwrap_or_else(|e| e.into_inner());
                    e.paths.iter().any(|p| files.contains(&resolved(p)))
                }
                // Events were lost (an overflowing queue): read everything again.
                Err(_) => true,
            };
            if relevant {
                board.files_changed();
            }
        })
        .map_err(|e| Error::resource(format!("cannot watch the scene's files: {e}")))?;
        Ok(Watch {
            watcher,
            folders: BTreeSet::new(),
            files,
        })
    }

    /// Watches `files` (and no others). A folder that cannot be watched (missing) is left
    /// out: its files are read again when another watched file changes.
    pub(crate) fn set(&mut self, files: impl IntoIterator<Item = PathBuf>) {
        let files: HashSet<PathBuf> = files.into_iter().map(|p| resolved(&p)).collect();
        let folders: BTreeSet<PathBuf> = (files.iter())
            .filter_map(|f| f.parent().map(Path::to_path_buf))
            .collect();
        for gone in self.folders.difference(&folders) {
            let _ = self.watcher.unwatch(gone);
        }
        let mut watched = BTreeSet::new();
        for folder in folders {
            if self.folders.contains(&folder)
                || self
                    .watcher
                    .watch(&folder, RecursiveMode::NonRecursive)
                    .is_ok()
            {
                watched.insert(folder);
            }
        }
        self.folders = watched;
        *self.files.lock().unwrap_or_else(|e| e.into_inner()) = files;
    }
}

/// `path` with its folder made absolute and resolved (links, `..`), so that the watcher's
/// paths and the scene's compare equal; as it is when its folder cannot be resolved.
fn resolved(path: &Path) -> PathBuf {
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match (folder.canonicalize(), path.file_name()) {
        (Ok(f), Some(name)) => f.join(name),
        _ => path.to_path_buf(),
    }
}

#[cfg(test)]
mod tests {
    use std::time::{Duration, Instant};

    use super::*;

    /// Waits up to 5 s for the board to be told of a change.
    fn told(board: &Board) -> bool {
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(5) {
            if board.lock().changed_at.take().is_some() {
                return true;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        false
    }

    #[test]
    fn a_watched_file_replaced_by_a_rename_is_seen_and_a_neighbour_is_not() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("s.toml");
        std::fs::write(&scene, "a").unwrap();
        let board = Arc::new(Board::new());
        board.lock().changed_at = None;
        let mut watch = Watch::new(Arc::clone(&board)).unwrap();
        watch.set([scene.clone()]);
        // Reading it is no change.
        std::fs::read(&scene).unwrap();
        std::fs::write(dir.path().join("other.txt"), "b").unwrap();
        std::thread::sleep(Duration::from_millis(200));
        assert!(board.lock().changed_at.is_none());
        // Saved as editors do: a new file renamed over it.
        let temporary = dir.path().join(".s.toml.swp");
        std::fs::write(&temporary, "c").unwrap();
        std::fs::rename(&temporary, &scene).unwrap();
        assert!(told(&board));
        // Written in place.
        std::fs::write(&scene, "d").unwrap();
        assert!(told(&board));
    }
}
