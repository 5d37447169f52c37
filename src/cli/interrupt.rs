//! SIGINT and SIGTERM: a command stops where it is, removes its temporary files (and the
//! folders created for them), says how far it got, and exits with 130 or 143 (128 + the
//! signal's number, as a shell reports a process the signal ended). Files already written
//! are complete and stay: a frame file is renamed into place only once it is whole.
//!
//! A thread waits for the signals; the work is not asked to stop at a boundary, so a long
//! frame is given up at once rather than finished. The files in flight are known to
//! [`io::stop_writing`], which also holds every later write back until the process exits.
//!
//! SIGXFSZ (a write past the file size limit, `ulimit -f`, that a scheduler may set) is
//! caught and ignored, so such a write fails as an I/O error (exit 1, the temporary file
//! removed) instead of killing the process and leaving its temporary file.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use signal_hook::consts::{SIGINT, SIGTERM, SIGXFSZ};
use signal_hook::iterator::Signals;

use raytrace_core::error::Error;
use raytrace_io as io;

/// What a render run has done, for the message of an interrupted run.
struct Tally {
    /// Set once the run knows its frames.
    started: AtomicBool,
    /// Frames selected.
    total: AtomicU64,
    /// Files written by this process before the run's first frame.
    written_before: AtomicU64,
    /// Frames left alone because their file existed.
    skipped: AtomicU64,
}

static TALLY: Tally = Tally {
    started: AtomicBool::new(false),
    total: AtomicU64::new(0),
    written_before: AtomicU64::new(0),
    skipped: AtomicU64::new(0),
};

/// Starts watching for SIGINT and SIGTERM (and ignoring SIGXFSZ) for the rest of the process.
pub(crate) fn install() -> Result<(), Error> {
    let fail = |e: std::io::Error| Error::resource(format!("cannot handle signals: {e}"));
    signal_hook::flag::register(SIGXFSZ, std::sync::Arc::new(AtomicBool::new(false)))
        .map_err(fail)?;
    let mut signals = Signals::new([SIGINT, SIGTERM]).map_err(fail)?;
    std::thread::Builder::new()
        .name("signals".to_string())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                stop(signal);
            }
        })
        .map_err(fail)?;
    Ok(())
}

/// A render run's frames are known: `total` of them.
pub(crate) fn frames_selected(total: u64) {
    TALLY.total.store(total, Ordering::SeqCst);
    TALLY
        .written_before
        .store(io::files_written(), Ordering::SeqCst);
    TALLY.started.store(true, Ordering::SeqCst);
}

/// A frame of the render run was skipped (its file existed).
pub(crate) fn frame_skipped() {
    TALLY.skipped.fetch_add(1, Ordering::SeqCst);
}

/// Removes the files in flight, prints how far the run got and exits.
fn stop(signal: i32) -> ! {
    let stopped = io::stop_writing();
    let name = if signal == SIGINT {
        "SIGINT"
    } else {
        "SIGTERM"
    };
    let message = if TALLY.started.load(Ordering::SeqCst) {
        let written = stopped.files_written - TALLY.written_before.load(Ordering::SeqCst);
        let total = TALLY.total.load(Ordering::SeqCst);
        let skipped = TALLY.skipped.load(Ordering::SeqCst);
        let existed = if skipped > 0 {
            format!(" ({skipped} more existed and were skipped)")
        } else {
            String::new()
        };
        format!("interrupted: {written} of {total} frames written{existed} ({name})")
    } else {
        format!("interrupted ({name})")
    };
    {
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "{message}");
    }
    std::process::exit(128 + signal)
}
