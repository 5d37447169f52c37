//! The processor a build's machine code needs. x86-64 builds target x86-64-v3 (AVX2, FMA,
//! BMI1/2, LZCNT, MOVBE; `.cargo/config.toml`), which renders the books' scene in 0.85 of
//! the time of a baseline x86-64 build, the same bytes (docs/performance.md). On a processor
//! without them the first such instruction would end the process with an illegal
//! instruction, wherever it came; `main` asks here first and stops with the way out instead.
//!
//! The processor is asked with `cpuid` directly: `is_x86_feature_detected!` answers `true`
//! at compile time for every feature a build is compiled for, without asking.

/// Which word of [`Bits`] holds a feature's bit.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
enum Word {
    Leaf1Ecx,
    Leaf7Ebx,
    ExtendedEcx,
}

/// A feature a build may be compiled for beyond baseline x86-64: its name (as
/// `target_feature` spells it), whether this build was compiled for it, and where `cpuid`
/// reports it (Intel's Software Developer's Manual, volume 2A, CPUID); `wide` for AVX and
/// what builds on it, which also need the system to save the wide registers (OSXSAVE).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
struct Feature {
    name: &'static str,
    compiled: bool,
    word: Word,
    bit: u32,
    wide: bool,
}

/// A [`Feature`] named once: its name is also what `cfg!(target_feature)` is asked.
#[cfg(target_arch = "x86_64")]
macro_rules! feature {
    ($name:tt, $word:ident, $bit:expr, $wide:expr) => {
        Feature {
            name: $name,
            compiled: cfg!(target_feature = $name),
            word: Word::$word,
            bit: $bit,
            wide: $wide,
        }
    };
}

/// The features of x86-64-v2 and x86-64-v3 beyond the baseline.
#[cfg(target_arch = "x86_64")]
const FEATURES: [Feature; 13] = [
    feature!("sse3", Leaf1Ecx, 0, false),
    feature!("ssse3", Leaf1Ecx, 9, false),
    feature!("fma", Leaf1Ecx, 12, true),
    feature!("sse4.1", Leaf1Ecx, 19, false),
    feature!("sse4.2", Leaf1Ecx, 20, false),
    feature!("movbe", Leaf1Ecx, 22, false),
    feature!("popcnt", Leaf1Ecx, 23, false),
    feature!("avx", Leaf1Ecx, 28, true),
    feature!("f16c", Leaf1Ecx, 29, true),
    feature!("bmi1", Leaf7Ebx, 3, false),
    feature!("avx2", Leaf7Ebx, 5, true),
    feature!("bmi2", Leaf7Ebx, 8, false),
    feature!("lzcnt", ExtendedEcx, 5, false),
];

/// The processor's feature bits: leaf 1's ECX, leaf 7's EBX (sub-leaf 0; zero where the
/// processor has no leaf 7) and leaf 0x8000_0001's ECX.
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

    /// Whether they include feature `f`.
    fn has(&self, f: &Feature) -> bool {
        let word = match f.word {
            Word::Leaf1Ecx => self.leaf1_ecx,
            Word::Leaf7Ebx => self.leaf7_ebx,
            Word::ExtendedEcx => self.extended_ecx,
        };
        let osxsave = self.leaf1_ecx >> 27 & 1 == 1;
        word >> f.bit & 1 == 1 && (osxsave || !f.wide)
    }

    /// Whether they lack a feature of `features` that the build was compiled for.
    fn lacks(&self, features: &[Feature]) -> bool {
        features.iter().any(|f| f.compiled && !self.has(f))
    }
}

/// What a processor without x86-64-v3 is told: this, the features it lacks, then
/// [`WAY_OUT`].
#[cfg(target_arch = "x86_64")]
const MESSAGE: &str = "error: this raytrace was built for x86-64-v3 processors (AVX2, FMA, \
    BMI1 and BMI2, LZCNT, MOVBE; .cargo/config.toml), and this one lacks";

/// How to build for an older processor.
#[cfg(target_arch = "x86_64")]
const WAY_OUT: &str = "; build one for any x86-64 with an empty RUSTFLAGS, which replaces \
    that setting: `RUSTFLAGS= cargo install --path .`\n";

/// Stops the process (exit status 1) where this processor lacks a feature the build was
/// compiled for, saying which and the way out. Integer code and calls into the standard
/// library (compiled for any x86-64) alone, no formatting: in a build for x86-64-v3 even a
/// copy of a few bytes may be an AVX instruction, which would end the process before the
/// message.
#[inline(never)]
pub(crate) fn require() {
    #[cfg(target_arch = "x86_64")]
    {
        let bits = Bits::read();
        if bits.lacks(&FEATURES) {
            use std::io::Write;
            let mut err = std::io::stderr().lock();
            let _ = err.write_all(MESSAGE.as_bytes());
            for f in FEATURES.iter().filter(|f| f.compiled && !bits.has(f)) {
                let _ = err.write_all(b" ");
                let _ = err.write_all(f.name.as_bytes());
            }
            let _ = err.write_all(WAY_OUT.as_bytes());
            std::process::exit(1);
        }
    }
}

// Every test reads x86-64 feature bits.
#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;

    #[test]
    fn the_message_says_the_way_out() {
        assert!(WAY_OUT.contains("`RUSTFLAGS= cargo install --path .`") && WAY_OUT.ends_with('\n'));
    }

    /// The bits of two processors: a Nehalem (2008: SSE4.2 and POPCNT, no AVX) lacks what an
    /// x86-64-v3 build needs, a Haswell (2013) has it all; AVX without the system's OSXSAVE
    /// counts as missing; a baseline build needs nothing of either.
    #[test]
    fn feature_bits_read_as_the_manual_numbers_them() {
        let v3 = FEATURES.map(|f| Feature {
            compiled: true,
            ..f
        });
        let baseline = FEATURES.map(|f| Feature {
            compiled: false,
            ..f
        });
        let named = |name: &str| *FEATURES.iter().find(|f| f.name == name).expect(name);
        // Leaf 1 ECX of a Nehalem: SSE3, SSSE3, SSE4.1, SSE4.2, POPCNT (and others).
        let nehalem = Bits {
            leaf1_ecx: 1 | 1 << 9 | 1 << 19 | 1 << 20 | 1 << 23,
            leaf7_ebx: 0,
            extended_ecx: 0,
        };
        assert!(nehalem.lacks(&v3) && !nehalem.lacks(&baseline));
        assert!(nehalem.has(&named("sse4.2")) && !nehalem.has(&named("avx2")));
        let haswell = Bits {
            leaf1_ecx: nehalem.leaf1_ecx | 1 << 12 | 1 << 22 | 1 << 27 | 1 << 28 | 1 << 29,
            leaf7_ebx: 1 << 3 | 1 << 5 | 1 << 8,
            extended_ecx: 1 << 5,
        };
        assert!(!haswell.lacks(&v3));
        let no_osxsave = Bits {
            leaf1_ecx: haswell.leaf1_ecx & !(1 << 27),
            ..haswell
        };
        assert!(!no_osxsave.has(&named("avx2")) && no_osxsave.has(&named("bmi2")));
    }

    /// The processor running the tests has what this build was compiled for (were a bit
    /// misnumbered, every run would stop here).
    #[test]
    fn the_processor_running_the_tests_has_what_the_build_needs() {
        assert!(!Bits::read().lacks(&FEATURES));
        // This build is compiled for x86-64-v3 unless RUSTFLAGS replaced that.
        assert!(FEATURES.iter().any(|f| f.compiled) || std::env::var_os("RUSTFLAGS").is_some());
    }
}
