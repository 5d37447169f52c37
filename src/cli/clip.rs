//! `raytrace clip`: assembles a shot's rendered frames into a clip (see [`raytrace_io::clip`]).

use std::path::Path;

use super::args::ClipArgs;
use super::jobs::select_frames;
use super::progress::print_line;
use raytrace_core::error::{Error, elide};
use raytrace_core::format::{FRAME_FORMATS, Format};
use raytrace_core::path_pattern::{self, FramePattern};
use raytrace_core::scene::Scene;
use raytrace_io::clip::{self, Source};
use raytrace_scene::scene_file::SceneFile;

/// `raytrace clip`: the frames selected by `--frames` (default: every frame of the shot),
/// found through `--input` or the scene's output path, assembled into the clip.
pub(crate) fn clip(args: &ClipArgs) -> Result<(), Error> {
    let scene = Scene::load(&args.scene)?;
    let pattern = match &args.input {
        Some(p) => {
            if Format::from_extension(Path::new(p), FRAME_FORMATS).is_none() {
                return Err(Error::Usage(format!(
                    "--input \"{}\": {}",
                    elide(p),
                    Format::unsupported(FRAME_FORMATS, "frame")
                )));
            }
            FramePattern::new(path_pattern::with_scene(p, &args.scene))
                .map_err(|e| Error::Usage(format!("--input \"{}\": {e}", elide(p))))?
        }
        None => scene.output.path.clone(),
    };
    let selected = select_frames(&scene, &args.frames_arg())?;
    if selected.len() > 1 && !path_pattern::pattern_has_frame_number(&pattern) {
        return Err(Error::Usage(format!(
            "frame path \"{}\" has no '#' for the frame number, so it names one file for {} frames",
            elide(&pattern),
            selected.len()
        )));
    }
    let path = path_pattern::with_scene(&args.clip.to_string_lossy(), &args.scene);
    let path = Path::new(&path);
    let source = Source {
        pattern: &pattern,
        exposure: args.exposure.unwrap_or(0.0),
    };
    let made = clip::make(
        path,
        scene.shot.fps,
        source,
        selected.iter(),
        selected.len(),
    )?;
    if !args.quiet {
        print_line(&made.line(path));
    }
    Ok(())
}
