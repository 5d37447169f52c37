//! MP4 clips: H.264 in yuv420p, made by the `ffmpeg` program, which reads the frames as raw
//! 8-bit RGB from its standard input (no frame is copied to disk).
//!
//! - The rate is the shot's exact rational (`-framerate 24000/1001`).
//! - yuv420p halves the chroma resolution, so both sides must be even: a frame of odd width
//!   or height is padded by repeating its last column or row.
//! - The RGB values are converted with the BT.709 matrix to limited-range YUV and tagged
//!   BT.709 (primaries, transfer, matrix), as players expect of HD video.
//! - `+faststart` puts the index first, so the clip plays while it downloads.
//!
//! ffmpeg writes into a temporary file beside the clip, renamed into place once it succeeded.
//! The file is created here and given to ffmpeg as its standard output, which it opens as
//! `file:/dev/stdout` (seekable, as `+faststart` needs): ffmpeg never creates a file of its
//! own, so a run stopped by a signal, which removes the temporary file, leaves nothing behind
//! even while ffmpeg finishes.

use std::io::{Read, Write};
use std::path::Path;
use std::process::{Command, Stdio};

use super::source::FrameImage;
use super::timing::Rate;
use raytrace_core::error::{Error, elide_path};

/// The program that encodes MP4 clips.
const FFMPEG: &str = "ffmpeg";

/// x264's constant rate factor: 18 is visually lossless for most material.
const CRF: &str = "18";

/// The most of ffmpeg's messages a failure quotes, in bytes (its last ones).
const MAX_MESSAGE: usize = 2000;

/// Whether ffmpeg can be run; if not, why not, and what else there is.
pub(super) fn check_ffmpeg(clip: &Path) -> Result<(), Error> {
    match Command::new(FFMPEG)
        .arg("-version")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
    {
        Ok(_) => Ok(()),
        Err(e) => Err(Error::resource(format!(
            "cannot make {}: .mp4 clips are made by the ffmpeg program, which could not be run \
             ({e}); install ffmpeg, or make a .gif, .apng or .png clip, which need no other \
             program",
            elide_path(clip)
        ))),
    }
}

/// The even size a frame of `width` x `height` is padded to.
pub(super) fn padded((width, height): (u32, u32)) -> (u32, u32) {
    (width.next_multiple_of(2), height.next_multiple_of(2))
}

/// `frame`'s pixels padded to `size` (at least its own) by repeating the last column and row.
fn pad(frame: &FrameImage, (w, h): (u32, u32)) -> Vec<u8> {
    if (frame.width, frame.height) == (w, h) {
        return frame.rgb.clone();
    }
    let row_bytes = frame.width as usize * 3;
    let mut out = Vec::with_capacity(w as usize * h as usize * 3);
    for y in 0..h.min(frame.height + 1) {
        let row = &frame.rgb[(y.min(frame.height - 1) as usize) * row_bytes..][..row_bytes];
        out.extend_from_slice(row);
        for _ in frame.width..w {
            out.extend_from_slice(&row[row_bytes - 3..]);
        }
    }
    let full_row = w as usize * 3;
    while out.len() < w as usize * h as usize * 3 {
        let start = out.len() - full_row;
        out.extend_from_within(start..start + full_row);
    }
    out
}

/// Encodes `frames` of `size` with ffmpeg into `out`, an empty file; `clip` names the clip
/// in messages.
pub(super) fn write(
    out: std::fs::File,
    clip: &Path,
    size: (u32, u32),
    rate: Rate,
    frames: impl Iterator<Item = Result<FrameImage, Error>>,
) -> Result<(), Error> {
    let (w, h) = padded(size);
    let mut child = Command::new(FFMPEG)
        .args(["-hide_banner", "-nostats", "-loglevel", "error"])
        .args(["-f", "rawvideo", "-pix_fmt", "rgb24"])
        .args(["-video_size", &format!("{w}x{h}")])
        .args(["-framerate", &rate.text()])
        .args(["-i", "pipe:0"])
        .args([
            "-vf",
            "scale=out_color_matrix=bt709:out_range=tv,format=yuv420p",
        ])
        .args(["-c:v", "libx264", "-crf", CRF, "-pix_fmt", "yuv420p"])
        .args(["-colorspace", "bt709", "-color_primaries", "bt709"])
        .args(["-color_trc", "bt709", "-color_range", "tv"])
        .args(["-movflags", "+faststart", "-f", "mp4", "-y"])
        .arg("file:/dev/stdout")
        .stdin(Stdio::piped())
        .stdout(Stdio::from(out))
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| Error::resource(format!("cannot run ffmpeg for {}: {e}", elide_path(clip))))?;
    // ffmpeg's messages are read while it runs, so that it never blocks on a full pipe.
    let mut stderr = child.stderr.take().expect("piped stderr");
    let messages = std::thread::spawn(move || {
        let mut text = Vec::new();
        let _ = stderr.read_to_end(&mut text);
        text
    });
    let mut stdin = child.stdin.take().expect("piped stdin");
    let mut fed = Ok(());
    for frame in frames {
        match frame {
            Ok(frame) => {
                if let Err(e) = stdin.write_all(&pad(&frame, (w, h))) {
                    // ffmpeg stopped reading: its status and messages say why.
                    fed = Err(Error::io(clip, e));
                    break;
                }
            }
            Err(e) => {
                let _ = child.kill();
                fed = Err(e);
                break;
            }
        }
    }
    drop(stdin);
    let status = child.wait().map_err(|e| Error::io(clip, e))?;
    let text = messages.join().unwrap_or_default();
    if let Err(e @ Error::Usage(_)) = fed {
        return Err(e);
    }
    if !status.success() {
        let text = String::from_utf8_lossy(&text);
        let text = text.trim();
        let start = text.floor_char_boundary(text.len().saturating_sub(MAX_MESSAGE));
        return Err(Error::Output {
            path: clip.to_path_buf(),
            message: format!("ffmpeg failed ({status}): {}", &text[start..]),
        });
    }
    fed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odd_sides_are_padded_with_the_last_column_and_row() {
        let frame = FrameImage {
            frame: 1,
            width: 3,
            height: 1,
            rgb: vec![1, 1, 1, 2, 2, 2, 3, 3, 3],
        };
        assert_eq!(padded((3, 1)), (4, 2));
        let p = pad(&frame, (4, 2));
        let row = [1, 1, 1, 2, 2, 2, 3, 3, 3, 3, 3, 3];
        assert_eq!(p, [row, row].concat());
        assert_eq!(pad(&frame, (3, 1)), frame.rgb);
    }
}
