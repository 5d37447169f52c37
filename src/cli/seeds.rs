//! The seeds a measurement renders with (`converge`'s points, `converge --flicker`'s routes):
//! the scene's, then seeds of their own.

use raytrace_core::rng::hash_words;
use raytrace_core::scene::Scene;

/// Default seeds a measurement is rendered with (`--seeds`).
pub(crate) const DEFAULT_SEEDS: u32 = 3;

/// A word hashed with the scene's seed into the measured renders' further seeds, so that they
/// are independent of each other and of the references'.
const MEASURED_SEED: u64 = 0x6d65_6173_7572_6564;

/// The `count` seeds a measurement is rendered with: the scene's, then seeds of their own.
pub(crate) fn measured_seeds(scene: &Scene, count: usize) -> Vec<u64> {
    (0..count as u64)
        .map(|k| match k {
            0 => scene.render.seed,
            _ => hash_words(&[scene.render.seed, MEASURED_SEED, k]) >> 1,
        })
        .collect()
}
