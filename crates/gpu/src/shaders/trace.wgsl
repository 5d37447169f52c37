// The path tracer (tracer.rs and renderer/tiles.rs): one invocation takes a window of one
// pixel's samples, in sample order, and adds them to the pixel's sums in the film on the
// device, with their passes (passes.rs).

// The pixel's pass sums, at the slots the film keeps them in: compensated, high and low words.
var<private> pass_hi: array<f32, MAX_STRIDE>;
var<private> pass_lo: array<f32, MAX_STRIDE>;
// Rays traced by the invocation, (low, high).
var<private> rays: vec2<u32>;
// A zero the compiler cannot see (P_ZERO): see `opaque`.
var<private> g_zero: u32;

fn slot(k: u32) -> u32 {
    return fu(H_SLOTS + k);
}

// `x`, through an operation the compiler cannot see through: the compensated sums' error
// terms, `(a + b) - a` and the like, are not algebra a driver may simplify (Mesa's NIR
// rewrites `(a + b) - a` to `b` in instructions not marked exact, and naga marks none), so
// their operands come through this XOR with a zero known only when the shader runs.
fn opaque(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) ^ g_zero);
}

fn opaque3(x: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(x) ^ vec3<u32>(g_zero));
}

// `(hi, lo) += v`, a float-float sum (Dekker 1971; Knuth, TAOCP 2, 4.2.2): Knuth's TwoSum
// finds the rounding error `e` of `hi + v` exactly, `e + lo` is the new low part, and Dekker's
// FastTwoSum renormalises the pair so that `lo` stays within half an ulp of `hi`. The pair keeps
// about 48 bits: each addition errs by at most about 2^-48 of the sum, where a plain `f32` sum
// errs by 2^-24 (and a low word summed plainly, without renormalising, gathers errors that
// grow with it: 2.6e-7 of the mean on 65,536 equal samples, against 0 here).
fn two_sum(hi: f32, lo: f32, v: f32) -> vec2<f32> {
    let s = opaque(hi + v);
    let b = opaque(s - hi);
    let e = ((hi - (s - b)) + (v - b)) + lo;
    let h = opaque(s + e);
    return vec2<f32>(h, e - opaque(h - s));
}

fn two_sum3(hi: vec3<f32>, lo: vec3<f32>, v: vec3<f32>) -> array<vec3<f32>, 2> {
    let s = opaque3(hi + v);
    let b = opaque3(s - hi);
    let e = ((hi - (s - b)) + (v - b)) + lo;
    let h = opaque3(s + e);
    return array<vec3<f32>, 2>(h, e - opaque3(h - s));
}

fn add_slot(k: u32, v: f32) {
    let r = two_sum(pass_hi[k], pass_lo[k], v);
    pass_hi[k] = r.x;
    pass_lo[k] = r.y;
}

fn add_pass(at: u32, v: vec3<f32>, n: u32) {
    for (var i = 0u; i < n; i++) {
        add_slot(at + i, v[i]);
    }
}

// The displacements in pixels (u right, v up) of the point `p` of what was struck (`h`) at
// time `t`, seen through `view`, to where it is one frame period later (xy) and earlier (zw).
// A sphere moves by its path over the shot (its record for the pass), a point of a cache on
// its line (passes.rs).
fn motion_vectors(p: vec3<f32>, h: Struck, t: f32, view: View) -> vec4<f32> {
    var record = NONE;
    if !h.point {
        record = fu(fu(H_PASS_MOTIONS) + h.prim.id);
    }
    var centre = p;
    if record != NONE {
        centre = motion_at(record, t);
    }
    let here = project(view, p);
    var mv = vec4<f32>(0.0);
    for (var k = 0u; k < 2u; k++) {
        let t2 = t + select(-1.0, 1.0, k == 0u) * ff(H_PERIOD);
        var p2 = p;
        if record != NONE {
            p2 = motion_at(record, t2) + (p - centre);
        }
        if h.point {
            p2 = p + h.velocity * (t2 - t);
        }
        var v2 = fixed_view();
        if flag(F_CAMERA_ANIMATED) {
            v2 = view_at(t2);
        }
        let d = project(v2, p2) - here;
        // Image rows grow downward, v upward; a displacement that cannot be projected is 0.
        var m = vec2<f32>(d.x, -d.y);
        if !finite3(vec3<f32>(m, 0.0)) {
            m = vec2<f32>(0.0);
        }
        if k == 0u {
            mv = vec4<f32>(m, mv.zw);
        } else {
            mv = vec4<f32>(mv.xy, m);
        }
    }
    return mv;
}

// What a camera ray's first intersection (`h`, its surface `s`) adds to the passes
// (passes.rs, PassContext::record): `hit` false for a ray that missed or was not traced.
fn record_first(view: View, dir: vec3<f32>, hit: bool, s: Surface, h: Struck, t: f32) {
    if !hit {
        let b = background(dir);
        if finite3(b) && slot(3u) != NONE {
            add_pass(slot(3u), b, 3u);
        }
        return;
    }
    if slot(0u) != NONE {
        add_slot(slot(0u), 1.0);
    }
    if slot(1u) != NONE {
        add_slot(slot(1u), dot(s.p - view.origin, forward(view)));
    }
    if slot(2u) != NONE {
        add_pass(slot(2u), s.normal, 3u);
    }
    if slot(3u) != NONE {
        add_pass(slot(3u), albedo_of(h.material, h.tint), 3u);
    }
    if slot(4u) != NONE {
        let mv = motion_vectors(s.p, h, t, view);
        for (var i = 0u; i < 4u; i++) {
            add_slot(slot(4u) + i, mv[i]);
        }
    }
}

// One sample's radiance; `traced` false when its camera ray was not finite (a degenerate
// view), which the film counts as a non-finite sample.
struct Radiance {
    value: vec3<f32>,
    traced: bool,
}

fn radiance(x: u32, y: u32, index: u32) -> Radiance {
    start_sample(x, y, index);
    let cam = camera_numbers(flag(F_LENS), flag(F_TIME));
    var t = 0.0;
    if flag(F_TIME) {
        t = sample_time(cam.time, (f32(y) + cam.pixel.y) / g_height);
    }
    var view: View;
    if flag(F_CAMERA_MOVES) {
        view = view_at(t);
    } else {
        view = fixed_view();
    }
    let ray = camera_ray(view, x, y, cam.pixel, cam.lens);
    let passes = g_stride > 0u;
    let none = Surface(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    let nothing = Struck(Primitive(vec3<f32>(0.0), 0.0, 0u), 0u, vec3<f32>(1.0), false, vec3<f32>(0.0));
    if !(finite3(ray.origin) && finite3(ray.dir) && finite3(vec3<f32>(t))) {
        if passes {
            record_first(view, ray.dir, false, none, nothing, t);
        }
        return Radiance(vec3<f32>(0.0), false);
    }
    var o = ray.origin;
    var d = ray.dir;
    var throughput = vec3<f32>(1.0);
    var skip = NONE;
    let max_depth = g_max_depth;
    g_iters += 1u;
    for (var depth = 0u; depth < max_depth; depth++) {
        g_iters += 1u;
        rays = add64(rays, vec2<u32>(1u, 0u));
        let h = world_hit(o, d, t, skip);
        let found = h.t < FAR;
        var s = none;
        var k = nothing;
        if found {
            k = struck(h, t);
            s = surface_point(k.prim.center, k.prim.radius, o, d, h.t);
        }
        if depth == 0u && passes {
            record_first(view, d, found, s, k, t);
        }
        if !found {
            if depth == 0u && flag(F_TRANSPARENT) {
                return Radiance(vec3<f32>(0.0), true);
            }
            return Radiance(throughput * background(d), true);
        }
        let sc = scatter(k.material, k.tint, d, s.normal, next_bounce());
        if sc.absorbed {
            return Radiance(vec3<f32>(0.0), true);
        }
        throughput *= sc.attenuation;
        skip = NONE;
        if sc.leaves_outside {
            skip = k.prim.id;
        }
        o = offset_origin(s.p, s.error, s.normal, sc.dir);
        d = sc.dir;
    }
    return Radiance(vec3<f32>(0.0), true);
}

// What an invocation did: the samples it added, the rays they traced, those that were not
// finite, and whether it was cut (its window discarded, see `window`).
struct Done {
    samples: u32,
    rays: vec2<u32>,
    non_finite: u32,
    cut: u32,
}

// Word `k` of pixel `i`'s film, `px` pixels a plane.
fn film_at(k: u32, i: u32, px: u32) -> u32 {
    return k * px + i;
}

fn film_f(k: u32, i: u32, px: u32) -> f32 {
    return bitcast<f32>(film[film_at(k, i, px)]);
}

fn film_v(k: u32, i: u32, px: u32) -> vec3<f32> {
    return vec3<f32>(film_f(k, i, px), film_f(k + 1u, i, px), film_f(k + 2u, i, px));
}

fn store_v(k: u32, i: u32, px: u32, v: vec3<f32>) {
    film[film_at(k, i, px)] = bitcast<u32>(v.x);
    film[film_at(k + 1u, i, px)] = bitcast<u32>(v.y);
    film[film_at(k + 2u, i, px)] = bitcast<u32>(v.z);
}

// Pass sum `k` of pixel `i` stored (a call per sum in `store_passes`, layout.rs).
fn store_pass(k: u32, i: u32, px: u32) {
    film[film_at(FILM_PASSES + k, i, px)] = bitcast<u32>(pass_hi[k]);
    film[film_at(FILM_PASSES + g_stride + k, i, px)] = bitcast<u32>(pass_lo[k]);
}

// Work entry `e`'s next samples, at most P_SAMPLES of them, added to its pixel's sums. The
// samples are taken in order and added one by one, so a pixel's sums are the same however
// its samples were split into windows. After the first sample, no sample is started once the
// invocation has run P_BUDGET loop iterations.
//
// Mesa's software device (lavapipe) ends every loop of an invocation once its loops together
// have run 65,535 iterations, silently. Such a cut ends the sample loop below without its own
// exit: the window is then discarded (nothing stored, its entry not advanced) and counted, and
// the host takes the pixel's samples again in smaller windows, or says that a sample needs
// more than the device runs (renderer/device.rs). Nothing is stored with a loop: a cut
// between two stores would leave a pixel half added.
fn window(e: u32) -> Done {
    var done = Done(0u, vec2<u32>(0u), 0u, 0u);
    let w = work[e];
    let next = w[W_NEXT];
    let end = w[W_END];
    if next >= end {
        return done;
    }
    let n = min(end - next, params[0][P_SAMPLES]);
    let budget = params[1][P_BUDGET - 4u];
    let i = w[W_INDEX];
    let x = w[W_XY] & 0xffffu;
    let y = w[W_XY] >> 16u;
    let px = params[0][P_PIXELS];
    load_header();
    load_view();
    s_block = NONE;
    rays = vec2<u32>(0u);
    g_iters = 0u;
    var hi = film_v(FILM_SUM, i, px);
    var lo = film_v(FILM_SUM_LOW, i, px);
    var odd = film_v(FILM_ODD, i, px);
    for (var k = 0u; k < g_stride; k++) {
        pass_hi[k] = film_f(FILM_PASSES + k, i, px);
        pass_lo[k] = film_f(FILM_PASSES + g_stride + k, i, px);
    }
    var j = 0u;
    var finished = false;
    loop {
        if j == n || (j > 0u && g_iters >= budget) {
            finished = true;
            break;
        }
        g_iters += 1u;
        let index = next + j;
        let r = radiance(x, y, index);
        var v = r.value;
        // As the film: a sample that is not finite counts as black (and the host checks the
        // sums again, should a driver have folded this test away).
        if !(r.traced && finite3(v)) {
            v = vec3<f32>(0.0);
            done.non_finite += 1u;
        }
        let t = two_sum3(hi, lo, v);
        hi = t[0];
        lo = t[1];
        if (index & 1u) == 1u {
            odd += v;
        }
        j += 1u;
    }
    if !finished {
        return Done(0u, vec2<u32>(0u), 0u, 1u);
    }
    store_v(FILM_SUM, i, px, hi);
    store_v(FILM_SUM_LOW, i, px, lo);
    store_v(FILM_ODD, i, px, odd);
    store_passes(i, px);
    work[e][W_NEXT] = next + j;
    done.samples = j;
    done.rays = rays;
    return done;
}

// Adds the 64-bit `v` to the dispatch's count at `k` (low word) and `k + 1` (high word):
// each addition that wraps the low word carries one. (`count`, in the constants' prelude,
// sums a subgroup's values first where the device has subgroups: one atomic a subgroup.)
fn dispatch_add(k: u32, v: vec2<u32>) {
    let old = atomicAdd(&counters[k], v.x);
    let carry = select(0u, 1u, old + v.x < old);
    if v.y + carry != 0u {
        atomicAdd(&counters[k + 1u], v.y + carry);
    }
}

@compute @workgroup_size(WORKGROUP)
fn trace(@builtin(global_invocation_id) gid: vec3<u32>) {
    g_zero = params[1][P_ZERO - 4u];
    var done = Done(0u, vec2<u32>(0u), 0u, 0u);
    if gid.x < params[0][P_ENTRIES] {
        done = window(params[0][P_FIRST] + gid.x);
    }
    // (No loop: after a cut, every loop of this invocation ends after one pass.)
    count(C_SAMPLES, vec2<u32>(done.samples, 0u));
    count(C_RAYS, done.rays);
    count(C_NON_FINITE, vec2<u32>(done.non_finite, 0u));
    count(C_CUT, vec2<u32>(done.cut, 0u));
}

// The sampler's numbers, for the tests that hold them to the CPU's: per work entry (x, y,
// sample index, what the camera uses: 1 the lens, 2 the time), the pixel position, the lens
// position, the time number and four bounces' (uc, u.0, u.1): NUMBERS words each, in the
// film's buffer.
@compute @workgroup_size(WORKGROUP)
fn numbers(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= params[0][P_ENTRIES] {
        return;
    }
    let run = work[i];
    load_header();
    s_block = NONE;
    start_sample(run.x, run.y, run.z);
    let c = camera_numbers((run.w & 1u) != 0u, (run.w & 2u) != 0u);
    let at = i * NUMBERS;
    film[at] = bitcast<u32>(c.pixel.x);
    film[at + 1u] = bitcast<u32>(c.pixel.y);
    film[at + 2u] = bitcast<u32>(c.lens.x);
    film[at + 3u] = bitcast<u32>(c.lens.y);
    film[at + 4u] = bitcast<u32>(c.time);
    for (var k = 0u; k < 4u; k++) {
        let b = next_bounce();
        for (var j = 0u; j < 3u; j++) {
            film[at + 5u + 3u * k + j] = bitcast<u32>(b[j]);
        }
    }
}
