//! `raytrace preview`: serves a live page of a shot (see [`crate::preview`]) and prints its
//! address. The scene file must be readable at the start; a scene that does not validate, now
//! or after an edit, is shown on the page with `check`'s message until it does.

use std::net::SocketAddr;

use super::args::PreviewArgs;
use super::jobs::select_frames;
use super::progress::print_line;
use crate::preview::{self, Frames, MAX_TIMELINE_FRAMES, Setup};
use raytrace_core::error::Error;
use raytrace_core::scene::Scene;
use raytrace_render::devices::supported;
use raytrace_scene::scene_file::{Overrides, SceneSource};

/// Serves the preview until a signal ends the process; returns only on an error.
pub(crate) fn preview(args: &PreviewArgs) -> Result<(), Error> {
    let overrides = Overrides {
        device: args.device,
        denoise_device: args.denoise_device,
        ..Overrides::default()
    };
    let source = SceneSource::read(&args.scene)?;
    // A --frames the shot cannot have is an error now, when the scene validates.
    if let Ok(scene) = source
        .scene(&overrides)
        .and_then(|s| supported(s, &overrides))
    {
        select_frames(&scene, &args.frames_arg())?;
    }
    let frames = args.frames_arg();
    let select = move |scene: &Scene| -> Result<Frames, Error> {
        let selected = select_frames(scene, &frames)?;
        let shown = selected.iter().take(MAX_TIMELINE_FRAMES).collect();
        Ok((shown, selected.len()))
    };
    let listener = preview::bind(SocketAddr::new(args.bind, args.port))?;
    let bound = listener
        .local_addr()
        .map_err(|e| Error::resource(format!("preview server: {e}")))?;
    print_line(&format!("preview: http://{bound}/"));
    if !args.bind.is_loopback() {
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr(),
            "preview: shared on {}: anyone who can reach it can open the page (the default, 127.0.0.1, is this machine only)",
            args.bind
        );
    }
    preview::run(
        listener,
        Setup {
            path: args.scene.clone(),
            overrides,
            select: Box::new(select),
            threads: 0,
        },
    )
}
