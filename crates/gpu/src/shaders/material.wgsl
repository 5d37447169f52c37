// The books' three materials and the background (material.rs), in f32, from the same
// bounce numbers.

const TAU: f32 = 6.28318531;

// A uniformly distributed unit vector from two numbers (material.rs, unit_vector).
fn unit_vector(a: f32, b: f32) -> vec3<f32> {
    let z = 1.0 - 2.0 * a;
    let r = sqrt(max(1.0 - z * z, 0.0));
    let sc = sin_cos(TAU * b);
    return vec3<f32>(r * sc.y, r * sc.x, z);
}

// The cube root of x >= 0: exp2(log2(x) / 3), polished by one Newton step.
fn cube_root(x: f32) -> f32 {
    if x <= 0.0 {
        return 0.0;
    }
    let y = exp2(log2(x) * (1.0 / 3.0));
    return y - (y * y * y - x) / (3.0 * y * y);
}

fn mirror(v: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return v - 2.0 * dot(v, n) * n;
}

fn bend(uv: vec3<f32>, n: vec3<f32>, eta_ratio: f32, cos_theta: f32) -> vec3<f32> {
    let perp = eta_ratio * (uv + cos_theta * n);
    let parallel = -sqrt(abs(1.0 - dot(perp, perp))) * n;
    return perp + parallel;
}

fn schlick(cosine: f32, eta_ratio: f32) -> f32 {
    var r0 = (1.0 - eta_ratio) / (1.0 + eta_ratio);
    r0 = r0 * r0;
    let m = 1.0 - cosine;
    return r0 + (1.0 - r0) * (m * m * m * m * m);
}

struct Scatter {
    dir: vec3<f32>,
    attenuation: vec3<f32>,
    // The new ray leaves the outside of an opaque sphere, which it cannot hit again.
    leaves_outside: bool,
    absorbed: bool,
}

// Scatters a ray arriving along `dir_in` at a point with outward normal `outward` on the
// material at `m` of the shot buffer, its albedo multiplied by `tint` (a point's colour,
// material.rs `Material::tinted`: glass keeps its own), with the bounce's numbers (uc, u.0,
// u.1).
fn scatter(m: u32, tint: vec3<f32>, dir_in: vec3<f32>, outward: vec3<f32>, numbers: vec3<f32>) -> Scatter {
    let front = dot(dir_in, outward) < 0.0;
    var n = outward;
    if !front {
        n = -outward;
    }
    let q0 = quad(0u, m);
    let kind = q0.x;
    let albedo = bitcast<vec3<f32>>(q0.yzw) * tint;
    if kind == LAMBERTIAN {
        var dir = n + unit_vector(numbers.y, numbers.z);
        // The books' near_zero().
        if max(max(abs(dir.x), abs(dir.y)), abs(dir.z)) < 1e-8 {
            dir = n;
        }
        return Scatter(normalize(dir), albedo, front, false);
    }
    let q1 = bitcast<vec4<f32>>(quad(0u, m + 4u));
    if kind == METAL {
        var dir = mirror(dir_in, n);
        let fuzz = q1.x;
        if fuzz > 0.0 {
            dir += fuzz * unit_vector(numbers.y, numbers.z) * cube_root(numbers.x);
        }
        if dot(dir, n) <= 0.0 {
            return Scatter(vec3<f32>(0.0), vec3<f32>(0.0), false, true);
        }
        return Scatter(normalize(dir), albedo, front, false);
    }
    let ior = q1.y;
    var ratio = ior;
    if front {
        ratio = 1.0 / ior;
    }
    let cos_theta = min(dot(-dir_in, n), 1.0);
    let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    var dir = bend(dir_in, n, ratio, cos_theta);
    if ratio * sin_theta > 1.0 || schlick(cos_theta, ratio) > numbers.x {
        dir = mirror(dir_in, n);
    }
    return Scatter(normalize(dir), vec3<f32>(1.0), false, false);
}

// The material's albedo, multiplied by `tint`, as a denoiser takes it (glass: 1).
fn albedo_of(m: u32, tint: vec3<f32>) -> vec3<f32> {
    let q0 = quad(0u, m);
    if q0.x == DIELECTRIC {
        return vec3<f32>(1.0);
    }
    return bitcast<vec3<f32>>(q0.yzw) * tint;
}

// What a ray leaving the scene along `d` sees: the books' sky, or a uniform colour.
fn background(d: vec3<f32>) -> vec3<f32> {
    if flag(F_UNIFORM) {
        return fv(H_BACKGROUND);
    }
    let a = 0.5 * (d.y + 1.0);
    return (1.0 - a) * vec3<f32>(1.0) + a * vec3<f32>(0.5, 0.7, 1.0);
}
