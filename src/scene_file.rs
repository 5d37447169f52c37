//! The scene file: TOML parsed into typed structs (unknown keys rejected), then validated into
//! a [`Scene`]. Syntax and type errors carry the file and line:column; value errors carry the
//! file and the field path (`sphere[12].radius must be > 0, got -1`).

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use glam::DVec3;
use serde::Deserialize;
use serde::de::{self, MapAccess, Visitor};

use crate::camera::CameraRig;
use crate::error::Error;
use crate::material::{Background, Material};
use crate::motion::{Key, Motion, Orbit};
use crate::sampler::SamplerKind;
use crate::scene::{OutputSettings, RenderSettings, Scene};
use crate::shutter::{Shot, ShutterPosition, shutter_from_angle};
use crate::sphere::SphereDesc;

/// Largest image side.
pub const MAX_SIDE: i64 = 65536;

type V3 = [f64; 3];

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawScene {
    #[serde(default)]
    shot: RawShot,
    #[serde(default)]
    output: RawOutput,
    #[serde(default)]
    render: RawRender,
    #[serde(default)]
    camera: RawCamera,
    background: Option<RawBackground>,
    #[serde(default)]
    materials: BTreeMap<String, RawMaterial>,
    #[serde(default)]
    sphere: Vec<RawSphere>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawShot {
    fps: Option<f64>,
    frames: Option<Number>,
    first_frame: Option<Number>,
    start_time: Option<f64>,
    shutter: Option<f64>,
    shutter_angle: Option<f64>,
    shutter_position: Option<RawShutterPosition>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RawShutterPosition {
    Start,
    Center,
    End,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawOutput {
    path: Option<String>,
    width: Option<Number>,
    height: Option<Number>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawRender {
    samples: Option<Number>,
    max_depth: Option<Number>,
    seed: Option<Number>,
    sampler: Option<RawSampler>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RawSampler {
    Independent,
    Sobol,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    look_from: Option<V3>,
    look_at: Option<V3>,
    up: Option<V3>,
    vfov: Option<f64>,
    aperture: Option<f64>,
    focus_distance: Option<f64>,
    orbit: Option<RawCameraOrbit>,
    keyframes: Option<Vec<RawCameraKey>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCameraOrbit {
    degrees_per_second: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCameraKey {
    time: f64,
    look_from: Option<V3>,
    look_at: Option<V3>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBackground {
    color: V3,
}

#[derive(Deserialize, Clone)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum RawMaterial {
    Lambertian {
        albedo: V3,
    },
    Metal {
        albedo: V3,
        #[serde(default)]
        fuzz: f64,
    },
    Dielectric {
        ior: f64,
    },
}

/// A number as written in the file, so that a float where an integer belongs can be reported
/// with its field's name.
#[derive(Clone, Copy, Debug)]
enum Number {
    Int(i64),
    Float(f64),
}

impl<'de> Deserialize<'de> for Number {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Number;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an integer")
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<Number, E> {
                Ok(Number::Int(x))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<Number, E> {
                Ok(i64::try_from(x).map_or(Number::Float(x as f64), Number::Int))
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<Number, E> {
                Ok(Number::Float(x))
            }
        }
        d.deserialize_any(V)
    }
}

/// A sphere's material: a name from `[materials]` or an inline table.
enum MaterialRef {
    Name(String),
    Inline(RawMaterial),
}

impl<'de> Deserialize<'de> for MaterialRef {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = MaterialRef;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a material name or an inline material table")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<MaterialRef, E> {
                Ok(MaterialRef::Name(s.to_string()))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<MaterialRef, A::Error> {
                RawMaterial::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(MaterialRef::Inline)
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSphere {
    center: Option<V3>,
    radius: f64,
    material: MaterialRef,
    velocity: Option<V3>,
    keyframes: Option<Vec<RawSphereKey>>,
    orbit: Option<RawOrbit>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSphereKey {
    time: f64,
    center: V3,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOrbit {
    pivot: V3,
    axis: V3,
    degrees_per_second: f64,
}

/// Files at least this large are parsed in pieces, in parallel (when their layout allows).
const PIECES_FROM_BYTES: usize = 1 << 20;
/// Spheres per piece.
const PIECE_SPHERES: usize = 4096;

/// Parses and validates scene text; `source` names the file in messages.
///
/// A large file is cut at its `[[sphere]]` headers into pieces parsed and validated in
/// parallel, so the whole document is never held as a TOML tree (a million spheres would take
/// gigabytes): see [`parse_in_pieces`]. Messages are the same either way.
pub fn parse(text: &str, source: &Path) -> Result<Scene, Error> {
    if text.len() >= PIECES_FROM_BYTES
        && let Some(result) = parse_in_pieces(text, source, PIECE_SPHERES)
    {
        return result;
    }
    parse_whole(text, source)
}

/// Parses the whole document at once.
fn parse_whole(text: &str, source: &Path) -> Result<Scene, Error> {
    let file = source.display().to_string();
    let raw: RawScene = toml::from_str(text).map_err(|e| {
        let (line, col) = e.span().map_or((1, 1), |s| line_col(text, s.start));
        Error::Scene(format!("{file}:{line}:{col}: {}", e.message().trim_end()))
    })?;
    Check { file: &file }
        .scene(raw, source)
        .map_err(Error::Scene)
}

/// What a top-level table header opens.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Section {
    /// Anything but the spheres (and the text before the first header).
    Other,
    /// `[[sphere]]`: the next sphere.
    Sphere,
    /// A header under `sphere` (`[sphere.orbit]`, `[[sphere.keyframes]]`): part of the last
    /// sphere.
    SphereSub,
}

/// Where each top-level section starts (the offset of its header's `[`) and what it is, found
/// with the TOML lexer, so brackets inside strings (even multi-line ones), comments and
/// multi-line arrays are never taken for headers. `None` when the layout is unusual (quoted
/// header keys, unbalanced brackets): the caller then parses the document whole.
fn sections(text: &str) -> Option<Vec<(usize, Section)>> {
    use toml_parser::lexer::TokenKind as K;
    let mut out = vec![(0, Section::Other)];
    let mut lexer = toml_parser::Source::new(text).lex();
    // Nesting of arrays and inline tables in a value; headers only occur outside values, at
    // the start of a line.
    let mut depth = 0usize;
    let mut line_start = true;
    let mut in_value = false;
    // Before the first header, where a `sphere` key would clash with `[[sphere]]`.
    let mut root = true;
    while let Some(tok) = lexer.next() {
        if root && depth == 0 && line_start && !in_value {
            let key = &text[tok.span().start()..tok.span().end()];
            let quoted = matches!(tok.kind(), K::BasicString | K::LiteralString);
            if quoted || (tok.kind() == K::Atom && key == "sphere") {
                return None;
            }
        }
        match tok.kind() {
            K::Whitespace | K::Comment => {}
            K::Newline => {
                if depth == 0 {
                    line_start = true;
                    in_value = false;
                }
            }
            K::LeftSquareBracket if depth == 0 && line_start && !in_value => {
                let start = tok.span().start();
                let mut next = || lexer.next();
                let mut t = next()?;
                let array = t.kind() == K::LeftSquareBracket && t.span().start() == start + 1;
                if array {
                    t = next()?;
                }
                while t.kind() == K::Whitespace {
                    t = next()?;
                }
                if t.kind() != K::Atom {
                    return None;
                }
                let first = &text[t.span().start()..t.span().end()];
                let mut single_key = true;
                loop {
                    t = next()?;
                    match t.kind() {
                        K::RightSquareBracket => break,
                        K::Whitespace => {}
                        K::Dot | K::Atom => single_key = false,
                        _ => return None,
                    }
                }
                if array && next()?.kind() != K::RightSquareBracket {
                    return None;
                }
                let kind = match (first, array && single_key) {
                    ("sphere", true) => Section::Sphere,
                    ("sphere", false) => Section::SphereSub,
                    _ => Section::Other,
                };
                out.push((start, kind));
                line_start = false;
                root = false;
            }
            K::LeftSquareBracket | K::LeftCurlyBracket => {
                depth += 1;
                line_start = false;
            }
            K::RightSquareBracket | K::RightCurlyBracket => {
                depth = depth.checked_sub(1)?;
                line_start = false;
            }
            K::Equals => {
                if depth == 0 {
                    in_value = true;
                }
                line_start = false;
            }
            K::Eof => break,
            _ => line_start = false,
        }
    }
    (depth == 0).then_some(out)
}

/// The spheres of one piece.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpheres {
    #[serde(default)]
    sphere: Vec<RawSphere>,
}

/// A piece's validated spheres and their inline materials (see [`Check::spheres`]).
type Validated = (Vec<SphereDesc>, Vec<Material>);

/// What went wrong in a piece.
enum PieceError {
    /// Syntax or type, at this offset of the whole text.
    Syntax(usize, String),
    /// A value, with its message.
    Value(String),
}

/// Parses `text` cut into pieces of about `per_piece` spheres: every run of `[[sphere]]`
/// sections (with their sub-tables) becomes pieces parsed and validated in parallel, and the
/// rest (settings, materials) is parsed as one document. Byte offsets in pieces are mapped
/// back to the whole text, so errors carry the same line:column as a whole parse, and sphere
/// indices count from the file's first sphere. The first syntax error in the file wins, then
/// settings errors, then the first sphere's error, as for a whole parse. `None` when the
/// layout is unusual (see [`sections`]) or the rest also defines `sphere`.
fn parse_in_pieces(text: &str, source: &Path, per_piece: usize) -> Option<Result<Scene, Error>> {
    use rayon::prelude::*;
    let sections = sections(text)?;
    // Pieces: (start, end, index of the first sphere); the rest: (start, end) ranges.
    let mut pieces: Vec<(usize, usize, usize)> = Vec::new();
    let mut rest: Vec<(usize, usize)> = Vec::new();
    let mut spheres = 0usize;
    let mut in_piece = 0usize; // spheres in the last piece, if it is open
    let mut open = false;
    for (i, &(start, kind)) in sections.iter().enumerate() {
        let end = sections.get(i + 1).map_or(text.len(), |s| s.0);
        match kind {
            Section::Other => {
                open = false;
                rest.push((start, end));
            }
            Section::Sphere => {
                if open && in_piece < per_piece {
                    pieces.last_mut()?.1 = end;
                    in_piece += 1;
                } else {
                    pieces.push((start, end, spheres));
                    in_piece = 1;
                    open = true;
                }
                spheres += 1;
            }
            // A sub-table right after its sphere; anywhere else the whole parse decides.
            Section::SphereSub if open => pieces.last_mut()?.1 = end,
            Section::SphereSub => return None,
        }
    }
    let file = source.display().to_string();
    let check = Check { file: &file };
    let syntax = |offset: usize, e: &toml::de::Error| {
        (
            offset + e.span().map_or(0, |s| s.start),
            e.message().trim_end().to_string(),
        )
    };
    // The rest as one document, with a map from its offsets back to the text's.
    let mut rest_text = String::new();
    let mut rest_map: Vec<(usize, usize)> = Vec::new();
    for &(a, b) in &rest {
        rest_map.push((rest_text.len(), a));
        rest_text.push_str(&text[a..b]);
    }
    let to_text = |off: usize| {
        let i = rest_map.partition_point(|m| m.0 <= off).max(1) - 1;
        rest_map.get(i).map_or(off, |&(r, t)| t + (off - r))
    };
    let head: Result<RawScene, (usize, String)> = toml::from_str(&rest_text).map_err(|e| {
        let (off, msg) = syntax(0, &e);
        (to_text(off), msg)
    });
    if let Ok(raw) = &head
        && !raw.sphere.is_empty()
        && !pieces.is_empty()
    {
        return None;
    }
    let checked_head = head.as_ref().ok().map(|raw| check.scene_head(raw, source));
    let names = match &checked_head {
        Some(Ok((_, names))) => Some(names),
        _ => None,
    };
    let results: Vec<Result<Validated, PieceError>> = pieces
        .par_iter()
        .map(|&(a, b, first)| {
            let raw: RawSpheres = toml::from_str(&text[a..b]).map_err(|e| {
                let (off, msg) = syntax(a, &e);
                PieceError::Syntax(off, msg)
            })?;
            match names {
                Some(names) => check
                    .spheres(&raw.sphere, first, names)
                    .map_err(PieceError::Value),
                None => Ok((Vec::new(), Vec::new())),
            }
        })
        .collect();
    let fail = |msg: String| Some(Err(Error::Scene(msg)));
    // The first syntax error in the text.
    let first_syntax = results
        .iter()
        .filter_map(|r| match r {
            Err(PieceError::Syntax(off, msg)) => Some((*off, msg.clone())),
            _ => None,
        })
        .chain(head.as_ref().err().cloned())
        .min_by_key(|e| e.0);
    if let Some((off, msg)) = first_syntax {
        let (line, col) = line_col(text, off);
        return fail(format!("{file}:{line}:{col}: {msg}"));
    }
    let mut scene = match checked_head? {
        Ok((scene, _)) => scene,
        Err(msg) => return fail(msg),
    };
    scene.spheres.reserve_exact(spheres);
    for r in results {
        match r {
            Ok((s, inline)) => add_spheres(&mut scene, s, inline),
            Err(PieceError::Value(msg)) => return fail(msg),
            Err(PieceError::Syntax(..)) => unreachable!("reported above"),
        }
    }
    Some(Ok(scene))
}

/// The 1-based line and column of byte `offset` in `text`.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Formats a number as the scene file would, with negative zero shown as `-0`.
fn show(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else {
        format!("{x}")
    }
}

/// Marks, in [`Check::spheres`]' output, a material index into that call's inline materials.
const INLINE: u32 = 1 << 31;

/// Appends validated spheres to `scene`, with their inline materials after its others.
fn add_spheres(scene: &mut Scene, mut spheres: Vec<SphereDesc>, inline: Vec<Material>) {
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

/// The validator: every method checks one kind of value and names the field on failure.
struct Check<'a> {
    file: &'a str,
}

impl Check<'_> {
    fn err<T>(&self, msg: impl fmt::Display) -> Result<T, String> {
        Err(format!("{}: {msg}", self.file))
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

    fn color(&self, field: &str, v: V3) -> Result<DVec3, String> {
        for (i, x) in v.iter().enumerate() {
            self.non_negative(&format!("{field}[{i}]"), *x)?;
        }
        Ok(DVec3::from_array(v))
    }

    fn int(
        &self,
        field: &str,
        x: Option<Number>,
        default: i64,
        min: i64,
        max: i64,
    ) -> Result<i64, String> {
        let x = match x {
            None => default,
            Some(Number::Int(x)) => x,
            Some(Number::Float(f)) => {
                return self.err(format_args!("{field} must be an integer, got {}", show(f)));
            }
        };
        if x < min || x > max {
            return self.err(format_args!("{field} must be in {min}..={max}, got {x}"));
        }
        Ok(x)
    }

    fn scene(&self, raw: RawScene, source: &Path) -> Result<Scene, String> {
        let (mut scene, names) = self.scene_head(&raw, source)?;
        let (spheres, inline) = self.spheres(&raw.sphere, 0, &names)?;
        add_spheres(&mut scene, spheres, inline);
        Ok(scene)
    }

    /// Everything but the spheres, and the material names (indices into `materials`).
    fn scene_head<'r>(
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
        };
        let camera = self.camera(&raw.camera)?;
        let background = match &raw.background {
            None => Background::Sky,
            Some(b) => Background::Uniform(self.color("background.color", b.color)?),
        };
        let mut materials = Vec::new();
        let mut names = BTreeMap::new();
        for (name, m) in &raw.materials {
            materials.push(self.material(&format!("materials.{name}"), m)?);
            names.insert(name.as_str(), (materials.len() - 1) as u32);
        }
        let scene = Scene {
            source: source.to_path_buf(),
            shot,
            output,
            render,
            camera,
            background,
            materials,
            spheres: Vec::new(),
        };
        Ok((scene, names))
    }

    /// Validates spheres numbered from `first`. Inline materials are returned in sphere order;
    /// a sphere with one refers to it by `INLINE | its index in that list`.
    fn spheres(
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
                MaterialRef::Name(n) => match names.get(n.as_str()) {
                    Some(&m) => m,
                    None => {
                        let known: Vec<&str> = names.keys().copied().collect();
                        let known = if known.is_empty() {
                            "none defined".to_string()
                        } else {
                            known.join(", ")
                        };
                        return self.err(format_args!(
                            "{field}.material \"{n}\" is not a material in [materials] (known: {known})"
                        ));
                    }
                },
                MaterialRef::Inline(m) => {
                    inline.push(self.material(&format!("{field}.material"), m)?);
                    INLINE | (inline.len() - 1) as u32
                }
            };
            spheres.push(SphereDesc {
                radius: self.positive(&format!("{field}.radius"), s.radius)?,
                motion: self.sphere_motion(&field, s)?,
                material,
            });
        }
        Ok((spheres, inline))
    }

    fn shot(&self, s: &RawShot) -> Result<Shot, String> {
        let fps = self.positive("shot.fps", s.fps.unwrap_or(24.0))?;
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
            (Some(x), None) => self.non_negative("shot.shutter", x)?,
            (None, a) => shutter_from_angle(
                self.non_negative("shot.shutter_angle", a.unwrap_or(180.0))?,
                fps,
            ),
        };
        let shutter = self.num("shot.shutter", shutter)?;
        let position = match s.shutter_position.unwrap_or(RawShutterPosition::Center) {
            RawShutterPosition::Start => ShutterPosition::Start,
            RawShutterPosition::Center => ShutterPosition::Center,
            RawShutterPosition::End => ShutterPosition::End,
        };
        let shot = Shot {
            fps,
            frames: frames as u32,
            first_frame: first_frame as u32,
            start_time: self.num("shot.start_time", s.start_time.unwrap_or(0.0))?,
            shutter,
            position,
        };
        // A tiny fps over many frames can push the last frame's time out of range.
        let whole = shot.whole_interval();
        for t in [whole.open, whole.close] {
            if !t.is_finite() || t.abs() > f32::MAX as f64 {
                return self.err(format_args!(
                    "shot: the last frame's time ({}) is out of range; check shot.fps and shot.frames",
                    show(t)
                ));
            }
        }
        Ok(shot)
    }

    fn output(&self, o: &RawOutput, source: &Path) -> Result<OutputSettings, String> {
        let path = match &o.path {
            Some(p) if p.trim().is_empty() => return self.err("output.path must not be empty"),
            Some(p) => p.clone(),
            None => {
                let stem = source
                    .file_stem()
                    .map_or("frame".into(), |s| s.to_string_lossy().into_owned());
                format!("{stem}_####.png")
            }
        };
        Ok(OutputSettings {
            path,
            width: self.int("output.width", o.width, 400, 1, MAX_SIDE)? as u32,
            height: self.int("output.height", o.height, 225, 1, MAX_SIDE)? as u32,
        })
    }

    fn material(&self, field: &str, m: &RawMaterial) -> Result<Material, String> {
        Ok(match m {
            RawMaterial::Lambertian { albedo } => Material::Lambertian {
                albedo: self.color(&format!("{field}.albedo"), *albedo)?,
            },
            RawMaterial::Metal { albedo, fuzz } => {
                let fuzz = self.non_negative(&format!("{field}.fuzz"), *fuzz)?;
                if fuzz > 1.0 {
                    return self.err(format_args!(
                        "{field}.fuzz must be in [0, 1], got {}",
                        show(fuzz)
                    ));
                }
                Material::Metal {
                    albedo: self.color(&format!("{field}.albedo"), *albedo)?,
                    fuzz,
                }
            }
            RawMaterial::Dielectric { ior } => Material::Dielectric {
                ior: self.positive(&format!("{field}.ior"), *ior)?,
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
            let times = self.keys(&kf, keys.iter().map(|k| k.time))?;
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
                o.degrees_per_second,
            )?;
            return Ok(Motion::Orbit { origin, orbit });
        }
        Ok(Motion::Still(origin))
    }

    fn orbit(&self, field: &str, pivot: V3, axis: V3, dps: f64) -> Result<Orbit, String> {
        let pivot = self.vec(&format!("{field}.pivot"), pivot)?;
        let axis = self.vec(&format!("{field}.axis"), axis)?;
        let degrees_per_second = self.num(&format!("{field}.degrees_per_second"), dps)?;
        let len = axis.length();
        if !(len > 0.0 && len.is_finite()) {
            return self.err(format_args!("{field}.axis must be a non-zero vector"));
        }
        Ok(Orbit {
            pivot,
            axis: axis / len,
            degrees_per_second,
        })
    }

    /// Checks that a view is not degenerate.
    fn view(&self, field: &str, from: DVec3, at: DVec3, up: DVec3) -> Result<(), String> {
        let view = at - from;
        if view.length() == 0.0 {
            return self.err(format_args!(
                "{field}: look_from and look_at must differ, both are {}",
                fmt_v(from)
            ));
        }
        if up.length() == 0.0 {
            return self.err("camera.up must be a non-zero vector");
        }
        if up.normalize().cross(view.normalize()).length() < 1e-9 {
            return self.err(format_args!(
                "{field}: camera.up {} is parallel to the view direction {}",
                fmt_v(up),
                fmt_v(view)
            ));
        }
        Ok(())
    }

    fn camera(&self, c: &RawCamera) -> Result<CameraRig, String> {
        let from = self.vec("camera.look_from", c.look_from.unwrap_or([0.0, 0.0, 0.0]))?;
        let at = self.vec("camera.look_at", c.look_at.unwrap_or([0.0, 0.0, -1.0]))?;
        let up = self.vec("camera.up", c.up.unwrap_or([0.0, 1.0, 0.0]))?;
        let vfov = self.positive("camera.vfov", c.vfov.unwrap_or(90.0))?;
        if vfov >= 180.0 {
            return self.err(format_args!(
                "camera.vfov must be < 180, got {}",
                show(vfov)
            ));
        }
        let aperture = self.non_negative("camera.aperture", c.aperture.unwrap_or(0.0))?;
        let focus_distance = c
            .focus_distance
            .map(|f| self.positive("camera.focus_distance", f))
            .transpose()?;
        if c.orbit.is_some() && c.keyframes.is_some() {
            return self.err("camera: give at most one of orbit and keyframes");
        }
        let (look_from, look_at) = if let Some(o) = &c.orbit {
            self.view("camera", from, at, up)?;
            let orbit = self.orbit(
                "camera.orbit",
                at.to_array(),
                up.to_array(),
                o.degrees_per_second,
            )?;
            (
                Motion::Orbit {
                    origin: from,
                    orbit,
                },
                Motion::Still(at),
            )
        } else if let Some(keys) = &c.keyframes {
            let times = self.keys("camera.keyframes", keys.iter().map(|k| k.time))?;
            let (mut f, mut a) = (from, at);
            let (mut fk, mut ak) = (Vec::new(), Vec::new());
            for (i, (k, time)) in keys.iter().zip(times).enumerate() {
                let field = format!("camera.keyframes[{i}]");
                if let Some(v) = k.look_from {
                    f = self.vec(&format!("{field}.look_from"), v)?;
                }
                if let Some(v) = k.look_at {
                    a = self.vec(&format!("{field}.look_at"), v)?;
                }
                self.view(&field, f, a, up)?;
                fk.push(Key { time, position: f });
                ak.push(Key { time, position: a });
            }
            (Motion::Keyframes(fk), Motion::Keyframes(ak))
        } else {
            self.view("camera", from, at, up)?;
            (Motion::Still(from), Motion::Still(at))
        };
        Ok(CameraRig {
            look_from,
            look_at,
            up,
            vfov,
            aperture,
            focus_distance,
        })
    }
}

fn fmt_v(v: DVec3) -> String {
    format!("[{}, {}, {}]", show(v.x), show(v.y), show(v.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ok(text: &str) -> Scene {
        parse(text, Path::new("s.toml")).unwrap_or_else(|e| panic!("{e}"))
    }

    fn err(text: &str) -> String {
        match parse(text, Path::new("s.toml")) {
            Ok(_) => panic!("accepted:\n{text}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn empty_scene_has_every_default() {
        let s = ok("");
        assert_eq!(s.shot, Shot::default());
        assert_eq!(s.shot.shutter, 1.0 / 48.0);
        assert_eq!(s.output.path, "s_####.png");
        assert_eq!((s.output.width, s.output.height), (400, 225));
        assert_eq!(
            s.render,
            RenderSettings {
                samples: 16,
                max_depth: 50,
                seed: 0,
                sampler: SamplerKind::Sobol,
            }
        );
        assert_eq!(s.camera.look_from, Motion::Still(DVec3::ZERO));
        assert_eq!(s.camera.look_at, Motion::Still(DVec3::new(0.0, 0.0, -1.0)));
        assert_eq!(
            (s.camera.up, s.camera.vfov, s.camera.aperture),
            (DVec3::Y, 90.0, 0.0)
        );
        assert_eq!(s.camera.focus_distance, None);
        assert_eq!(s.background, Background::Sky);
        assert!(s.spheres.is_empty() && s.materials.is_empty());
    }

    #[test]
    fn the_contracts_example_parses() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../shared/scene-format.md"
        ));
        // The contract sits beside the project in development; the same example is kept here.
        let example = text.ok().and_then(|t| {
            let start = t.find("```toml\n")? + 8;
            let end = start + t[start..].find("```")?;
            Some(t[start..end].to_string())
        });
        let example = example.unwrap_or_else(|| CONTRACT_EXAMPLE.to_string());
        let s = ok(&example);
        assert_eq!(s.spheres.len(), 4);
        assert_eq!(s.shot.shutter, 0.0208333);
        assert!(matches!(s.spheres[1].motion, Motion::Velocity { .. }));
        assert!(matches!(s.spheres[2].motion, Motion::Keyframes(_)));
        assert!(matches!(s.spheres[3].motion, Motion::Orbit { .. }));
        assert_eq!(s.materials.len(), 3);
        assert_eq!(s.background, Background::Uniform(DVec3::ONE));
        ok(CONTRACT_EXAMPLE);
    }

    const CONTRACT_EXAMPLE: &str = r#"
[shot]
fps = 24.0
frames = 48
first_frame = 1
start_time = 0.0
shutter = 0.0208333
shutter_position = "center"
[output]
path = "renders/shot_####.exr"
[render]
samples = 100
[camera]
look_from = [13.0, 2.0, 3.0]
look_at = [0.0, 0.0, 0.0]
vfov = 20.0
aperture = 0.1
focus_distance = 10.0
[background]
color = [1.0, 1.0, 1.0]
[materials]
ground = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
steel  = { type = "metal", albedo = [0.7, 0.6, 0.5], fuzz = 0.0 }
glass  = { type = "dielectric", ior = 1.5 }
[[sphere]]
center = [0.0, -1000.0, 0.0]
radius = 1000.0
material = "ground"
[[sphere]]
center = [1.2, 0.2, 3.4]
radius = 0.2
material = "steel"
velocity = [0.0, 0.25, 0.0]
[[sphere]]
radius = 0.5
material = "glass"
keyframes = [ { time = 0.0, center = [0, 1, 0] }, { time = 1.0, center = [2, 1, 0] } ]
[[sphere]]
center = [0.0, 1.0, 0.0]
radius = 0.3
material = "steel"
orbit = { pivot = [0.0, 1.0, 0.0], axis = [0.0, 1.0, 0.0], degrees_per_second = 90.0 }
"#;

    #[test]
    fn shutter_angle_and_seconds() {
        assert_eq!(
            ok("[shot]\nfps = 25\nshutter_angle = 90\n").shot.shutter,
            0.01
        );
        assert_eq!(ok("[shot]\nshutter = 0.004\n").shot.shutter, 0.004);
        assert_eq!(
            ok("[shot]\nshutter_position = \"end\"\n").shot.position,
            ShutterPosition::End
        );
    }

    #[test]
    fn materials_by_name_and_inline() {
        let s = ok(r#"
[materials]
a = { type = "metal", albedo = [0.1, 0.2, 0.3] }
[[sphere]]
center = [0, 0, 0]
radius = 1
material = "a"
[[sphere]]
center = [0, 0, 0]
radius = 1
material = { type = "dielectric", ior = 1.33 }
"#);
        assert_eq!(
            s.materials[s.spheres[0].material as usize],
            Material::Metal {
                albedo: DVec3::new(0.1, 0.2, 0.3),
                fuzz: 0.0
            }
        );
        assert_eq!(
            s.materials[s.spheres[1].material as usize],
            Material::Dielectric { ior: 1.33 }
        );
    }

    #[test]
    fn orbit_axis_is_normalised_and_camera_motions_convert() {
        let s = ok(
            "[[sphere]]\ncenter = [1, 0, 0]\nradius = 0.1\nmaterial = { type = \"lambertian\", albedo = [1, 1, 1] }\norbit = { pivot = [0, 0, 0], axis = [0, 2, 0], degrees_per_second = 10 }\n",
        );
        let Motion::Orbit { orbit, .. } = &s.spheres[0].motion else {
            panic!()
        };
        assert_eq!(orbit.axis, DVec3::Y);
        let s = ok(
            "[camera]\nlook_from = [0, 1, 5]\nlook_at = [0, 1, 0]\norbit = { degrees_per_second = 45 }\n",
        );
        let Motion::Orbit { origin, orbit } = &s.camera.look_from else {
            panic!()
        };
        assert_eq!(
            (*origin, orbit.pivot, orbit.axis),
            (
                DVec3::new(0.0, 1.0, 5.0),
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::Y
            )
        );
        let s = ok(r#"
[camera]
look_from = [0, 0, 5]
look_at = [0, 0, 0]
keyframes = [ { time = 0 }, { time = 1, look_from = [5, 0, 0] }, { time = 2, look_at = [0, 1, 0] } ]
"#);
        let (Motion::Keyframes(f), Motion::Keyframes(a)) = (&s.camera.look_from, &s.camera.look_at)
        else {
            panic!()
        };
        assert_eq!(
            f.iter().map(|k| k.position).collect::<Vec<_>>(),
            [
                DVec3::new(0.0, 0.0, 5.0),
                DVec3::new(5.0, 0.0, 0.0),
                DVec3::new(5.0, 0.0, 0.0)
            ]
        );
        assert_eq!(
            a.iter().map(|k| k.position).collect::<Vec<_>>(),
            [DVec3::ZERO, DVec3::ZERO, DVec3::Y]
        );
    }

    #[test]
    fn malformed_scenes_name_the_place() {
        let sphere = |extra: &str| {
            format!(
                "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\n{extra}"
            )
        };
        let cases: Vec<(String, &str)> = vec![
            ("[shot]\nfpz = 3\n".into(), "s.toml:2:1"),
            ("[camera]\nlook_from = [0, 0]\n".into(), "s.toml:2:"),
            ("[[sphere]]\ncenter = [0, 0, 0]\nmaterial = \"x\"\n".into(), "radius"),
            ("[shot]\nfps = nan\n".into(), "shot.fps must be a finite number, got nan"),
            ("[shot]\nfps = inf\n".into(), "shot.fps"),
            ("[shot]\nstart_time = 1e39\n".into(), "shot.start_time is too large"),
            ("[shot]\nshutter = -0.0\n".into(), "shot.shutter must be >= 0, got -0"),
            ("[shot]\nframes = 0\n".into(), "shot.frames must be in 1"),
            ("[shot]\nframes = -4\n".into(), "shot.frames"),
            ("[shot]\nfirst_frame = 4294967295\nframes = 2\n".into(), "first_frame + shot.frames"),
            ("[camera]\naperture = -0.0\n".into(), "camera.aperture"),
            ("[camera]\nvfov = 180\n".into(), "camera.vfov must be < 180"),
            ("[camera]\nup = [0, 0, 2]\n".into(), "parallel"),
            ("[camera]\nup = [0, 0, 0]\n".into(), "camera.up"),
            ("[camera]\norbit = { degrees_per_second = 1 }\nkeyframes = [ { time = 0 } ]\n".into(), "at most one of orbit and keyframes"),
            ("[camera]\nkeyframes = []\n".into(), "camera.keyframes must have at least one key"),
            ("[camera]\nkeyframes = [ { time = 1 }, { time = 1 } ]\n".into(), "camera.keyframes[1].time must be greater"),
            ("[camera]\nkeyframes = [ { time = 0, look_at = [0, 0, 0] } ]\n".into(), "camera.keyframes[0]: look_from and look_at must differ"),
            (sphere("velocity = [1, 0, 0]\norbit = { pivot = [0, 0, 0], axis = [0, 1, 0], degrees_per_second = 1 }\n"), "sphere[0]: give at most one"),
            (sphere("keyframes = [ { time = 0, center = [0, 0, 0] } ]\n"), "keyframes replace center"),
            (sphere("orbit = { pivot = [0, 0, 0], axis = [0, 0, 0], degrees_per_second = 1 }\n"), "sphere[0].orbit.axis must be a non-zero"),
            (sphere("velocity = [0, nan, 0]\n"), "sphere[0].velocity[1]"),
            ("[[sphere]]\ncenter = [0, 0, 0]\nradius = -0.0\nmaterial = \"m\"\n[materials]\nm = { type = \"dielectric\", ior = 1 }\n".into(), "sphere[0].radius must be > 0, got -0"),
            ("[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"steel\"\n".into(), "sphere[0].material \"steel\" is not a material"),
            ("[materials]\nm = { type = \"plastic\" }\n".into(), "plastic"),
            ("[materials]\nm = { type = \"metal\", albedo = [1, 1, 1], fuzz = 2 }\n".into(), "materials.m.fuzz must be in [0, 1], got 2"),
            ("[materials]\nm = { type = \"metal\", albedo = [1, 1, 1], shine = 2 }\n".into(), "shine"),
            ("[materials]\nm = { type = \"lambertian\", albedo = [-1, 1, 1] }\n".into(), "materials.m.albedo[0] must be >= 0"),
            ("[background]\ncolor = [1, 1, inf]\n".into(), "background.color[2]"),
            ("[output]\nwidth = 0\n".into(), "output.width"),
            ("[render]\nseed = -1\n".into(), "render.seed"),
            ("[render]\nsamples = 0\n".into(), "render.samples"),
            ("[shot]\nshutter = 0.1\nshutter_angle = 10\n".into(), "at most one of shutter and shutter_angle"),
            ("[shot]\nshutter_position = \"middle\"\n".into(), "s.toml:2:"),
            ("[shot\n".into(), "s.toml:1:"),
            ("[shot]\nfps = 1e-38\nframes = 100\n".into(), "out of range"),
        ];
        for (text, want) in cases {
            let e = err(&text);
            assert!(e.contains(want), "{text:?}: {e:?} lacks {want:?}");
            assert!(e.starts_with("s.toml"), "{e}");
        }
    }

    /// The parse in pieces agrees with the whole parse: same scene, or the same message.
    /// Unbalanced brackets make the cut impossible (`must_cut` false): then it is the
    /// fallback that must agree.
    fn same_both_ways(text: &str, must_cut: bool) {
        let whole = parse_whole(text, Path::new("s.toml"));
        for per_piece in [1, 2, 3, 1000] {
            let pieces = parse_in_pieces(text, Path::new("s.toml"), per_piece);
            assert!(
                pieces.is_some() || !must_cut,
                "not cut into pieces:\n{text}"
            );
            let pieces = pieces.unwrap_or_else(|| parse(text, Path::new("s.toml")));
            match (&whole, &pieces) {
                (Ok(a), Ok(b)) => assert_eq!(a, b),
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{text}"),
                _ => panic!("{text}\nwhole: {whole:?}\npieces: {pieces:?}"),
            }
        }
    }

    #[test]
    fn pieces_agree_with_the_whole_parse() {
        let sphere = |i: usize, extra: &str| {
            format!(
                "[[sphere]]\ncenter = [{i}, 0, 0]\nradius = 1\nmaterial = {}\n{extra}",
                if i.is_multiple_of(2) {
                    "\"a\"".to_string()
                } else {
                    format!("{{ type = \"dielectric\", ior = 1.{i} }}")
                }
            )
        };
        let spheres = |n: usize, bad: Option<(usize, &str)>| {
            (0..n)
                .map(|i| match bad {
                    Some((j, extra)) if j == i => sphere(i, extra),
                    _ => sphere(i, "velocity = [0, 1, 0]\n"),
                })
                .collect::<String>()
        };
        let head = "# [[sphere]] in a comment\n[shot]\nframes = 3\n[materials]\na = { type = \"metal\", albedo = [0.5, 0.5, 0.5] }\n";
        let cases = [
            format!("{head}{}", spheres(7, None)),
            // Settings after the spheres, a multi-line string holding a header, a
            // multi-line array with brackets at line starts.
            format!(
                "{}[output]\npath = \"\"\"\n[[sphere]]\nx_####.png\"\"\"\n[camera]\nlook_from = [\n[0][0],\n1, 2]\n{head}",
                spheres(5, None)
            ),
            format!(
                "{}[output]\npath = \"\"\"x\n[[sphere]]\n_####.png\"\"\"\n{head}",
                spheres(5, None)
            ),
            // Sub-tables of a sphere.
            format!(
                "{head}{}{}",
                spheres(3, None),
                sphere(
                    3,
                    "[sphere.orbit]\npivot = [0, 0, 0]\naxis = [0, 1, 0]\ndegrees_per_second = 9\n"
                )
            ),
            format!(
                "{head}{}[[sphere]]\nradius = 1\nmaterial = \"a\"\n[[sphere.keyframes]]\ntime = 0\ncenter = [0, 0, 0]\n[[sphere.keyframes]]\ntime = 1\ncenter = [1, 0, 0]\n",
                spheres(4, None)
            ),
            // Errors: syntax in a late sphere, values in a sphere, settings and a piece both bad.
            format!("{head}{}", spheres(6, Some((4, "velocity = [0, 1\n")))),
            format!("{head}{}", spheres(6, Some((5, "radius = 2\n")))),
            format!("{head}{}", spheres(6, Some((3, "colour = 2\n")))),
            format!(
                "{head}{}",
                spheres(6, Some((4, "velocity = [0, nan, 0]\n")))
            ),
            format!("{head}{}", spheres(6, Some((2, "orbit = 1\n")))),
            format!(
                "{}{head}[shot]\nfps = 2\n",
                spheres(6, Some((4, "velocity = [0, 1\n")))
            ),
            format!(
                "{}{head}[camera]\nvfov = 200\n",
                spheres(6, Some((1, "velocity = [0, nan, 0]\n")))
            ),
            format!("{head}{}", spheres(6, Some((2, "material = \"nope\"\n")))),
            format!("{head}[render]\nsamples = 0\n{}", spheres(3, None)),
            format!("{head}{}[[sphere]]\ncenter = [0, 0, 0]\n", spheres(3, None)),
            format!("{head}{}[[sphere]\n", spheres(3, None)),
            spheres(3, None),
        ];
        for (i, text) in cases.iter().enumerate() {
            same_both_ways(text, ![5, 10, 15].contains(&i));
        }
        same_both_ways(
            &crate::generate::scene_text(&crate::generate::GenerateOptions {
                spheres: 3000,
                moving: 0.5,
                seed: 9,
                frames: 1,
            }),
            true,
        );
    }

    /// Layouts the pieces cannot follow are parsed whole.
    #[test]
    fn unusual_layouts_are_parsed_whole() {
        let s = "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"a\"\n";
        for text in [
            format!(
                "[materials]\na = {{ type = \"dielectric\", ior = 1 }}\n[\"sphere\"]\nx = 1\n{s}"
            ),
            format!(
                "{s}[materials]\na = {{ type = \"dielectric\", ior = 1 }}\n[sphere.orbit]\nx = 1\n"
            ),
            format!("sphere = []\n{s}"),
        ] {
            assert!(
                parse_in_pieces(&text, Path::new("s.toml"), 1).is_none(),
                "{text}"
            );
            assert!(parse(&text, Path::new("s.toml")).is_err());
        }
    }

    #[test]
    fn negative_zero_coordinates_are_zero() {
        let s = ok("[camera]\nlook_from = [-0.0, 0, 0]\n");
        assert_eq!(s.camera.look_from.at(0.0), DVec3::ZERO);
    }
}
