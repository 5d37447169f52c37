//! An image: `width` x `height` pixels of named channels, each a plane of values row-major,
//! top row first, with how a file stores it (as pbrt-v4's `Image` carries its channel
//! descriptors). The one form a frame takes from the film to the file: the film's replicates
//! ([`crate::film::Film::replicates`]), what the denoiser reads and gives back, the written
//! frame's terms and colour, history's earlier frames, and the frame the writers encode
//! ([`crate::renderer::FrameResult::image`]: the film's colour and the passes' channels).
//!
//! A group of three channels (a colour, a normal) is named once, as an [`Rgb`], and read or
//! written as a `Vec3` a pixel ([`Image::rgb`], [`Image::set_rgb`]), never by offsets.

use glam::{DVec3, Vec3};

/// How a file stores a channel (an EXR file; a PNG file stores 8 bits whatever it says).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// 16-bit float (`half`).
    Half,
    /// 32-bit float.
    Float,
}

/// A channel's values: floats, or counts an `f32` would not always hold exactly (a pixel's
/// samples, up to 2^32).
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    Float(Vec<f32>),
    Count(Vec<u32>),
}

impl Values {
    fn len(&self) -> usize {
        match self {
            Values::Float(v) => v.len(),
            Values::Count(v) => v.len(),
        }
    }
}

/// One channel: its name (an EXR channel name), its storage and its values, a pixel each.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    pub name: &'static str,
    pub precision: Precision,
    pub values: Values,
}

impl Channel {
    /// The channel's values as floats, if they are floats.
    pub fn floats(&self) -> Option<&[f32]> {
        match &self.values {
            Values::Float(v) => Some(v),
            Values::Count(_) => None,
        }
    }
}

/// The names of three channels read and written together: a colour's red, green and blue, a
/// normal's x, y and z.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rgb(pub [&'static str; 3]);

/// The colour: the channels every frame file holds.
pub const COLOUR: Rgb = Rgb(["R", "G", "B"]);

/// An image of named channels, a plane each.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    width: u32,
    height: u32,
    channels: Vec<Channel>,
    /// Whether the colour is premultiplied by the `A` channel (a transparent background: a
    /// camera ray that misses adds black); a PNG file divides it out.
    pub premultiplied: bool,
}

/// Three float planes of an image, read a pixel at a time.
#[derive(Clone, Copy, Debug)]
pub struct RgbPlanes<'a>([&'a [f32]; 3]);

impl RgbPlanes<'_> {
    /// Pixel `i`'s three values.
    #[inline]
    pub fn at(&self, i: usize) -> Vec3 {
        Vec3::new(self.0[0][i], self.0[1][i], self.0[2][i])
    }

    /// Pixel `i`'s three values, widened to `f64`.
    #[inline]
    pub fn at_f64(&self, i: usize) -> DVec3 {
        self.at(i).as_dvec3()
    }
}

impl Image {
    /// The bytes an image of `pixels` pixels and `channels` channels holds (4 a value: an
    /// `f32`, or a count).
    pub fn bytes_for(pixels: u64, channels: usize) -> u64 {
        pixels * channels as u64 * 4
    }

    /// An image of `width` x `height` pixels and no channels.
    pub fn new(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            channels: Vec::new(),
            premultiplied: false,
        }
    }

    /// The image's width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// The image's height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The number of pixels.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The channels, in the order they were added.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// The channel named `name`, if the image has it.
    pub fn channel(&self, name: &str) -> Option<&Channel> {
        self.channels.iter().find(|c| c.name == name)
    }

    /// The float values of the channel named `name`, if the image has it as floats.
    pub fn floats(&self, name: &str) -> Option<&[f32]> {
        self.channel(name).and_then(Channel::floats)
    }

    /// The counts of the channel named `name`, if the image has it as counts.
    pub fn counts(&self, name: &str) -> Option<&[u32]> {
        match &self.channel(name)?.values {
            Values::Count(v) => Some(v),
            Values::Float(_) => None,
        }
    }

    /// The three float channels `names`, if the image has them.
    pub fn rgb(&self, names: Rgb) -> Option<RgbPlanes<'_>> {
        let [a, b, c] = names.0.map(|n| self.floats(n));
        Some(RgbPlanes([a?, b?, c?]))
    }

    /// Adds a channel (replacing one of the same name, in its place). Its values must be one a
    /// pixel.
    pub fn set(&mut self, name: &'static str, precision: Precision, values: Values) {
        assert_eq!(
            values.len(),
            self.pixels(),
            "channel {name}: a value a pixel"
        );
        let channel = Channel {
            name,
            precision,
            values,
        };
        match self.channels.iter_mut().find(|c| c.name == name) {
            Some(c) => *c = channel,
            None => self.channels.push(channel),
        }
    }

    /// Adds `channel` (replacing one of the same name, in its place). Its values must be one
    /// a pixel.
    pub fn set_channel(&mut self, channel: Channel) {
        self.set(channel.name, channel.precision, channel.values);
    }

    /// The channels, taken.
    pub fn into_channels(self) -> Vec<Channel> {
        self.channels
    }

    /// Adds the three float channels `names` from `values`, a pixel each.
    pub fn set_rgb(&mut self, names: Rgb, values: impl Iterator<Item = Vec3>) {
        let mut planes: [Vec<f32>; 3] = std::array::from_fn(|_| Vec::with_capacity(self.pixels()));
        for v in values {
            for (p, x) in planes.iter_mut().zip(v.to_array()) {
                p.push(x);
            }
        }
        for (name, plane) in names.0.into_iter().zip(planes) {
            self.set(name, Precision::Float, Values::Float(plane));
        }
    }

    /// Adds the float channels of `groups`, three a group, from `f`, which gives each pixel's
    /// values (a `Vec3` a group), pixel by pixel: the planes are filled as they are made, with
    /// no copy of the image beside them.
    pub fn set_rgbs<const N: usize>(
        &mut self,
        groups: [Rgb; N],
        mut f: impl FnMut(usize) -> [Vec3; N],
    ) {
        let n = self.pixels();
        let mut planes: [[Vec<f32>; 3]; N] =
            std::array::from_fn(|_| std::array::from_fn(|_| Vec::with_capacity(n)));
        for i in 0..n {
            for (group, v) in planes.iter_mut().zip(f(i)) {
                for (plane, x) in group.iter_mut().zip(v.to_array()) {
                    plane.push(x);
                }
            }
        }
        for (names, group) in groups.into_iter().zip(planes) {
            for (name, plane) in names.0.into_iter().zip(group) {
                self.set(name, Precision::Float, Values::Float(plane));
            }
        }
    }

    /// The image with `names`' channels only, in that order (those it has).
    pub fn select(&self, names: &[&str]) -> Image {
        Image {
            width: self.width,
            height: self.height,
            channels: names
                .iter()
                .filter_map(|n| self.channel(n).cloned())
                .collect(),
            premultiplied: self.premultiplied,
        }
    }

    /// The three float channels `names` interleaved, a pixel after another: what a library
    /// that takes packed colours reads (the denoiser's).
    pub fn interleaved(&self, names: Rgb) -> Option<Vec<f32>> {
        let planes = self.rgb(names)?;
        Some(
            (0..self.pixels())
                .flat_map(|i| planes.at(i).to_array())
                .collect(),
        )
    }

    /// An image of the three float channels `names` from `values`, interleaved (three a
    /// pixel).
    pub fn from_interleaved(width: u32, height: u32, names: Rgb, values: &[f32]) -> Image {
        let mut image = Image::new(width, height);
        image.set_rgb(
            names,
            values.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])),
        );
        image
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_are_named_once_and_read_as_triples() {
        let mut image = Image::new(2, 1);
        image.set_rgb(COLOUR, [Vec3::X, Vec3::new(0.5, 1.5, 2.5)].into_iter());
        image.set(
            "samples",
            Precision::Float,
            Values::Count(vec![3, u32::MAX]),
        );
        assert_eq!(image.rgb(COLOUR).unwrap().at(1), Vec3::new(0.5, 1.5, 2.5));
        assert_eq!(image.floats("G"), Some(&[0.0, 1.5][..]));
        assert_eq!(image.counts("samples"), Some(&[3, u32::MAX][..]));
        assert_eq!(image.floats("samples"), None);
        assert_eq!(
            image.interleaved(COLOUR).unwrap(),
            [1.0, 0.0, 0.0, 0.5, 1.5, 2.5]
        );
        let back = Image::from_interleaved(2, 1, COLOUR, &image.interleaved(COLOUR).unwrap());
        assert_eq!(
            back.select(&["R", "G", "B"]),
            image.select(&["R", "G", "B"])
        );
        // A channel set again keeps its place.
        image.set("R", Precision::Half, Values::Float(vec![7.0, 8.0]));
        let names: Vec<&str> = image.channels().iter().map(|c| c.name).collect();
        assert_eq!(names, ["R", "G", "B", "samples"]);
    }
}
