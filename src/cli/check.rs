//! `raytrace check`: validates scenes, and everything a render of them would check, and
//! describes each.

use std::fmt::Write;

use super::args::{CheckArgs, FramesArg};
use super::frames::{self, Selection};
use super::jobs::{Job, load_shots};
use raytrace_core::error::{Error, elide, elide_path};
use raytrace_core::motion::Motion;
use raytrace_core::points::PointCacheDesc;
use raytrace_core::scene::Scene;
use raytrace_render::devices::{Needs, adapter_line};
use raytrace_render::memory::{check_memory, memory_estimate, mib};
use raytrace_scene::point_cache::{FrameSurvey, ShotPoints, SurveyDepth};
use raytrace_scene::scene_file::Overrides;

/// `raytrace check`: validates scenes, and what `raytrace render` of them would check before
/// rendering (their frames and files, with the same code), and describes each. With several
/// scenes, `--chunk-size` counts the chunks of the whole batch, on one `chunks:` line.
pub(crate) fn check(args: &CheckArgs) -> Result<String, Error> {
    let overrides = Overrides {
        device: args.device,
        ..Overrides::default()
    };
    let shots = load_shots(
        &args.scenes,
        &overrides,
        &FramesArg::Every,
        None,
        SurveyDepth::Values,
    )?;
    // The adapter a render on the GPU would take, found once.
    let gpu = Needs::of(shots.iter().map(|s| &s.scene))
        .gpu
        .then(adapter_line);
    let gpu = gpu.as_deref();
    if let [shot] = &shots[..] {
        return describe(shot, args.chunk_size, gpu);
    }
    let mut s = String::new();
    for shot in &shots {
        s.push_str(&describe(shot, None, gpu)?);
    }
    let frames: u64 = shots.iter().map(|s| s.targets.frames.len()).sum();
    let _ = writeln!(s, "batch: {} scenes, {frames} frames", shots.len());
    if let Some(size) = args.chunk_size {
        let _ = writeln!(
            s,
            "chunks: {} of up to {size} frames",
            frames::chunk_count(frames, size)
        );
    }
    Ok(s)
}

/// The description of one shot (with its chunk count when `chunk_size` is given; `gpu`: the
/// GPU's line, [`adapter_line`], when a shot renders on it).
fn describe(shot: &Job, chunk_size: Option<u64>, gpu: Option<&str>) -> Result<String, Error> {
    let (scene_path, scene) = (&shot.path, &shot.scene);
    let selected = &shot.targets.frames;
    let memory = check_memory(scene, shot.points)?;
    // Every file of every selected frame was read and checked, value by value, once, by the
    // survey.
    let caches = &shot.caches;
    let mut s = String::new();
    let _ = writeln!(s, "{}: ok", elide_path(scene_path));
    write_shot(&mut s, scene);
    write_points(&mut s, scene, selected, caches)?;
    let _ = writeln!(s, "camera: {}", camera_note(scene));
    write_image(&mut s, scene, gpu);
    let _ = writeln!(s, "memory: about {}", mib(memory));
    let per_frame =
        scene.output.width as u64 * scene.output.height as u64 * scene.render.samples as u64;
    // Up to 2^32 frames of up to 2^64 samples: a u128 holds the product.
    let _ = writeln!(
        s,
        "total samples: {} ({} per frame)",
        per_frame as u128 * selected.len() as u128,
        per_frame
    );
    if let Some(size) = chunk_size {
        let _ = writeln!(
            s,
            "chunks: {} of up to {size} frames",
            frames::chunk_count(selected.len(), size)
        );
    }
    write_frames(&mut s, scene, caches)?;
    Ok(s)
}

/// Writes the `shot:` line (with the `shutter:` note when the shutter has one) and the
/// `spheres:` line.
fn write_shot(s: &mut String, scene: &Scene) {
    let shot = &scene.shot;
    let _ = writeln!(
        s,
        "shot: {} frames ({}-{}) at {} fps, shutter {} s ({}), start time {} s",
        shot.frames,
        shot.first_frame,
        shot.last_frame(),
        shot.fps,
        shot.shutter,
        shot.position.name(),
        shot.start_time
    );
    if let Some(note) = shot.exposure_note() {
        // The frames' intervals below are then each frame's whole exposure.
        let _ = writeln!(s, "shutter: {note}");
    }
    let moving = scene
        .spheres
        .iter()
        .filter(|s| s.motion.is_animated())
        .count();
    let _ = writeln!(
        s,
        "spheres: {} ({} moving, {} static)",
        scene.spheres.len(),
        moving,
        scene.spheres.len() - moving
    );
}

/// Writes a `points[i]:` line per point cache and, after the last, the `points:` line of the
/// points a frame holds over the `selected` frames, from the survey `caches`.
fn write_points(
    s: &mut String,
    scene: &Scene,
    selected: &Selection,
    caches: &ShotPoints,
) -> Result<(), Error> {
    for (i, p) in scene.points.iter().enumerate() {
        let kind = if p.is_sequence() {
            "a file per frame"
        } else {
            "one file for every frame"
        };
        let motion = p
            .motion
            .map_or("default (velocity where the file has it)", |m| m.name());
        let radius = p
            .radius
            .map_or("from the file".to_string(), |r| r.to_string());
        let _ = writeln!(
            s,
            "points[{i}]: {} ({kind}, {}), motion {motion}, radius {radius}{}",
            elide(&p.file),
            p.format.name(),
            looks(p)
        );
        if i + 1 == scene.points.len()
            && let (Some(first), Some(last)) = (selected.first(), selected.last())
        {
            let (least, most) = caches.count_range(scene, first, last)?;
            let _ = writeln!(
                s,
                "points: {least} to {most} a frame over {} frames, every file checked ({} files read once each)",
                selected.len(),
                caches.files_read()
            );
        }
    }
    Ok(())
}

/// The camera's motion and lens, as the `camera:` line states them: `still, pinhole, vfov 40`.
fn camera_note(scene: &Scene) -> String {
    let cam = match (&scene.camera.look_from, &scene.camera.look_at) {
        (Motion::Orbit { orbit, .. }, _) => {
            format!("orbit at {} degrees/s", orbit.degrees_per_second)
        }
        (Motion::Keyframes(k), _) | (_, Motion::Keyframes(k)) => format!("{} keyframes", k.len()),
        _ => "still".to_string(),
    };
    let lens = if scene.camera.aperture > 0.0 {
        format!("thin lens, aperture {}", scene.camera.aperture)
    } else {
        "pinhole".to_string()
    };
    format!("{cam}, {lens}, vfov {}", scene.camera.vfov)
}

/// Writes the `image:` line, and the lines of what else the frames are made and written
/// with: the GPU's `device:` line (`gpu`, when the scene renders on it), `passes:` and
/// `clip:`.
fn write_image(s: &mut String, scene: &Scene, gpu: Option<&str>) {
    let _ = writeln!(
        s,
        "image: {}x{}, {} samples/pixel, max depth {}, seed {}, output {}",
        scene.output.width,
        scene.output.height,
        scene.render.samples,
        scene.render.max_depth,
        scene.render.seed,
        elide(&scene.output.path)
    );
    if let (raytrace_core::scene::Device::Gpu, Some(gpu)) = (scene.render.device, gpu) {
        let _ = writeln!(s, "device: gpu, adapter: {gpu}");
    }
    if !scene.output.passes.is_empty() || scene.transparent {
        let mut passes = vec!["colour"];
        passes.extend(scene.output.passes.iter().map(|p| p.name()));
        let background = if scene.transparent {
            " (transparent background)"
        } else {
            ""
        };
        let _ = writeln!(s, "passes: {}{background}", passes.join(", "));
    }
    if let Some(c) = &scene.output.clip {
        let _ = writeln!(s, "clip: {}", elide(c));
    }
}

/// Writes the `frames:` list: every frame of a short shot, the first 20 and the last 5 of a
/// long one (`...` between), each with its line.
fn write_frames(s: &mut String, scene: &Scene, caches: &ShotPoints) -> Result<(), Error> {
    let _ = writeln!(s, "frames:");
    let shot = &scene.shot;
    let (first, last) = (shot.first_frame, shot.last_frame());
    let listed: Vec<Option<u32>> = if shot.frames <= 50 {
        (first..=last).map(Some).collect()
    } else {
        (first..first + 20)
            .map(Some)
            .chain([None])
            .chain((last - 4..=last).map(Some))
            .collect()
    };
    for f in listed {
        match f {
            Some(f) => {
                let _ = writeln!(s, "{}", frame_line(scene, caches, f)?);
            }
            None => {
                let _ = writeln!(s, "  ...");
            }
        }
    }
    Ok(())
}

/// A frame's line in the `frames:` list: its exposure and the spheres moving in it, with its
/// points (their survey in `caches`) and memory when the scene has point caches.
fn frame_line(scene: &Scene, caches: &ShotPoints, f: u32) -> Result<String, Error> {
    let i = scene.shot.interval(f);
    let moving_now = scene
        .spheres
        .iter()
        .filter(|s| s.prepare(i).motion.is_moving())
        .count();
    let points = match scene.points.is_empty() {
        true => String::new(),
        false => {
            let p: FrameSurvey = caches.frame_survey(scene, f)?;
            let moving = match p.moving {
                Some(m) => format!("{m} moving"),
                None => "moving to their next snapshot".to_string(),
            };
            format!(
                ", {} points ({moving}), memory about {}",
                p.points,
                mib(memory_estimate(scene, p.load))
            )
        }
    };
    Ok(format!(
        "  {f}: shutter [{}, {}] s, {moving_now} moving{points}",
        i.open, i.close
    ))
}

/// A cache's looks and time, as `check` lists them after its motion: `, color_by c_speed
/// (viridis, range from the frames)`, `, periodic`, ...; nothing for a plain cache.
fn looks(p: &PointCacheDesc) -> String {
    let mut parts = Vec::new();
    if let raytrace_core::points::SnapshotTime::Timestep { dt } = p.snapshots {
        parts.push(format!("snapshots at TIMESTEP * {dt} s"));
    }
    if p.velocity_scale != 1.0 {
        parts.push(format!("velocity scale {}", p.velocity_scale));
    }
    match p.periodic {
        Some(true) => parts.push("periodic".into()),
        Some(false) => parts.push("box ignored".into()),
        None => {}
    }
    if let Some(c) = &p.color_by {
        let range = c
            .range
            .map_or("range from the frames".to_string(), |[a, b]| {
                format!("range {a} to {b}")
            });
        parts.push(format!(
            "color_by {} ({}, {range})",
            elide(&c.column),
            c.map.name()
        ));
    }
    if let Some(r) = &p.radius_by {
        parts.push(format!("radius_by {}", elide(r)));
    }
    if !p.types.is_empty() {
        parts.push(format!("{} types", p.types.len()));
    }
    parts.iter().map(|x| format!(", {x}")).collect()
}
