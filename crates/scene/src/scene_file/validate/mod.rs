//! The one validator: from the file's raw values (with command-line [`Overrides`] written into
//! them first) to a [`Scene`]. Every method checks one kind of value and names the field (or
//! the flag that gave it) on failure: `sphere[12].radius must be > 0, got -1`. The camera's
//! checks, solved exactly between keyframes, are in [`camera`].

mod camera;
mod points;

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use glam::DVec3;

use super::overrides::Overrides;
use super::report;
use super::schema::{
    MaterialRef, Named, Number, RawCamera, RawCurve, RawMaterial, RawOutput, RawPass,
    RawReadoutDirection, RawSampler, RawScene, RawShot, RawShutterPosition, RawSphere, V3,
};
use raytrace_core::camera::{
    CameraRig, DEGENERATE_UP, DEGENERATE_VIEW, TINY, most_parallel_on_segment, robust_length,
    shortest_on_segment,
};
use raytrace_core::format::{CLIP_FORMATS, FRAME_FORMATS, Format};
use raytrace_core::material::{Background, Material};
use raytrace_core::motion::{Key, Motion, Orbit};
use raytrace_core::pass::{Pass, PassSet};
use raytrace_core::path_pattern::{self, FramePattern};
use raytrace_core::sampler::SamplerKind;
use raytrace_core::scene::{
    Carry, DenoiseSettings, MAX_SIDE, OutputSettings, RenderSettings, Scene,
};
use raytrace_core::show::{show, show_approx};
use raytrace_core::shutter::{
    ReadoutDirection, RollingShutter, Shot, ShutterCurve, ShutterPosition, shutter_from_angle,
};
use raytrace_core::sphere::SphereDesc;

/// Largest integer a float field may stand for in an integer field: floats hold every
/// integer exactly up to 2^53, and no larger one is likely to be meant exactly.
const EXACT_INTEGERS: f64 = 9_007_199_254_740_992.0;

/// Largest albedo component. A surface reflects at most the light it receives, so every path's
/// throughput stays at most 1 (glass attenuates by 1) and no pixel can exceed the brightest
/// light; an albedo above 1 would multiply a path by up to albedo^max_depth (3e38 twice
/// overflowed 32-bit frames to infinity).
pub(super) const MAX_ALBEDO: f64 = 1.0;

/// Largest background radiance component: with throughput at most 1 no sample exceeds it, and
/// sums of squares over 2^32 samples (noise estimates) stay below 1e22, far inside 32-bit
/// range. A million times a white sky is brighter than any scene the format can light.
pub(super) const MAX_RADIANCE: f64 = 1e6;

/// A piece's validated spheres and their inline materials (see [`Validator::spheres`]).
pub(super) type Validated = (Vec<SphereDesc>, Vec<Material>);

/// Marks, in [`Validator::spheres`]' output, a material index into that call's inline materials.
const INLINE: u32 = 1 << 31;

/// Appends validated spheres to `scene`, with their inline materials after its others.
pub(super) fn add_spheres(scene: &mut Scene, mut spheres: Vec<SphereDesc>, inline: Vec<Material>) {
    let base = scene.materials.len() as u32;
    for s in &mut spheres {
        if s.material & INLINE != 0 {
            s.material = base + (s.material & !INLINE);
        }
    }
    scene.materials.extend(inline);
    if scene.spheres.is_empty() {
        scene.spheres = spheres;
    } else {
        scene.spheres.extend(spheres);
    }
}

/// The validator of one file, with the overrides applied to it.
pub(super) struct Validator<'a> {
    file: &'a str,
    overrides: &'a Overrides,
}

/// The fields the command line can override, and the flag that does.
const FLAGS: [(&str, &str); 12] = [
    ("output.path", "--output"),
    ("output.width", "--width"),
    ("output.height", "--height"),
    ("render.samples", "--samples"),
    ("render.seed", "--seed"),
    ("render.sampler", "--sampler"),
    ("output.clip", "--clip"),
    ("output.passes", "--passes"),
    ("output.denoise", "--denoise"),
    ("render.device", "--device"),
    ("output.denoise_quality", "--denoise-quality"),
    ("output.temporal", "--temporal"),
];

impl<'a> Validator<'a> {
    pub(super) fn new(file: &'a str, overrides: &'a Overrides) -> Validator<'a> {
        Validator { file, overrides }
    }

    /// Writes the overrides into the file's raw values, to be validated with them.
    pub(super) fn apply(&self, raw: &mut RawScene) {
        let o = self.overrides;
        let int = |x: u64| Some(Number::Int(x.into()));
        if let Some(p) = &o.output {
            raw.output.path = Some(p.clone());
        }
        if let Some(w) = o.width {
            raw.output.width = int(w.into());
        }
        if let Some(h) = o.height {
            raw.output.height = int(h.into());
        }
        if let Some(n) = o.samples {
            raw.render.samples = int(n.into());
        }
        if let Some(seed) = o.seed {
            raw.render.seed = int(seed);
        }
        if let Some(c) = &o.clip {
            raw.output.clip = Some(c.clone());
        }
        if let Some(passes) = &o.passes {
            raw.output.passes = Some(passes.iter().map(|p| RawPass(*p)).collect());
        }
        if let Some(d) = o.denoise {
            raw.output.denoise = Some(d);
        }
        if let Some(d) = o.device {
            raw.render.device = Some(Named(d));
        }
        if let Some(q) = o.denoise_quality {
            raw.output.denoise_quality = Some(Named(q));
        }
        if let Some(k) = o.sampler {
            raw.render.sampler = Some(match k {
                SamplerKind::Independent => RawSampler::Independent,
                SamplerKind::Sobol => RawSampler::Sobol,
            });
        }
    }

    /// The name of `field` in messages: the flag that set it, if the command line did.
    fn name(&self, field: &str) -> String {
        let o = self.overrides;
        let set = [
            o.output.is_some(),
            o.width.is_some(),
            o.height.is_some(),
            o.samples.is_some(),
            o.seed.is_some(),
            o.sampler.is_some(),
            o.clip.is_some(),
            o.passes.is_some(),
            o.denoise.is_some(),
            o.device.is_some(),
            o.denoise_quality.is_some(),
            o.temporal.is_some(),
        ];
        match FLAGS
            .iter()
            .zip(set)
            .find(|((f, _), set)| *set && *f == field)
        {
            Some(((_, flag), _)) => (*flag).to_string(),
            None => field.to_string(),
        }
    }

    /// A message about the file, or only about a flag when a flag gave the value. Quoted
    /// values are cut short and control characters escaped ([`report::clean`]).
    fn err<T>(&self, msg: impl fmt::Display) -> Result<T, String> {
        let msg = report::clean(&msg.to_string());
        if msg.starts_with("--") {
            Err(msg)
        } else {
            Err(format!("{}: {msg}", self.file))
        }
    }

    /// Any finite number that fits the single-precision range frames are stored in.
    fn num(&self, field: &str, x: f64) -> Result<f64, String> {
        if !x.is_finite() {
            return self.err(format_args!(
                "{field} must be a finite number, got {}",
                show(x)
            ));
        }
        if x.abs() > f32::MAX as f64 {
            return self.err(format_args!(
                "{field} is too large, got {} (overflows 32-bit floats, largest 3.4e38)",
                show(x)
            ));
        }
        Ok(x)
    }

    fn vec(&self, field: &str, v: V3) -> Result<DVec3, String> {
        let v = v.0;
        for (i, x) in v.iter().enumerate() {
            self.num(&format!("{field}[{i}]"), *x)?;
        }
        Ok(DVec3::from_array(v))
    }

    fn positive(&self, field: &str, x: f64) -> Result<f64, String> {
        let x = self.num(field, x)?;
        if x > 0.0 {
            Ok(x)
        } else {
            self.err(format_args!("{field} must be > 0, got {}", show(x)))
        }
    }

    /// `>= 0`; negative zero is rejected too (it usually means a sign error upstream).
    fn non_negative(&self, field: &str, x: f64) -> Result<f64, String> {
        let x = self.num(field, x)?;
        if x > 0.0 || (x == 0.0 && x.is_sign_positive()) {
            Ok(x)
        } else if x == 0.0 {
            self.err(format_args!("{field} must be >= 0, got -0 (negative zero)"))
        } else {
            self.err(format_args!("{field} must be >= 0, got {}", show(x)))
        }
    }

    /// A colour whose components are in [0, `max`].
    fn color(&self, field: &str, v: V3, max: f64) -> Result<DVec3, String> {
        let v = v.0;
        for (i, x) in v.iter().enumerate() {
            let field = format!("{field}[{i}]");
            if self.non_negative(&field, *x)? > max {
                return self.err(format_args!(
                    "{field} must be in [0, {}], got {}",
                    show(max),
                    show(*x)
                ));
            }
        }
        Ok(DVec3::from_array(v))
    }

    /// An integer field. A float written for it counts when it is a whole number that floats
    /// hold exactly (`2.0`); `2.5`, `nan`, `1e39` and `-0.0` are refused by name.
    fn int(
        &self,
        field: &str,
        x: Option<Number>,
        default: i64,
        min: i64,
        max: i64,
    ) -> Result<i64, String> {
        let field = self.name(field);
        let x: i128 = match x {
            None => default.into(),
            Some(Number::Int(x)) => x,
            Some(Number::Huge(x)) => {
                return self.err(format_args!("{field} must be in {min}..={max}, got {x}"));
            }
            Some(Number::Float(f)) => {
                if f == 0.0 && f.is_sign_negative() {
                    return self.err(format_args!(
                        "{field} must be an integer, got -0 (negative zero)"
                    ));
                }
                if f.fract() != 0.0 || f.abs() > EXACT_INTEGERS || !f.is_finite() {
                    return self.err(format_args!("{field} must be an integer, got {}", show(f)));
                }
                f as i128
            }
        };
        if x < min.into() || x > max.into() {
            return self.err(format_args!("{field} must be in {min}..={max}, got {x}"));
        }
        Ok(x as i64)
    }

    pub(super) fn scene(&self, raw: RawScene, source: &Path) -> Result<Scene, String> {
        let (mut scene, names) = self.scene_head(&raw, source)?;
        let (spheres, inline) = self.spheres(&raw.sphere, 0, &names)?;
        add_spheres(&mut scene, spheres, inline);
        Ok(scene)
    }

    /// Everything but the spheres, and the material names (indices into `materials`).
    pub(super) fn scene_head<'r>(
        &self,
        raw: &'r RawScene,
        source: &Path,
    ) -> Result<(Scene, BTreeMap<&'r str, u32>), String> {
        let shot = self.shot(&raw.shot)?;
        let output = self.output(&raw.output, source)?;
        let render = RenderSettings {
            samples: self.int("render.samples", raw.render.samples, 16, 1, u32::MAX as i64)? as u32,
            max_depth: self.int(
                "render.max_depth",
                raw.render.max_depth,
                50,
                1,
                u32::MAX as i64,
            )? as u32,
            seed: self.int("render.seed", raw.render.seed, 0, 0, i64::MAX)? as u64,
            sampler: match raw.render.sampler {
                None => SamplerKind::default(),
                Some(RawSampler::Independent) => SamplerKind::Independent,
                Some(RawSampler::Sobol) => SamplerKind::Sobol,
            },
            device: raw.render.device.map(|d| d.0).unwrap_or_default(),
        };
        let camera = self.camera(&raw.camera)?;
        let background = match raw.background.as_ref().and_then(|b| b.color) {
            None => Background::Sky,
            Some(c) => Background::Uniform(self.color("background.color", c, MAX_RADIANCE)?),
        };
        let transparent = raw
            .background
            .as_ref()
            .and_then(|b| b.transparent)
            .unwrap_or(false);
        let mut materials = Vec::new();
        let mut names = BTreeMap::new();
        for (name, m) in &raw.materials {
            materials.push(self.material(&format!("materials.{name}"), m)?);
            names.insert(name.as_str(), (materials.len() - 1) as u32);
        }
        let points = self.points(&raw.points, source, &names, &mut materials)?;
        let scene = Scene {
            source: source.to_path_buf(),
            shot,
            output,
            render,
            camera,
            background,
            transparent,
            materials,
            spheres: Vec::new(),
            points,
        };
        Ok((scene, names))
    }

    /// Validates spheres numbered from `first`. Inline materials are returned in sphere order;
    /// a sphere with one refers to it by `INLINE | its index in that list`.
    pub(super) fn spheres(
        &self,
        raw: &[RawSphere],
        first: usize,
        names: &BTreeMap<&str, u32>,
    ) -> Result<Validated, String> {
        let mut spheres = Vec::with_capacity(raw.len());
        let mut inline = Vec::new();
        for (i, s) in raw.iter().enumerate() {
            let field = format!("sphere[{}]", first + i);
            let material = match &s.material {
                MaterialRef::Name(n) => self.named_material(&field, n, names)?,
                MaterialRef::Inline(m) => {
                    inline.push(self.material(&format!("{field}.material"), m)?);
                    INLINE | (inline.len() - 1) as u32
                }
            };
            spheres.push(SphereDesc {
                radius: self.positive(&format!("{field}.radius"), s.radius.0)?,
                motion: self.sphere_motion(&field, s)?,
                material,
            });
        }
        Ok((spheres, inline))
    }

    /// The index of the material named `n` in `[materials]` (for `{field}.material`).
    fn named_material(
        &self,
        field: &str,
        n: &str,
        names: &BTreeMap<&str, u32>,
    ) -> Result<u32, String> {
        if let Some(&m) = names.get(n) {
            return Ok(m);
        }
        let mut known: Vec<&str> = names.keys().copied().take(10).collect();
        let more = format!("and {} more", names.len().saturating_sub(10));
        if names.len() > 10 {
            known.push(&more);
        }
        let known = if known.is_empty() {
            "none defined".to_string()
        } else {
            known.join(", ")
        };
        self.err(format_args!(
            "{field}.material \"{n}\" is not a material in [materials] (known: {known})"
        ))
    }

    fn shot(&self, s: &RawShot) -> Result<Shot, String> {
        let fps = self.positive("shot.fps", s.fps.map_or(24.0, |f| f.0))?;
        let frames = self.int("shot.frames", s.frames, 1, 1, u32::MAX as i64)?;
        let first_frame = self.int("shot.first_frame", s.first_frame, 1, 0, u32::MAX as i64)?;
        if first_frame + frames - 1 > u32::MAX as i64 {
            return self.err(format_args!(
                "shot.first_frame + shot.frames - 1 must be at most {}, got {}",
                u32::MAX,
                first_frame + frames - 1
            ));
        }
        let shutter = match (s.shutter, s.shutter_angle) {
            (Some(_), Some(_)) => {
                return self.err("shot: give at most one of shutter and shutter_angle");
            }
            (Some(x), None) => self.non_negative("shot.shutter", x.0)?,
            (None, a) => {
                let angle = self.non_negative("shot.shutter_angle", a.map_or(180.0, |a| a.0))?;
                let shutter = shutter_from_angle(angle, fps);
                // Only a tiny fps makes the shutter overflow: blame the keys written.
                if !shutter.is_finite() || shutter > f32::MAX as f64 {
                    let (field, x) = match s.fps {
                        Some(_) => ("shot.fps", fps),
                        None => ("shot.shutter_angle", angle),
                    };
                    return self.err(format_args!(
                        "{field} gives a shutter of {} s (shutter_angle {} / 360 / fps {}), more than 3.4e38; got {}",
                        show_approx(shutter),
                        show(angle),
                        show(fps),
                        show(x)
                    ));
                }
                shutter
            }
        };
        let position = match s.shutter_position.unwrap_or(RawShutterPosition::Center) {
            RawShutterPosition::Start => ShutterPosition::Start,
            RawShutterPosition::Center => ShutterPosition::Center,
            RawShutterPosition::End => ShutterPosition::End,
        };
        let shot = Shot {
            fps,
            frames: frames as u32,
            first_frame: first_frame as u32,
            start_time: self.num("shot.start_time", s.start_time.map_or(0.0, |t| t.0))?,
            shutter,
            position,
            // The points were checked as they were read (see `RawCurve`).
            curve: match &s.shutter_curve {
                None | Some(RawCurve::Box) => ShutterCurve::Box,
                Some(RawCurve::Triangle) => ShutterCurve::Triangle,
                Some(RawCurve::Points(p)) => ShutterCurve::Points(p.clone()),
            },
            rolling: match &s.rolling_shutter {
                None => None,
                Some(r) => Some(RollingShutter {
                    readout: self.non_negative("shot.rolling_shutter.readout", r.readout.0)?,
                    direction: match r.direction {
                        None | Some(RawReadoutDirection::TopToBottom) => {
                            ReadoutDirection::TopToBottom
                        }
                        Some(RawReadoutDirection::BottomToTop) => ReadoutDirection::BottomToTop,
                    },
                }),
            },
        };
        // A tiny fps over many frames can push the last frame's time out of range.
        let whole = shot.whole_interval();
        for t in [whole.open, whole.close] {
            if !t.is_finite() || t.abs() > f32::MAX as f64 {
                return self.err(format_args!(
                    "shot: the last frame's time ({} s) is out of range; check shot.fps and shot.frames",
                    show_approx(t)
                ));
            }
        }
        Ok(shot)
    }

    fn output(&self, o: &RawOutput, source: &Path) -> Result<OutputSettings, String> {
        let (path, format) = match &o.path {
            Some(p) if p.trim().is_empty() => {
                return self.err(format_args!(
                    "{} must not be empty",
                    self.name("output.path")
                ));
            }
            Some(p) => {
                let Some(format) = Format::from_extension(Path::new(p), FRAME_FORMATS) else {
                    return self.err(format_args!(
                        "{} \"{p}\": the file name must end in .exr or .png",
                        self.name("output.path")
                    ));
                };
                let path = FramePattern::new(path_pattern::with_scene(p, source)).or_else(|e| {
                    self.err(format_args!("{} \"{p}\": {e}", self.name("output.path")))
                })?;
                (path, format)
            }
            None => {
                let name = format!("{}_####.png", path_pattern::scene_name(source));
                let path = FramePattern::new(name).or_else(|e| {
                    self.err(format_args!(
                        "the scene file's name (output.path's default): {e}"
                    ))
                })?;
                (path, Format::Png)
            }
        };
        let clip = match &o.clip {
            None => None,
            Some(c) => {
                if Format::from_extension(Path::new(c), CLIP_FORMATS).is_none() {
                    return self.err(format_args!(
                        "{} \"{c}\": the file name must end in {}",
                        self.name("output.clip"),
                        Format::names(CLIP_FORMATS)
                    ));
                }
                Some(path_pattern::with_scene(c, source))
            }
        };
        let denoise = o.denoise.unwrap_or(false);
        let temporal = self.overrides.temporal.unwrap_or(false);
        if temporal && !denoise {
            return self.err(format_args!(
                "{} is off, and {} keeps a denoised sequence from flickering: turn denoising on (--denoise or [output] denoise = true), or leave {} out",
                self.name("output.denoise"),
                self.name("output.temporal"),
                self.name("output.temporal")
            ));
        }
        Ok(OutputSettings {
            clip,
            passes: self.passes(o.passes.as_deref().unwrap_or(&[]), format, denoise)?,
            denoise: denoise.then(|| DenoiseSettings {
                quality: o.denoise_quality.map(|q| q.0).unwrap_or_default(),
                temporal,
                carry: Carry::Nothing,
                device: self.overrides.denoise_device.unwrap_or_default(),
            }),
            path,
            format,
            width: self.int("output.width", o.width, 400, 1, MAX_SIDE.into())? as u32,
            height: self.int("output.height", o.height, 225, 1, MAX_SIDE.into())? as u32,
        })
    }

    /// The passes listed, each once, and each one the output's `format` can hold (a PNG output
    /// takes only `alpha`: [`Format::takes_channel`]); `noisy` only with `denoise`.
    fn passes(&self, list: &[RawPass], format: Format, denoise: bool) -> Result<PassSet, String> {
        let field = self.name("output.passes");
        let mut set = PassSet::EMPTY;
        for (i, RawPass(pass)) in list.iter().enumerate() {
            if set.contains(*pass) {
                return self.err(format_args!(
                    "{field}: \"{}\" is listed twice (entry {i}); list each pass once",
                    pass.name()
                ));
            }
            if !pass.channels().iter().all(|c| format.takes_channel(c)) {
                return self.err(format_args!(
                    "{field}: pass \"{}\" cannot be written to a PNG output ({} ends in .png), which takes only the alpha pass; write .exr frames for the other passes",
                    pass.name(),
                    self.name("output.path")
                ));
            }
            if *pass == Pass::Noisy && !denoise {
                return self.err(format_args!(
                    "{field}: pass \"noisy\" is the colour before denoising, and {} is off: turn it on, or leave \"noisy\" out (the colour is then the noisy image)",
                    self.name("output.denoise")
                ));
            }
            set = set.with(*pass);
        }
        Ok(set)
    }

    fn material(&self, field: &str, m: &RawMaterial) -> Result<Material, String> {
        Ok(match m {
            RawMaterial::Lambertian { albedo } => Material::Lambertian {
                albedo: self.color(&format!("{field}.albedo"), *albedo, MAX_ALBEDO)?,
            },
            RawMaterial::Metal { albedo, fuzz } => {
                let fuzz = self.non_negative(&format!("{field}.fuzz"), fuzz.0)?;
                if fuzz > 1.0 {
                    return self.err(format_args!(
                        "{field}.fuzz must be in [0, 1], got {}",
                        show(fuzz)
                    ));
                }
                Material::Metal {
                    albedo: self.color(&format!("{field}.albedo"), *albedo, MAX_ALBEDO)?,
                    fuzz,
                }
            }
            RawMaterial::Dielectric { ior } => Material::Dielectric {
                ior: self.positive(&format!("{field}.ior"), ior.0)?,
            },
        })
    }

    fn keys(&self, field: &str, times: impl Iterator<Item = f64>) -> Result<Vec<f64>, String> {
        let mut out: Vec<f64> = Vec::new();
        for (i, t) in times.enumerate() {
            let t = self.num(&format!("{field}[{i}].time"), t)?;
            if let Some(&prev) = out.last()
                && t <= prev
            {
                return self.err(format_args!(
                    "{field}[{i}].time must be greater than {field}[{}].time ({}), got {}",
                    i - 1,
                    show(prev),
                    show(t)
                ));
            }
            out.push(t);
        }
        if out.is_empty() {
            return self.err(format_args!("{field} must have at least one key"));
        }
        Ok(out)
    }

    fn sphere_motion(&self, field: &str, s: &RawSphere) -> Result<Motion, String> {
        let kinds = [
            s.velocity.is_some(),
            s.keyframes.is_some(),
            s.orbit.is_some(),
        ];
        if kinds.iter().filter(|k| **k).count() > 1 {
            return self.err(format_args!(
                "{field}: give at most one of velocity, keyframes and orbit"
            ));
        }
        if let Some(keys) = &s.keyframes {
            if s.center.is_some() {
                return self.err(format_args!(
                    "{field}: keyframes replace center; give one of them"
                ));
            }
            let kf = format!("{field}.keyframes");
            let times = self.keys(&kf, keys.iter().map(|k| k.time.0))?;
            let keys = keys
                .iter()
                .zip(times)
                .enumerate()
                .map(|(i, (k, time))| {
                    Ok(Key {
                        time,
                        position: self.vec(&format!("{kf}[{i}].center"), k.center)?,
                    })
                })
                .collect::<Result<Vec<_>, String>>()?;
            return Ok(Motion::Keyframes(keys));
        }
        let Some(center) = s.center else {
            return self.err(format_args!("{field}.center is required (or keyframes)"));
        };
        let origin = self.vec(&format!("{field}.center"), center)?;
        if let Some(v) = s.velocity {
            return Ok(Motion::Velocity {
                origin,
                velocity: self.vec(&format!("{field}.velocity"), v)?,
            });
        }
        if let Some(o) = &s.orbit {
            let orbit = self.orbit(
                &format!("{field}.orbit"),
                o.pivot,
                o.axis,
                o.degrees_per_second.0,
            )?;
            return Ok(Motion::Orbit { origin, orbit });
        }
        Ok(Motion::Still(origin))
    }

    fn orbit(&self, field: &str, pivot: V3, axis: V3, dps: f64) -> Result<Orbit, String> {
        let pivot = self.vec(&format!("{field}.pivot"), pivot)?;
        let axis = self.vec(&format!("{field}.axis"), axis)?;
        let degrees_per_second = self.num(&format!("{field}.degrees_per_second"), dps)?;
        let len = robust_length(axis);
        if !(len > 0.0 && len.is_finite()) {
            return self.err(format_args!("{field}.axis must be a non-zero vector"));
        }
        Ok(Orbit {
            pivot,
            axis: axis / len,
            degrees_per_second,
        })
    }
}
