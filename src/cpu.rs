//! The processor a build's machine code needs. x86-64 builds target x86-64-v3 (AVX2, FMA,
//! BMI1/2, LZCNT, MOVBE; `.cargo/config.toml`), which renders the books' scene in 0.85 of
//! the time of a baseline x86-64 build, the same bytes (docs/performance.md). On a processor
//! without them the first such instruction would end the process with an illegal
//! instruction, wherever it came; `main` asks here first and stops with the way out instead.

/// The x86-64 features a build may be compiled for beyond the baseline, by the names
/// `is_x86_feature_detected!` takes, and whether this build was.
#[cfg(target_arch = "x86_64")]
const COMPILED: [(&str, bool); 13] = [
    ("sse3", cfg!(target_feature = "sse3")),
    ("ssse3", cfg!(target_feature = "ssse3")),
    ("sse4.1", cfg!(target_feature = "sse4.1")),
    ("sse4.2", cfg!(target_feature = "sse4.2")),
    ("popcnt", cfg!(target_feature = "popcnt")),
    ("avx", cfg!(target_feature = "avx")),
    ("avx2", cfg!(target_feature = "avx2")),
    ("fma", cfg!(target_feature = "fma")),
    ("bmi1", cfg!(target_feature = "bmi1")),
    ("bmi2", cfg!(target_feature = "bmi2")),
    ("lzcnt", cfg!(target_feature = "lzcnt")),
    ("movbe", cfg!(target_feature = "movbe")),
    ("f16c", cfg!(target_feature = "f16c")),
];

/// The processor's feature bits, as `cpuid` gives them: leaf 1's ECX, leaf 7's EBX (sub-leaf
/// 0; zero where the processor has no leaf 7) and leaf 0x8000_0001's ECX (Intel's Software
/// Developer's Manual, volume 2A, CPUID). Read directly: `is_x86_feature_detected!` answers
/// `true` at compile time for every feature a build is compiled for, without asking.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
struct Bits {
    leaf1_ecx: u32,
    leaf7_ebx: u32,
    extended_ecx: u32,
}

#[cfg(target_arch = "x86_64")]
impl Bits {
    /// This processor's.
    fn read() -> Bits {
        use std::arch::x86_64::__cpuid;
        let highest = __cpuid(0).eax;
        let highest_extended = __cpuid(0x8000_0000).eax;
        Bits {
            leaf1_ecx: __cpuid(1).ecx,
            leaf7_ebx: if highest >= 7 { __cpuid(7).ebx } else { 0 },
            extended_ecx: if highest_extended >= 0x8000_0001 {
                __cpuid(0x8000_0001).ecx
            } else {
                0
            },
        }
    }

    /// Whether they include the feature named `name`; `None` for a name not one of
    /// [`COMPILED`]'s. AVX and what builds on it also need the system to save the wide
    /// registers (OSXSAVE).
    fn has(&self, name: &str) -> Option<bool> {
        let bit = |word: u32, n: u32| word >> n & 1 == 1;
        let (c1, b7, ce) = (self.leaf1_ecx, self.leaf7_ebx, self.extended_ecx);
        let wide = bit(c1, 27);
        Some(match name {
            "sse3" => bit(c1, 0),
            "ssse3" => bit(c1, 9),
            "sse4.1" => bit(c1, 19),
            "sse4.2" => bit(c1, 20),
            "popcnt" => bit(c1, 23),
            "movbe" => bit(c1, 22),
            "avx" => wide && bit(c1, 28),
            "fma" => wide && bit(c1, 12),
            "f16c" => wide && bit(c1, 29),
            "avx2" => wide && bit(b7, 5),
            "bmi1" => bit(b7, 3),
            "bmi2" => bit(b7, 8),
            "lzcnt" => bit(ce, 5),
            _ => return None,
        })
    }
}

/// Whether a processor that has what `detected` says lacks some of `compiled` (names, and
/// whether the build was compiled for them).
fn lacks(compiled: &[(&str, bool)], detected: impl Fn(&str) -> bool) -> bool {
    compiled
        .iter()
        .any(|&(name, built)| built && !detected(name))
}

/// What a processor without x86-64-v3 is told.
const MESSAGE: &str = "error: this raytrace was built for x86-64-v3 processors (AVX2, FMA, \
    BMI1 and BMI2, LZCNT, MOVBE; .cargo/config.toml), which this one is not; build one for any \
    x86-64 with an empty RUSTFLAGS, which replaces that setting: `RUSTFLAGS= cargo install \
    --path .`\n";

/// Stops the process with [`MESSAGE`] (exit status 1) where this processor lacks a feature the
/// build was compiled for. Integer code and calls into the standard library (compiled for any
/// x86-64) alone, no formatting: in a build for x86-64-v3 even a copy of a few bytes may be an
/// AVX instruction, which would end the process before the message.
#[inline(never)]
pub(crate) fn require() {
    #[cfg(target_arch = "x86_64")]
    if lacks(&COMPILED, {
        let bits = Bits::read();
        move |name| bits.has(name) == Some(true)
    }) {
        use std::io::Write;
        let _ = std::io::stderr().write_all(MESSAGE.as_bytes());
        std::process::exit(1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_processor_lacking_a_compiled_feature_is_stopped_with_the_way_out() {
        let compiled = [("avx2", true), ("fma", true), ("f16c", false)];
        // A processor with everything the build needs.
        assert!(!lacks(&compiled, |_| true));
        // One without AVX2 and F16C: only what the build was compiled for counts.
        assert!(lacks(&compiled, |name| name == "fma"));
        assert!(!lacks(&compiled, |name| name != "f16c"));
        // A baseline build needs nothing of any processor.
        assert!(!lacks(&[("avx2", false), ("fma", false)], |_| false));
        assert!(MESSAGE.contains("`RUSTFLAGS= cargo install --path .`") && MESSAGE.ends_with('\n'));
    }

    /// Every feature a build may be compiled for is one the processor is asked about (a
    /// misspelt name would read as lacking, and stop every run on every processor), and the
    /// processor running the tests has what this build was compiled for.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn every_feature_compiled_for_is_asked_about() {
        let bits = Bits::read();
        for (name, _) in COMPILED {
            assert!(bits.has(name).is_some(), "{name}");
        }
        assert!(!lacks(&COMPILED, |name| bits.has(name) == Some(true)));
    }

    /// The bits of two processors: a Nehalem (2008: SSE4.2 and POPCNT, no AVX) lacks what an
    /// x86-64-v3 build needs, a Haswell (2013) has it all; AVX without the system's OSXSAVE
    /// counts as missing.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn feature_bits_read_as_the_manual_numbers_them() {
        let v3 = [
            "sse3", "ssse3", "sse4.1", "sse4.2", "popcnt", "avx", "avx2", "fma", "bmi1", "bmi2",
            "lzcnt", "movbe", "f16c",
        ];
        let compiled: Vec<(&str, bool)> = v3.iter().map(|&n| (n, true)).collect();
        // Leaf 1 ECX of a Nehalem: SSE3, SSSE3, SSE4.1, SSE4.2, POPCNT (and others).
        let nehalem = Bits {
            leaf1_ecx: 1 | 1 << 9 | 1 << 19 | 1 << 20 | 1 << 23,
            leaf7_ebx: 0,
            extended_ecx: 0,
        };
        assert!(lacks(&compiled, |n| nehalem.has(n) == Some(true)));
        assert_eq!(nehalem.has("sse4.2"), Some(true));
        assert_eq!(nehalem.has("avx2"), Some(false));
        let haswell = Bits {
            leaf1_ecx: nehalem.leaf1_ecx | 1 << 12 | 1 << 22 | 1 << 27 | 1 << 28 | 1 << 29,
            leaf7_ebx: 1 << 3 | 1 << 5 | 1 << 8,
            extended_ecx: 1 << 5,
        };
        assert!(!lacks(&compiled, |n| haswell.has(n) == Some(true)));
        let no_osxsave = Bits {
            leaf1_ecx: haswell.leaf1_ecx & !(1 << 27),
            ..haswell
        };
        assert_eq!(no_osxsave.has("avx2"), Some(false));
        assert_eq!(haswell.has("avx512f"), None);
    }
}
