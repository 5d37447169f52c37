// The camera at one time (camera.rs, View) and the sample's time in the frame's exposure
// (shutter.rs, FrameTimes::time, and the shutter curve's inverse, shutter_curve.rs).

struct View {
    origin: vec3<f32>,
    u: vec3<f32>,
    v: vec3<f32>,
    pixel00: vec3<f32>,
    du: vec3<f32>,
    dv: vec3<f32>,
    lens: f32,
}

// The view made on the CPU, in f64, for a camera that does not move during the frame: read
// once per run.
var<private> g_view: View;

fn load_view() {
    g_view = View(fv(H_VIEW), fv(H_VIEW + 3u), fv(H_VIEW + 6u), fv(H_VIEW + 9u), fv(H_VIEW + 12u), fv(H_VIEW + 15u), ff(H_VIEW + 18u));
}

fn fixed_view() -> View {
    return g_view;
}

// The books' thin-lens camera at time `t`.
fn view_at(t: f32) -> View {
    let eye = motion_at(fu(H_CAM_FROM), t);
    let look = motion_at(fu(H_CAM_AT), t);
    var focus = length(eye - look);
    if flag(F_FOCUS) {
        focus = ff(H_CAM_FOCUS);
    }
    let width = f32(fu(H_WIDTH));
    let height = f32(fu(H_HEIGHT));
    let viewport_h = 2.0 * ff(H_CAM_TAN) * focus;
    let viewport_w = viewport_h * (width / height);
    let w = normalize(eye - look);
    let u = normalize(cross(fv(H_CAM_UP), w));
    let v = cross(w, u);
    let vu = viewport_w * u;
    let vv = -viewport_h * v;
    let du = vu / width;
    let dv = vv / height;
    let upper_left = eye - focus * w - 0.5 * vu - 0.5 * vv;
    return View(eye, u, v, upper_left + 0.5 * (du + dv), du, dv, ff(H_CAM_LENS));
}

// The unit disk from [0, 1)^2, Shirley and Chiu's concentric mapping (camera.rs).
fn concentric_disk(a: vec2<f32>) -> vec2<f32> {
    let x = 2.0 * a.x - 1.0;
    let y = 2.0 * a.y - 1.0;
    if x == 0.0 && y == 0.0 {
        return vec2<f32>(0.0);
    }
    var r = y;
    var theta = PI / 2.0 - PI / 4.0 * (x / y);
    if abs(x) > abs(y) {
        r = x;
        theta = PI / 4.0 * (y / x);
    }
    let sc = sin_cos(theta);
    return vec2<f32>(r * sc.y, r * sc.x);
}

struct Ray {
    origin: vec3<f32>,
    dir: vec3<f32>,
}

// The ray through pixel (x, y) at offset `jitter` in it, through lens point `lens`.
fn camera_ray(view: View, x: u32, y: u32, jitter: vec2<f32>, lens: vec2<f32>) -> Ray {
    let aim = view.pixel00 + (f32(x) + jitter.x - 0.5) * view.du + (f32(y) + jitter.y - 0.5) * view.dv;
    var origin = view.origin;
    if view.lens > 0.0 {
        let l = concentric_disk(lens);
        origin = view.origin + view.lens * (l.x * view.u + l.y * view.v);
    }
    return Ray(origin, normalize(aim - origin));
}

// The unit direction the camera looks along.
fn forward(view: View) -> vec3<f32> {
    return cross(view.v, view.u);
}

// Where `q` appears in the image through the lens centre, in pixels (x right, y down).
fn project(view: View, q: vec3<f32>) -> vec2<f32> {
    let f = forward(view);
    let d = q - view.origin;
    let to_plane = view.pixel00 - view.origin;
    let on_plane = d * (dot(to_plane, f) / dot(d, f)) - to_plane;
    return vec2<f32>(dot(on_plane, view.du) / dot(view.du, view.du) + 0.5, dot(on_plane, view.dv) / dot(view.dv, view.dv) + 0.5);
}

// The shutter curve's inverse CDF at `u` (shutter_curve.rs, CurveTable::sample): `n` knots at
// `at`: positions, weights, cumulative areas.
fn curve_sample(u: f32) -> f32 {
    let at = fu(H_CURVE);
    let n = fu(H_CURVE_N);
    let cdf = at + 2u * n;
    // The last knot whose cumulative area is at most u.
    var count = 0u;
    g_iters += 2u;
    for (var k = 0u; k < n; k++) {
        g_iters += 1u;
        if ff(cdf + k) <= u {
            count += 1u;
        }
    }
    var i = clamp(count, 1u, n - 1u) - 1u;
    while i > 0u && ff(cdf + i + 1u) == ff(cdf + i) {
        g_iters += 1u;
        i -= 1u;
    }
    let a = ff(at + n + i);
    let b = ff(at + n + i + 1u);
    let c0 = ff(cdf + i);
    let c1 = ff(cdf + i + 1u);
    let f = clamp((u - c0) / (c1 - c0), 0.0, 1.0);
    let den = a + sqrt((1.0 - f) * a * a + f * b * b);
    var x = 0.0;
    if den > 0.0 {
        x = clamp(f * (a + b) / den, 0.0, 1.0);
    }
    let s0 = ff(at + i);
    let s1 = ff(at + i + 1u);
    return clamp(s0 + (s1 - s0) * x, s0, s1);
}

// A sample's time since the frame's opening from its time number `u` and its row (0 at the
// image's top edge, 1 at its bottom).
fn sample_time(u: f32, row: f32) -> f32 {
    var v = u;
    if fu(H_CURVE_N) > 0u {
        v = curve_sample(u);
    }
    let duration = g_duration;
    if flag(F_ROLLING) {
        var r = row;
        if flag(F_BOTTOM_TO_TOP) {
            r = 1.0 - row;
        }
        return clamp(ff(H_READOUT) * r + ff(H_SHUTTER) * v, 0.0, duration);
    }
    return duration * v;
}
