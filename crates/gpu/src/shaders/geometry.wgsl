// Geometry in f32: paths, spheres (the CPU's robust intersection, sphere.rs), the
// hierarchies' traversal and the nearest hit of a ray at its time. A time `t` is the
// seconds since the frame's opening.

const PI: f32 = 3.14159265;
// pi / 2 in two parts, for an argument reduction that keeps its digits (Cody and Waite).
const HALF_PI_HI: f32 = 1.5707963705062866;
const HALF_PI_LO: f32 = -4.371139000186243e-8;

// (sin x, cos x), to about an ulp for |x| up to a few turns: the builtins' accuracy is the
// device's (Vulkan allows 2^-11 absolute), these are the same on every device. Cephes'
// polynomials on [-pi/4, pi/4] after removing a multiple of pi/2.
fn sin_cos(x: f32) -> vec2<f32> {
    let q = round(x * (2.0 / PI));
    let r = (x - q * HALF_PI_HI) - q * HALF_PI_LO;
    let r2 = r * r;
    let s = r + r * r2 * (-1.6666654611e-1 + r2 * (8.3321608736e-3 + r2 * -1.9515295891e-4));
    let c = 1.0 - 0.5 * r2 + r2 * r2 * (4.166664568298827e-2 + r2 * (-1.388731625493765e-3 + r2 * 2.443315711809948e-5));
    switch i32(q) & 3 {
        case 0: { return vec2<f32>(s, c); }
        case 1: { return vec2<f32>(c, -s); }
        case 2: { return vec2<f32>(-s, -c); }
        default: { return vec2<f32>(-c, s); }
    }
}

// (sin, cos) of an angle in degrees, reduced to [-180, 180) first.
fn sin_cos_degrees(d: f32) -> vec2<f32> {
    var a = d - 360.0 * floor(d / 360.0);
    if a >= 180.0 {
        a -= 360.0;
    }
    return sin_cos(a * (PI / 180.0));
}

// The position at `t` of the motion record at `m` (layout.rs: a point, a line, a circle, or
// keys interpolated linearly, held before the first and after the last).
fn motion_at(m: u32, t: f32) -> vec3<f32> {
    let head = fquad(m);
    let kind = head[MO_KIND];
    let tau = t + bitcast<f32>(head[MO_SHIFT]);
    let a = xyz(fquad(m + MO_A));
    if kind == FIXED {
        return a;
    }
    let b = fquad(m + MO_B);
    if kind == LINE {
        return a + xyz(b) * tau;
    }
    if kind == CIRCLE {
        let degrees = bitcast<f32>(head[MO_DEGREES]) + bitcast<f32>(head[MO_DEGREES_PER_SECOND]) * tau;
        let sc = sin_cos_degrees(degrees);
        return a + xyz(b) * sc.y + xyz(fquad(m + MO_C)) * sc.x;
    }
    let first = b.x;
    let n = b.y;
    if tau <= ff(first) {
        return fv(first + 1u);
    }
    let last = first + KEY_WORDS * (n - 1u);
    if tau >= ff(last) {
        return fv(last + 1u);
    }
    // Key `lo` is at or before tau, key `hi` after it.
    var lo = 0u;
    var hi = n - 1u;
    g_iters += 1u;
    while hi - lo > 1u {
        g_iters += 1u;
        let mid = (lo + hi) / 2u;
        if ff(first + KEY_WORDS * mid) <= tau {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let ka = bitcast<vec4<f32>>(fquad(first + KEY_WORDS * lo));
    let kb = bitcast<vec4<f32>>(fquad(first + KEY_WORDS * hi));
    let s = clamp((tau - ka.x) / (kb.x - ka.x), 0.0, 1.0);
    return (1.0 - s) * ka.yzw + s * kb.yzw;
}

// A sphere's record: its centre and radius, its velocity and material, its index and motion.
struct Sphere {
    center: vec3<f32>,
    radius: f32,
    velocity: vec3<f32>,
    material: u32,
    id: u32,
    motion: u32,
}

fn sphere_at(src: u32, at: u32) -> Sphere {
    let q0 = quad(src, at);
    let q1 = quad(src, at + 4u);
    let q2 = quad(src, at + 8u);
    return Sphere(xyz(q0), bitcast<f32>(q0.w), xyz(q1), q1.w, q2.x, q2.y);
}

// A sphere's centre at `t`.
fn center_at(s: Sphere, t: f32) -> vec3<f32> {
    if s.motion == NONE {
        return s.center + s.velocity * t;
    }
    return motion_at(s.motion, t);
}

// The nearest intersection in (0, t_max) of the ray `o + t d` (d of unit length) with the
// sphere at `c` of radius `r`, or -1: the discriminant from the ray's closest approach to the
// centre and the stable roots of Ray Tracing Gems, chapter 7 (sphere.rs, intersect).
fn intersect(c: vec3<f32>, r: f32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> f32 {
    let f = o - c;
    let b = dot(f, d);
    let rr = r * r;
    // Certain misses, with a margin for the device's rounding.
    let rr_up = rr * (1.0 + 16.0 * 1.1920929e-7);
    if b > 0.0 && dot(f, f) > rr_up {
        return -1.0;
    }
    let l = f - b * d;
    let l2 = dot(l, l);
    if l2 > rr_up {
        return -1.0;
    }
    let l_len = sqrt(l2);
    let disc = (r - l_len) * (r + l_len);
    // A tangent ray misses (its side cannot be told).
    if disc <= 0.0 {
        return -1.0;
    }
    let f_len = length(f);
    let cc = (f_len - r) * (f_len + r);
    let q = -(b + select(-1.0, 1.0, b >= 0.0) * sqrt(disc));
    var t0 = cc / q;
    var t1 = q;
    if t0 > t1 {
        t0 = q;
        t1 = cc / q;
    }
    if t0 > 0.0 && t0 < t_max {
        return t0;
    }
    if t1 > 0.0 && t1 < t_max {
        return t1;
    }
    return -1.0;
}

// Where the primitives a hierarchy's leaves hold lie: the shot's spheres (`src` 0, as `quad`
// names the shot's words), the frame's spheres (1) and the frame's points (POINTS, whose
// records are in the frame's words too).
const POINTS: u32 = 2u;

// The nearest hit so far: its distance (FAR: none), where its primitive lies (`src`) and the
// offset of its record.
struct Hit {
    t: f32,
    src: u32,
    sphere: u32,
}

// A leaf's primitive at time `t`: its centre, radius and number as a sphere.
struct Primitive {
    center: vec3<f32>,
    radius: f32,
    id: u32,
}

// The number as a sphere of the point whose record is at `at`: its place among the frame's
// points, after the scene's spheres.
fn point_id(at: u32) -> u32 {
    return g_points.y + (at - g_points.x) / POINT_WORDS;
}

// The primitive whose record is at `at` in `src` (a sphere's, or a point's: its centre at the
// frame's opening plus its velocity times `t`, as traced_points.rs places it), at time `t`.
fn primitive_at(src: u32, at: u32, t: f32) -> Primitive {
    if src == POINTS {
        let q0 = quad(1u, at + PT_CENTER);
        let q1 = quad(1u, at + PT_VELOCITY);
        return Primitive(xyz(q0) + xyz(q1) * t, bitcast<f32>(q0[PT_RADIUS - PT_CENTER]), point_id(at));
    }
    let sphere = sphere_at(src, at);
    return Primitive(center_at(sphere, t), sphere.radius, sphere.id);
}

// What a ray hit, for its shading and passes: the primitive at the hit's time, its material
// (its offset in the shot's words), the colour that multiplies the material's albedo (a
// point's colour; 1 for a sphere and a point without one, world.rs), and the velocity of a
// point's line for the motion pass (`point`: the primitive is a point).
struct Struck {
    prim: Primitive,
    material: u32,
    tint: vec3<f32>,
    point: bool,
    velocity: vec3<f32>,
}

fn struck(h: Hit, t: f32) -> Struck {
    let prim = primitive_at(h.src, h.sphere, t);
    if h.src == POINTS {
        let q1 = quad(1u, h.sphere + PT_VELOCITY);
        let look = fquad(g_looks + LOOK_WORDS * q1[PT_LOOK - PT_VELOCITY]);
        let m = g_materials + MATERIAL_WORDS * look[L_MATERIAL];
        return Struck(prim, m, bitcast<vec3<f32>>(look.xyz), true, xyz(q1));
    }
    let sphere = sphere_at(h.src, h.sphere);
    let m = g_materials + MATERIAL_WORDS * sphere.material;
    return Struck(prim, m, vec3<f32>(1.0), false, vec3<f32>(0.0));
}

// The ray against the hierarchy of the primitives of `src` (`n` entries from `entries`,
// depth first, its primitives' records from `spheres`) at time `t` (`s` of the shutter),
// skipping the sphere of index `skip`: a walk of the entries, into a node's children when the
// ray enters its box before the nearest hit so far, past its subtree otherwise (flatten.rs).
fn traverse(src: u32, entries: u32, n: u32, spheres: u32, o: vec3<f32>, d: vec3<f32>, inv: vec3<f32>, s: f32, t: f32, skip: u32, best: ptr<function, Hit>) {
    // The words the hierarchy lies in: the shot's, or the frame's (its spheres and points).
    let words = min(src, 1u);
    let stride = select(SPHERE_WORDS, POINT_WORDS, src == POINTS);
    var e = 0u;
    g_iters += 1u;
    while e < n {
        g_iters += 1u;
        let at = entries + ENTRY_WORDS * e;
        let q0 = quad(words, at);
        let q1 = quad(words, at + E_UPPER);
        let q2 = quad(words, at + E_LOWER_CHANGE);
        var lo = xyz(q0);
        var hi = xyz(q1);
        // A still hierarchy (the shot's) has no changes.
        if words == 1u {
            lo += s * xyz(q2);
            hi += s * xyz(quad(words, at + E_UPPER_CHANGE));
        }
        let a = (lo - o) * inv;
        let b = (hi - o) * inv;
        let n3 = min(a, b);
        let f3 = max(a, b);
        var tn = max(max(n3.x, n3.y), n3.z);
        var tf = min(min(f3.x, f3.y), f3.z);
        // Widened for the rounding of these few operations.
        tn -= abs(tn) * 9.5e-7;
        tf += abs(tf) * 9.5e-7;
        let enters = tn <= tf && tf >= 0.0 && tn < (*best).t;
        let count = q1.w;
        if enters && count == 0u {
            // A node: its children follow.
            e += 1u;
            continue;
        }
        if enters {
            let first = q2.w;
            g_iters += 1u;
            for (var i = first; i < first + count; i++) {
                g_iters += 1u;
                let record = spheres + stride * i;
                let p = primitive_at(src, record, t);
                if p.id == skip {
                    continue;
                }
                let th = intersect(p.center, p.radius, o, d, (*best).t);
                if th > 0.0 {
                    (*best).t = th;
                    (*best).src = src;
                    (*best).sphere = record;
                }
            }
        }
        e = q0.w;
    }
}

// The nearest sphere along the ray at time `t`, except sphere `skip`: the still spheres,
// then the animated ones before that distance, then each group's points before the nearest
// of those (as world.rs).
fn world_hit(o: vec3<f32>, d: vec3<f32>, t: f32, skip: u32) -> Hit {
    var best = Hit(FAR, 0u, 0u);
    // Reciprocals of direction components no smaller than 1e-18 in magnitude.
    let tiny = vec3<f32>(1e-18);
    let safe = select(max(d, tiny), min(d, -tiny), d < vec3<f32>(0.0));
    let inv = 1.0 / safe;
    var s = 0.0;
    if g_duration > 0.0 {
        s = clamp(t / g_duration, 0.0, 1.0);
    }
    traverse(0u, g_still.x, g_still.y, g_still.z, o, d, inv, s, t, skip, &best);
    traverse(1u, g_moving.x, g_moving.y, g_moving.z, o, d, inv, s, t, skip, &best);
    g_iters += 1u;
    for (var k = 0u; k < g_point_groups.y; k++) {
        g_iters += 1u;
        let group = fquad(g_point_groups.x + POINT_GROUP_WORDS * k);
        traverse(POINTS, group[G_ENTRIES], group[G_ENTRY_N], group[G_POINTS], o, d, inv, s, t, skip, &best);
    }
    return best;
}

// A point on a sphere: the hit point projected onto it, its error bound and unit normal.
struct Surface {
    p: vec3<f32>,
    error: vec3<f32>,
    normal: vec3<f32>,
}

// Error bounds of the projected point in f32, twice pbrt-v4's gamma(5) and gamma(1) (the
// device's square root and division may be off by more than half an ulp).
const RELATIVE_ERROR: f32 = 6.0e-7;
const ABSOLUTE_ERROR: f32 = 1.2e-7;

fn surface_point(c: vec3<f32>, r: f32, o: vec3<f32>, d: vec3<f32>, t: f32) -> Surface {
    let rel = (o - c) + t * d;
    let len = length(rel);
    var n = -d;
    if len > 0.0 {
        n = rel / len;
    }
    let onto = n * r;
    let p = c + onto;
    return Surface(p, RELATIVE_ERROR * abs(onto) + ABSOLUTE_ERROR * abs(p), n);
}

// The next f32 away from `x` in the direction of `dir`'s sign (0: `x`).
fn nudge(x: f32, dir: f32) -> f32 {
    if dir == 0.0 {
        return x;
    }
    if x == 0.0 {
        return select(-1.1754944e-38, 1.1754944e-38, dir > 0.0);
    }
    let b = bitcast<u32>(x);
    if (x > 0.0) == (dir > 0.0) {
        return bitcast<f32>(b + 1u);
    }
    return bitcast<f32>(b - 1u);
}

// The origin of a ray leaving `p` in direction `w`, past the error box on `w`'s side of the
// normal (ray.rs, offset_origin).
fn offset_origin(p: vec3<f32>, error: vec3<f32>, n: vec3<f32>, w: vec3<f32>) -> vec3<f32> {
    var offset = dot(abs(n), error) * n;
    if dot(w, n) < 0.0 {
        offset = -offset;
    }
    let po = p + offset;
    return vec3<f32>(nudge(po.x, offset.x), nudge(po.y, offset.y), nudge(po.z, offset.z));
}
