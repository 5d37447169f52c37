//! The shot's and the frame's words split over several storage bindings, *pages*, so that a
//! scene larger than one binding still renders: a device binds at most
//! `max_storage_buffer_binding_size` bytes a buffer (WebGPU guarantees 128 MiB; Vulkan on
//! NVIDIA offers 4 GiB), and the tracer binds each of its two word buffers as up to
//! [`MAX_PAGES`] buffers of [`Pages::page_words`] words each, a power of two, so the shaders
//! find a word's page and its place in it with a shift and a mask (the `quad` function the
//! prelude writes, `layout::wgsl_prelude`). Records are read a quad at a time and a page
//! holds whole quads, so no read straddles two pages.

use super::context::capped;
use super::layout::MAX_PAGES;

/// Storage buffers the tracer binds besides the pages: the work entries, the film's sums and
/// the dispatch's counts (`context::bind_group_layout`).
const OTHER_STORAGE: u32 = 3;

/// Largest page, in words: 2^29 (2 GiB). Word offsets are `u32`, so the pages of a buffer
/// together stay below 2^32 words.
const MAX_PAGE_WORDS: u64 = 1 << 29;

/// How the shot's or the frame's words lie over bindings on a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pages {
    /// Bindings each of the two word buffers may span.
    count: u32,
    /// Words a page holds: a power of two, at least a quad.
    page_words: u32,
    /// The largest storage binding the device takes, bytes (its
    /// `max_storage_buffer_binding_size`, within its `max_buffer_size`).
    binding: u64,
}

impl Pages {
    /// The pages a device with `limits` binds: as many as its storage bindings a stage
    /// allow beside the tracer's others, up to [`MAX_PAGES`], each the largest power of two
    /// of words one binding holds.
    pub fn of(limits: &wgpu::Limits) -> Pages {
        let binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let words = (binding / 4).clamp(4, MAX_PAGE_WORDS);
        let count = (limits
            .max_storage_buffers_per_shader_stage
            .saturating_sub(OTHER_STORAGE)
            / 2)
        .clamp(1, MAX_PAGES);
        Pages {
            count,
            page_words: 1 << words.ilog2(),
            binding,
        }
    }

    /// What every device binds: WebGPU's limits (two pages of 128 MiB), within
    /// [`MAX_BINDING_VARIABLE`](super::MAX_BINDING_VARIABLE) where it is set.
    pub(crate) fn guaranteed() -> Pages {
        Pages::of(&capped(wgpu::Limits::default()))
    }

    /// Bindings a word buffer may span.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Words a page holds.
    pub(crate) fn page_words(&self) -> u32 {
        self.page_words
    }

    /// The largest storage binding the device takes, bytes.
    pub(crate) fn binding(&self) -> u64 {
        self.binding
    }

    /// These pages cut to the fewest that hold `bytes` (at least one).
    pub(crate) fn holding(&self, bytes: u64) -> Pages {
        let page_bytes = 4 * self.page_words as u64;
        Pages {
            count: bytes.div_ceil(page_bytes).clamp(1, self.count as u64) as u32,
            ..*self
        }
    }

    /// Bytes a word buffer may hold over its pages.
    pub fn bytes(&self) -> u64 {
        4 * self.count as u64 * self.page_words as u64
    }

    /// `words` cut into pages (the last one shorter), or `None` when they take more than
    /// [`bytes`](Self::bytes).
    pub(super) fn split<'w>(&self, words: &'w [u32]) -> Option<Vec<&'w [u32]>> {
        let pages: Vec<&[u32]> = words.chunks(self.page_words as usize).collect();
        (pages.len() <= self.count as usize).then_some(pages)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pages_are_the_largest_power_of_two_a_binding_holds() {
        let default = Pages::guaranteed();
        assert_eq!((default.count(), default.page_words()), (2, 1 << 25));
        assert_eq!(default.bytes(), 256 << 20);
        // Vulkan on NVIDIA: a binding of 4 GiB - 1 byte, buffers of 2^40 bytes, and storage
        // bindings without number: pages of 2 GiB, the most there are.
        let nvidia = wgpu::Limits {
            max_storage_buffer_binding_size: u32::MAX as u64,
            max_buffer_size: 1 << 40,
            max_storage_buffers_per_shader_stage: 1 << 20,
            ..Default::default()
        };
        let p = Pages::of(&nvidia);
        assert_eq!((p.count(), p.page_words()), (MAX_PAGES, 1 << 29));
        assert!(p.count() as u64 * p.page_words() as u64 <= 1 << 32);
        // A binding of 3000 bytes (750 words) holds pages of 512 words; the buffer size
        // binds too.
        let small = wgpu::Limits {
            max_storage_buffer_binding_size: 3000,
            ..Default::default()
        };
        assert_eq!(Pages::of(&small).page_words(), 512);
        let short = wgpu::Limits {
            max_buffer_size: 1 << 20,
            ..Default::default()
        };
        assert_eq!(Pages::of(&short).page_words(), 1 << 18);
    }

    #[test]
    fn words_are_cut_into_whole_pages_until_they_run_out() {
        let p = Pages::of(&wgpu::Limits {
            max_storage_buffer_binding_size: 64,
            ..Default::default()
        });
        assert_eq!((p.count(), p.page_words()), (2, 16));
        let words: Vec<u32> = (0..20).collect();
        let pages = p.split(&words).unwrap();
        assert_eq!(pages, [&words[..16], &words[16..]]);
        assert_eq!(p.split(&words[..5]).unwrap(), [&words[..5]]);
        assert!(p.split(&[0; 32]).is_some());
        assert!(p.split(&[0; 33]).is_none());
        // The fewest pages that hold the bytes: 64 bytes a page.
        let counts = [0, 1, 64, 65, 128, 129].map(|b| p.holding(b).count());
        assert_eq!(counts, [1, 1, 1, 2, 2, 2]);
        assert_eq!(p.holding(65).page_words(), 16);
    }
}
