//! Generates `scenes/bouncing_spheres.toml`: the final scene of "Ray Tracing: The Next Week",
//! chapter 2 (motion blur) -- the "Ray Tracing in One Weekend" cover scene with its small
//! diffuse spheres bouncing upwards while the shutter is open.
//!
//! ```text
//! cargo run --example gen_bouncing_spheres > scenes/bouncing_spheres.toml
//! ```
//!
//! The random numbers come from SplitMix64 (Steele, Lea and Flood 2014) seeded with
//! [`SEED`] = 2026, implemented inline so the output is the same on every platform and with
//! every version of every crate. Uniform doubles in [0, 1) use the top 53 bits of each word.
//! The numbers are drawn in the order of the book's v3.2 `random_scene()`, reading every
//! `color::random()` and `vec3` constructor left to right (x, then y, then z), and the first
//! factor of `color::random() * color::random()` before the second.
//!
//! Only std is used. Floats are written with the shortest decimal that reads back to the
//! same f64, always with a decimal point and never in exponent form.

use std::fmt::Write as _;

/// The seed of the scene's random numbers. Change it for a different scatter of spheres.
const SEED: u64 = 2026;

/// SplitMix64: a 64-bit state advanced by the golden-ratio increment, then mixed.
struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    fn new(seed: u64) -> SplitMix64 {
        SplitMix64 { state: seed }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1): the book's `random_double()`.
    fn random(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [min, max): the book's `random_double(min, max)`.
    fn random_in(&mut self, min: f64, max: f64) -> f64 {
        min + (max - min) * self.random()
    }

    /// The book's `color::random()`.
    fn color(&mut self) -> [f64; 3] {
        let x = self.random();
        let y = self.random();
        let z = self.random();
        [x, y, z]
    }

    /// The book's `color::random(min, max)`.
    fn color_in(&mut self, min: f64, max: f64) -> [f64; 3] {
        let x = self.random_in(min, max);
        let y = self.random_in(min, max);
        let z = self.random_in(min, max);
        [x, y, z]
    }
}

/// A TOML float: the shortest round-tripping decimal, with a decimal point.
fn num(x: f64) -> String {
    assert!(x.is_finite(), "non-finite value {x}");
    // `Display` of f64 never uses exponent notation and prints the shortest digits that read
    // back to the same value; it prints integral values without a point ("1"), so add ".0".
    let s = format!("{x}");
    if s.contains('.') { s } else { format!("{s}.0") }
}

/// A TOML array of three floats.
fn vec3(v: [f64; 3]) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

/// The materials of the small spheres.
enum Material {
    Lambertian([f64; 3]),
    Metal([f64; 3], f64),
    Glass,
}

fn main() {
    let mut rng = SplitMix64::new(SEED);
    let mut out = String::new();

    // The small spheres, exactly as the book's loop draws them.
    let mut small = String::new();
    let mut counts = [0usize; 3];
    for a in -11..11 {
        for b in -11..11 {
            let choose_mat = rng.random();
            let cx = a as f64 + 0.9 * rng.random();
            let cz = b as f64 + 0.9 * rng.random();
            let center = [cx, 0.2, cz];
            let d = [cx - 4.0, 0.0, cz];
            if (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() <= 0.9 {
                continue;
            }
            let (material, dy) = if choose_mat < 0.8 {
                let c1 = rng.color();
                let c2 = rng.color();
                let albedo = [c1[0] * c2[0], c1[1] * c2[1], c1[2] * c2[2]];
                // center2 = center + (0, random_double(0, .5), 0) over the shutter [0, 1].
                let dy = rng.random_in(0.0, 0.5);
                counts[0] += 1;
                (Material::Lambertian(albedo), Some(dy))
            } else if choose_mat < 0.95 {
                let albedo = rng.color_in(0.5, 1.0);
                let fuzz = rng.random_in(0.0, 0.5);
                counts[1] += 1;
                (Material::Metal(albedo, fuzz), None)
            } else {
                counts[2] += 1;
                (Material::Glass, None)
            };
            writeln!(small).unwrap();
            writeln!(small, "[[sphere]]").unwrap();
            writeln!(small, "center = {}", vec3(center)).unwrap();
            writeln!(small, "radius = 0.2").unwrap();
            match material {
                Material::Lambertian(albedo) => writeln!(
                    small,
                    "material = {{ type = \"lambertian\", albedo = {} }}",
                    vec3(albedo)
                ),
                Material::Metal(albedo, fuzz) => writeln!(
                    small,
                    "material = {{ type = \"metal\", albedo = {}, fuzz = {} }}",
                    vec3(albedo),
                    num(fuzz)
                ),
                Material::Glass => writeln!(small, "material = \"glass\""),
            }
            .unwrap();
            if let Some(dy) = dy {
                // Units per second; the shutter is open over [0, 1], so the sphere rises by dy.
                writeln!(small, "velocity = {}", vec3([0.0, dy, 0.0])).unwrap();
            }
        }
    }

    write!(
        out,
        "\
# The final scene of \"Ray Tracing: The Next Week\", chapter 2 (motion blur): the cover of
# \"Ray Tracing in One Weekend\" with its diffuse spheres bouncing up while the shutter is open.
#
# Generated by `cargo run --example gen_bouncing_spheres` (examples/gen_bouncing_spheres.rs)
# with SplitMix64 seed {SEED}; do not edit by hand, edit the generator and run it again:
#   cargo run --example gen_bouncing_spheres > scenes/bouncing_spheres.toml
#
# {total} small spheres: {lam} moving diffuse, {met} metal, {gla} glass.

# The book's single still: the shutter is open over times [0, 1].
[shot]
fps = 1.0
frames = 1
first_frame = 0
shutter = 1.0
shutter_position = \"start\"

[output]
path = \"renders/bouncing_spheres_####.exr\"
width = 400
height = 225

[render]
samples = 100
max_depth = 50
seed = 0

[camera]
look_from = [13.0, 2.0, 3.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
vfov = 20.0
aperture = 0.1
focus_distance = 10.0

# No [background]: the sky gradient.

[materials]
ground = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}
glass = {{ type = \"dielectric\", ior = 1.5 }}
brown = {{ type = \"lambertian\", albedo = [0.4, 0.2, 0.1] }}
bronze = {{ type = \"metal\", albedo = [0.7, 0.6, 0.5], fuzz = 0.0 }}

# The ground.
[[sphere]]
center = [0.0, -1000.0, 0.0]
radius = 1000.0
material = \"ground\"

# The small spheres, in the order the book generates them.
",
        total = counts.iter().sum::<usize>(),
        lam = counts[0],
        met = counts[1],
        gla = counts[2],
    )
    .unwrap();
    out.push_str(&small);
    // The three large spheres, added after the small ones as in the book.
    out.push_str(
        "
# The three large spheres.
[[sphere]]
center = [0.0, 1.0, 0.0]
radius = 1.0
material = \"glass\"

[[sphere]]
center = [-4.0, 1.0, 0.0]
radius = 1.0
material = \"brown\"

[[sphere]]
center = [4.0, 1.0, 0.0]
radius = 1.0
material = \"bronze\"
",
    );
    print!("{out}");
}
