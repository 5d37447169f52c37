//! A set of up to [`Bits::CAPACITY`] small numbers, a bit each, on the stack: the paths still
//! going in a batch ([`crate::tracer::STREAM`]) and the rays waiting to walk in turns.

/// A set of numbers below [`Bits::CAPACITY`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Bits([u128; 2]);

impl Bits {
    /// Numbers a set can hold: `0..CAPACITY`.
    pub(crate) const CAPACITY: usize = 256;

    /// Adds `i`.
    #[inline(always)]
    pub(crate) fn insert(&mut self, i: usize) {
        self.0[i >> 7] |= 1 << (i & 127);
    }

    /// Removes `i`.
    #[inline(always)]
    pub(crate) fn remove(&mut self, i: usize) {
        self.0[i >> 7] &= !(1 << (i & 127));
    }

    /// Whether the set is empty.
    #[inline(always)]
    pub(crate) fn is_empty(&self) -> bool {
        self.0 == [0; 2]
    }

    /// Removes the smallest number and returns it; `None` for an empty set.
    #[inline(always)]
    pub(crate) fn pop_first(&mut self) -> Option<usize> {
        for (w, word) in self.0.iter_mut().enumerate() {
            if *word != 0 {
                let i = word.trailing_zeros() as usize;
                *word &= *word - 1;
                return Some(w * 128 + i);
            }
        }
        None
    }

    /// The numbers, smallest first.
    #[inline(always)]
    pub(crate) fn iter(self) -> impl Iterator<Item = usize> {
        let mut rest = self;
        std::iter::from_fn(move || rest.pop_first())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a sorted list, across both words.
    #[test]
    fn holds_what_was_inserted_and_not_removed() {
        let mut bits = Bits::default();
        let mut want = std::collections::BTreeSet::new();
        let mut r = crate::rng::Pcg32::new(5, 9);
        for _ in 0..2000 {
            let i = (r.next_f64() * Bits::CAPACITY as f64) as usize;
            if r.next_f64() < 0.6 {
                bits.insert(i);
                want.insert(i);
            } else {
                bits.remove(i);
                want.remove(&i);
            }
            assert_eq!(bits.is_empty(), want.is_empty());
            assert!(bits.iter().eq(want.iter().copied()));
        }
        while let Some(i) = bits.pop_first() {
            assert_eq!(Some(i), want.pop_first());
        }
        assert!(want.is_empty() && bits.is_empty());
    }
}
