//! What a pass for compositing is: its name in the scene format, its EXR channels and their
//! storage, and sets of passes. A low room of names that the description, the validator, the
//! film's passes ([`crate::passes`]) and the writers all share.

use crate::image::Rgb;

/// A pass: a closed set, named as in the scene format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Pass {
    /// `A`: the fraction of the camera samples whose ray hits a sphere.
    Alpha,
    /// `Z`: distance along the view direction to the first hit, mean over the hits.
    Depth,
    /// `N.X`, `N.Y`, `N.Z`: world-space outward unit normal at the first hit, mean over hits.
    Normal,
    /// `albedo.R/G/B`: the first hit's albedo, or the background's radiance for a miss.
    Albedo,
    /// `forward.u/v`, `backward.u/v`: image-space displacement in pixels, mean over hits.
    Motion,
    /// `variance.R/G/B`: the estimated variance of the pixel's mean colour.
    Variance,
    /// `samples`: the samples the pixel took (they differ from pixel to pixel under adaptive
    /// sampling).
    Samples,
    /// `noisy.R/G/B`: the colour before denoising (with denoising only; EXR only).
    Noisy,
}

pub use crate::image::Precision;

/// The variance pass's channels: the estimated variance of each pixel's mean colour (also a
/// film's replicates image's).
pub const VARIANCE: Rgb = Rgb(["variance.R", "variance.G", "variance.B"]);

/// The depth pass's channel: distance along the view direction to the first hit.
pub const DEPTH: &str = "Z";

/// The normal pass's channels: the first hit's world-space unit normal.
pub const NORMAL: Rgb = Rgb(["N.X", "N.Y", "N.Z"]);

/// The motion pass's forward channels: where the first hit's surface will be one frame period
/// later, in pixels (`u` right, `v` up).
pub const FORWARD: [&str; 2] = ["forward.u", "forward.v"];

/// The motion pass's backward channels: where the first hit's surface was one frame period
/// earlier, in pixels (`u` right, `v` up).
pub const BACKWARD: [&str; 2] = ["backward.u", "backward.v"];

/// The samples pass's channel: the samples each pixel took (also a film's replicates
/// image's, as counts).
pub const SAMPLES: &str = "samples";

impl Pass {
    /// Every pass, in the order the scene format lists them.
    pub const ALL: [Pass; 8] = [
        Pass::Alpha,
        Pass::Depth,
        Pass::Normal,
        Pass::Albedo,
        Pass::Motion,
        Pass::Variance,
        Pass::Samples,
        Pass::Noisy,
    ];

    /// The name in `[output] passes` and `--passes`.
    pub fn name(self) -> &'static str {
        match self {
            Pass::Alpha => "alpha",
            Pass::Depth => "depth",
            Pass::Normal => "normal",
            Pass::Albedo => "albedo",
            Pass::Motion => "motion",
            Pass::Variance => "variance",
            Pass::Samples => "samples",
            Pass::Noisy => "noisy",
        }
    }

    /// The pass named `name`, if any.
    pub fn from_name(name: &str) -> Option<Pass> {
        Pass::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The EXR channels of the pass, in the order a frame's image holds them.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            Pass::Alpha => &["A"],
            Pass::Depth => &[DEPTH],
            Pass::Normal => &NORMAL.0,
            Pass::Albedo => &["albedo.R", "albedo.G", "albedo.B"],
            Pass::Motion => &[FORWARD[0], FORWARD[1], BACKWARD[0], BACKWARD[1]],
            Pass::Variance => &VARIANCE.0,
            Pass::Samples => &[SAMPLES],
            Pass::Noisy => &["noisy.R", "noisy.G", "noisy.B"],
        }
    }

    /// How the pass is stored: `half` where 11 bits of mantissa lose nothing that matters
    /// (unit normals, albedos and coverage in [0, 1]), `float` where range or precision does
    /// (depths, displacements in pixels, variances spanning many decades, sample counts
    /// beyond 2048, exact as `float` up to 2^24).
    pub fn precision(self) -> Precision {
        match self {
            Pass::Alpha | Pass::Normal | Pass::Albedo => Precision::Half,
            Pass::Depth | Pass::Motion | Pass::Variance | Pass::Samples | Pass::Noisy => {
                Precision::Float
            }
        }
    }
}

/// A set of passes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassSet(u8);

impl PassSet {
    /// No pass: colour only.
    pub const EMPTY: PassSet = PassSet(0);

    /// The set with `pass` added.
    pub fn with(self, pass: Pass) -> PassSet {
        PassSet(self.0 | 1 << pass as u8)
    }

    /// Whether `pass` is in the set.
    pub fn contains(self, pass: Pass) -> bool {
        self.0 & (1 << pass as u8) != 0
    }

    /// Whether the set is empty.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The passes of the set, in [`Pass::ALL`]'s order.
    pub fn iter(self) -> impl Iterator<Item = Pass> {
        Pass::ALL.into_iter().filter(move |p| self.contains(*p))
    }
}

impl FromIterator<Pass> for PassSet {
    fn from_iter<I: IntoIterator<Item = Pass>>(iter: I) -> PassSet {
        iter.into_iter().fold(PassSet::EMPTY, PassSet::with)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_sets_hold_what_was_added() {
        for p in Pass::ALL {
            assert_eq!(Pass::from_name(p.name()), Some(p));
        }
        assert_eq!(Pass::from_name("beauty"), None);
        let s: PassSet = [Pass::Motion, Pass::Alpha].into_iter().collect();
        assert_eq!(s.iter().collect::<Vec<_>>(), [Pass::Alpha, Pass::Motion]);
        assert!(!s.contains(Pass::Depth));
        assert!(PassSet::EMPTY.is_empty());
    }
}
