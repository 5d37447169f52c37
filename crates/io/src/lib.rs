//! `raytrace-io`: files in and out: frame paths from patterns, atomic writes (every file the
//! renderer writes goes through [`atomic`]), EXR and PNG frames, and clips assembled from the
//! frames ([`clip`]). The formats themselves are named in `raytrace_core::format`.
#![forbid(unsafe_code)]

mod atomic;
pub mod clip;
mod exr;
mod files;
mod frame_file;
mod png;

#[cfg(test)]
mod tests;

pub(crate) use atomic::write_with_temp_file;
pub use atomic::{
    check_target, files_written, remove_stale_temp_files, stop_writing, write_file, write_with,
};
pub(crate) use exr::fps_rational;

pub use exr::{FrameInfo, read_exr_colour};
pub use files::file_kind;
pub use frame_file::check_frame_file;
pub use frame_file::{bytes_for, write_image};
pub use png::{encode as encode_png, linear_to_srgb8};
