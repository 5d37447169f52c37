//! Keeping a driver's stray line out of raytrace's output.
//!
//! Finding a Vulkan device goes through Mesa's device-selection layer, which asks the Wayland
//! library for a display; when `XDG_RUNTIME_DIR` is unset (a batch job, a container, CI) that
//! library prints `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` on the
//! process's standard error, twice, though nothing is wrong: raytrace needs no display. While
//! the adapter is requested with that variable unset, the standard error is pointed at a pipe
//! (rustix's safe `dup2`), and afterwards every line it caught is passed on except those.

/// The start of the line the Wayland library prints.
const STRAY: &str = "XDG_RUNTIME_DIR is invalid or not set";

/// Runs `f`, keeping the Wayland library's `XDG_RUNTIME_DIR` line out of the standard error
/// when the variable is unset or not an absolute path (when it would print it); any other
/// line written meanwhile is passed on after `f` returns.
pub(super) fn without_stray_lines<T>(f: impl FnOnce() -> T) -> T {
    let set =
        std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|d| std::path::Path::new(&d).is_absolute());
    if set {
        return f();
    }
    #[cfg(unix)]
    {
        capture(f)
    }
    #[cfg(not(unix))]
    {
        f()
    }
}

#[cfg(unix)]
fn capture<T>(f: impl FnOnce() -> T) -> T {
    use std::io::{Read, Write};
    // If the standard error cannot be redirected, run unfiltered: a stray line is better
    // than no render.
    let Ok(saved) = rustix::io::dup(std::io::stderr()) else {
        return f();
    };
    let Ok((read, write)) = rustix::pipe::pipe_with(rustix::pipe::PipeFlags::CLOEXEC) else {
        return f();
    };
    // Read on a thread of its own, so a chatty driver never fills the pipe and blocks.
    let reader = std::thread::spawn(move || {
        let mut text = Vec::new();
        let _ = std::fs::File::from(read).read_to_end(&mut text);
        text
    });
    let _ = std::io::stderr().flush();
    let redirected = rustix::stdio::dup2_stderr(&write).is_ok();
    // The pipe's only writer is now the standard error: restoring it ends the reader.
    drop(write);
    let result = f();
    if redirected {
        let _ = rustix::stdio::dup2_stderr(&saved);
    }
    let caught = reader.join().unwrap_or_default();
    let kept = passed_on(&String::from_utf8_lossy(&caught));
    if !kept.is_empty() {
        let _ = std::io::stderr().write_all(kept.as_bytes());
    }
    result
}

/// The lines of `text` other than the stray ones.
fn passed_on(text: &str) -> String {
    text.split_inclusive('\n')
        .filter(|line| !line.contains(STRAY))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_stray_lines_are_dropped() {
        let text = "error: XDG_RUNTIME_DIR is invalid or not set in the environment.\nMESA: warning: something real\nerror: XDG_RUNTIME_DIR is invalid or not set in the environment.\nlast";
        assert_eq!(passed_on(text), "MESA: warning: something real\nlast");
        assert_eq!(passed_on(""), "");
    }
}
