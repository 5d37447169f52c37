//! The binned surface-area heuristic's bins (Wald 2007): each primitive's centroid put in one
//! of `N` bins per axis ([`BinMap`]), the unions of the boxes in each bin at the shutter's
//! opening and closing ([`Bin`]), and the sweep over the boundaries between bins that finds a
//! span's best split ([`best_split`]), its parts' areas computed a boundary a lane.

use glam::Vec3A;
use rayon::prelude::*;

use super::build::{Box3, BuildBox, expected_half_areas};

/// Centroid bins per axis for the SAH sweep of a span of `n` primitives whose leaves hold
/// about `per_leaf` (a build's node cost, at least 1: one sphere a leaf, four points): 16, and
/// 8 for spans of at most 16 leaves' worth (as Embree's `BinMapping` takes fewer for small
/// spans), where filling and sweeping 16 bins cost more than the primitives. For the points
/// (spans of at most 64) the hierarchy in 0.95 of the time of 8 bins up to 16 primitives
/// only, the render the same; the spheres keep 8 up to 16, where 8 up to 64 cost their
/// render 3% (docs/performance.md).
pub(super) fn bins_for(n: usize, per_leaf: f64) -> usize {
    if n as f64 <= 16.0 * per_leaf.max(1.0) {
        8
    } else {
        16
    }
}

/// Spans of more primitives than this are binned in parallel, in chunks of this many: a
/// number that does not depend on the threads, though the bins would not either (their
/// unions and counts are exact in any order).
pub(super) const PARALLEL_BINS: usize = 1 << 15;
/// Spans of more primitives than this bin a sample of them, every `n / SAMPLE`-th (16,384
/// to 32,768 primitives, a thousand or more a bin), as the top of a large build is where
/// every primitive is binned again and again for splits a sample decides as well: on a frame
/// of 1e7 points the hierarchy in 0.89 of the time (2.65 s against 2.99 s), 0.3% fewer nodes
/// visited by the render's rays (docs/performance.md).
/// Such a span's halves are measured by their sample's boxes (their counts and centroids
/// exactly, by the partition): their boxes only weigh splits and choose which child a node
/// opens next, and a hierarchy's boxes come from its refit.
pub(super) const SAMPLED_BINS: usize = 1 << 16;
/// Primitives a sampled span bins, at least.
const SAMPLE: usize = 1 << 14;

/// One centroid bin: how many primitives fell in it and the unions of their boxes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Bin {
    pub(super) count: usize,
    pub(super) open: Box3,
    pub(super) close: Box3,
}

impl Bin {
    pub(super) const EMPTY: Bin = Bin {
        count: 0,
        open: Box3::EMPTY,
        close: Box3::EMPTY,
    };

    #[inline(always)]
    pub(super) fn add(&mut self, open: Box3, close: Box3) {
        self.count += 1;
        self.open = self.open.union(open);
        self.close = self.close.union(close);
    }

    #[inline(always)]
    pub(super) fn merge(&self, o: &Bin) -> Bin {
        Bin {
            count: self.count + o.count,
            open: self.open.union(o.open),
            close: self.close.union(o.close),
        }
    }
}

/// Per axis, `N` bins.
type Bins<const N: usize> = [[Bin; N]; 3];

/// The two parts of one axis's bins at every boundary `i` (in `1..N`: bins `0..i` left, `i..N`
/// right): `count[side][i]` and `area[side][i]`, side 0 the left. The areas are computed a
/// boundary a lane ([`expected_half_areas`]), where the sweep had computed them one by one
/// with three-lane vectors' horizontal sums: the same bits.
struct Sides<const N: usize> {
    count: [[u32; N]; 2],
    area: [[f32; N]; 2],
}

impl<const N: usize> Sides<N> {
    #[inline(always)]
    fn of(bins: &[Bin; N]) -> Sides<N> {
        // `sides[side][e][k][i]`: of side `side`'s union at boundary `i`, end `e`'s box (0
        // opening, 1 closing), its side `k` (`Box3::sides`). Lane 0 is no boundary and stays
        // zero (its area unused).
        let mut sides = [[[[0f32; N]; 6]; 2]; 2];
        let mut count = [[0u32; N]; 2];
        let mut put = |side: usize, i: usize, b: &Bin| {
            count[side][i] = b.count as u32;
            for (e, bx) in [b.open, b.close].iter().enumerate() {
                for (k, x) in bx.sides().into_iter().enumerate() {
                    sides[side][e][k][i] = x;
                }
            }
        };
        let mut acc = Bin::EMPTY;
        for i in (1..N).rev() {
            acc = acc.merge(&bins[i]);
            put(1, i, &acc);
        }
        let mut acc = Bin::EMPTY;
        for i in 1..N {
            acc = acc.merge(&bins[i - 1]);
            put(0, i, &acc);
        }
        Sides {
            count,
            area: sides.map(|s| expected_half_areas(&s)),
        }
    }
}

/// Where a centroid falls: the number of bins, and per axis the bins' origin and their
/// number per unit.
#[derive(Clone, Copy, Debug)]
pub(super) struct BinMap {
    pub(super) count: usize,
    origin: Vec3A,
    scale: Vec3A,
    /// The last bin, `count - 1`, in every lane.
    last: Vec3A,
}

impl BinMap {
    pub(super) fn new(centroids: Box3, count: usize) -> BinMap {
        let extent = centroids.hi - centroids.lo;
        // An axis without extent (or a NaN one) puts everything in bin 0 and is not split.
        let scale = Vec3A::select(
            extent.cmpgt(Vec3A::ZERO),
            Vec3A::splat(count as f32) / extent,
            Vec3A::ZERO,
        );
        BinMap {
            count,
            origin: centroids.lo,
            scale,
            last: Vec3A::splat((count - 1) as f32),
        }
    }

    /// The bins of centroid `c` along the three axes; a NaN centroid is in bin 0. Clamped
    /// before the conversion (`max` gives its second operand, 0, for a NaN: SSE's `maxps`, as
    /// glam's scalar form), so it is exact and needs no saturation: four lanes at once.
    #[inline(always)]
    fn bins(&self, c: Vec3A) -> [usize; 3] {
        truncate(
            ((c - self.origin) * self.scale)
                .max(Vec3A::ZERO)
                .min(self.last),
        )
    }

    /// Whether centroid `c`'s bin along `axis`, as [`BinMap::bins`] gives it, is below
    /// `boundary` (in `1..count`): one lane's product compared, where the bin would clamp and
    /// convert all three. The same answer: the product `x` is the lane's, and a bin below a
    /// whole `boundary` at most the last is `x < boundary`, or a NaN `x` (bin 0).
    #[inline(always)]
    pub(super) fn below(&self, c: Vec3A, axis: usize, boundary: usize) -> bool {
        debug_assert!((1..self.count).contains(&boundary));
        let x = (c[axis] - self.origin[axis]) * self.scale[axis];
        x < boundary as f32 || x.is_nan()
    }
}

/// The whole numbers of the first three lanes of `x` (each in `0..=15`), towards zero.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn truncate(x: Vec3A) -> [usize; 3] {
    let i: [i32; 4] = safe_arch::truncate_m128_to_m128i(safe_arch::m128(x.into())).into();
    [i[0] as usize, i[1] as usize, i[2] as usize]
}

/// The whole numbers of `x`'s lanes (each in `0..=15`), towards zero.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn truncate(x: Vec3A) -> [usize; 3] {
    [x.x as usize, x.y as usize, x.z as usize]
}

/// Adds `items` to `bins`, on one thread.
#[inline(always)]
fn bin_serial<'a, P: 'a, const N: usize>(
    bins: &mut Bins<N>,
    items: impl IntoIterator<Item = &'a P>,
    map: &BinMap,
    bounds: &impl Fn(&P) -> BuildBox,
) {
    for p in items {
        let (open, close, c) = bounds(p).parts();
        for (axis, b) in map.bins(c).into_iter().enumerate() {
            bins[axis][b].add(open, close);
        }
    }
}

/// Adds `items` to `bins` (empty), in parallel for many.
fn fill_bins<P: Sync, const N: usize>(
    bins: &mut Bins<N>,
    items: &[P],
    map: &BinMap,
    bounds: &(impl Fn(&P) -> BuildBox + Sync),
) {
    if items.len() > SAMPLED_BINS {
        bin_serial(
            bins,
            items.iter().step_by(items.len() / SAMPLE),
            map,
            bounds,
        );
        return;
    }
    if items.len() <= PARALLEL_BINS {
        bin_serial(bins, items, map, bounds);
        return;
    }
    let parts: Vec<Box<Bins<N>>> = items
        .par_chunks(PARALLEL_BINS)
        .map(|chunk| {
            let mut part = Box::new([[Bin::EMPTY; N]; 3]);
            bin_serial(&mut part, chunk, map, bounds);
            part
        })
        .collect();
    for part in parts {
        for (bins, part) in bins.iter_mut().zip(part.iter()) {
            for (b, p) in bins.iter_mut().zip(part) {
                *b = b.merge(p);
            }
        }
    }
}

/// The binned SAH's best split of `items` into two, with `N` bins per axis: its cost, axis,
/// the bin boundary, and the bins left and right of it merged; `None` when no axis has two
/// bins with primitives.
pub(super) fn best_split<P: Sync, const N: usize>(
    items: &[P],
    map: &BinMap,
    bounds: &(impl Fn(&P) -> BuildBox + Sync),
) -> Option<(f32, usize, usize, Bin, Bin)> {
    let mut bins = [[Bin::EMPTY; N]; 3];
    fill_bins(&mut bins, items, map, bounds);
    // (cost, axis, bin boundary)
    let mut best: Option<(f32, usize, usize)> = None;
    for (axis, bins) in bins.iter().enumerate() {
        if map.scale[axis] == 0.0 {
            continue;
        }
        let sides = Sides::of(bins);
        for i in 1..N {
            let (left_count, right_count) = (sides.count[0][i], sides.count[1][i]);
            if left_count == 0 || right_count == 0 {
                continue;
            }
            let cost = left_count as f32 * sides.area[0][i] + right_count as f32 * sides.area[1][i];
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, i));
            }
        }
    }
    let (cost, axis, boundary) = best?;
    let merged = |bins: &[Bin]| bins.iter().fold(Bin::EMPTY, |a, b| a.merge(b));
    let (l, r) = bins[axis].split_at(boundary);
    Some((cost, axis, boundary, merged(l), merged(r)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// A partition's side, one lane compared, is the bin's: for centroids inside, on and
    /// beyond the bins' edges, and infinite and NaN ones, every axis and boundary, 8 and 16
    /// bins, and an axis without extent (its scale 0).
    #[test]
    fn below_a_boundary_is_a_bin_below_it() {
        let mut r = Pcg32::new(6, 1);
        let centroids = Box3 {
            lo: Vec3A::new(-1.5, 0.25, 3.0),
            hi: Vec3A::new(2.5, 0.25, 1e6),
        };
        let extent = centroids.hi - centroids.lo;
        for count in [8, 16] {
            let map = BinMap::new(centroids, count);
            // The bins' edges, and values about them.
            let mut values: Vec<Vec3A> = (0..=count)
                .flat_map(|k| {
                    let edge = centroids.lo + extent * (k as f32 / count as f32);
                    [-1, 0, 1].map(|d| {
                        Vec3A::from_array(
                            edge.to_array()
                                .map(|x| f32::from_bits((x.to_bits() as i64 + d).max(0) as u32)),
                        )
                    })
                })
                .collect();
            values.extend((0..1000).map(|_| {
                let u = Vec3A::new(
                    r.next_f64() as f32,
                    r.next_f64() as f32,
                    r.next_f64() as f32,
                ) * 1.4
                    - 0.2;
                centroids.lo + extent * u
            }));
            values.extend([
                Vec3A::splat(f32::NAN),
                Vec3A::splat(f32::INFINITY),
                Vec3A::splat(f32::NEG_INFINITY),
                Vec3A::splat(-0.0),
            ]);
            for c in values {
                let bins = map.bins(c);
                for (axis, &bin) in bins.iter().enumerate() {
                    for boundary in 1..count {
                        assert_eq!(
                            map.below(c, axis, boundary),
                            bin < boundary,
                            "{c} axis {axis} boundary {boundary} of {count}"
                        );
                    }
                }
            }
        }
    }
}
