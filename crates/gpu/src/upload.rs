//! A shot and a frame in the GPU's words ([`super::layout`]): a serialisation of what the
//! CPU prepared, deciding nothing of its own. A shot's words ([`ShotWords`]) hold what never
//! changes: the materials, the Sobol tables, and the shot's [`StaticGeometry`] (the spheres
//! that never move, in their hierarchy's leaf order, and that hierarchy flattened,
//! [`super::flatten`]). A frame's words ([`FrameWords`]) hold its [`PreparedFrame`]: its header
//! (size, depth, the sampler's key, the camera's and the shutter's settings), the shutter
//! curve, the camera's motion, and its world's animated spheres prepared for its interval
//! with their hierarchy and curved paths, and its points (of its point caches) prepared for
//! its interval, with their groups' hierarchies and their looks. Which spheres are still is
//! the world's rule ([`raytrace_core::world::one_hierarchy`]).
//! Times on the GPU are `f32` seconds since the frame's opening, so a late frame keeps its
//! digits as on the CPU.

use glam::DVec3;
use sobol_burley::parts::sobol_int4_rev;

use super::flatten::{Flat, flatten};
use super::layout::*;
use raytrace_core::material::{Background, Material};
use raytrace_core::motion::{FrameMotion, Motion};
use raytrace_core::passes::SumLayout;
use raytrace_core::prepared::PreparedFrame;
use raytrace_core::rng::hash_words;
use raytrace_core::sampler::SamplerKind;
use raytrace_core::scene::Scene;
use raytrace_core::shutter::{Interval, ReadoutDirection};
use raytrace_core::world::{StaticGeometry, TracedSphere};

/// What a shot keeps on the GPU for all its frames.
#[derive(Clone, Debug)]
pub(super) struct ShotWords {
    pub(super) words: Words,
    materials: u32,
    tables: u32,
    spheres: u32,
    hierarchy: Flat,
}

/// One frame's words.
#[derive(Clone, Debug)]
pub(super) struct FrameWords {
    pub(super) words: Words,
}

impl ShotWords {
    /// The words of `scene`'s shot: its materials, the Sobol tables, and `statics` (built for
    /// `scene`): its spheres that never move with their hierarchy.
    pub(super) fn new(scene: &Scene, statics: &StaticGeometry) -> ShotWords {
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
        let (still, hierarchy) = statics.still_spheres();
        w.align();
        let spheres = w.at();
        for s in still {
            sphere(&mut w, &s, NONE);
        }
        let eye = scene.camera.look_from.at(0.0).as_vec3().to_array();
        let hierarchy = flatten(hierarchy, eye, &mut w);
        ShotWords {
            words: w,
            materials,
            tables,
            spheres,
            hierarchy,
        }
    }

    /// Writes to a frame's header where the shot's words hold its still spheres, their
    /// hierarchy, the materials and the Sobol tables.
    fn locate(&self, w: &mut Words) {
        w.set(H_STILL_SPHERES, self.spheres);
        w.set(H_STILL_ENTRIES, self.hierarchy.entries);
        w.set(H_STILL_ENTRY_N, self.hierarchy.count);
        w.set(H_MATERIALS, self.materials);
        w.set(H_TABLES, self.tables);
    }
}

/// Appends the record of sphere `s` (at a multiple of four words when the last record ends
/// there), with its motion record at `motion` ([`NONE`]: its centre plus its velocity times
/// the time).
fn sphere(w: &mut Words, s: &TracedSphere, motion: u32) {
    let start = w.at();
    debug_assert_eq!(start % 4, 0);
    w.v(s.center);
    w.f(s.radius);
    w.v(s.velocity);
    w.u(s.material);
    w.u(s.id);
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

impl FrameWords {
    /// The words of the frame `prepared`, with `shot` (its shot's words) already on the GPU,
    /// for a film kept by `layout`.
    pub(super) fn new(
        prepared: &PreparedFrame,
        shot: &ShotWords,
        layout: &SumLayout,
    ) -> FrameWords {
        let scene = prepared.scene;
        let interval = prepared.interval();
        let period = 1.0 / scene.shot.fps;
        // The camera and the motion pass look one frame period beyond the exposure.
        let widened = Interval {
            open: interval.open - period,
            close: interval.close + period,
        };
        let mut w = Words::default();
        w.pad_to(0, HEADER_WORDS);
        let mut flags = frame_settings(&mut w, prepared);
        w.set_f(H_PERIOD, period);
        w.set(H_STRIDE, layout.stride as u32);
        let s = layout.slots();
        for (i, slot) in [s.hits, s.depth, s.normal, s.albedo, s.motion]
            .into_iter()
            .enumerate()
        {
            w.set(H_SLOTS + i as u32, slot.map_or(NONE, |x| x as u32));
        }
        flags |= camera(&mut w, prepared, widened);
        shot.locate(&mut w);
        animated_spheres(&mut w, prepared);
        points(&mut w, prepared);
        w.set(H_PASS_MOTIONS, NONE);
        if s.motion.is_some() {
            motion_pass(&mut w, prepared, widened);
        }
        w.set(H_FLAGS, flags);
        FrameWords { words: w }
    }
}

/// Writes the frame `prepared`'s size, depth, sampler, shutter and background to the header
/// (a shutter curve's knots appended); returns their flags.
fn frame_settings(w: &mut Words, prepared: &PreparedFrame) -> u32 {
    let scene = prepared.scene;
    let times = &prepared.times;
    w.set(H_WIDTH, scene.output.width);
    w.set(H_HEIGHT, scene.output.height);
    w.set(H_MAX_DEPTH, scene.render.max_depth);
    // The GPU's samplers start their hashes from the CPU samplers' key hashed once more
    // (the CPU's `hash_words(&[key, pixel, index])` begins by mixing it).
    let key = hash_words(&[prepared.key]);
    w.set(H_KEY, key as u32);
    w.set(H_KEY + 1, (key >> 32) as u32);
    w.set_f(H_DURATION, prepared.interval().duration());
    w.set_f(H_SHUTTER, times.shutter());
    let mut flags = 0;
    if prepared.sampler == SamplerKind::Sobol {
        flags |= F_SOBOL;
    }
    if let Some((readout, direction)) = times.rolling() {
        flags |= F_ROLLING;
        if direction == ReadoutDirection::BottomToTop {
            flags |= F_BOTTOM_TO_TOP;
        }
        w.set_f(H_READOUT, readout);
    }
    if let Some(table) = times.curve() {
        let knots: Vec<(f64, f64, f64)> = table.knots().collect();
        w.set(H_CURVE, w.at());
        w.set(H_CURVE_N, knots.len() as u32);
        knots.iter().for_each(|k| w.f(k.0));
        knots.iter().for_each(|k| w.f(k.1));
        knots.iter().for_each(|k| w.f(k.2));
    }
    if let Background::Uniform(c) = prepared.world.background {
        flags |= F_UNIFORM;
        for (i, x) in c.to_array().into_iter().enumerate() {
            w.set_f(H_BACKGROUND + i as u32, x);
        }
    }
    if scene.transparent {
        flags |= F_TRANSPARENT;
    }
    flags
}

/// Writes the camera of the frame `prepared` to the header: its view at the opening, which
/// every sample takes when it does not move during the frame (as the CPU tracer), else its
/// motion over `widened` (the records appended), to make a view per sample, and its lens;
/// returns its flags.
fn camera(w: &mut Words, prepared: &PreparedFrame, widened: Interval) -> u32 {
    let cam = &prepared.scene.camera;
    let open = prepared.interval().open;
    let (vectors, lens_radius) = prepared.fixed_view.vectors();
    for (i, v) in vectors.iter().enumerate() {
        for a in 0..3 {
            w.set_f(H_VIEW + 3 * i as u32 + a, v[a as usize]);
        }
    }
    w.set_f(H_VIEW + 18, lens_radius);
    let mut flags = 0;
    if prepared.camera_moves {
        flags |= F_CAMERA_MOVES;
    }
    if prepared.has_lens {
        flags |= F_LENS;
    }
    if prepared.sample_time {
        flags |= F_TIME;
    }
    if cam.look_from.is_animated() || cam.look_at.is_animated() {
        flags |= F_CAMERA_ANIMATED;
    }
    let from = motion(w, &cam.look_from.prepare(widened), widened.open, open);
    let at = motion(w, &cam.look_at.prepare(widened), widened.open, open);
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
    flags
}

/// The camera's position at the shutter's opening of the frame `prepared`: where the
/// flattened hierarchies put the nearest children first (`flatten`).
fn eye_at_opening(prepared: &PreparedFrame) -> [f32; 3] {
    let open = prepared.interval().open;
    prepared
        .scene
        .camera
        .look_from
        .at(open)
        .as_vec3()
        .to_array()
}

/// Appends the world's animated spheres, prepared for the frame `prepared`'s interval, and
/// their hierarchy, each curved path's record after them, and writes where they are to the
/// header.
fn animated_spheres(w: &mut Words, prepared: &PreparedFrame) {
    let open = prepared.interval().open;
    let (animated, hierarchy) = prepared.world.animated_spheres();
    let mut curved = Vec::new();
    w.align();
    let spheres = w.at();
    for s in animated {
        if let Some(path) = s.path {
            // Its record comes after the spheres: its place is set then.
            curved.push((w.at() + S_MOTION, path));
        }
        sphere(w, &s, NONE);
    }
    let eye = eye_at_opening(prepared);
    let hierarchy = flatten(hierarchy, eye, w);
    for (slot, path) in curved {
        let record = motion(w, path, open, open);
        w.set(slot, record);
    }
    w.set(H_MOVING_SPHERES, spheres);
    w.set(H_MOVING_ENTRIES, hierarchy.entries);
    w.set(H_MOVING_ENTRY_N, hierarchy.count);
}

/// Appends the frame `prepared`'s points (of its point caches), prepared for its interval:
/// every group's records in its hierarchy's leaf order, one group after another, then each
/// group's hierarchy and its entry in the groups' list, then the looks the records name (one
/// a material for points without colours, one a point with a colour); and writes where they
/// are to the header. A point is numbered on the GPU by its place among the records, after
/// the scene's spheres ([`H_FIRST_POINT`]).
fn points(w: &mut Words, prepared: &PreparedFrame) {
    let world = &prepared.world;
    // Looks of points without colours, by material; then every look's words.
    let mut plain: Vec<Option<u32>> = vec![None; prepared.scene.materials.len()];
    let mut looks: Vec<([f32; 3], u32)> = Vec::new();
    w.align();
    let records = w.at();
    let mut views = Vec::new();
    for (group, view) in world.point_groups() {
        views.push((w.at(), view));
        for p in group {
            let start = w.at();
            let (material, color) = world.point_look(p.id);
            let look = match color {
                Some(c) => {
                    looks.push((c, material));
                    looks.len() as u32 - 1
                }
                None => *plain[material as usize].get_or_insert_with(|| {
                    looks.push(([1.0; 3], material));
                    looks.len() as u32 - 1
                }),
            };
            w.v(p.center);
            w.f(p.radius);
            debug_assert_eq!(w.at() - start, PT_VELOCITY);
            w.v(p.velocity);
            debug_assert_eq!(w.at() - start, PT_LOOK);
            w.u(look);
            w.pad_to(start, POINT_WORDS);
        }
    }
    let eye = eye_at_opening(prepared);
    let flats: Vec<(u32, Flat)> = views
        .into_iter()
        .map(|(first, view)| (first, flatten(view, eye, w)))
        .collect();
    w.align();
    let groups = w.at();
    for (first, flat) in &flats {
        let start = w.at();
        w.pad_to(start, POINT_GROUP_WORDS);
        w.set(start + G_ENTRIES, flat.entries);
        w.set(start + G_ENTRY_N, flat.count);
        w.set(start + G_POINTS, *first);
    }
    let at = w.at();
    for (color, material) in looks {
        let start = w.at();
        color.iter().for_each(|&c| w.f(c.into()));
        debug_assert_eq!(w.at() - start, L_MATERIAL);
        w.u(material);
        w.pad_to(start, LOOK_WORDS);
    }
    w.set(H_POINTS, records);
    w.set(H_POINT_GROUPS, groups);
    w.set(H_POINT_GROUP_N, flats.len() as u32);
    w.set(H_FIRST_POINT, prepared.scene.spheres.len() as u32);
    w.set(H_LOOKS, at);
}

/// Appends the motion pass's paths: every animated sphere's over `widened`, by its index in
/// the scene (others [`NONE`]), and writes where they are to the header.
fn motion_pass(w: &mut Words, prepared: &PreparedFrame, widened: Interval) {
    let scene = prepared.scene;
    let open = prepared.interval().open;
    let index = w.at();
    w.set(H_PASS_MOTIONS, index);
    w.pad_to(index, scene.spheres.len() as u32);
    for i in index..w.at() {
        w.set(i, NONE);
    }
    for (id, sphere) in scene.spheres.iter().enumerate() {
        let path: &Motion = &sphere.motion;
        if !path.is_animated() {
            continue;
        }
        let record = motion(w, &path.prepare(widened), widened.open, open);
        w.set(index + id as u32, record);
    }
}
