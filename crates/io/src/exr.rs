//! OpenEXR frames: linear 32-bit float RGB, ZIP compressed, with the frame's metadata as
//! header attributes written in a fixed order; and reading RGB back.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use raytrace_core::error::Error;
use raytrace_core::image::{COLOUR, Image};

/// The metadata stored with a frame (in EXR headers; PNG files carry none).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameInfo {
    /// The frame number.
    pub frame: u32,
    /// Frames per second of the shot, > 0.
    pub fps: f64,
    /// Absolute time in seconds the shutter opens.
    pub shutter_open: f64,
    /// Absolute time in seconds the shutter closes.
    pub shutter_close: f64,
    /// Samples per pixel requested.
    pub samples: u32,
    /// The seed of the frame's random numbers.
    pub seed: u64,
    /// The name of the sampler that placed the samples.
    pub sampler: String,
    /// A rolling shutter's readout in seconds, if the shot has one (the shutter times above
    /// are then those of the whole exposure, first row's opening to last row's closing).
    pub rolling_shutter_readout: Option<f64>,
    /// The shutter curve as the scene writes it, unless a box.
    pub shutter_curve: Option<String>,
    /// The denoiser that made the colour, if it is denoised.
    pub denoiser: Option<String>,
    /// Further numeric attributes, stored as doubles under their names. A name must be 1 to
    /// 255 printable Latin-1 characters, must be unique, and must not be one of the names
    /// above nor a standard OpenEXR attribute name.
    pub extra: Vec<(String, f64)>,
}

/// Names of the custom EXR attributes written from [`FrameInfo`].
pub(crate) mod attribute_names {
    /// The frame number: an int, or a double above `i32::MAX`.
    pub(crate) const FRAME: &str = "frame";
    /// Shutter opening time in seconds, a double.
    pub(crate) const SHUTTER_OPEN: &str = "shutterOpen";
    /// Shutter closing time in seconds, a double.
    pub(crate) const SHUTTER_CLOSE: &str = "shutterClose";
    /// Samples per pixel: an int, or a double above `i32::MAX`.
    pub(crate) const SAMPLES: &str = "samples";
    /// The 64-bit seed as decimal text (no EXR attribute type holds a u64).
    pub(crate) const SEED: &str = "seed";
    /// The sampler's name, as text.
    pub(crate) const SAMPLER: &str = "sampler";
    /// A rolling shutter's readout in seconds, a double (only with a rolling shutter).
    pub(crate) const ROLLING_SHUTTER_READOUT: &str = "rollingShutterReadout";
    /// The shutter curve, as text (only when not a box).
    pub(crate) const SHUTTER_CURVE: &str = "shutterCurve";
    /// The denoiser that made the colour, as text (only for a denoised frame).
    pub(crate) const DENOISER: &str = "denoiser";
    /// All of the above.
    pub(crate) const ALL: &[&str] = &[
        FRAME,
        SHUTTER_OPEN,
        SHUTTER_CLOSE,
        SAMPLES,
        SEED,
        SAMPLER,
        ROLLING_SHUTTER_READOUT,
        SHUTTER_CURVE,
        DENOISER,
    ];
}

/// Reads the colour of an EXR file (its first layer's R, G and B) as an image of linear
/// radiance ([`COLOUR`]). Errors are the decoder's message.
pub fn read_exr_colour(path: &Path) -> Result<Image, String> {
    use exr::prelude::read_first_rgba_layer_from_file;
    use glam::Vec3;
    let image = read_first_rgba_layer_from_file(
        path,
        |size, _| (size.width(), vec![Vec3::ZERO; size.width() * size.height()]),
        |(w, pixels): &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            pixels[pos.y() * *w + pos.x()] = Vec3::new(r, g, b);
        },
    )
    .map_err(|e| e.to_string())?;
    let size = image.layer_data.size;
    let (_, pixels) = image.layer_data.channel_data.pixels;
    let mut colour = Image::new(size.width() as u32, size.height() as u32);
    colour.set_rgb(COLOUR, pixels.into_iter());
    Ok(colour)
}

/// A frame rate as the rational of the standard `framesPerSecond` attribute.
///
/// Whole numbers are exact (`24` → 24/1); the NTSC rates `n * 1000/1001` written to a few
/// decimals are recognised (`23.976` → 24000/1001, `29.97` → 30000/1001); anything else is
/// the closest continued-fraction convergent with a denominator of at most 1,000,000.
/// `None` for rates that are not finite and positive or do not fit.
pub(crate) fn fps_rational(fps: f64) -> Option<(i32, u32)> {
    if !fps.is_finite() || fps <= 0.0 || fps > i32::MAX as f64 {
        return None;
    }
    if fps.fract() == 0.0 {
        return Some((fps as i32, 1));
    }
    let ntsc = (fps * 1.001).round();
    if ntsc >= 1.0 && (fps * 1.001 - ntsc).abs() <= 1e-5 * ntsc && ntsc * 1000.0 <= i32::MAX as f64
    {
        return Some(((ntsc as i32) * 1000, 1001));
    }
    const MAX_DENOMINATOR: f64 = 1_000_000.0;
    // Convergents h/k of the continued fraction of fps.
    let (mut h_prev, mut h) = (1.0_f64, fps.floor());
    let (mut k_prev, mut k) = (0.0_f64, 1.0_f64);
    let mut x = fps - fps.floor();
    while x > 1e-12 && (h / k - fps).abs() > 1e-12 * fps {
        let y = 1.0 / x;
        let a = y.floor();
        x = y - a;
        let (h_next, k_next) = (a * h + h_prev, a * k + k_prev);
        if k_next > MAX_DENOMINATOR || h_next > i32::MAX as f64 {
            break;
        }
        (h_prev, h, k_prev, k) = (h, h_next, k, k_next);
    }
    if h < 1.0 {
        return None;
    }
    Some((h as i32, k as u32))
}

/// An integer attribute, or a double when the value does not fit an `i32`.
fn int_attribute(value: u32) -> exr::meta::attribute::AttributeValue {
    use exr::meta::attribute::AttributeValue;
    match i32::try_from(value) {
        Ok(v) => AttributeValue::I32(v),
        Err(_) => AttributeValue::F64(value as f64),
    }
}

/// The layer attributes of a frame, or a message saying what is wrong with `info`.
pub(super) fn attributes(info: &FrameInfo) -> Result<exr::meta::header::LayerAttributes, String> {
    use exr::meta::attribute::{AttributeValue, Text};
    use exr::meta::header::LayerAttributes;

    let mut attributes = LayerAttributes {
        frames_per_second: Some(
            fps_rational(info.fps)
                .ok_or_else(|| format!("invalid frame rate {} for the EXR header", info.fps))?,
        ),
        software_name: Some(Text::from(concat!("raytrace ", env!("CARGO_PKG_VERSION")))),
        ..LayerAttributes::default()
    };
    let other = &mut attributes.other;
    let mut insert = |name: &str, value| other.insert(Text::from(name), value);
    insert(attribute_names::FRAME, int_attribute(info.frame));
    insert(
        attribute_names::SHUTTER_OPEN,
        AttributeValue::F64(info.shutter_open),
    );
    insert(
        attribute_names::SHUTTER_CLOSE,
        AttributeValue::F64(info.shutter_close),
    );
    insert(attribute_names::SAMPLES, int_attribute(info.samples));
    insert(
        attribute_names::SEED,
        AttributeValue::Text(Text::from(info.seed.to_string().as_str())),
    );
    insert(
        attribute_names::SAMPLER,
        latin1(&info.sampler, || {
            format!("sampler name \"{}\"", info.sampler)
        })?,
    );
    if let Some(readout) = info.rolling_shutter_readout {
        insert(
            attribute_names::ROLLING_SHUTTER_READOUT,
            AttributeValue::F64(readout),
        );
    }
    if let Some(curve) = &info.shutter_curve {
        insert(
            attribute_names::SHUTTER_CURVE,
            latin1(curve, || format!("shutter curve \"{curve}\""))?,
        );
    }
    if let Some(denoiser) = &info.denoiser {
        insert(
            attribute_names::DENOISER,
            latin1(denoiser, || format!("denoiser \"{denoiser}\""))?,
        );
    }
    insert_extra(other, &info.extra)?;
    Ok(attributes)
}

/// `text` as a text attribute, or a message saying that `what` is not Latin-1.
fn latin1(
    text: &str,
    what: impl FnOnce() -> String,
) -> Result<exr::meta::attribute::AttributeValue, String> {
    exr::meta::attribute::Text::new_or_none(text)
        .map(exr::meta::attribute::AttributeValue::Text)
        .ok_or_else(|| format!("{} is not Latin-1", what()))
}

/// Adds the frame's extra attributes (a number each) to `other`, or says which name is not
/// allowed: EXR names, unique, and none of ours or the standard ones.
fn insert_extra(
    other: &mut std::collections::HashMap<
        exr::meta::attribute::Text,
        exr::meta::attribute::AttributeValue,
    >,
    extra: &[(String, f64)],
) -> Result<(), String> {
    use exr::meta::attribute::{AttributeValue, Text};
    use exr::meta::header::standard_names;

    for (name, value) in extra {
        let bad = |why: &str| format!("extra attribute name \"{name}\" {why}");
        // Up to 31 characters: longer names need the file's long-name flag.
        if name.is_empty() || name.len() > 31 {
            return Err(bad("must have 1 to 31 characters"));
        }
        if name.chars().any(char::is_control) {
            return Err(bad("contains a control character"));
        }
        let text = Text::new_or_none(name).ok_or_else(|| bad("has characters outside Latin-1"))?;
        if attribute_names::ALL.contains(&name.as_str())
            || standard_names::ALL.contains(&name.as_bytes())
        {
            return Err(bad("is reserved"));
        }
        if other.insert(text, AttributeValue::F64(*value)).is_some() {
            return Err(bad("appears twice"));
        }
    }
    Ok(())
}

/// Writes the frame as EXR into `writer`, with `attributes` spliced into the header in name
/// order.
pub(super) fn write(
    writer: &mut BufWriter<File>,
    path: &Path,
    image: &Image,
    attributes: exr::meta::header::LayerAttributes,
) -> Result<(), Error> {
    use exr::prelude::{
        Blocks, Compression, Encoding, Image, Layer, LineOrder, SpecificChannels, Vec2,
        WritableImage,
    };

    let (w, height) = (image.width() as usize, image.height());
    let rgb = image.rgb(COLOUR).expect("a frame's colour");
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    if super::frame_file::passes(image).next().is_some() {
        return write_with_passes(writer, path, image, attributes, encoding);
    }
    let pixels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let [r, g, b] = rgb.at(p.y() * w + p.x()).to_array();
        (r, g, b)
    });
    encode(writer, path, attributes, |attributes, sink| {
        let layer = Layer::new((w, height as usize), attributes, encoding, pixels);
        Image::from_layer(layer)
            .write()
            .non_parallel()
            .to_buffered(sink)
    })
}

/// Encodes a frame into `writer` with `write`, which builds the layer from the attributes it
/// is handed and writes it into the sink. The exr crate writes custom attributes in the
/// iteration order of a randomly seeded HashMap, so the same frame would get different bytes
/// in different processes: `write` gets them as a [`Placeholder`], filled in afterwards.
fn encode(
    writer: &mut BufWriter<File>,
    path: &Path,
    attributes: exr::meta::header::LayerAttributes,
    write: impl FnOnce(
        exr::meta::header::LayerAttributes,
        &mut HeaderCapture,
    ) -> Result<(), exr::error::Error>,
) -> Result<(), Error> {
    let (attributes, placeholder) = Placeholder::take(attributes).map_err(|m| output(path, m))?;
    let mut sink = HeaderCapture::new(writer);
    write(attributes, &mut sink).map_err(|e| encoder_error(path, e))?;
    placeholder.fill(sink).map_err(|e| Error::io(path, e))
}

/// The encoder's error as the renderer's.
fn encoder_error(path: &Path, e: exr::error::Error) -> Error {
    match e {
        exr::error::Error::Io(e) => Error::io(path, e),
        other => output(path, format!("EXR encoder: {other}")),
    }
}

/// Writes the frame with its passes: one part whose channels are R, G, B (float) and each
/// pass's channels under their names, `half` or `float` as the pass says (the encoder sorts
/// the channel list by name, as the format requires).
fn write_with_passes(
    writer: &mut BufWriter<File>,
    path: &Path,
    image: &Image,
    attributes: exr::meta::header::LayerAttributes,
    encoding: exr::prelude::Encoding,
) -> Result<(), Error> {
    use exr::prelude::{
        AnyChannel, AnyChannels, FlatSamples, Image, Layer, SmallVec, WritableImage, f16,
    };
    use raytrace_core::image::{Precision, Values};

    let (w, height) = (image.width() as usize, image.height());
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for name in COLOUR.0 {
        let values = image.floats(name).expect("a frame's colour").to_vec();
        list.push(AnyChannel::new(name, FlatSamples::F32(values)));
    }
    for c in super::frame_file::passes(image) {
        let floats: Vec<f32> = match &c.values {
            Values::Float(v) => v.clone(),
            Values::Count(v) => v.iter().map(|&n| n as f32).collect(),
        };
        let samples = match c.precision {
            Precision::Float => FlatSamples::F32(floats),
            Precision::Half => FlatSamples::F16(floats.into_iter().map(f16::from_f32).collect()),
        };
        list.push(AnyChannel::new(c.name, samples));
    }
    encode(writer, path, attributes, |attributes, sink| {
        let layer = Layer::new(
            (w, height as usize),
            attributes,
            encoding,
            AnyChannels::sort(list),
        );
        Image::from_layer(layer)
            .write()
            .non_parallel()
            .to_buffered(sink)
    })
}

/// An output error naming `path`.
fn output(path: &Path, message: String) -> Error {
    Error::Output {
        path: path.to_path_buf(),
        message,
    }
}

/// The name of the attribute that holds the custom attributes' place while the encoder writes.
const PLACEHOLDER: &str = "~";

/// The frame's custom attributes, in name order, serialized, and the placeholder the encoder
/// writes in their stead.
///
/// The exr crate writes custom attributes in the iteration order of a randomly seeded
/// `HashMap`, so the same frame would get different bytes in different processes. So the
/// encoder gets one custom attribute only, a string attribute as long in the file as all of
/// them together; it writes the image straight into the file (no copy of the encoded image in
/// memory), and [`fill`](Placeholder::fill) then overwrites the placeholder's bytes with the
/// attributes in name order. No offset in the file moves. (OpenEXR layout: magic and version,
/// attributes as `name\0 type\0 size value`, a null byte, the offset table, the chunks.)
struct Placeholder {
    /// The custom attributes as the file holds them, in name order.
    bytes: Vec<u8>,
}

impl Placeholder {
    /// Takes the custom attributes out of `attributes` and puts the placeholder in.
    fn take(
        mut attributes: exr::meta::header::LayerAttributes,
    ) -> Result<(exr::meta::header::LayerAttributes, Placeholder), String> {
        use exr::meta::attribute::{AttributeValue, Text};
        let mut custom: Vec<_> = attributes.other.drain().collect();
        custom.sort_by(|a, b| a.0.as_slice().cmp(b.0.as_slice()));
        let mut bytes = Vec::new();
        for (name, value) in &custom {
            let (kind, data): (&str, Vec<u8>) = match value {
                AttributeValue::I32(v) => ("int", v.to_le_bytes().to_vec()),
                AttributeValue::F64(v) => ("double", v.to_le_bytes().to_vec()),
                AttributeValue::Text(t) => ("string", t.as_slice().to_vec()),
                other => return Err(format!("unsupported custom attribute {other:?}")),
            };
            bytes.extend_from_slice(name.as_slice());
            bytes.push(0);
            bytes.extend_from_slice(kind.as_bytes());
            bytes.push(0);
            bytes.extend_from_slice(&(data.len() as u32).to_le_bytes());
            bytes.extend_from_slice(&data);
        }
        // The placeholder's own name, type and size fields; its value fills the rest. Every
        // frame has more custom attributes than these 14 bytes.
        let overhead = PLACEHOLDER.len() + 1 + "string".len() + 1 + 4;
        let fill = bytes
            .len()
            .checked_sub(overhead)
            .ok_or("too few custom attributes for the placeholder")?;
        attributes.other.insert(
            Text::from(PLACEHOLDER),
            AttributeValue::Text(Text::from_bytes_unchecked(vec![b' '; fill].into())),
        );
        Ok((attributes, Placeholder { bytes }))
    }

    /// Finds the placeholder in the header `sink` captured and overwrites it with the
    /// attributes; leaves the file's position at its end.
    fn fill(self, sink: HeaderCapture) -> std::io::Result<()> {
        use std::io::{Seek, SeekFrom};
        let malformed =
            || std::io::Error::other("EXR encoder produced an unexpected header".to_string());
        let header = &sink.header;
        let mut pos = 8;
        loop {
            let field_end = |from: usize| {
                header
                    .get(from..)
                    .and_then(|r| r.iter().position(|&b| b == 0))
                    .map(|i| from + i)
                    .ok_or_else(malformed)
            };
            let name_end = field_end(pos)?;
            if name_end == pos {
                return Err(malformed());
            }
            let type_end = field_end(name_end + 1)?;
            let size: [u8; 4] = header
                .get(type_end + 1..type_end + 5)
                .ok_or_else(malformed)?
                .try_into()
                .expect("four bytes");
            let end = type_end + 5 + u32::from_le_bytes(size) as usize;
            if &header[pos..name_end] == PLACEHOLDER.as_bytes() {
                if end - pos != self.bytes.len() {
                    return Err(malformed());
                }
                break;
            }
            pos = end;
        }
        let writer = sink.writer;
        writer.seek(SeekFrom::Start(sink.start + pos as u64))?;
        writer.write_all(&self.bytes)?;
        writer.seek(SeekFrom::End(0))?;
        Ok(())
    }
}

/// A writer into the file that keeps a copy of the file's first [`HeaderCapture::LIMIT`] bytes
/// (the header, where [`Placeholder`] is found) and passes everything on.
struct HeaderCapture<'a> {
    writer: &'a mut BufWriter<File>,
    /// The file position the image starts at.
    start: u64,
    /// The position relative to `start`.
    pos: u64,
    header: Vec<u8>,
}

impl<'a> HeaderCapture<'a> {
    /// Headers are a few hundred bytes.
    const LIMIT: usize = 1 << 16;

    fn new(writer: &'a mut BufWriter<File>) -> HeaderCapture<'a> {
        use std::io::Seek;
        let start = writer.stream_position().unwrap_or(0);
        HeaderCapture {
            writer,
            start,
            pos: 0,
            header: Vec::new(),
        }
    }
}

impl Write for HeaderCapture<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.writer.write(buf)?;
        let from = self.pos as usize;
        if from < Self::LIMIT {
            let to = (from + n).min(Self::LIMIT);
            if self.header.len() < to {
                self.header.resize(to, 0);
            }
            self.header[from..to].copy_from_slice(&buf[..to - from]);
        }
        self.pos += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.writer.flush()
    }
}

impl std::io::Seek for HeaderCapture<'_> {
    fn seek(&mut self, to: std::io::SeekFrom) -> std::io::Result<u64> {
        use std::io::SeekFrom;
        let to = match to {
            SeekFrom::Start(p) => SeekFrom::Start(self.start + p),
            other => other,
        };
        let absolute = self.writer.seek(to)?;
        self.pos = absolute - self.start;
        Ok(self.pos)
    }
}

/// Whether the EXR file at `path` is whole, cheaply: its header reads, every chunk its offset
/// table lists starts inside the file, and (for a single-part image, as frames are) the last
/// chunk ends inside it. Reads the header, the offset table and a few bytes; decodes no pixel.
/// The error says what is wrong.
pub(super) fn check_complete(path: &Path) -> Result<(), String> {
    use exr::meta::BlockDescription;
    use std::io::{BufReader, Read, Seek, SeekFrom};

    /// Counts the bytes read through it.
    struct Counting<R> {
        inner: R,
        count: u64,
    }
    impl<R: Read> Read for Counting<R> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = self.inner.read(buf)?;
            self.count += n as u64;
            Ok(n)
        }
    }

    let truncated = "truncated (it ends before its last chunk of pixels)";
    let file = File::open(path).map_err(|e| e.to_string())?;
    let len = file.metadata().map_err(|e| e.to_string())?.len();
    let mut reader = Counting {
        inner: BufReader::new(file),
        count: 0,
    };
    let meta = exr::meta::MetaData::read_from_buffered(&mut reader, false)
        .map_err(|e| format!("not a readable EXR file ({e})"))?;
    // The header ends with its terminating byte, which the reader consumed: the offset
    // tables start here.
    let chunks: u64 = meta.headers.iter().map(|h| h.chunk_count as u64).sum();
    let table_end = chunks
        .checked_mul(8)
        .and_then(|n| n.checked_add(reader.count))
        .filter(|&end| end <= len)
        .ok_or(truncated)?;
    let mut last_chunk = 0;
    for _ in 0..chunks {
        let mut offset = [0u8; 8];
        reader.read_exact(&mut offset).map_err(|_| truncated)?;
        let offset = u64::from_le_bytes(offset);
        if offset < table_end || offset >= len {
            return Err(truncated.to_string());
        }
        last_chunk = last_chunk.max(offset);
    }
    if let [header] = meta.headers.as_slice()
        && !header.deep
    {
        // A chunk starts with its coordinates (a scan line: one int; a tile: four), then the
        // size of its data.
        let coordinates = match header.blocks {
            BlockDescription::ScanLines => 4,
            BlockDescription::Tiles(_) => 16,
        };
        let mut file = reader.inner.into_inner();
        let mut size = [0u8; 4];
        file.seek(SeekFrom::Start(last_chunk + coordinates))
            .and_then(|_| file.read_exact(&mut size))
            .map_err(|_| truncated)?;
        let size = i32::from_le_bytes(size);
        if size < 0 || last_chunk + coordinates + 4 + size as u64 > len {
            return Err(truncated.to_string());
        }
    }
    Ok(())
}
