//! `raytrace generate`: writes a large random test scene (see [`crate::scene_file::generate`]).

use super::args::GenerateArgs;
use crate::error::Error;
use crate::format::Format;
use crate::io;
use crate::scene_file::generate::{RandomScene, scene_text};

/// Writes the scene to its `.toml` file, atomically. The argument ranges were checked by the
/// command line's parsers.
pub(crate) fn generate(args: &GenerateArgs) -> Result<(), Error> {
    Format::of(&args.output, &[Format::Toml], "scene").map_err(Error::Usage)?;
    io::check_target(&args.output).map_err(Error::Usage)?;
    let scene = RandomScene {
        spheres: args.spheres,
        moving: args.moving,
        seed: args.seed,
        frames: args.frames,
    };
    io::write_file(&args.output, scene_text(&scene).as_bytes())
}
