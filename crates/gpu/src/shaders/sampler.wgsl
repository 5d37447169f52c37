// The CPU's samplers (sampler.rs), drawing the same numbers: the independent sampler's
// PCG32 stream per sample, and the Owen-scrambled Sobol points of two interleaved replicates
// per pixel, with the same dimensions (pixel 0-1, lens 2-3, time 4, bounce k 5+3k). Numbers
// are f32 in [0, 1): the Sobol points are the CPU's own f32; the independent sampler's 32
// random bits are cut to 24 (the CPU keeps all 32 in f64).

struct Pcg {
    state: vec2<u32>,
    inc: vec2<u32>,
}

// One invocation samples one pixel: the sampler's state.
var<private> s_rng: Pcg;
// The independent stream's next dimension.
var<private> s_dim: u32;
var<private> s_bounce: u32;
// Sobol: the sample's replicate, its point's index in its block of 2^16, the block whose
// scrambles are computed (NONE: none yet), each replicate's seed, and per replicate and
// domain (pixel, camera, first bounce) the scramble's index shuffle and Owen seeds.
var<private> s_replicate: u32;
var<private> s_index: u32;
var<private> s_block: u32;
// (Named variables rather than arrays: software devices pay dearly for an array indexed
// per invocation.)
var<private> s_seed0: vec2<u32>;
var<private> s_seed1: vec2<u32>;
var<private> s_shuffle0: vec3<u32>;
var<private> s_shuffle1: vec3<u32>;
var<private> s_owen00: vec4<u32>;
var<private> s_owen01: vec4<u32>;
var<private> s_owen02: vec4<u32>;
var<private> s_owen10: vec4<u32>;
var<private> s_owen11: vec4<u32>;
var<private> s_owen12: vec4<u32>;

fn rng_seed(seed: vec2<u32>, stream: vec2<u32>) {
    s_rng.inc = vec2<u32>((stream.x << 1u) | 1u, (stream.y << 1u) | (stream.x >> 31u));
    s_rng.state = pcg_step(vec2<u32>(0u, 0u), s_rng.inc);
    s_rng.state = add64(s_rng.state, seed);
    s_rng.state = pcg_step(s_rng.state, s_rng.inc);
}

fn rng_next() -> u32 {
    let old = s_rng.state;
    s_rng.state = pcg_step(old, s_rng.inc);
    return pcg_output(old);
}

// 32 random bits as a number in [0, 1): the top 24, exactly.
fn unit(x: u32) -> f32 {
    return f32(x >> 8u) * (1.0 / 16777216.0);
}

// The independent sampler's dimension `d` (not before the last one drawn).
fn dimension(d: u32) -> f32 {
    g_iters += 1u;
    while s_dim < d {
        g_iters += 1u;
        rng_next();
        s_dim += 1u;
    }
    s_dim = d + 1u;
    return unit(rng_next());
}

// A scramble's Owen seeds and index shuffle from a 32-bit seed (sampler.rs, Scramble::new).
fn owen_seeds(seed: u32) -> vec4<u32> {
    let sc = seed * 0x9c8f2d3bu;
    return hash4(vec4<u32>(sc ^ 0x912f69bau, sc ^ 0x174f18abu, sc ^ 0x691e72cau, sc ^ 0xb40cc1b8u));
}

fn shuffle_seed(seed: u32) -> u32 {
    return hash32(seed ^ 0x79c68e4au);
}

// Domain `d`'s scramble seed of a replicate's seed.
fn domain_seed(seed: vec2<u32>, d: u32) -> u32 {
    let h = mix64(seed ^ vec2<u32>(d, 0u));
    return h.x ^ h.y;
}

// Replicate `r`'s seed and scrambles of the pixel (hashed to `h`) and block.
fn replicate_scrambles(h: vec2<u32>, block: u32, r: u32) -> vec2<u32> {
    let seed = mix64(h ^ vec2<u32>(block * 2u + r, 0u));
    let d0 = domain_seed(seed, 0u);
    let d1 = domain_seed(seed, 1u);
    let d2 = domain_seed(seed, 2u);
    if r == 0u {
        s_owen00 = owen_seeds(d0);
        s_owen01 = owen_seeds(d1);
        s_owen02 = owen_seeds(d2);
        s_shuffle0 = vec3<u32>(shuffle_seed(d0), shuffle_seed(d1), shuffle_seed(d2));
    } else {
        s_owen10 = owen_seeds(d0);
        s_owen11 = owen_seeds(d1);
        s_owen12 = owen_seeds(d2);
        s_shuffle1 = vec3<u32>(shuffle_seed(d0), shuffle_seed(d1), shuffle_seed(d2));
    }
    return seed;
}

fn start_sample(x: u32, y: u32, index: u32) {
    s_bounce = 0u;
    let pixel = vec2<u32>(x, y);
    let key = g_key;
    if flag(F_SOBOL) {
        s_replicate = index % 2u;
        let point = index / 2u;
        let block = point / 65536u;
        s_index = point % 65536u;
        if block != s_block {
            s_block = block;
            let h = mix64(key ^ pixel);
            s_seed0 = replicate_scrambles(h, block, 0u);
            s_seed1 = replicate_scrambles(h, block, 1u);
        }
    } else {
        let h = mix64(mix64(key ^ pixel) ^ vec2<u32>(index, 0u));
        rng_seed(h, shr64(h, 17u));
        s_dim = 0u;
    }
}

// The Sobol table's entry `i` (four words).
fn sobol_table(i: u32) -> vec4<u32> {
    return quad(0u, g_tables + 4u * i);
}

// The current sample's point of Sobol domain `d`: its first four dimensions.
fn sobol_point(d: u32) -> vec4<f32> {
    let odd = s_replicate == 1u;
    var owen = select(s_owen00, s_owen10, odd);
    if d == 1u {
        owen = select(s_owen01, s_owen11, odd);
    } else if d == 2u {
        owen = select(s_owen02, s_owen12, odd);
    }
    var i = s_index;
    if d != 0u {
        i = reverseBits(owen_rev(reverseBits(i), select(s_shuffle0, s_shuffle1, odd)[d]));
    }
    let sobol = sobol_table(i & 0xffu) ^ sobol_table(256u + ((i >> 8u) & 0xffu));
    let bits = reverseBits(owen4_rev(sobol, owen));
    return bitcast<vec4<f32>>((bits >> vec4<u32>(9u)) | vec4<u32>(0x3f800000u)) - vec4<f32>(1.0);
}

struct CameraNumbers {
    pixel: vec2<f32>,
    lens: vec2<f32>,
    time: f32,
}

fn camera_numbers(lens: bool, time: bool) -> CameraNumbers {
    var c = CameraNumbers(vec2<f32>(0.0), vec2<f32>(0.5), 0.5);
    if flag(F_SOBOL) {
        c.pixel = sobol_point(0u).xy;
        if lens || time {
            let q = sobol_point(1u);
            if lens {
                c.lens = q.xy;
            }
            if time {
                c.time = q.z;
            }
        }
    } else {
        let px = dimension(0u);
        let py = dimension(1u);
        c.pixel = vec2<f32>(px, py);
        if lens {
            let lx = dimension(2u);
            let ly = dimension(3u);
            c.lens = vec2<f32>(lx, ly);
        }
        if time {
            c.time = dimension(4u);
        }
    }
    return c;
}

// The next bounce's numbers: (uc, u.0, u.1).
fn next_bounce() -> vec3<f32> {
    let k = s_bounce;
    s_bounce += 1u;
    if flag(F_SOBOL) {
        if k == 0u {
            let p = sobol_point(2u);
            return vec3<f32>(p.z, p.x, p.y);
        }
        if k == 1u {
            let h = mix64(select(s_seed0, s_seed1, s_replicate == 1u) ^ mix64(vec2<u32>(s_index, 0u)));
            rng_seed(h, shr64(h, 17u));
        }
        let uc = unit(rng_next());
        let u0 = unit(rng_next());
        let u1 = unit(rng_next());
        return vec3<f32>(uc, u0, u1);
    }
    let d = 5u + 3u * k;
    let uc = dimension(d);
    let u0 = dimension(d + 1u);
    let u1 = dimension(d + 2u);
    return vec3<f32>(uc, u0, u1);
}
