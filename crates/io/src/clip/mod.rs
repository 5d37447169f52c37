//! Clips: a shot's rendered frames, read back from disk, assembled into one file to watch.
//! The clip's extension picks the kind ([`CLIP_FORMATS`]):
//!
//! - `.mp4`: H.264 made by the `ffmpeg` program ([`mp4`]);
//! - `.gif`: an animated GIF ([`gif`]);
//! - `.apng`: an animated PNG with exact frame delays ([`apng`]);
//! - `.png`: a contact sheet, the frames in a labelled grid ([`sheet`]).
//!
//! Frames are shown in frame order, one frame period each, at the shot's exact rate
//! ([`timing`]), as 8-bit sRGB exactly as the PNG frame output writes them ([`source`]).
//! Everything that can be checked is checked before the clip is written: every frame's file
//! must be there and complete, so a missing frame writes nothing. The clip is written
//! atomically (a temporary file beside it, renamed into place).

mod apng;
mod digits;
mod gif;
mod mp4;
mod sheet;
mod source;
mod timing;

use std::path::Path;

pub use source::Source;
pub(crate) use timing::Rate;

use raytrace_core::error::{Error, elide_path};
use raytrace_core::format::{CLIP_FORMATS, Format};

/// What a clip holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Made {
    pub frames: u64,
    pub width: u32,
    pub height: u32,
    pub rate: Rate,
}

impl Made {
    /// `clip renders/shot.mp4: 48 frames, 320x180 at 24/1 fps, 2.000 s`.
    pub fn line(&self, path: &Path) -> String {
        format!(
            "clip {}: {} frames, {}x{} at {} fps, {:.3} s",
            elide_path(path),
            self.frames,
            self.width,
            self.height,
            self.rate.text(),
            self.rate.duration(self.frames)
        )
    }
}

/// The kind of clip `path` names, or a usage error naming the kinds there are.
pub fn kind(path: &Path) -> Result<Format, Error> {
    Format::of(path, CLIP_FORMATS, "clip").map_err(Error::Usage)
}

/// Checks what can be checked of a clip before any frame is rendered: its kind, the frame
/// rate and, for `.mp4`, that ffmpeg can be run.
pub fn check(path: &Path, fps: f64) -> Result<(Format, Rate), Error> {
    let kind = kind(path)?;
    let rate = Rate::of_fps(fps).ok_or_else(|| {
        Error::Usage(format!(
            "{}: the shot's rate of {fps} fps cannot be written as a clip's frame rate",
            elide_path(path)
        ))
    })?;
    crate::check_target(path).map_err(Error::Usage)?;
    if kind == Format::Mp4 {
        mp4::check_ffmpeg(path)?;
    }
    Ok((kind, rate))
}

/// Assembles `frames` (in increasing order, `count` of them) of `source` into the clip at
/// `path`, at `fps` frames per second. Every frame is checked to be on disk first: a missing
/// one is a usage error naming it, and nothing is written.
pub fn make<I>(path: &Path, fps: f64, source: Source, frames: I, count: u64) -> Result<Made, Error>
where
    I: Iterator<Item = u32> + Clone,
{
    let (kind, rate) = check(path, fps)?;
    if count == 0 {
        return Err(Error::Usage(format!(
            "{}: no frames selected for the clip",
            elide_path(path)
        )));
    }
    if source.exposure != 0.0
        && Format::from_extension(Path::new(source.pattern.as_str()), &[Format::Exr]).is_none()
    {
        return Err(Error::Usage(
            "--exposure applies to EXR frames only: PNG frames are already 8-bit sRGB".to_string(),
        ));
    }
    if kind == Format::Png && count > sheet::MAX_FRAMES {
        return Err(Error::Usage(format!(
            "{}: a contact sheet shows at most {} frames, and {count} are selected: choose \
             fewer with --frames (1-480:10 is every 10th)",
            elide_path(path),
            sheet::MAX_FRAMES
        )));
    }
    source.check_present(frames.clone())?;
    let mut order = frames.clone();
    let first_frame = order.next().expect("at least one frame");
    let first = source.read(first_frame, None)?;
    let size = (first.width, first.height);
    let all = std::iter::once(Ok(first)).chain(order.map(|f| source.read(f, Some(size))));
    match kind {
        Format::Mp4 => {
            crate::write_with_temp_file(path, |file| mp4::write(file, path, size, rate, all))?
        }
        Format::Gif => {
            if size.0 > u16::MAX as u32 || size.1 > u16::MAX as u32 {
                return Err(Error::Usage(format!(
                    "{}: GIF images are at most 65535 pixels a side, the frames are {}x{}",
                    elide_path(path),
                    size.0,
                    size.1
                )));
            }
            crate::write_with(path, |w| gif::write(&mut *w, path, rate, all))?
        }
        Format::Apng => {
            let n = u32::try_from(count).map_err(|_| {
                Error::Usage(format!("{}: too many frames for APNG", elide_path(path)))
            })?;
            crate::write_with(path, |w| {
                apng::write(&mut *w, path, (size.0, size.1, n), rate, all)
            })?
        }
        _ => {
            let last_frame = frames.clone().last().unwrap_or(first_frame);
            let mut sheet = sheet::Sheet::new(sheet::SheetGrid::new(count, size, last_frame));
            for (i, frame) in all.enumerate() {
                sheet.add(i as u64, &frame?);
            }
            crate::write_with(path, |w| sheet.write(&mut *w, path))?
        }
    }
    Ok(Made {
        frames: count,
        width: size.0,
        height: size.1,
        rate,
    })
}
