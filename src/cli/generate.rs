//! `raytrace generate`: writes a large random test scene (see [`raytrace_scene::scene_file::generate`]),
//! or a fountain's point cache, a PLY file per frame (see [`raytrace_scene::fountain`]).

use super::args::GenerateArgs;
use raytrace_core::error::{Error, elide_path};
use raytrace_core::format::Format;
use raytrace_core::path_pattern::{FramePattern, frame_path, pattern_has_frame_number};
use raytrace_io as io;
use raytrace_scene::fountain::{FPS, Fountain, write_points_frame};
use raytrace_scene::scene_file::generate::{RandomScene, scene_text};

/// Writes the scene to its `.toml` file, or the point cache's `.ply` files, atomically. The
/// argument ranges were checked by the command line's parsers. Returns what was written.
pub(crate) fn generate(args: &GenerateArgs) -> Result<String, Error> {
    let format =
        Format::of(&args.output, &[Format::Toml, Format::Ply], "scene").map_err(Error::Usage)?;
    if format == Format::Ply {
        return point_cache(args);
    }
    io::check_target(&args.output).map_err(Error::Usage)?;
    let scene = RandomScene {
        spheres: args.spheres,
        moving: args.moving,
        seed: args.seed,
        frames: args.frames,
    };
    io::write_file(&args.output, scene_text(&scene).as_bytes())?;
    Ok(String::new())
}

/// The fountain's frames 1 to `args.frames`, one file each.
fn point_cache(args: &GenerateArgs) -> Result<String, Error> {
    let pattern = FramePattern::new(args.output.to_string_lossy())
        .map_err(|e| Error::Usage(format!("--output \"{}\": {e}", elide_path(&args.output))))?;
    if args.frames > 1 && !pattern_has_frame_number(&pattern) {
        return Err(Error::Usage(format!(
            "{}: {} frames of a point cache need a '#' in the name for the frame number",
            elide_path(&args.output),
            args.frames
        )));
    }
    let paths: Vec<_> = (1..=args.frames).map(|f| frame_path(&pattern, f)).collect();
    for p in [paths.first(), paths.last()].into_iter().flatten() {
        io::check_target(p).map_err(Error::Usage)?;
    }
    let fountain = Fountain {
        points: args.points,
        seed: args.seed,
    };
    let (mut least, mut most) = (usize::MAX, 0);
    for (k, path) in paths.iter().enumerate() {
        let n = write_points_frame(&fountain, k as f64 / FPS, path, args.encoding.encoding())?;
        (least, most) = (least.min(n), most.max(n));
    }
    Ok(format!(
        "{} frames of a fountain ({least} to {most} points a frame) written to {}",
        args.frames,
        elide_path(&args.output)
    ))
}
