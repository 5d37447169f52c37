//! Large buffers whose memory is first written on every thread.
//!
//! The first write to each page of a fresh allocation is a page fault, and the kernel's
//! handling of it (finding, clearing and mapping a 4 KiB page) is not free: on the 2-core
//! test machine a frame of ten million points at 4 samples took 424,000 faults and 0.77 s of
//! system time (`/usr/bin/time`), about 1.8 µs a fault. Written by one thread, a buffer's
//! faults are serial; written here first, they are spread over every thread of the pool,
//! and the later, serial writes find the pages mapped (the point cache's read:
//! docs/performance.md).

use rayon::prelude::*;

/// Buffers of fewer values than this are made as usual: their faults are few.
const SPREAD_FROM: usize = 1 << 16;

/// `n` copies of `x`, their memory written on every thread where `n` is large.
pub fn filled<T: Copy + Send + Sync>(n: usize, x: T) -> Vec<T> {
    if n < SPREAD_FROM {
        return vec![x; n];
    }
    let mut v = Vec::with_capacity(n);
    v.par_extend((0..n).into_par_iter().map(|_| x));
    v
}

/// An empty vector with room for `n` values, its memory written (with `T::default()`) on
/// every thread where `n` is large, for a serial loop to push into.
pub fn room<T: Default + Copy + Send + Sync>(n: usize) -> Vec<T> {
    if n < SPREAD_FROM {
        return Vec::with_capacity(n);
    }
    let mut v = filled(n, T::default());
    v.clear();
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Either way, the values asked for and the room asked for, small or large.
    #[test]
    fn filled_and_room_hold_what_was_asked() {
        for n in [0, 1, SPREAD_FROM - 1, SPREAD_FROM, 3 * SPREAD_FROM + 7] {
            let v = filled(n, 7u32);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|&x| x == 7));
            let r: Vec<f64> = room(n);
            assert!(r.is_empty() && r.capacity() >= n);
        }
    }
}
