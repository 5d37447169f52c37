//! Colour maps for colouring points by a value (`[[points]] colormap`): the perceptually
//! uniform maps of matplotlib (viridis, magma, inferno, plasma, cividis) and Google's turbo,
//! through the `colorous` crate (d3-scale-chromatic's tables and formulas).
//!
//! A map's colours are sRGB, 8 bits a channel; an albedo is linear, so a map's colour is
//! decoded with the sRGB transfer function (IEC 61966-2-1) before it becomes a point's
//! albedo: a point lit to white is then written (sRGB-encoded) as the map's own colour.

/// A named colour map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Colormap {
    Viridis,
    Magma,
    Inferno,
    Plasma,
    Cividis,
    Turbo,
}

impl Colormap {
    /// Every map with its name in scene files.
    pub const ALL: [(&'static str, Colormap); 6] = [
        ("viridis", Colormap::Viridis),
        ("magma", Colormap::Magma),
        ("inferno", Colormap::Inferno),
        ("plasma", Colormap::Plasma),
        ("cividis", Colormap::Cividis),
        ("turbo", Colormap::Turbo),
    ];

    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        Colormap::ALL
            .iter()
            .find(|(_, m)| *m == self)
            .map_or("viridis", |(n, _)| n)
    }

    fn gradient(self) -> colorous::Gradient {
        match self {
            Colormap::Viridis => colorous::VIRIDIS,
            Colormap::Magma => colorous::MAGMA,
            Colormap::Inferno => colorous::INFERNO,
            Colormap::Plasma => colorous::PLASMA,
            Colormap::Cividis => colorous::CIVIDIS,
            Colormap::Turbo => colorous::TURBO,
        }
    }

    /// The map's sRGB colour at `t` (clamped to [0, 1]), 8 bits a channel.
    pub(crate) fn srgb(self, t: f64) -> [u8; 3] {
        let c = self.gradient().eval_continuous(t);
        [c.r, c.g, c.b]
    }

    /// The map's colour at `t` as a linear albedo.
    pub fn linear(self, t: f64) -> [f32; 3] {
        self.srgb(t).map(srgb_to_linear)
    }

    /// The linear albedo of `value` on a map spanning `range` (`[least, greatest]`): the
    /// least is the map's start, the greatest its end, values beyond are clamped; a range of
    /// one value gives the map's middle.
    pub fn color_of(self, value: f64, range: [f64; 2]) -> [f32; 3] {
        let span = range[1] - range[0];
        let t = if span > 0.0 {
            (value - range[0]) / span
        } else {
            0.5
        };
        self.linear(t)
    }
}

/// An 8-bit sRGB channel as a linear value (IEC 61966-2-1).
pub(crate) fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f64 / 255.0;
    let l = if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    };
    l as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_run_from_their_published_ends() {
        // matplotlib's viridis runs from #440154 to #fde725.
        assert_eq!(Colormap::Viridis.srgb(0.0), [0x44, 0x01, 0x54]);
        assert_eq!(Colormap::Viridis.srgb(1.0), [0xfd, 0xe7, 0x25]);
        assert_eq!(Colormap::Viridis.srgb(-3.0), Colormap::Viridis.srgb(0.0));
        for (name, m) in Colormap::ALL {
            assert_eq!(m.name(), name);
            assert_ne!(m.srgb(0.0), m.srgb(1.0));
        }
    }

    #[test]
    fn the_transfer_function_has_its_known_values() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert_eq!(srgb_to_linear(255), 1.0);
        // 0.5 linear encodes to 188 (0.7354); 188 decodes to 0.5029.
        assert!((srgb_to_linear(188) - 0.5029).abs() < 1e-4);
        let r = [2.0, 4.0];
        assert_eq!(
            Colormap::Magma.color_of(3.0, r),
            Colormap::Magma.linear(0.5)
        );
        assert_eq!(
            Colormap::Magma.color_of(9.0, r),
            Colormap::Magma.linear(1.0)
        );
        assert_eq!(
            Colormap::Magma.color_of(1.0, [1.0, 1.0]),
            Colormap::Magma.linear(0.5)
        );
    }
}
