// The buffers, read as 32-bit words (see layout.rs), and integer arithmetic: WGSL has no
// 64-bit integers, so the CPU samplers' 64-bit hashes and PCG32 state are pairs of u32
// (low, high), with the same results bit for bit.

// The shot's words (what every frame of the shot shares: materials, Sobol tables, still
// spheres, their hierarchy) and the frame's (its header, curve, camera motion, animated
// spheres, their hierarchy and motions, its points, their hierarchies and looks) are bound as pages of quads, which the prelude
// declares with `quad(src, i)`, the quad holding word `i` (a multiple of four) of the shot's
// (`src` 0) or the frame's (1) words (pages.rs). Records start at multiples of four words
// and are read a quad at a time (one load instead of four).
// The round's work in this part of the film, an entry per pixel with samples to take (layout.rs,
// W_*); an entry's next sample advances as samples are added.
@group(0) @binding(2) var<storage, read_write> work: array<vec4<u32>>;
// This part of the film on the device: its planes of sums (layout.rs, FILM_*).
@group(0) @binding(3) var<storage, read_write> film: array<u32>;
// This dispatch's parameters (layout.rs, P_*).
@group(0) @binding(4) var<uniform> params: array<vec4<u32>, 2>;
// This dispatch's counts (layout.rs, C_*), summed with atomics: integer sums, the same in any
// order.
@group(0) @binding(7) var<storage, read_write> counters: array<atomic<u32>, COUNTER_WORDS>;

// A word (`fu`, which the prelude declares), a float and three floats of the frame's words.
fn ff(i: u32) -> f32 { return bitcast<f32>(fu(i)); }
fn fv(i: u32) -> vec3<f32> { return vec3<f32>(ff(i), ff(i + 1u), ff(i + 2u)); }
fn fquad(i: u32) -> vec4<u32> { return quad(1u, i); }
fn xyz(q: vec4<u32>) -> vec3<f32> { return bitcast<vec3<f32>>(q.xyz); }

// The header's words used per sample, read once per run (every load costs on a software
// device).
var<private> g_flags: u32;
var<private> g_key: vec2<u32>;
var<private> g_height: f32;
var<private> g_max_depth: u32;
var<private> g_duration: f32;
var<private> g_stride: u32;
var<private> g_tables: u32;
var<private> g_materials: u32;
// Each hierarchy's entries, entry count and spheres: the shot's (still) and the frame's.
var<private> g_still: vec3<u32>;
var<private> g_moving: vec3<u32>;
// The points' records and the first point's number as a sphere; their groups and the
// groups' count; their looks.
var<private> g_points: vec2<u32>;
var<private> g_point_groups: vec2<u32>;
var<private> g_looks: u32;
// Loop iterations so far in this invocation (every loop body counts one, and every entry into
// a loop one, as lavapipe counts them): an invocation stops starting samples past a budget
// (trace.wgsl).
var<private> g_iters: u32;

fn load_header() {
    g_flags = fu(H_FLAGS);
    g_key = vec2<u32>(fu(H_KEY), fu(H_KEY + 1u));
    g_height = f32(fu(H_HEIGHT));
    g_max_depth = fu(H_MAX_DEPTH);
    g_duration = ff(H_DURATION);
    g_stride = fu(H_STRIDE);
    g_tables = fu(H_TABLES);
    g_materials = fu(H_MATERIALS);
    g_still = vec3<u32>(fu(H_STILL_ENTRIES), fu(H_STILL_ENTRY_N), fu(H_STILL_SPHERES));
    g_moving = vec3<u32>(fu(H_MOVING_ENTRIES), fu(H_MOVING_ENTRY_N), fu(H_MOVING_SPHERES));
    g_points = vec2<u32>(fu(H_POINTS), fu(H_FIRST_POINT));
    g_point_groups = vec2<u32>(fu(H_POINT_GROUPS), fu(H_POINT_GROUP_N));
    g_looks = fu(H_LOOKS);
}

fn flag(f: u32) -> bool { return (g_flags & f) != 0u; }

// The largest finite f32: "no hit yet".
const FAR: f32 = 3.4028234e38;

// Whether every component is finite (WGSL has no isnan; the exponent bits tell).
fn finite3(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return all(e != vec3<u32>(0x7f800000u));
}

// 64-bit integers as (low, high).
fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

// The full 64-bit product of two u32, from 16-bit halves.
fn mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((mid << 16u) | (p00 & 0xffffu), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

// The low 64 bits of a 64-bit product (wrapping, as Rust's wrapping_mul).
fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = mul_wide(a.x, b.x);
    return vec2<u32>(lo.x, lo.y + a.x * b.y + a.y * b.x);
}

// a >> n for n in 1..=63.
fn shr64(a: vec2<u32>, n: u32) -> vec2<u32> {
    if n >= 32u {
        return vec2<u32>(a.y >> (n - 32u), 0u);
    }
    return vec2<u32>((a.x >> n) | (a.y << (32u - n)), a.y >> n);
}

// SplitMix64's finaliser (rng.rs, mix64).
fn mix64(x0: vec2<u32>) -> vec2<u32> {
    var x = add64(x0, vec2<u32>(0x7f4a7c15u, 0x9e3779b9u));
    x = mul64(x ^ shr64(x, 30u), vec2<u32>(0x1ce4e5b9u, 0xbf58476du));
    x = mul64(x ^ shr64(x, 27u), vec2<u32>(0x133111ebu, 0x94d049bbu));
    return x ^ shr64(x, 31u);
}

// PCG32 (rng.rs): the multiplier 6364136223846793005, a step, and the XSH-RR output.
const PCG_MUL: vec2<u32> = vec2<u32>(0x4c957f2du, 0x5851f42du);

fn pcg_step(state: vec2<u32>, inc: vec2<u32>) -> vec2<u32> {
    return add64(mul64(state, PCG_MUL), inc);
}

fn pcg_output(old: vec2<u32>) -> u32 {
    let xs = shr64(old ^ shr64(old, 18u), 27u).x;
    let rot = old.y >> 27u;
    return (xs >> rot) | (xs << ((32u - rot) & 31u));
}

// sobol_burley's hash and Owen scramble of a reversed index (parts.rs), on one or four lanes.
fn hash32(n0: u32) -> u32 {
    var n = n0 ^ 0xe6fe3bebu;
    n ^= n >> 16u;
    n *= 0x7feb352du;
    n ^= n >> 15u;
    n *= 0x846ca68bu;
    n ^= n >> 16u;
    return n;
}

fn hash4(n0: vec4<u32>) -> vec4<u32> {
    var n = n0 ^ vec4<u32>(0xe6fe3bebu);
    n ^= n >> vec4<u32>(16u);
    n *= vec4<u32>(0x7feb352du);
    n ^= n >> vec4<u32>(15u);
    n *= vec4<u32>(0x846ca68bu);
    n ^= n >> vec4<u32>(16u);
    return n;
}

fn owen_rev(n0: u32, scramble: u32) -> u32 {
    var n = n0;
    n ^= n * 0x3d20adeau;
    n += scramble;
    n *= (scramble >> 16u) | 1u;
    n ^= n * 0x05526c56u;
    n ^= n * 0x53a22864u;
    return n;
}

fn owen4_rev(n0: vec4<u32>, scramble: vec4<u32>) -> vec4<u32> {
    var n = n0;
    n ^= n * vec4<u32>(0x3d20adeau);
    n += scramble;
    n *= (scramble >> vec4<u32>(16u)) | vec4<u32>(1u);
    n ^= n * vec4<u32>(0x05526c56u);
    n ^= n * vec4<u32>(0x53a22864u);
    return n;
}
