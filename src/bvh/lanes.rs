//! Four `f32` lanes: SSE registers on x86-64 (SSE2 is part of its baseline; `safe_arch`
//! wraps the intrinsics, which the standard library has as unsafe functions), plain arrays
//! elsewhere, with the same results lane by lane.

#[cfg(target_arch = "x86_64")]
use safe_arch::*;

/// Four `f32`s.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub struct F4(m128);

#[cfg(target_arch = "x86_64")]
impl F4 {
    #[inline(always)]
    pub fn splat(x: f32) -> F4 {
        F4(set_splat_m128(x))
    }
    #[inline(always)]
    pub fn load(a: &[f32; 4]) -> F4 {
        F4(load_unaligned_m128(a))
    }
    #[inline(always)]
    pub fn add(self, o: F4) -> F4 {
        F4(add_m128(self.0, o.0))
    }
    #[inline(always)]
    pub fn sub(self, o: F4) -> F4 {
        F4(sub_m128(self.0, o.0))
    }
    #[inline(always)]
    pub fn mul(self, o: F4) -> F4 {
        F4(mul_m128(self.0, o.0))
    }
    /// Per lane, `self` if it is greater than `acc`, else `acc` (so `acc` when `self` is
    /// NaN): SSE's `maxps`.
    #[inline(always)]
    pub fn max_keep(self, acc: F4) -> F4 {
        F4(max_m128(self.0, acc.0))
    }
    /// Per lane, `self` if it is less than `acc`, else `acc` (so `acc` when `self` is
    /// NaN): SSE's `minps`.
    #[inline(always)]
    pub fn min_keep(self, acc: F4) -> F4 {
        F4(min_m128(self.0, acc.0))
    }
    /// Bit `k` set where lane `k` of `self` is at most that of `o` (false for NaN).
    #[inline(always)]
    pub fn le_mask(self, o: F4) -> u32 {
        move_mask_m128(cmp_le_mask_m128(self.0, o.0)) as u32
    }
    #[inline(always)]
    pub fn to_array(self) -> [f32; 4] {
        self.0.to_array()
    }
}

/// Four `f32`s.
#[cfg(not(target_arch = "x86_64"))]
#[derive(Clone, Copy, Debug)]
pub struct F4([f32; 4]);

#[cfg(not(target_arch = "x86_64"))]
impl F4 {
    #[inline(always)]
    pub fn splat(x: f32) -> F4 {
        F4([x; 4])
    }
    #[inline(always)]
    pub fn load(a: &[f32; 4]) -> F4 {
        F4(*a)
    }
    #[inline(always)]
    fn zip(self, o: F4, f: impl Fn(f32, f32) -> f32) -> F4 {
        F4(std::array::from_fn(|k| f(self.0[k], o.0[k])))
    }
    #[inline(always)]
    pub fn add(self, o: F4) -> F4 {
        self.zip(o, |a, b| a + b)
    }
    #[inline(always)]
    pub fn sub(self, o: F4) -> F4 {
        self.zip(o, |a, b| a - b)
    }
    #[inline(always)]
    pub fn mul(self, o: F4) -> F4 {
        self.zip(o, |a, b| a * b)
    }
    /// Per lane, `self` if it is greater than `acc`, else `acc` (so `acc` when `self` is
    /// NaN).
    #[inline(always)]
    pub fn max_keep(self, acc: F4) -> F4 {
        self.zip(acc, |a, b| if a > b { a } else { b })
    }
    /// Per lane, `self` if it is less than `acc`, else `acc` (so `acc` when `self` is NaN).
    #[inline(always)]
    pub fn min_keep(self, acc: F4) -> F4 {
        self.zip(acc, |a, b| if a < b { a } else { b })
    }
    /// Bit `k` set where lane `k` of `self` is at most that of `o` (false for NaN).
    #[inline(always)]
    pub fn le_mask(self, o: F4) -> u32 {
        (0..4).fold(0, |m, k| m | (u32::from(self.0[k] <= o.0[k]) << k))
    }
    #[inline(always)]
    pub fn to_array(self) -> [f32; 4] {
        self.0
    }
}
