//! Files in and out: frame paths from patterns, atomic writes (every file the renderer writes
//! goes through [`atomic`]), EXR and PNG frames. This file only declares and re-exports; the
//! formats themselves are named in [`crate::format`].

mod atomic;
mod exr;
mod files;
mod frame;
mod image;
mod png;

#[cfg(test)]
mod tests;

pub(crate) use atomic::{
    check_target, files_written, remove_stale_temp_files, stop_writing, write_file, write_with,
    write_with_temp_file,
};
pub(crate) use exr::fps_rational;
pub use exr::{FrameInfo, read_exr_number, read_exr_rgb};
pub use files::file_kind;
pub(crate) use frame::check_frame_file;
pub use frame::{write_frame, write_frame_from, write_frame_with_passes};
pub use image::{Image, RgbSource};
pub use png::{encode as encode_png, linear_to_srgb8};
