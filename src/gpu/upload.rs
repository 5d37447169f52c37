//! The scene in the GPU's words ([`super::layout`]), made on the CPU from the validated scene
//! with the CPU tracer's own per-frame preparation: each sphere's motion prepared for the
//! frame's interval ([`crate::sphere::SphereDesc::prepare`]), its boxes at the shutter's
//! opening and closing, the hierarchies built by [`crate::bvh`] and flattened
//! ([`super::flatten`]), the camera's view, the shutter's times.
//!
//! A shot's words ([`ShotWords`]) hold what never changes: the materials, the Sobol tables and
//! the spheres that never move with their hierarchy. A frame's words ([`FrameWords`]) hold its
//! header, the shutter curve, the camera's motion and the animated spheres prepared for it;
//! in a small scene with animated spheres ([`MERGE_LIMIT`]), every sphere.
//! Times on the GPU are `f32` seconds since the frame's opening, so a late frame keeps its
//! digits as on the CPU.

use glam::DVec3;
use sobol_burley::parts::sobol_int4_rev;

use super::flatten::{Flat, flatten};
use super::layout::*;
use crate::aabb::Aabb;
use crate::bvh::Bvh;
use crate::material::{Background, Material};
use crate::motion::{FrameMotion, Motion};
use crate::passes::Layout;
use crate::rng::hash_words;
use crate::sampler::SamplerKind;
use crate::scene::Scene;
use crate::shutter::{Interval, ReadoutDirection};
use crate::world::MERGE_LIMIT;

/// What a shot keeps on the GPU for all its frames.
#[derive(Clone, Debug)]
pub(super) struct ShotWords {
    pub(super) words: Words,
    materials: u32,
    tables: u32,
    spheres: u32,
    hierarchy: Flat,
    /// The spheres prepared per frame: the animated ones, or every one (see
    /// [`MERGE_LIMIT`]); the others are in this buffer.
    animated: Vec<u32>,
}

/// Whether `scene` is traced through one hierarchy per frame over every sphere: it has
/// animated spheres and at most the CPU's world's [`MERGE_LIMIT`] spheres in all (the
/// world's shared topology for larger, mostly animated scenes has no counterpart here).
pub(super) fn one_hierarchy(scene: &Scene) -> bool {
    scene.spheres.len() <= MERGE_LIMIT && scene.spheres.iter().any(|s| s.motion.is_animated())
}

/// One frame's words, and what the renderer reports of it.
#[derive(Clone, Debug)]
pub(super) struct FrameWords {
    pub(super) words: Words,
    /// Spheres moving during the frame's exposure.
    pub(super) moving: usize,
}

impl ShotWords {
    /// The words of `scene`'s shot: its materials, the Sobol tables, and its spheres that
    /// never move with their hierarchy (built as the CPU tracer builds its own).
    pub(super) fn new(scene: &Scene) -> Result<ShotWords, String> {
        if !scene.points.is_empty() {
            // Refused when the scene is validated (`super::support`).
            return Err("the GPU renders no point caches ([[points]])".to_string());
        }
        let mut w = Words::default();
        let materials = w.at();
        for m in &scene.materials {
            let start = w.at();
            let (kind, albedo, fuzz, ior) = match *m {
                Material::Lambertian { albedo } => (LAMBERTIAN, albedo, 0.0, 1.0),
                Material::Metal { albedo, fuzz } => (METAL, albedo, fuzz, 1.0),
                Material::Dielectric { ior } => (DIELECTRIC, DVec3::ONE, 0.0, ior),
            };
            w.u(kind);
            w.v(albedo);
            w.f(fuzz);
            w.f(ior);
            w.pad_to(start, MATERIAL_WORDS);
        }
        w.align();
        let tables = w.at();
        // The first four dimensions of the Sobol sequence for the low and the high byte of a
        // 16-bit index, as the CPU's SobolSampler tabulates them.
        for high in [false, true] {
            for b in 0..256u32 {
                let index = if high { b << 8 } else { b };
                let entry: [u32; 4] = sobol_int4_rev(index.reverse_bits(), 0).into();
                entry.iter().for_each(|&x| w.u(x));
            }
        }
        // As the CPU's world: a scene with animated spheres and at most MERGE_LIMIT spheres
        // in all is one hierarchy per frame (one walk per ray, one nearest distance pruning
        // it); a larger one keeps its still spheres apart, built once.
        let n = scene.spheres.len() as u32;
        let (still, animated): (Vec<u32>, Vec<u32>) = if one_hierarchy(scene) {
            (Vec::new(), (0..n).collect())
        } else {
            (0..n).partition(|&i| !scene.spheres[i as usize].motion.is_animated())
        };
        let boxes: Vec<Aabb> = still
            .iter()
            .map(|&i| scene.spheres[i as usize].still_box())
            .collect();
        let bvh = Bvh::build(&boxes);
        w.align();
        let spheres = w.at();
        for &k in bvh.order() {
            let id = still[k as usize];
            let s = &scene.spheres[id as usize];
            sphere(
                &mut w,
                s.motion.at(0.0),
                DVec3::ZERO,
                s.radius,
                s.material,
                id,
                NONE,
            );
        }
        let eye = scene.camera.look_from.at(0.0).as_vec3().to_array();
        let hierarchy = flatten(bvh.view(), eye, &mut w);
        Ok(ShotWords {
            words: w,
            materials,
            tables,
            spheres,
            hierarchy,
            animated,
        })
    }
}

/// Appends a sphere record (at a multiple of four words when the last record ends there).
fn sphere(w: &mut Words, c: DVec3, v: DVec3, radius: f64, material: u32, id: u32, motion: u32) {
    let start = w.at();
    debug_assert_eq!(start % 4, 0);
    w.v(c);
    w.f(radius);
    w.v(v);
    w.u(material);
    w.u(id);
    w.u(motion);
    w.pad_to(start, SPHERE_WORDS);
}

/// Appends the record of `m` (prepared over an interval opening at `t0`), evaluated on the
/// GPU at `tau = t + shift` for `t` the seconds since `open`, the frame's opening; returns its
/// offset. A keyframed path's keys follow its record.
fn motion(w: &mut Words, m: &FrameMotion, t0: f64, open: f64) -> u32 {
    w.align();
    let start = w.at();
    let (kind, a) = match m {
        FrameMotion::Fixed(p) => (FIXED, *p),
        FrameMotion::Linear { start, .. } => (LINE, *start),
        FrameMotion::Circle(c) => (CIRCLE, c.center),
        FrameMotion::Keyframes(_) => (KEYS, DVec3::ZERO),
    };
    w.u(kind);
    w.f(open - t0);
    if let FrameMotion::Circle(c) = m {
        // The angle at t0, reduced to [0, 360) in f64 (Motion::prepare), then its rate.
        w.f(c.degrees0);
        w.f(c.degrees_per_second);
    }
    w.pad_to(start, MO_A);
    w.v(a);
    w.pad_to(start, MO_B);
    match m {
        FrameMotion::Linear { velocity, .. } => w.v(*velocity),
        FrameMotion::Circle(c) => {
            w.v(c.e1);
            w.pad_to(start, MO_C);
            w.v(c.e2);
        }
        _ => {}
    }
    w.pad_to(start, MOTION_WORDS);
    if let FrameMotion::Keyframes(keys) = m {
        w.set(start + MO_B, w.at());
        w.set(start + MO_B + 1, keys.len() as u32);
        for k in keys.iter() {
            w.f(k.time - t0);
            w.v(k.position);
        }
    }
    start
}

/// The key the GPU's samplers start their hashes from: the CPU samplers' key for the seed and
/// frame, hashed once more (`hash_words(&[key, pixel, index])` begins by mixing it).
fn sampler_key(kind: SamplerKind, seed: u64, frame: u32) -> u64 {
    let key = match kind {
        SamplerKind::Independent => hash_words(&[seed, frame as u64]),
        // The SobolSampler's own key (sampler.rs).
        SamplerKind::Sobol => hash_words(&[seed, frame as u64, 0x0005_0b01]),
    };
    hash_words(&[key])
}

impl FrameWords {
    /// The words of frame `frame` of `scene`, with `shot` already on the GPU, for a film kept
    /// by `layout`.
    pub(super) fn new(
        scene: &Scene,
        shot: &ShotWords,
        frame: u32,
        layout: &Layout,
    ) -> Result<FrameWords, String> {
        let (width, height) = (scene.output.width, scene.output.height);
        let times = &scene.shot;
        let interval = times.interval(frame);
        let open = interval.open;
        let period = 1.0 / times.fps;
        // The camera and the motion pass look one frame period beyond the exposure.
        let widened = Interval {
            open: open - period,
            close: interval.close + period,
        };
        let mut w = Words::default();
        w.pad_to(0, HEADER_WORDS);
        w.set(H_WIDTH, width);
        w.set(H_HEIGHT, height);
        w.set(H_MAX_DEPTH, scene.render.max_depth);
        let key = sampler_key(scene.render.sampler, scene.render.seed, frame);
        w.set(H_KEY, key as u32);
        w.set(H_KEY + 1, (key >> 32) as u32);
        w.set_f(H_DURATION, interval.duration());
        w.set_f(H_SHUTTER, times.shutter);
        let mut flags = 0;
        if scene.render.sampler == SamplerKind::Sobol {
            flags |= F_SOBOL;
        }
        // As Shot::frame_times: a zero readout is a global shutter, a zero shutter ignores
        // the curve.
        if let Some(r) = times.rolling.filter(|r| r.readout > 0.0) {
            flags |= F_ROLLING;
            if r.direction == ReadoutDirection::BottomToTop {
                flags |= F_BOTTOM_TO_TOP;
            }
            w.set_f(H_READOUT, r.readout);
        }
        if let Some(table) = times.curve.table().filter(|_| times.shutter > 0.0) {
            let knots: Vec<(f64, f64, f64)> = table.knots().collect();
            w.set(H_CURVE, w.at());
            w.set(H_CURVE_N, knots.len() as u32);
            knots.iter().for_each(|k| w.f(k.0));
            knots.iter().for_each(|k| w.f(k.1));
            knots.iter().for_each(|k| w.f(k.2));
        }
        if let Background::Uniform(c) = scene.background {
            flags |= F_UNIFORM;
            for (i, x) in c.to_array().into_iter().enumerate() {
                w.set_f(H_BACKGROUND + i as u32, x);
            }
        }
        if scene.transparent {
            flags |= F_TRANSPARENT;
        }
        w.set_f(H_PERIOD, period);
        w.set(H_STRIDE, layout.stride as u32);
        let s = layout.slots();
        for (i, slot) in [s.hits, s.depth, s.normal, s.albedo, s.motion, None]
            .into_iter()
            .enumerate()
        {
            w.set(H_SLOTS + i as u32, slot.map_or(NONE, |x| x as u32));
        }
        // The camera: its view at the opening when it does not move during the frame (as
        // the CPU tracer), else its motion, to make a view per sample.
        let cam = &scene.camera;
        let camera_moves = cam.moves_in(interval);
        let view = cam.view_at(open, width, height);
        let (vectors, lens_radius) = view.vectors();
        for (i, v) in vectors.iter().enumerate() {
            for a in 0..3 {
                w.set_f(H_VIEW + 3 * i as u32 + a, v[a as usize]);
            }
        }
        w.set_f(H_VIEW + 18, lens_radius);
        if camera_moves {
            flags |= F_CAMERA_MOVES;
        }
        if view.has_lens() {
            flags |= F_LENS;
        }
        if cam.look_from.is_animated() || cam.look_at.is_animated() {
            flags |= F_CAMERA_ANIMATED;
        }
        let from = motion(&mut w, &cam.look_from.prepare(widened), widened.open, open);
        let at = motion(&mut w, &cam.look_at.prepare(widened), widened.open, open);
        w.set(H_CAM_FROM, from);
        w.set(H_CAM_AT, at);
        for a in 0..3 {
            w.set_f(H_CAM_UP + a, cam.up[a as usize]);
        }
        w.set_f(H_CAM_TAN, (cam.vfov.to_radians() / 2.0).tan());
        w.set_f(H_CAM_LENS, cam.aperture / 2.0);
        if let Some(f) = cam.focus_distance {
            flags |= F_FOCUS;
            w.set_f(H_CAM_FOCUS, f);
        }
        // The shot's buffer.
        w.set(H_STILL_SPHERES, shot.spheres);
        w.set(H_STILL_ENTRIES, shot.hierarchy.entries);
        w.set(H_STILL_ENTRY_N, shot.hierarchy.count);
        w.set(H_MATERIALS, shot.materials);
        w.set(H_TABLES, shot.tables);
        // The animated spheres, prepared for the frame's interval, and their hierarchy.
        let prepared: Vec<_> = shot
            .animated
            .iter()
            .map(|&i| scene.spheres[i as usize].prepare(interval))
            .collect();
        let (open_boxes, close_boxes): (Vec<Aabb>, Vec<Aabb>) =
            prepared.iter().map(|p| p.shutter_boxes(interval)).unzip();
        let bvh = Bvh::build_moving(&open_boxes, &close_boxes);
        drop((open_boxes, close_boxes));
        let mut moving = 0;
        let mut curved = Vec::new();
        w.align();
        let spheres = w.at();
        for &k in bvh.order() {
            let id = shot.animated[k as usize];
            let p = &prepared[k as usize];
            let material = scene.spheres[id as usize].material;
            let (c, v) = match &p.motion {
                FrameMotion::Fixed(c) => (*c, DVec3::ZERO),
                FrameMotion::Linear {
                    start, velocity, ..
                } => (*start, *velocity),
                _ => {
                    // Its record comes after the spheres: its place is set then.
                    curved.push((w.at() + S_MOTION, k));
                    (DVec3::ZERO, DVec3::ZERO)
                }
            };
            if p.motion.is_moving() {
                moving += 1;
            }
            sphere(&mut w, c, v, p.radius, material, id, NONE);
        }
        let eye = cam.look_from.at(open).as_vec3().to_array();
        let hierarchy = flatten(bvh.view(), eye, &mut w);
        for (slot, k) in curved {
            let record = motion(&mut w, &prepared[k as usize].motion, open, open);
            w.set(slot, record);
        }
        w.set(H_MOVING_SPHERES, spheres);
        w.set(H_MOVING_ENTRIES, hierarchy.entries);
        w.set(H_MOVING_ENTRY_N, hierarchy.count);
        // The motion pass: every animated sphere's path over the widened interval, by its
        // index in the scene.
        w.set(H_PASS_MOTIONS, NONE);
        if s.motion.is_some() {
            let index = w.at();
            w.set(H_PASS_MOTIONS, index);
            w.pad_to(index, scene.spheres.len() as u32);
            for i in index..w.at() {
                w.set(i, NONE);
            }
            for &id in &shot.animated {
                let path: &Motion = &scene.spheres[id as usize].motion;
                if !path.is_animated() {
                    continue;
                }
                let record = motion(&mut w, &path.prepare(widened), widened.open, open);
                w.set(index + id, record);
            }
        }
        if moving > 0 || camera_moves {
            flags |= F_TIME;
        }
        w.set(H_FLAGS, flags);
        Ok(FrameWords { words: w, moving })
    }
}
