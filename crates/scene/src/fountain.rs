//! A fountain, simulated and written as a point cache (`raytrace generate -o NAME_####.ply`):
//! particles leave a nozzle at the origin at a steady rate, fly under gravity and die where
//! they fall back through the ground plane `y = 0`, so every frame has births, deaths and
//! particles that live on with the same `id`.
//!
//! Each particle's flight is closed-form (`p0 + v0 a + g a^2 / 2` at age `a`), drawn from its
//! own PCG32 stream seeded by (seed, id): a frame is computed on its own, in parallel, and the
//! same for a seed on any machine. Velocities are exact (`v0 + g a`), in units per second.
//! Frame `n` is at time `(n - 1) / FPS`, as a shot with `fps = 24`, `first_frame = 1` and
//! `start_time = 0` times it; the fountain has been running for a whole flight by frame 1.

use rayon::prelude::*;

use crate::ply::{Column, Encoding, Scalar, write_vertices};
use raytrace_core::error::Error;
use raytrace_core::rng::{Pcg32, hash_words};

/// Frames per second of the cache.
pub const FPS: f64 = 24.0;
/// Gravity, units per second squared (downward).
const GRAVITY: f64 = 9.81;
/// The launch speed's range, units per second.
const SPEED: (f64, f64) = (5.0, 6.0);
/// Largest angle of a launch from straight up, degrees.
const CONE_DEGREES: f64 = 24.0;
/// The longest flight, seconds: straight up at the highest speed.
const LONGEST_FLIGHT: f64 = 2.0 * SPEED.1 / GRAVITY;
/// The most particles a frame may hold.
pub const MAX_POINTS: u64 = 100_000_000;

/// What to simulate.
#[derive(Clone, Copy, Debug)]
pub struct Fountain {
    /// Particles alive at once, about (the rate is set for it).
    pub points: u64,
    pub seed: u64,
}

/// One particle's launch: its birth time, position, velocity, radius and colour.
struct Launch {
    born: f64,
    origin: [f64; 3],
    velocity: [f64; 3],
    radius: f64,
    color: [f64; 3],
}

impl Fountain {
    /// The mean flight time, seconds: twice the mean upward speed over gravity (the cosine of
    /// a launch's angle is uniform between the cone's and 1).
    fn mean_flight(&self) -> f64 {
        let mean_cos = 0.5 * (1.0 + CONE_DEGREES.to_radians().cos());
        2.0 * 0.5 * (SPEED.0 + SPEED.1) * mean_cos / GRAVITY
    }

    /// Particles launched per second.
    fn rate(&self) -> f64 {
        self.points as f64 / self.mean_flight()
    }

    /// The typical radius: the particles' volume stays about that of 2000 of radius 0.022.
    fn radius(&self) -> f64 {
        0.022 * (2000.0 / self.points.max(1) as f64).cbrt()
    }

    /// Particle `id`'s launch.
    fn launch(&self, id: u64) -> Launch {
        let mut r = Pcg32::new(hash_words(&[self.seed, 0x666f_756e_7461_696e, id]), 5);
        let speed = SPEED.0 + (SPEED.1 - SPEED.0) * r.next_f64();
        // Uniform over the cap of the cone.
        let cos_max = CONE_DEGREES.to_radians().cos();
        let cos = 1.0 - (1.0 - cos_max) * r.next_f64();
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = std::f64::consts::TAU * r.next_f64();
        let jitter = 0.02 * self.radius() / 0.022;
        let origin = [
            jitter * (r.next_f64() - 0.5),
            0.05,
            jitter * (r.next_f64() - 0.5),
        ];
        let shade = r.next_f64();
        Launch {
            // From the first frame's time less a whole flight, so frame 1 is in full flow.
            born: id as f64 / self.rate() - LONGEST_FLIGHT,
            origin,
            velocity: [
                speed * sin * phi.cos(),
                speed * cos,
                speed * sin * phi.sin(),
            ],
            radius: self.radius() * (0.6 + 0.8 * r.next_f64()),
            // From deep blue to white.
            color: [
                0.25 + 0.75 * shade,
                0.55 + 0.45 * shade,
                0.85 + 0.15 * shade,
            ],
        }
    }

    /// The particles alive at time `t` as columns: x, y, z, pscale, vx, vy, vz, red, green,
    /// blue (0 to 255), id.
    pub fn frame(&self, t: f64) -> [Vec<f64>; 11] {
        let rate = self.rate();
        // Born at most a longest flight ago, and not after `t`.
        let first = ((t * rate).floor().max(0.0)) as u64;
        let last = (((t + LONGEST_FLIGHT) * rate).floor().max(0.0)) as u64;
        let alive: Vec<(u64, [f64; 10])> = (first..=last)
            .into_par_iter()
            .filter_map(|id| {
                let l = self.launch(id);
                let age = t - l.born;
                if age < 0.0 {
                    return None;
                }
                let y = l.origin[1] + l.velocity[1] * age - 0.5 * GRAVITY * age * age;
                if y < 0.0 {
                    return None;
                }
                let p = [
                    l.origin[0] + l.velocity[0] * age,
                    y,
                    l.origin[2] + l.velocity[2] * age,
                ];
                let v = [l.velocity[0], l.velocity[1] - GRAVITY * age, l.velocity[2]];
                let c = l.color.map(|c| (c * 255.0).round());
                Some((
                    id,
                    [
                        p[0], p[1], p[2], l.radius, v[0], v[1], v[2], c[0], c[1], c[2],
                    ],
                ))
            })
            .collect();
        let mut columns: [Vec<f64>; 11] = Default::default();
        for c in &mut columns {
            c.reserve_exact(alive.len());
        }
        for (id, values) in alive {
            for (c, v) in columns.iter_mut().zip(values) {
                c.push(v);
            }
            columns[10].push(id as f64);
        }
        columns
    }
}

/// The names and PLY types of [`Fountain::frame`]'s columns.
const COLUMNS: [(&str, Scalar); 11] = [
    ("x", Scalar::F32),
    ("y", Scalar::F32),
    ("z", Scalar::F32),
    ("pscale", Scalar::F32),
    ("vx", Scalar::F32),
    ("vy", Scalar::F32),
    ("vz", Scalar::F32),
    ("red", Scalar::U8),
    ("green", Scalar::U8),
    ("blue", Scalar::U8),
    ("id", Scalar::U32),
];

/// Writes the fountain's frame at time `t` to `path` in `encoding`, atomically. Returns the
/// number of particles written.
pub fn write_points_frame(
    fountain: &Fountain,
    t: f64,
    path: &std::path::Path,
    encoding: Encoding,
) -> Result<usize, Error> {
    let columns = fountain.frame(t);
    let cols: Vec<Column> = COLUMNS
        .iter()
        .zip(&columns)
        .map(|(&(name, ty), values)| Column { name, ty, values })
        .collect();
    raytrace_io::write_with(path, |w| {
        write_vertices(w, encoding, &cols).map_err(|e| Error::io(path, e))
    })?;
    Ok(columns[0].len())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// About the asked number alive; births and deaths between frames; survivors keep their
    /// id and move as their velocities say; every particle above the ground.
    #[test]
    fn a_fountain_has_births_deaths_and_steady_flow() {
        let f = Fountain {
            points: 3000,
            seed: 4,
        };
        let dt = 1.0 / FPS;
        let a = f.frame(0.5);
        let b = f.frame(0.5 + dt);
        let n = a[0].len() as f64;
        assert!((n / 3000.0 - 1.0).abs() < 0.1, "{n}");
        let ids_a: std::collections::BTreeSet<u64> = a[10].iter().map(|&i| i as u64).collect();
        let ids_b: std::collections::BTreeSet<u64> = b[10].iter().map(|&i| i as u64).collect();
        let born = ids_b.difference(&ids_a).count();
        let died = ids_a.difference(&ids_b).count();
        assert!(born > 50 && died > 50, "{born} {died}");
        assert!(a[1].iter().all(|&y| y >= 0.0));
        // A survivor's position one frame on: by its velocity, to second order in dt.
        let k = a[10]
            .iter()
            .position(|id| ids_b.contains(&(*id as u64)))
            .unwrap();
        let j = b[10].iter().position(|&id| id == a[10][k]).unwrap();
        for axis in 0..3 {
            let predicted = a[axis][k] + a[4 + axis][k] * dt;
            let slack = if axis == 1 {
                0.5 * GRAVITY * dt * dt + 1e-12
            } else {
                1e-12
            };
            assert!((b[axis][j] - predicted).abs() <= slack);
        }
        // The same seed, the same frame.
        assert_eq!(f.frame(0.5), a);
    }
}
