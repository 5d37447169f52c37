//! Where everything lies in the GPU's buffers: every record is a run of 32-bit words (`u32`,
//! or `f32` by its bits), read by the shaders with `bitcast`, so no WGSL struct layout rule
//! (alignment, padding) can differ from what the CPU writes. The offsets are the constants
//! here, and the shaders get the same constants from [`wgsl_prelude`]: one source for both.
//!
//! Records are read four words at a time (the shaders also see each buffer as `vec4<u32>`),
//! so every record starts at a multiple of four words and keeps its fields in quads: a
//! sphere is (centre, radius), (velocity, material), (index, motion, -, -). Software
//! devices (lavapipe) pay for every load; a quad costs about what a word does.
//!
//! Two storage buffers hold the scene: the *shot* buffer, written once per shot (materials,
//! the Sobol tables, the spheres that never move and their hierarchy), and the *frame*
//! buffer, written per frame (the header below, the shutter curve, the camera's motion, the
//! animated spheres prepared for the frame's interval, their hierarchy and motions, the
//! points of its point caches with their groups' hierarchies and their looks). Beside
//! them: the film on the device (its sums), a round's work entries, each dispatch's
//! parameters and counts.

use super::pages::Pages;

/// A word that stands for no offset or no slot.
pub(super) const NONE: u32 = u32::MAX;

// The frame header: the frame buffer's first words.
pub(super) const H_WIDTH: u32 = 0;
pub(super) const H_HEIGHT: u32 = 1;
pub(super) const H_MAX_DEPTH: u32 = 2;
/// [`F_SOBOL`] and the other flags.
pub(super) const H_FLAGS: u32 = 3;
/// Two words (low, high): the sampler's key, hashed once (see `sampler_key`).
pub(super) const H_KEY: u32 = 4;
/// The frame's whole exposure, in seconds (times are relative to its opening).
pub(super) const H_DURATION: u32 = 6;
/// Seconds each row is open.
pub(super) const H_SHUTTER: u32 = 7;
/// A rolling shutter's readout, seconds.
pub(super) const H_READOUT: u32 = 8;
/// Where the shutter curve's knots start: `n` positions, `n` weights, `n` cumulative areas.
pub(super) const H_CURVE: u32 = 9;
/// The curve's knots, 0 for a box.
pub(super) const H_CURVE_N: u32 = 10;
/// Three words: a uniform background's radiance.
pub(super) const H_BACKGROUND: u32 = 11;
/// One frame period, 1 / fps, seconds.
pub(super) const H_PERIOD: u32 = 14;
/// Pass sums per pixel.
pub(super) const H_STRIDE: u32 = 15;
/// Five words: where the hit count, depth, normal, albedo and motion sums start in a pixel's
/// run ([`NONE`]: not kept), as [`raytrace_core::passes::Slots`] lists them.
pub(super) const H_SLOTS: u32 = 16;
/// The camera's view when it does not move during the frame, 19 words: lens centre, right,
/// up, centre of pixel (0, 0), steps right and down (3 each), lens radius.
pub(super) const H_VIEW: u32 = 21;
/// The camera's motion records (look_from, look_at), prepared over the frame's interval
/// widened by one frame period each side (for the motion pass).
pub(super) const H_CAM_FROM: u32 = 40;
pub(super) const H_CAM_AT: u32 = 41;
/// Three words: the camera's up vector.
pub(super) const H_CAM_UP: u32 = 42;
/// tan(vfov / 2).
pub(super) const H_CAM_TAN: u32 = 45;
pub(super) const H_CAM_LENS: u32 = 46;
/// The focus distance, when the scene gives one ([`F_FOCUS`]).
pub(super) const H_CAM_FOCUS: u32 = 47;
/// The still spheres and their hierarchy's entries, in the shot buffer.
pub(super) const H_STILL_SPHERES: u32 = 48;
pub(super) const H_STILL_ENTRIES: u32 = 49;
pub(super) const H_STILL_ENTRY_N: u32 = 50;
/// The animated spheres and their hierarchy's entries, in the frame buffer.
pub(super) const H_MOVING_SPHERES: u32 = 51;
pub(super) const H_MOVING_ENTRIES: u32 = 52;
pub(super) const H_MOVING_ENTRY_N: u32 = 53;
/// The materials and the Sobol tables, in the shot buffer.
pub(super) const H_MATERIALS: u32 = 54;
pub(super) const H_TABLES: u32 = 55;
/// Per sphere of the scene, its motion record over the widened interval for the motion
/// pass ([`NONE`]: the sphere never moves).
pub(super) const H_PASS_MOTIONS: u32 = 56;
/// The frame's points' records (all its groups', one after another), in the frame buffer.
pub(super) const H_POINTS: u32 = 57;
/// The points' groups (sets sharing a time, each with its hierarchy): where their records
/// ([`POINT_GROUP_WORDS`] each) start, and how many there are.
pub(super) const H_POINT_GROUPS: u32 = 58;
pub(super) const H_POINT_GROUP_N: u32 = 59;
/// The number of the frame's first point as a sphere: the scene's spheres come first.
pub(super) const H_FIRST_POINT: u32 = 60;
/// The points' looks ([`LOOK_WORDS`] each), in the frame buffer.
pub(super) const H_LOOKS: u32 = 61;
/// Words in the header.
pub(super) const HEADER_WORDS: u32 = 62;

// Flags (`H_FLAGS`).
pub(super) const F_SOBOL: u32 = 1;
/// Sample time (something moves during the frame).
pub(super) const F_TIME: u32 = 2;
/// Sample the lens.
pub(super) const F_LENS: u32 = 4;
/// The camera moves during the frame: a view per sample.
pub(super) const F_CAMERA_MOVES: u32 = 8;
pub(super) const F_TRANSPARENT: u32 = 16;
pub(super) const F_ROLLING: u32 = 32;
pub(super) const F_BOTTOM_TO_TOP: u32 = 64;
/// A uniform background (else the sky).
pub(super) const F_UNIFORM: u32 = 128;
/// The camera moves at some time of the shot: the motion pass projects through its views
/// one period away.
pub(super) const F_CAMERA_ANIMATED: u32 = 256;
pub(super) const F_FOCUS: u32 = 512;

// A sphere: 12 words.
pub(super) const SPHERE_WORDS: u32 = 12;
/// Three words: its centre (at the frame's opening for an animated one).
pub(super) const S_CENTER: u32 = 0;
pub(super) const S_RADIUS: u32 = 3;
/// Three words: its velocity when its path is a line.
pub(super) const S_VELOCITY: u32 = 4;
pub(super) const S_MATERIAL: u32 = 7;
/// Its index in the scene.
pub(super) const S_ID: u32 = 8;
/// Its motion record, or [`NONE`] for a line (centre plus velocity times the time).
pub(super) const S_MOTION: u32 = 9;

// A point of a point cache: 8 words, (centre, radius), (velocity, look). The CPU's record
// (traced_points.rs) with its centre moved to the frame's opening and its number replaced by
// its look; its number as a sphere is its place among the frame's points after
// [`H_FIRST_POINT`].
pub(super) const POINT_WORDS: u32 = 8;
/// Three words: its centre at the frame's opening (at time `t` after it, `centre + velocity t`).
pub(super) const PT_CENTER: u32 = 0;
pub(super) const PT_RADIUS: u32 = 3;
/// Three words: its velocity, zero for a point that does not move.
pub(super) const PT_VELOCITY: u32 = 4;
/// Its look's index in the looks ([`H_LOOKS`]).
pub(super) const PT_LOOK: u32 = 7;

// A look of points: 4 words, the colour that multiplies the material's albedo (1, 1, 1 for a
// set without colours) and the material's index.
pub(super) const LOOK_WORDS: u32 = 4;
/// Three words: the colour.
pub(super) const L_TINT: u32 = 0;
pub(super) const L_MATERIAL: u32 = 3;

// A group of points (its sets share a time): 4 words, its hierarchy's entries and their
// count, and where its records start (its hierarchy's leaves index them from there).
pub(super) const POINT_GROUP_WORDS: u32 = 4;
pub(super) const G_ENTRIES: u32 = 0;
pub(super) const G_ENTRY_N: u32 = 1;
pub(super) const G_POINTS: u32 = 2;

// A material: 8 words.
pub(super) const MATERIAL_WORDS: u32 = 8;
pub(super) const M_KIND: u32 = 0;
pub(super) const M_ALBEDO: u32 = 1;
pub(super) const M_FUZZ: u32 = 4;
pub(super) const M_IOR: u32 = 5;
pub(super) const LAMBERTIAN: u32 = 0;
pub(super) const METAL: u32 = 1;
pub(super) const DIELECTRIC: u32 = 2;

// A motion record: 16 words, a path evaluated at `tau = t + shift`, `t` the time since the
// frame's opening.
pub(super) const MOTION_WORDS: u32 = 16;
pub(super) const MO_KIND: u32 = 0;
pub(super) const MO_SHIFT: u32 = 1;
/// A circle's angle at `tau = 0` and its rate, in degrees.
pub(super) const MO_DEGREES: u32 = 2;
pub(super) const MO_DEGREES_PER_SECOND: u32 = 3;
/// Three words: a fixed point, a line's start or a circle's centre.
pub(super) const MO_A: u32 = 4;
/// Three words: a line's velocity, a circle's first axis; for keyframes the first key's
/// word offset and the count.
pub(super) const MO_B: u32 = 8;
/// Three words: a circle's second axis.
pub(super) const MO_C: u32 = 12;
pub(super) const FIXED: u32 = 0;
pub(super) const LINE: u32 = 1;
pub(super) const CIRCLE: u32 = 2;
pub(super) const KEYS: u32 = 3;
/// A key: its time (as `tau`) and position.
pub(super) const KEY_WORDS: u32 = 4;

// A hierarchy's child entry, in depth-first order (see flatten.rs): 16 words, its box's lower
// and upper sides at the shutter's opening and their changes until its closing, where the
// walk goes when the ray misses it, and for a leaf its spheres (first, count; 0 for a node).
pub(super) const ENTRY_WORDS: u32 = 16;
pub(super) const E_LOWER: u32 = 0;
pub(super) const E_SKIP: u32 = 3;
pub(super) const E_UPPER: u32 = 4;
pub(super) const E_COUNT: u32 = 7;
pub(super) const E_LOWER_CHANGE: u32 = 8;
pub(super) const E_FIRST: u32 = 11;
pub(super) const E_UPPER_CHANGE: u32 = 12;

/// The Sobol tables: 512 entries of four words (the low byte's 256, then the high byte's).
pub(super) const TABLE_WORDS: u32 = 512 * 4;

// The film on the device (device_film.rs): a part of the film's pixels (a run of the film's
// storage order), each sum a plane of words, word `k` of the part's pixel `i` at
// `k * pixels + i` (neighbouring invocations touch neighbouring words). The colour's sum is
// compensated, a high and a low f32 (trace.wgsl, two_sum); the odd samples' sum is a plain
// f32, as the CPU's film keeps it; the pass sums are compensated, their highs then their lows.
/// Three planes: the colour sum's high words.
pub(super) const FILM_SUM: u32 = 0;
/// Three planes: its low words.
pub(super) const FILM_SUM_LOW: u32 = 3;
/// Three planes: the odd samples' sum.
pub(super) const FILM_ODD: u32 = 6;
/// The pass sums' planes: `stride` high, then `stride` low.
pub(super) const FILM_PASSES: u32 = 9;

/// Planes of a film keeping `stride` pass sums a pixel.
pub(super) const fn film_planes(stride: u32) -> u32 {
    FILM_PASSES + 2 * stride
}

// A work entry: one pixel's samples in a round, four words.
/// The pixel's place in its part.
pub(super) const W_INDEX: u32 = 0;
/// Its position, `x | y << 16`.
pub(super) const W_XY: u32 = 1;
/// Its next sample, advanced on the device as samples are added.
pub(super) const W_NEXT: u32 = 2;
/// The sample its round stops before.
pub(super) const W_END: u32 = 3;

// A dispatch's parameters: eight words, a uniform at a dynamic offset (PARAMS_SLOT bytes
// apart).
/// The first work entry, and the entries, one invocation each.
pub(super) const P_FIRST: u32 = 0;
pub(super) const P_ENTRIES: u32 = 1;
/// Samples an invocation takes at most.
pub(super) const P_SAMPLES: u32 = 2;
/// Pixels of the part: words a plane.
pub(super) const P_PIXELS: u32 = 3;
/// Loop iterations after which an invocation starts no other sample.
pub(super) const P_BUDGET: u32 = 4;
/// Zero, which the shader cannot know before it runs (trace.wgsl, opaque).
pub(super) const P_ZERO: u32 = 5;
pub(super) const PARAMS_WORDS: u32 = 8;

// A dispatch's counts, pairs of words (low, high), at a dynamic offset (COUNTS_SLOT bytes apart).
/// Samples added.
pub(super) const C_SAMPLES: u32 = 0;
/// Rays traced for them.
pub(super) const C_RAYS: u32 = 2;
/// Samples that were not finite, counted as black.
pub(super) const C_NON_FINITE: u32 = 4;
/// Invocations cut by the device's loop limit (trace.wgsl, window): windows discarded.
pub(super) const C_CUT: u32 = 6;
pub(super) const COUNTER_WORDS: u32 = 8;

/// Bytes between two dispatches' parameters, and their counts: the largest offset alignment
/// a device may ask for a dynamic binding (WebGPU's limits allow 256).
pub(super) const SLOT_BYTES: u64 = 256;

/// The test entry point's words per sample (trace.wgsl, numbers).
pub(super) const NUMBERS: u32 = 17;

/// Pass sums a pixel may have, at most: every pass's ([`raytrace_core::passes::SumLayout`]: the hit
/// count, depth, normal, albedo and motion).
pub(super) const MAX_STRIDE: u32 = 12;

/// Threads of a workgroup.
pub(super) const WORKGROUP: u32 = 64;

/// Bindings the shot's words, and the frame's, may each span at most ([`super::pages`]).
pub(super) const MAX_PAGES: u32 = 4;
/// The binding of the shot's first page; its others follow.
pub(super) const SHOT_PAGES: u32 = 8;
/// The binding of the frame's first page; its others follow.
pub(super) const FRAME_PAGES: u32 = SHOT_PAGES + MAX_PAGES;
/// The binding of the frame's words read a word at a time (`fu`) by a tracer of one page: its
/// one page again, as `array<u32>`, so that a word is one load rather than an element picked
/// out of a quad by a dynamic index.
pub(super) const FRAME_WORDS: u32 = 1;

// Records' fields lie inside their records; every record is whole quads, and a three-word
// field never straddles two quads.
const _: () = {
    assert!(S_MOTION < SPHERE_WORDS && M_IOR < MATERIAL_WORDS);
    assert!(PT_LOOK < POINT_WORDS && L_MATERIAL < LOOK_WORDS && G_POINTS < POINT_GROUP_WORDS);
    assert!(MO_C + 3 <= MOTION_WORDS && E_UPPER_CHANGE + 3 <= ENTRY_WORDS);
    let records = [
        SPHERE_WORDS,
        POINT_WORDS,
        LOOK_WORDS,
        POINT_GROUP_WORDS,
        MATERIAL_WORDS,
        MOTION_WORDS,
        KEY_WORDS,
        ENTRY_WORDS,
    ];
    let mut i = 0;
    while i < records.len() {
        assert!(records[i].is_multiple_of(4));
        i += 1;
    }
    let fields = [
        S_CENTER,
        S_VELOCITY,
        PT_CENTER,
        PT_VELOCITY,
        L_TINT,
        M_ALBEDO,
        MO_A,
        MO_B,
        MO_C,
        E_LOWER,
        E_UPPER,
        E_LOWER_CHANGE,
        E_UPPER_CHANGE,
    ];
    let mut i = 0;
    while i < fields.len() {
        assert!(fields[i] % 4 < 2);
        i += 1;
    }
};

/// Every constant the shaders use, by name.
const CONSTANTS: &[(&str, u32)] = &[
    ("NONE", NONE),
    ("H_WIDTH", H_WIDTH),
    ("H_HEIGHT", H_HEIGHT),
    ("H_MAX_DEPTH", H_MAX_DEPTH),
    ("H_FLAGS", H_FLAGS),
    ("H_KEY", H_KEY),
    ("H_DURATION", H_DURATION),
    ("H_SHUTTER", H_SHUTTER),
    ("H_READOUT", H_READOUT),
    ("H_CURVE", H_CURVE),
    ("H_CURVE_N", H_CURVE_N),
    ("H_BACKGROUND", H_BACKGROUND),
    ("H_PERIOD", H_PERIOD),
    ("H_STRIDE", H_STRIDE),
    ("H_SLOTS", H_SLOTS),
    ("H_VIEW", H_VIEW),
    ("H_CAM_FROM", H_CAM_FROM),
    ("H_CAM_AT", H_CAM_AT),
    ("H_CAM_UP", H_CAM_UP),
    ("H_CAM_TAN", H_CAM_TAN),
    ("H_CAM_LENS", H_CAM_LENS),
    ("H_CAM_FOCUS", H_CAM_FOCUS),
    ("H_STILL_SPHERES", H_STILL_SPHERES),
    ("H_STILL_ENTRIES", H_STILL_ENTRIES),
    ("H_STILL_ENTRY_N", H_STILL_ENTRY_N),
    ("H_MOVING_SPHERES", H_MOVING_SPHERES),
    ("H_MOVING_ENTRIES", H_MOVING_ENTRIES),
    ("H_MOVING_ENTRY_N", H_MOVING_ENTRY_N),
    ("H_MATERIALS", H_MATERIALS),
    ("H_TABLES", H_TABLES),
    ("H_PASS_MOTIONS", H_PASS_MOTIONS),
    ("H_POINTS", H_POINTS),
    ("H_POINT_GROUPS", H_POINT_GROUPS),
    ("H_POINT_GROUP_N", H_POINT_GROUP_N),
    ("H_FIRST_POINT", H_FIRST_POINT),
    ("H_LOOKS", H_LOOKS),
    ("F_SOBOL", F_SOBOL),
    ("F_TIME", F_TIME),
    ("F_LENS", F_LENS),
    ("F_CAMERA_MOVES", F_CAMERA_MOVES),
    ("F_TRANSPARENT", F_TRANSPARENT),
    ("F_ROLLING", F_ROLLING),
    ("F_BOTTOM_TO_TOP", F_BOTTOM_TO_TOP),
    ("F_UNIFORM", F_UNIFORM),
    ("F_CAMERA_ANIMATED", F_CAMERA_ANIMATED),
    ("F_FOCUS", F_FOCUS),
    ("SPHERE_WORDS", SPHERE_WORDS),
    ("S_CENTER", S_CENTER),
    ("S_RADIUS", S_RADIUS),
    ("S_VELOCITY", S_VELOCITY),
    ("S_MATERIAL", S_MATERIAL),
    ("S_ID", S_ID),
    ("S_MOTION", S_MOTION),
    ("POINT_WORDS", POINT_WORDS),
    ("PT_CENTER", PT_CENTER),
    ("PT_RADIUS", PT_RADIUS),
    ("PT_VELOCITY", PT_VELOCITY),
    ("PT_LOOK", PT_LOOK),
    ("LOOK_WORDS", LOOK_WORDS),
    ("L_TINT", L_TINT),
    ("L_MATERIAL", L_MATERIAL),
    ("POINT_GROUP_WORDS", POINT_GROUP_WORDS),
    ("G_ENTRIES", G_ENTRIES),
    ("G_ENTRY_N", G_ENTRY_N),
    ("G_POINTS", G_POINTS),
    ("MATERIAL_WORDS", MATERIAL_WORDS),
    ("M_KIND", M_KIND),
    ("M_ALBEDO", M_ALBEDO),
    ("M_FUZZ", M_FUZZ),
    ("M_IOR", M_IOR),
    ("LAMBERTIAN", LAMBERTIAN),
    ("METAL", METAL),
    ("DIELECTRIC", DIELECTRIC),
    ("MO_KIND", MO_KIND),
    ("MO_SHIFT", MO_SHIFT),
    ("MO_A", MO_A),
    ("MO_B", MO_B),
    ("MO_C", MO_C),
    ("MO_DEGREES", MO_DEGREES),
    ("MO_DEGREES_PER_SECOND", MO_DEGREES_PER_SECOND),
    ("FIXED", FIXED),
    ("LINE", LINE),
    ("CIRCLE", CIRCLE),
    ("KEYS", KEYS),
    ("KEY_WORDS", KEY_WORDS),
    ("ENTRY_WORDS", ENTRY_WORDS),
    ("E_LOWER", E_LOWER),
    ("E_SKIP", E_SKIP),
    ("E_UPPER", E_UPPER),
    ("E_COUNT", E_COUNT),
    ("E_LOWER_CHANGE", E_LOWER_CHANGE),
    ("E_FIRST", E_FIRST),
    ("E_UPPER_CHANGE", E_UPPER_CHANGE),
    ("FILM_SUM", FILM_SUM),
    ("FILM_SUM_LOW", FILM_SUM_LOW),
    ("FILM_ODD", FILM_ODD),
    ("FILM_PASSES", FILM_PASSES),
    ("W_INDEX", W_INDEX),
    ("W_XY", W_XY),
    ("W_NEXT", W_NEXT),
    ("W_END", W_END),
    ("P_FIRST", P_FIRST),
    ("P_ENTRIES", P_ENTRIES),
    ("P_SAMPLES", P_SAMPLES),
    ("P_PIXELS", P_PIXELS),
    ("P_BUDGET", P_BUDGET),
    ("P_ZERO", P_ZERO),
    ("C_SAMPLES", C_SAMPLES),
    ("C_RAYS", C_RAYS),
    ("C_NON_FINITE", C_NON_FINITE),
    ("C_CUT", C_CUT),
    ("COUNTER_WORDS", COUNTER_WORDS),
    ("NUMBERS", NUMBERS),
    ("MAX_STRIDE", MAX_STRIDE),
    ("WORKGROUP", WORKGROUP),
];

/// How a dispatch's invocations add to its counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Counting {
    /// A subgroup's values summed first, then one atomic addition (devices with subgroups).
    Subgroups,
    /// An atomic addition per invocation of what it counted, when not zero.
    Atomics,
}

/// What the shaders' text is put after: the constants as WGSL declarations
/// (`const H_WIDTH: u32 = 0u;`); the pages of the shot's and the frame's words as `pages`
/// lays them on the device, and `quad(src, i)`, which reads the quad of word `i` (a multiple
/// of four) of the shot's (`src` 0) or the frame's (1) words from its page;
/// `store_passes(i, px)`, which stores pixel `i`'s pass sums one by one without a loop
/// (trace.wgsl, window: a loop there could be cut halfway); `count(k, v)`, which adds an
/// invocation's `v` to the dispatch's count `k` (trace.wgsl, dispatch_add).
pub(super) fn wgsl_prelude(counting: Counting, pages: &Pages) -> String {
    // (naga takes subgroup operations where the device was opened with wgpu's `SUBGROUP`
    // feature, without WGSL's `enable subgroups`, which it does not parse yet.)
    let mut text = String::new();
    for (name, value) in CONSTANTS {
        text += &format!("const {name}: u32 = {value}u;\n");
    }
    text += &paged_reads(pages);
    text += "fn store_passes(i: u32, px: u32) {\n";
    for k in 0..MAX_STRIDE {
        text += &format!("    if g_stride > {k}u {{ store_pass({k}u, i, px); }}\n");
    }
    text += "}\n";
    text + match counting {
        // Each count an invocation adds is below 2^32 (its samples, rays, non-finite samples,
        // cuts): summed as 16-bit halves, a subgroup's sums stay below 2^32 too.
        Counting::Subgroups => {
            "fn count(k: u32, v: vec2<u32>) {
    let low = subgroupAdd(v.x & 0xffffu);
    let mid = subgroupAdd(v.x >> 16u);
    let high = subgroupAdd(v.y);
    // The subgroup's first active invocation (naga has no subgroupElect).
    if subgroupExclusiveAdd(1u) == 0u {
        let sum = add64(vec2<u32>(low, high), vec2<u32>(mid << 16u, mid >> 16u));
        if sum.x != 0u || sum.y != 0u {
            dispatch_add(k, sum);
        }
    }
}
"
        }
        Counting::Atomics => {
            "fn count(k: u32, v: vec2<u32>) {
    if v.x != 0u || v.y != 0u {
        dispatch_add(k, v);
    }
}
"
        }
    }
}

/// The page bindings of the shot's and the frame's words (`shot_page0`, ...) and `quad`,
/// which finds a quad's page by a shift and its place in the page by a mask: a page holds
/// `2^k` words, a power of two ([`Pages`]); and `fu(i)`, word `i` of the frame's words, read
/// from the one page's word view ([`FRAME_WORDS`]) where there is one page.
fn paged_reads(pages: &Pages) -> String {
    let mut text = String::new();
    let quads = pages.page_words() / 4;
    let shift = quads.trailing_zeros();
    text += "fn quad(src: u32, i: u32) -> vec4<u32> {\n    let q = i >> 2u;\n";
    if pages.count() > 1 {
        text += &format!(
            "    let page = q >> {shift}u;\n    let at = q & {}u;\n",
            quads - 1
        );
    } else {
        text += "    let at = q;\n";
    }
    for (src, name, first) in [(0, "shot", SHOT_PAGES), (1, "frame", FRAME_PAGES)] {
        for k in 0..pages.count() {
            text = format!(
                "@group(0) @binding({}) var<storage, read> {name}_page{k}: array<vec4<u32>>;\n{text}",
                first + k
            );
        }
        // The last page takes what the others do not: no branch is left without a return.
        text += &format!("    if src == {src}u {{\n");
        for k in 0..pages.count() - 1 {
            text += &format!("        if page == {k}u {{ return {name}_page{k}[at]; }}\n");
        }
        text += &format!(
            "        return {name}_page{}[at];\n    }}\n",
            pages.count() - 1
        );
    }
    text += "    return vec4<u32>(0u);\n}\n";
    // A word of the frame's: where its words are one page, read from that page's word view.
    if pages.count() == 1 {
        text += &format!(
            "@group(0) @binding({FRAME_WORDS}) var<storage, read> frame_words: array<u32>;\n\
             fn fu(i: u32) -> u32 {{ return frame_words[i]; }}\n"
        );
    } else {
        text += "fn fu(i: u32) -> u32 { return quad(1u, i & ~3u)[i & 3u]; }\n";
    }
    text
}

/// A buffer's words as it is written, with the offsets of what was appended.
#[derive(Clone, Debug, Default)]
pub(super) struct Words(pub(super) Vec<u32>);

impl Words {
    /// The offset the next word will have.
    pub(super) fn at(&self) -> u32 {
        self.0.len() as u32
    }

    pub(super) fn u(&mut self, w: u32) {
        self.0.push(w);
    }

    pub(super) fn f(&mut self, x: f64) {
        self.0.push((x as f32).to_bits());
    }

    pub(super) fn v(&mut self, v: glam::DVec3) {
        self.f(v.x);
        self.f(v.y);
        self.f(v.z);
    }

    /// Zero words up to the next multiple of four: where the next record starts.
    pub(super) fn align(&mut self) {
        while !self.at().is_multiple_of(4) {
            self.u(0);
        }
    }

    /// Zero words up to `n` words since `start`.
    pub(super) fn pad_to(&mut self, start: u32, n: u32) {
        while self.at() < start + n {
            self.u(0);
        }
    }

    /// Sets word `i` (already written).
    pub(super) fn set(&mut self, i: u32, w: u32) {
        self.0[i as usize] = w;
    }

    pub(super) fn set_f(&mut self, i: u32, x: f64) {
        self.set(i, (x as f32).to_bits());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_have_distinct_names_and_header_fields_do_not_overlap() {
        let mut names: Vec<&str> = CONSTANTS.iter().map(|c| c.0).collect();
        names.sort_unstable();
        let n = names.len();
        names.dedup();
        assert_eq!(names.len(), n);
        // Header fields in order, with their sizes: each starts where the last ends.
        let fields = [
            (H_WIDTH, 1),
            (H_HEIGHT, 1),
            (H_MAX_DEPTH, 1),
            (H_FLAGS, 1),
            (H_KEY, 2),
            (H_DURATION, 1),
            (H_SHUTTER, 1),
            (H_READOUT, 1),
            (H_CURVE, 1),
            (H_CURVE_N, 1),
            (H_BACKGROUND, 3),
            (H_PERIOD, 1),
            (H_STRIDE, 1),
            (H_SLOTS, 5),
            (H_VIEW, 19),
            (H_CAM_FROM, 1),
            (H_CAM_AT, 1),
            (H_CAM_UP, 3),
            (H_CAM_TAN, 1),
            (H_CAM_LENS, 1),
            (H_CAM_FOCUS, 1),
            (H_STILL_SPHERES, 1),
            (H_STILL_ENTRIES, 1),
            (H_STILL_ENTRY_N, 1),
            (H_MOVING_SPHERES, 1),
            (H_MOVING_ENTRIES, 1),
            (H_MOVING_ENTRY_N, 1),
            (H_MATERIALS, 1),
            (H_TABLES, 1),
            (H_PASS_MOTIONS, 1),
            (H_POINTS, 1),
            (H_POINT_GROUPS, 1),
            (H_POINT_GROUP_N, 1),
            (H_FIRST_POINT, 1),
            (H_LOOKS, 1),
        ];
        let mut next = 0;
        for (at, len) in fields {
            assert_eq!(at, next);
            next += len;
        }
        assert_eq!(next, HEADER_WORDS);
        for counting in [Counting::Subgroups, Counting::Atomics] {
            let text = wgsl_prelude(counting, &Pages::guaranteed());
            assert!(text.contains("const H_VIEW: u32 = 21u;\n"));
            assert!(text.contains("if g_stride > 11u { store_pass(11u, i, px); }"));
            assert!(!text.contains("12u, i"));
            assert_eq!(
                text.contains("subgroupAdd"),
                counting == Counting::Subgroups
            );
        }
    }
}
