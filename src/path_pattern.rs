//! Path patterns: frame file names (runs of `#` become the frame number) and `{scene}`.

use std::path::{Path, PathBuf};

/// The placeholder of a path pattern that stands for the scene file's name.
pub(crate) const SCENE_PLACEHOLDER: &str = "{scene}";

/// The name `{scene}` stands for: the scene file's name without its extension
/// (`shots/a.toml` → `a`); `frame` for a path without a file name.
pub(crate) fn scene_name(source: &Path) -> String {
    source
        .file_stem()
        .map_or("frame".into(), |s| s.to_string_lossy().into_owned())
}

/// `pattern` with every `{scene}` replaced by the scene file's name without its extension
/// ([`scene_name`]): `renders/{scene}_####.exr` for `shots/a.toml` is `renders/a_####.exr`.
pub(crate) fn with_scene(pattern: &str, source: &Path) -> String {
    pattern.replace(SCENE_PLACEHOLDER, &scene_name(source))
}

/// Whether the pattern contains `{scene}`, that is, whether scenes of different names get
/// different paths from [`with_scene`].
pub(crate) fn pattern_has_scene(pattern: &str) -> bool {
    pattern.contains(SCENE_PLACEHOLDER)
}

/// The output path of `frame` for a file name pattern.
///
/// Every run of `#` in the pattern becomes the frame number, zero-padded to the length of the
/// run (`render.####.exr` → `render.0001.exr`). A number with more digits than the run is
/// written in full, never truncated (frame 12345 with `##` → `12345`).
///
/// A pattern without any `#` is returned unchanged, so every frame then writes the same
/// file; callers rendering more than one frame should check [`pattern_has_frame_number`].
pub(crate) fn frame_path(pattern: &str, frame: u32) -> PathBuf {
    let mut out = String::with_capacity(pattern.len() + 8);
    let mut chars = pattern.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '#' {
            let mut width = 1;
            while chars.next_if_eq(&'#').is_some() {
                width += 1;
            }
            out.push_str(&format!("{frame:0width$}"));
        } else {
            out.push(c);
        }
    }
    PathBuf::from(out)
}

/// Whether the pattern contains a `#` run, that is, whether different frames get different
/// paths from [`frame_path`].
pub(crate) fn pattern_has_frame_number(pattern: &str) -> bool {
    pattern.contains('#')
}
