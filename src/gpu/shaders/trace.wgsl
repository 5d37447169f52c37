// The path tracer (tracer.rs and renderer/tiles.rs): one invocation traces one run of a
// pixel's samples and sums them, in sample order, with their passes (passes.rs).

// The run's pass sums, at the slots the film keeps them in.
var<private> pass_sums: array<f32, MAX_STRIDE>;
// Rays traced by the run, (low, high).
var<private> rays: vec2<u32>;

fn slot(k: u32) -> u32 {
    return fu(H_SLOTS + k);
}

fn add_pass(at: u32, v: vec3<f32>, n: u32) {
    for (var i = 0u; i < n; i++) {
        pass_sums[at + i] += v[i];
    }
}

// The displacements in pixels (u right, v up) of the point `p` of sphere `id` at time `t`,
// seen through `view`, to where it is one frame period later (xy) and earlier (zw).
fn motion_vectors(p: vec3<f32>, id: u32, t: f32, view: View) -> vec4<f32> {
    let record = fu(fu(H_PASS_MOTIONS) + id);
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

// What a camera ray's first intersection adds to the passes (passes.rs, PassContext::record):
// `hit` false for a ray that missed or was not traced.
fn record_first(view: View, dir: vec3<f32>, hit: bool, s: Surface, m: u32, id: u32, t: f32, odd: bool) {
    let guides = slot(5u);
    if !hit {
        let b = background(dir);
        if finite3(b) {
            if guides != NONE {
                add_pass(guides + select(0u, 6u, odd), b, 3u);
            }
            if slot(3u) != NONE {
                add_pass(slot(3u), b, 3u);
            }
        }
        return;
    }
    if guides != NONE {
        let g = guides + select(0u, 6u, odd);
        add_pass(g, albedo_of(m), 3u);
        add_pass(g + 3u, s.normal, 3u);
    }
    if slot(0u) != NONE {
        pass_sums[slot(0u)] += 1.0;
    }
    if slot(1u) != NONE {
        pass_sums[slot(1u)] += dot(s.p - view.origin, forward(view));
    }
    if slot(2u) != NONE {
        add_pass(slot(2u), s.normal, 3u);
    }
    if slot(3u) != NONE {
        add_pass(slot(3u), albedo_of(m), 3u);
    }
    if slot(4u) != NONE {
        let mv = motion_vectors(s.p, id, t, view);
        for (var i = 0u; i < 4u; i++) {
            pass_sums[slot(4u) + i] += mv[i];
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
    let odd = (index & 1u) == 1u;
    let passes = g_stride > 0u;
    let none = Surface(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    if !(finite3(ray.origin) && finite3(ray.dir) && finite3(vec3<f32>(t))) {
        if passes {
            record_first(view, ray.dir, false, none, 0u, 0u, t, odd);
        }
        return Radiance(vec3<f32>(0.0), false);
    }
    var o = ray.origin;
    var d = ray.dir;
    var throughput = vec3<f32>(1.0);
    var skip = NONE;
    let max_depth = g_max_depth;
    for (var depth = 0u; depth < max_depth; depth++) {
        rays = add64(rays, vec2<u32>(1u, 0u));
        let h = world_hit(o, d, t, skip);
        let found = h.t < FAR;
        var s = none;
        var m = 0u;
        var id = 0u;
        if found {
            let sphere = sphere_at(h.src, h.sphere);
            s = surface_point(center_at(sphere, t), sphere.radius, o, d, h.t);
            m = g_materials + MATERIAL_WORDS * sphere.material;
            id = sphere.id;
        }
        if depth == 0u && passes {
            record_first(view, d, found, s, m, id, t, odd);
        }
        if !found {
            if depth == 0u && flag(F_TRANSPARENT) {
                return Radiance(vec3<f32>(0.0), true);
            }
            return Radiance(throughput * background(d), true);
        }
        let sc = scatter(m, d, s.normal, next_bounce());
        if sc.absorbed {
            return Radiance(vec3<f32>(0.0), true);
        }
        throughput *= sc.attenuation;
        skip = NONE;
        if sc.leaves_outside {
            skip = id;
        }
        o = offset_origin(s.p, s.error, s.normal, sc.dir);
        d = sc.dir;
    }
    return Radiance(vec3<f32>(0.0), true);
}

@compute @workgroup_size(WORKGROUP)
fn trace(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= params.x {
        return;
    }
    let run = run_list[i];
    load_header();
    load_view();
    s_block = NONE;
    rays = vec2<u32>(0u);
    for (var k = 0u; k < MAX_STRIDE; k++) {
        pass_sums[k] = 0.0;
    }
    var sum = vec3<f32>(0.0);
    var odd = vec3<f32>(0.0);
    var non_finite = 0u;
    for (var j = 0u; j < run.w; j++) {
        let index = run.z + j;
        let r = radiance(run.x, run.y, index);
        var v = r.value;
        // As the film: a sample that is not finite counts as black.
        if !(r.traced && finite3(v)) {
            v = vec3<f32>(0.0);
            non_finite += 1u;
        }
        sum += v;
        if (index & 1u) == 1u {
            odd += v;
        }
    }
    let at = i * params.y;
    for (var c = 0u; c < 3u; c++) {
        records[at + O_SUM + c] = bitcast<u32>(sum[c]);
        records[at + O_ODD + c] = bitcast<u32>(odd[c]);
    }
    records[at + O_NON_FINITE] = non_finite;
    records[at + O_RAYS] = rays.x;
    records[at + O_RAYS + 1u] = rays.y;
    for (var k = 0u; k < g_stride; k++) {
        records[at + O_PASSES + k] = bitcast<u32>(pass_sums[k]);
    }
}

// The sampler's numbers, for the tests that hold them to the CPU's: per run (x, y, sample
// index, what the camera uses: 1 the lens, 2 the time), the pixel position, the lens
// position, the time number and four bounces' (uc, u.0, u.1): 17 words.
@compute @workgroup_size(WORKGROUP)
fn numbers(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= params.x {
        return;
    }
    let run = run_list[i];
    load_header();
    s_block = NONE;
    start_sample(run.x, run.y, run.z);
    let c = camera_numbers((run.w & 1u) != 0u, (run.w & 2u) != 0u);
    let at = i * params.y;
    records[at] = bitcast<u32>(c.pixel.x);
    records[at + 1u] = bitcast<u32>(c.pixel.y);
    records[at + 2u] = bitcast<u32>(c.lens.x);
    records[at + 3u] = bitcast<u32>(c.lens.y);
    records[at + 4u] = bitcast<u32>(c.time);
    for (var k = 0u; k < 4u; k++) {
        let b = next_bounce();
        for (var j = 0u; j < 3u; j++) {
            records[at + 5u + 3u * k + j] = bitcast<u32>(b[j]);
        }
    }
}
