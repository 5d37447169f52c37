//! Eight `f32` lanes, one per child of a node, on three machines with the same results lane by
//! lane: AVX (one 256-bit register), chosen at run time where the processor has AVX2 and FMA
//! (the `pulp` crate detects them and compiles the traversal for them, so no `unsafe` is
//! written here); SSE otherwise on x86-64 (two 128-bit registers; SSE2 is part of the
//! baseline; `safe_arch` wraps the intrinsics); plain arrays on other targets. A release
//! build targets x86-64-v3 (`.cargo/config.toml`), whose processors all take the AVX lanes;
//! the SSE lanes are what a build for any x86-64 (`RUSTFLAGS=`) takes on older ones, and the
//! tests run all three wherever they run.
//!
//! Why `pulp`: the standard library's intrinsics may only be called safely inside a function
//! compiled for their target feature, and calling such a function from code compiled without
//! it is `unsafe`, which `forbid(unsafe_code)` rules out; `safe_arch` only offers features
//! enabled at compile time. `pulp` (a dependency of `exr` already) checks the processor once,
//! runs a closure inside a function compiled with the AVX2 feature set (`V3::vectorize`), and
//! offers the AVX intrinsics as safe methods of a token that proves the check passed.

/// Lanes per vector: a node's children.
pub(super) const LANES: usize = 8;

/// A machine with eight `f32` lanes: a token, zero-sized, whose methods are its operations.
/// Every operation is lane by lane and rounds as IEEE 754 single precision does, so every
/// implementation gives the same bits.
pub(super) trait Lanes: Copy {
    /// Eight `f32`s.
    type V: Copy;
    fn splat(self, x: f32) -> Self::V;
    fn load(self, a: &[f32; LANES]) -> Self::V;
    /// Eight bytes as `f32`s (exactly).
    #[inline(always)]
    fn load_u8(self, a: &[u8; LANES]) -> Self::V {
        self.load(&a.map(f32::from))
    }
    fn add(self, a: Self::V, b: Self::V) -> Self::V;
    fn sub(self, a: Self::V, b: Self::V) -> Self::V;
    fn mul(self, a: Self::V, b: Self::V) -> Self::V;
    /// Per lane, `x` if it is greater than `acc`, else `acc` (so `acc` when `x` is NaN):
    /// SSE's and AVX's `maxps`.
    fn max_keep(self, x: Self::V, acc: Self::V) -> Self::V;
    /// Per lane, `x` if it is less than `acc`, else `acc` (so `acc` when `x` is NaN):
    /// `minps`.
    fn min_keep(self, x: Self::V, acc: Self::V) -> Self::V;
    /// Bit `k` set where lane `k` of `a` is at most that of `b` (false for NaN).
    fn le_mask(self, a: Self::V, b: Self::V) -> u32;
    /// Per lane, `a` where `mask` is [`Lanes::all_ones`], `b` where it is zero.
    fn select(self, mask: Self::V, a: Self::V, b: Self::V) -> Self::V;
    /// Every lane's bits set (a mask for [`Lanes::select`]), or every lane zero.
    #[inline(always)]
    fn all_ones(self, set: bool) -> Self::V {
        self.splat(f32::from_bits(if set { u32::MAX } else { 0 }))
    }
    fn to_array(self, a: Self::V) -> [f32; LANES];
    /// Asks for the cache line holding `r` to be loaded, without waiting for it (nothing
    /// where there is no such instruction).
    #[inline(always)]
    fn prefetch<T>(self, r: &T) {
        let _ = r;
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use x86::{Avx, Sse};

/// The AVX token where the processor has AVX2 and FMA, for tests: on CI (`CI` set), whose
/// x86-64 machines have them, a missing AVX2 fails instead of leaving the AVX kernels
/// untested.
#[cfg(all(test, target_arch = "x86_64"))]
pub(crate) fn avx_where_available() -> Option<pulp::x86::V3> {
    let v3 = pulp::x86::V3::try_new();
    assert!(
        v3.is_some() || std::env::var_os("CI").is_none(),
        "no AVX2 on a CI machine: the AVX kernels would go untested"
    );
    v3
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    // By its crate path: tests/integration/architecture.rs reads a `super::` path as leading to the
    // file's parent module, which for this inline module would be `bvh`.
    use crate::bvh::lanes::{LANES, Lanes};
    use core::arch::x86_64::{__m256, _CMP_LE_OQ};
    use pulp::x86::V3;
    use safe_arch::*;

    /// Two SSE registers of four lanes each (the baseline of x86-64).
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Sse;

    impl Lanes for Sse {
        type V = [m128; 2];
        #[inline(always)]
        fn splat(self, x: f32) -> [m128; 2] {
            [set_splat_m128(x); 2]
        }
        #[inline(always)]
        fn load(self, a: &[f32; LANES]) -> [m128; 2] {
            let [p, q]: &[[f32; 4]; 2] = bytemuck_halves(a);
            [load_unaligned_m128(p), load_unaligned_m128(q)]
        }
        #[inline(always)]
        fn add(self, a: [m128; 2], b: [m128; 2]) -> [m128; 2] {
            [add_m128(a[0], b[0]), add_m128(a[1], b[1])]
        }
        #[inline(always)]
        fn sub(self, a: [m128; 2], b: [m128; 2]) -> [m128; 2] {
            [sub_m128(a[0], b[0]), sub_m128(a[1], b[1])]
        }
        #[inline(always)]
        fn mul(self, a: [m128; 2], b: [m128; 2]) -> [m128; 2] {
            [mul_m128(a[0], b[0]), mul_m128(a[1], b[1])]
        }
        #[inline(always)]
        fn max_keep(self, x: [m128; 2], acc: [m128; 2]) -> [m128; 2] {
            [max_m128(x[0], acc[0]), max_m128(x[1], acc[1])]
        }
        #[inline(always)]
        fn min_keep(self, x: [m128; 2], acc: [m128; 2]) -> [m128; 2] {
            [min_m128(x[0], acc[0]), min_m128(x[1], acc[1])]
        }
        #[inline(always)]
        fn le_mask(self, a: [m128; 2], b: [m128; 2]) -> u32 {
            let low = move_mask_m128(cmp_le_mask_m128(a[0], b[0])) as u32;
            let high = move_mask_m128(cmp_le_mask_m128(a[1], b[1])) as u32;
            low | high << 4
        }
        #[inline(always)]
        fn select(self, mask: [m128; 2], a: [m128; 2], b: [m128; 2]) -> [m128; 2] {
            let one =
                |k: usize| bitor_m128(bitand_m128(mask[k], a[k]), bitandnot_m128(mask[k], b[k]));
            [one(0), one(1)]
        }
        #[inline(always)]
        fn to_array(self, a: [m128; 2]) -> [f32; LANES] {
            let (p, q) = (a[0].to_array(), a[1].to_array());
            [p[0], p[1], p[2], p[3], q[0], q[1], q[2], q[3]]
        }
        #[inline(always)]
        fn prefetch<T>(self, r: &T) {
            prefetch_t0(r);
        }
    }

    /// The two halves of eight lanes.
    #[inline(always)]
    fn bytemuck_halves(a: &[f32; LANES]) -> &[[f32; 4]; 2] {
        pulp::bytemuck::cast_ref(a)
    }

    /// One AVX register of eight lanes; only made from a [`V3`] token, which exists only
    /// where the processor has AVX2 and FMA (x86-64-v3).
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Avx(pub V3);

    impl Lanes for Avx {
        type V = __m256;
        #[inline(always)]
        fn splat(self, x: f32) -> __m256 {
            self.0.avx._mm256_set1_ps(x)
        }
        #[inline(always)]
        fn load(self, a: &[f32; LANES]) -> __m256 {
            pulp::cast(*a)
        }
        #[inline(always)]
        fn add(self, a: __m256, b: __m256) -> __m256 {
            self.0.avx._mm256_add_ps(a, b)
        }
        #[inline(always)]
        fn sub(self, a: __m256, b: __m256) -> __m256 {
            self.0.avx._mm256_sub_ps(a, b)
        }
        #[inline(always)]
        fn mul(self, a: __m256, b: __m256) -> __m256 {
            self.0.avx._mm256_mul_ps(a, b)
        }
        #[inline(always)]
        fn max_keep(self, x: __m256, acc: __m256) -> __m256 {
            self.0.avx._mm256_max_ps(x, acc)
        }
        #[inline(always)]
        fn min_keep(self, x: __m256, acc: __m256) -> __m256 {
            self.0.avx._mm256_min_ps(x, acc)
        }
        #[inline(always)]
        fn le_mask(self, a: __m256, b: __m256) -> u32 {
            let m = self.0.avx._mm256_cmp_ps::<_CMP_LE_OQ>(a, b);
            self.0.avx._mm256_movemask_ps(m) as u32
        }
        #[inline(always)]
        fn select(self, mask: __m256, a: __m256, b: __m256) -> __m256 {
            // `blendv` takes its second operand where the mask's sign bit is set.
            self.0.avx._mm256_blendv_ps(b, a, mask)
        }
        #[inline(always)]
        fn to_array(self, a: __m256) -> [f32; LANES] {
            pulp::cast(a)
        }
        #[inline(always)]
        fn prefetch<T>(self, r: &T) {
            prefetch_t0(r);
        }
    }
}

/// Plain arrays, left to the compiler (targets other than x86-64).
#[derive(Clone, Copy, Debug)]
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
pub(super) struct Plain;

impl Lanes for Plain {
    type V = [f32; LANES];
    #[inline(always)]
    fn splat(self, x: f32) -> [f32; LANES] {
        [x; LANES]
    }
    #[inline(always)]
    fn load(self, a: &[f32; LANES]) -> [f32; LANES] {
        *a
    }
    #[inline(always)]
    fn add(self, a: [f32; LANES], b: [f32; LANES]) -> [f32; LANES] {
        std::array::from_fn(|k| a[k] + b[k])
    }
    #[inline(always)]
    fn sub(self, a: [f32; LANES], b: [f32; LANES]) -> [f32; LANES] {
        std::array::from_fn(|k| a[k] - b[k])
    }
    #[inline(always)]
    fn mul(self, a: [f32; LANES], b: [f32; LANES]) -> [f32; LANES] {
        std::array::from_fn(|k| a[k] * b[k])
    }
    #[inline(always)]
    fn max_keep(self, x: [f32; LANES], acc: [f32; LANES]) -> [f32; LANES] {
        std::array::from_fn(|k| if x[k] > acc[k] { x[k] } else { acc[k] })
    }
    #[inline(always)]
    fn min_keep(self, x: [f32; LANES], acc: [f32; LANES]) -> [f32; LANES] {
        std::array::from_fn(|k| if x[k] < acc[k] { x[k] } else { acc[k] })
    }
    #[inline(always)]
    fn le_mask(self, a: [f32; LANES], b: [f32; LANES]) -> u32 {
        (0..LANES).fold(0, |m, k| m | (u32::from(a[k] <= b[k]) << k))
    }
    #[inline(always)]
    fn select(self, mask: [f32; LANES], a: [f32; LANES], b: [f32; LANES]) -> [f32; LANES] {
        std::array::from_fn(|k| if mask[k].to_bits() != 0 { a[k] } else { b[k] })
    }
    #[inline(always)]
    fn to_array(self, a: [f32; LANES]) -> [f32; LANES] {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// Every machine available here gives the same bits as plain arrays, lane by lane,
    /// including NaN and infinite inputs and the NaN rules of `max_keep` and `min_keep`.
    fn agrees_with_plain<M: Lanes>(m: M) {
        let mut r = Pcg32::new(5, 5);
        let special = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            1e-40,
        ];
        let value = |r: &mut Pcg32| {
            if r.next_f64() < 0.2 {
                special[(r.next_f64() * special.len() as f64) as usize % special.len()]
            } else {
                ((r.next_f64() - 0.5) * 2f64.powi((r.next_f64() * 60.0) as i32 - 30)) as f32
            }
        };
        let bits = |a: [f32; LANES]| a.map(f32::to_bits);
        for _ in 0..20_000 {
            let a: [f32; LANES] = std::array::from_fn(|_| value(&mut r));
            let b: [f32; LANES] = std::array::from_fn(|_| value(&mut r));
            let (p, q) = (m.load(&a), m.load(&b));
            let (pa, pb) = (Plain.load(&a), Plain.load(&b));
            let same = |x: M::V, y: [f32; LANES]| {
                let (x, y) = (m.to_array(x), y);
                // NaNs may differ in payload: compare them as NaN.
                (0..LANES)
                    .all(|k| (x[k].is_nan() && y[k].is_nan()) || x[k].to_bits() == y[k].to_bits())
            };
            assert!(same(m.add(p, q), Plain.add(pa, pb)));
            assert!(same(m.sub(p, q), Plain.sub(pa, pb)));
            assert!(same(m.mul(p, q), Plain.mul(pa, pb)));
            assert!(same(m.max_keep(p, q), Plain.max_keep(pa, pb)));
            assert!(same(m.min_keep(p, q), Plain.min_keep(pa, pb)));
            assert_eq!(m.le_mask(p, q), Plain.le_mask(pa, pb));
            for set in [false, true] {
                let (mask, plain_mask) = (m.all_ones(set), Plain.all_ones(set));
                assert!(same(m.select(mask, p, q), Plain.select(plain_mask, pa, pb)));
                let chosen = Plain.select(plain_mask, pa, pb);
                assert_eq!(bits(chosen), bits(if set { a } else { b }));
            }
            assert_eq!(bits(m.to_array(m.splat(a[3]))), bits([a[3]; LANES]));
        }
    }

    #[test]
    fn every_machine_gives_the_same_lanes() {
        agrees_with_plain(Plain);
        #[cfg(target_arch = "x86_64")]
        {
            agrees_with_plain(Sse);
            if let Some(v3) = avx_where_available() {
                v3.vectorize(|| agrees_with_plain(Avx(v3)));
            }
        }
    }
}
