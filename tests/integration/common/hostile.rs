//! What the hostile-input tests share: runs under their limits, refusals checked with what
//! they leave behind, and small scenes with point caches.

use std::path::Path;
use std::process::Output;

/// Each run's limit in seconds and in address space (`ulimit -v`, KiB).
pub(crate) const SECONDS: u64 = 5;
pub(crate) const MEMORY_KIB: u64 = 1 << 20;

/// Runs the binary in `dir` under [`SECONDS`] and [`MEMORY_KIB`].
pub(crate) fn run(dir: &Path, args: &[&str]) -> Output {
    super::run_limited(dir, args, SECONDS, MEMORY_KIB)
}

/// The names in `dir`, sorted.
pub(crate) fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Runs `args` in `dir` and asserts exit status 2, every one of `want` in the message, no
/// panic, and nothing in `dir` but `kept` afterwards. Returns what the run printed.
pub(crate) fn refused(dir: &Path, args: &[&str], want: &[&str], kept: &[&str]) -> String {
    let o = run(dir, args);
    let t = super::text(&o);
    let shown = super::shorten(&t);
    assert_eq!(o.status.code(), Some(2), "{:?}: {shown}", &args[..1]);
    for w in want {
        assert!(t.contains(w), "{w:?} missing in: {}", shorten_long(&t));
    }
    assert!(!t.contains("panicked"), "{shown}");
    let mut kept: Vec<String> = kept.iter().map(|k| k.to_string()).collect();
    kept.sort();
    assert_eq!(names(dir), kept, "{:?} wrote something", &args[..1]);
    t
}

/// A message as an assertion shows it: cut after 3000 bytes.
fn shorten_long(t: &str) -> String {
    match t.char_indices().nth(3000) {
        Some((end, _)) => format!("{}… ({} bytes)", &t[..end], t.len()),
        None => t.to_string(),
    }
}

/// A shot of two 8x6 frames of one sphere written to `output`, with `extra` (tables) after.
pub(crate) fn scene(output: &str, extra: &str) -> String {
    format!(
        "[shot]\nframes = 2\n[output]\npath = \"{output}\"\nwidth = 8\nheight = 6\n\
         [render]\nsamples = 1\n[camera]\nlook_from = [0.0, 0.0, 5.0]\n\
         [[sphere]]\ncenter = [0.0, 0.0, -1.0]\nradius = 0.5\n\
         material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\n{extra}"
    )
}

/// A `[[points]]` table reading `file` (TOML's escapes allowed), radius 0.1, and `more` keys.
pub(crate) fn points(file: &str, more: &str) -> String {
    format!(
        "[[points]]\nfile = \"{file}\"\nradius = 0.1\n\
         material = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\n{more}"
    )
}

/// A folder holding `shot.toml` with `text`, and `files` (name, bytes).
pub(crate) fn setup(text: &str, files: &[(&str, &[u8])]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), text).unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    dir
}
