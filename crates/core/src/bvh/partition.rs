//! Moving a span's items that go left before those that go right (the build's split), on one
//! thread or, for many items, on several, in an order that does not depend on the threads.

use glam::Vec3A;
use rayon::prelude::*;

use super::build::Box3;

/// Spans of more items than twice this are partitioned in parallel, in chunks of this many
/// (a number that does not depend on the threads): on a frame of 1e7 points the first three
/// levels' partitions ran on one thread while the other waited.
pub(super) const PARALLEL_PARTITION: usize = 1 << 16;

/// Moves the items whose centroid `side` puts left before the others; returns how many
/// there are and the bounds of the left and the right ones' centroids. Every item's side is
/// found once, and nothing branches on it (Lomuto's scheme without branches: each item is
/// swapped with the first right one, which only moves it when it goes left), since a side
/// is a coin toss a branch would mispredict half the time.
pub(super) fn partition<P>(
    items: &mut [P],
    side: impl Fn(&P) -> (bool, Vec3A),
) -> (usize, Box3, Box3) {
    let mut mid = 0;
    let (mut lc, mut rc) = (Box3::EMPTY, Box3::EMPTY);
    for i in 0..items.len() {
        let (left, c) = side(&items[i]);
        let on = glam::BVec3A::splat(left);
        let off = glam::BVec3A::splat(!left);
        lc = Box3 {
            lo: Vec3A::select(on, lc.lo.min(c), lc.lo),
            hi: Vec3A::select(on, lc.hi.max(c), lc.hi),
        };
        rc = Box3 {
            lo: Vec3A::select(off, rc.lo.min(c), rc.lo),
            hi: Vec3A::select(off, rc.hi.max(c), rc.hi),
        };
        items.swap(i, mid);
        mid += usize::from(left);
    }
    (mid, lc, rc)
}

/// [`partition`] of many items in parallel: chunks of [`PARALLEL_PARTITION`] items, each
/// partitioned on its own (its left items, then its right ones); then the right items that
/// lie before the left items' total and the left items that lie after it, as many of each,
/// swapped in pairs. A chunk's size does not depend on the threads, so neither does the
/// order. Fewer items are partitioned as `partition` does.
pub(super) fn partition_parallel<P: Send>(
    items: &mut [P],
    side: impl Fn(&P) -> (bool, Vec3A) + Sync,
) -> (usize, Box3, Box3) {
    let n = items.len();
    if n <= 2 * PARALLEL_PARTITION {
        return partition(items, side);
    }
    let parts: Vec<(usize, Box3, Box3)> = items
        .par_chunks_mut(PARALLEL_PARTITION)
        .map(|chunk| partition(chunk, &side))
        .collect();
    let mid: usize = parts.iter().map(|p| p.0).sum();
    let (lc, rc) = parts.iter().fold((Box3::EMPTY, Box3::EMPTY), |(l, r), p| {
        (l.union(p.1), r.union(p.2))
    });
    // Chunk `i`'s left items lie at `i C..i C + m_i`, its right ones after them up to the
    // chunk's end: the right ones before `mid` and the left ones from it on are misplaced.
    let misplaced = |left: bool, within: std::ops::Range<usize>| {
        let parts = &parts;
        (0..parts.len()).filter_map(move |i| {
            let start = i * PARALLEL_PARTITION;
            let cut = start + parts[i].0;
            let end = (start + PARALLEL_PARTITION).min(n);
            let run = if left { start..cut } else { cut..end };
            let (a, b) = (run.start.max(within.start), run.end.min(within.end));
            (a < b).then(|| a - within.start..b - within.start)
        })
    };
    let (front, back) = items.split_at_mut(mid);
    let rights = pieces(front, misplaced(false, 0..mid));
    let lefts = pieces(back, misplaced(true, mid..n));
    pairs(rights, lefts)
        .into_par_iter()
        .for_each(|(a, b)| a.swap_with_slice(b));
    (mid, lc, rc)
}

/// The pieces of `items` at `ranges` (increasing, apart).
fn pieces<P>(
    mut items: &mut [P],
    ranges: impl Iterator<Item = std::ops::Range<usize>>,
) -> Vec<&mut [P]> {
    let mut at = 0;
    let mut out = Vec::new();
    for r in ranges {
        let (_, rest) = std::mem::take(&mut items).split_at_mut(r.start - at);
        let (piece, rest) = rest.split_at_mut(r.len());
        out.push(piece);
        items = rest;
        at = r.end;
    }
    out
}

/// The pieces of `a` and of `b` (as many items in all) cut into pairs of equal lengths, in
/// order.
fn pairs<'a, P>(a: Vec<&'a mut [P]>, b: Vec<&'a mut [P]>) -> Vec<(&'a mut [P], &'a mut [P])> {
    let mut out = Vec::new();
    let (mut a, mut b) = (a.into_iter(), b.into_iter());
    let (mut x, mut y): (&mut [P], &mut [P]) = (&mut [], &mut []);
    loop {
        if x.is_empty() {
            match a.next() {
                Some(next) => x = next,
                None => break,
            }
        }
        if y.is_empty() {
            match b.next() {
                Some(next) => y = next,
                None => break,
            }
        }
        let k = x.len().min(y.len());
        let (x0, x1) = std::mem::take(&mut x).split_at_mut(k);
        let (y0, y1) = std::mem::take(&mut y).split_at_mut(k);
        out.push((x0, y0));
        (x, y) = (x1, y1);
    }
    debug_assert!(x.is_empty() && y.is_empty() && a.next().is_none() && b.next().is_none());
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// A partition in parallel puts every item on its side, keeps every item, and gives the
    /// serial partition's count and centroid bounds; the same order on any number of threads.
    #[test]
    fn a_parallel_partition_is_a_partition() {
        let mut r = Pcg32::new(8, 3);
        for n in [2 * PARALLEL_PARTITION + 1, 5 * PARALLEL_PARTITION + 12_345] {
            let items: Vec<(u32, Vec3A)> = (0..n as u32)
                .map(|i| {
                    let p = [r.next_f64(), r.next_f64(), r.next_f64()].map(|x| x as f32);
                    (i, Vec3A::from(p))
                })
                .collect();
            // Unevenly: about a third left.
            let side = |p: &(u32, Vec3A)| (p.1.x < 0.33, p.1);
            let mut serial = items.clone();
            let want = partition(&mut serial, side);
            let split = |threads| {
                let mut items = items.clone();
                let got = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| partition_parallel(&mut items, side));
                (items, got)
            };
            let (parallel, (mid, lc, rc)) = split(3);
            assert_eq!(mid, want.0);
            assert!(parallel[..mid].iter().all(|p| side(p).0));
            assert!(parallel[mid..].iter().all(|p| !side(p).0));
            let mut ids: Vec<u32> = parallel.iter().map(|p| p.0).collect();
            ids.sort_unstable();
            assert!(ids.iter().copied().eq(0..n as u32));
            for (a, b) in [(lc, want.1), (rc, want.2)] {
                assert_eq!((a.lo, a.hi), (b.lo, b.hi));
            }
            let (alone, _) = split(1);
            assert!(alone.iter().map(|p| p.0).eq(parallel.iter().map(|p| p.0)));
        }
    }
}
