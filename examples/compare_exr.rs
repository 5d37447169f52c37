//! Whether two renders of the same frame agree within their noise.
//!
//! ```sh
//! cargo run --release --example compare_exr -- BLOCK A.exr B.exr [C.exr]
//! ```
//! Each image is an EXR, or a PFM (the little-endian float RGB format many renderers write,
//! rows bottom to top), so another renderer's image can be compared too.
//! Prints each image's mean per channel and, over BLOCK x BLOCK-pixel blocks, the largest and
//! the root-mean-square difference of the block means of A and B. With a third image C (A's
//! frame rendered again with another seed), also the same figures for A against C: the spread
//! that noise alone gives, to judge A against B by. Used to check that a change to the
//! renderer keeps its images (docs/architecture.md, docs/convergence.md). Also prints A's
//! (and C's) whole-image error with B as the reference: the relative error (the square root
//! of the relative MSE, as `raytrace converge` and a render's `est. error` state it) and the
//! RMSE, which measures an image against a high-sample reference (docs/performance.md).

use std::process::ExitCode;

use glam::{DVec3, Vec3};
use raytrace_core::image::{COLOUR, Image};
use raytrace_core::metrics;
use raytrace_io::read_exr_colour;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if !(3..=4).contains(&args.len()) {
        eprintln!("usage: compare_exr BLOCK A.exr B.exr [C.exr]");
        return ExitCode::from(2);
    }
    let Ok(block) = args[0].parse::<usize>() else {
        eprintln!("BLOCK must be a whole number, got {}", args[0]);
        return ExitCode::from(2);
    };
    let mut images: Vec<Image> = Vec::new();
    for path in &args[1..] {
        let read = if path.ends_with(".pfm") {
            read_pfm(path)
        } else {
            read_exr_colour(path.as_ref())
        };
        match read {
            Ok(image) => images.push(image),
            Err(e) => {
                eprintln!("{path}: {e}");
                return ExitCode::from(1);
            }
        }
    }
    let size = |i: &Image| (i.width(), i.height());
    if images.iter().any(|i| size(i) != size(&images[0])) || block == 0 {
        eprintln!("the images differ in size, or BLOCK is 0");
        return ExitCode::from(2);
    }
    for (path, image) in args[1..].iter().zip(&images) {
        let m = colour(image).sum::<DVec3>() / image.pixels() as f64;
        println!("{path}: mean {:.5} {:.5} {:.5}", m.x, m.y, m.z);
    }
    let (max, rms) = block_difference(&images[0], &images[1], block);
    println!("A vs B: block means differ by at most {max:.5}, rms {rms:.5}");
    for (name, image) in [("A", Some(&images[0])), ("C", images.get(2))] {
        if let Some(image) = image {
            let rel = metrics::rel_mse(image, &images[1]).sqrt();
            let rmse = metrics::mse(image, &images[1]).sqrt();
            println!(
                "{name} against B as reference: relative error {:.4}%, RMSE {rmse:.6}",
                100.0 * rel
            );
        }
    }
    if let Some(c) = images.get(2) {
        let (max, rms) = block_difference(&images[0], c, block);
        println!("A vs C (noise): block means differ by at most {max:.5}, rms {rms:.5}");
    }
    ExitCode::SUCCESS
}

/// Reads a little-endian RGB PFM file (`PF`, width height, a negative scale, then rows of
/// 32-bit floats from the bottom row up) as rows from the top.
fn read_pfm(path: &str) -> Result<Image, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    // The header is three lines of text.
    let mut lines = 0;
    let end = bytes
        .iter()
        .position(|&b| {
            lines += (b == b'\n') as u32;
            lines == 3
        })
        .ok_or("not a PFM file")?;
    let header = String::from_utf8_lossy(&bytes[..end]);
    let fields: Vec<&str> = header.split_whitespace().collect();
    let parse = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok());
    let (Some("PF"), Some(w), Some(h), Some(scale)) =
        (fields.first().copied(), parse(1), parse(2), parse(3))
    else {
        return Err("not an RGB PFM file".into());
    };
    if scale >= 0.0 {
        return Err("big-endian PFM files are not read".into());
    }
    let (w, h) = (w as usize, h as usize);
    let data = &bytes[end + 1..];
    if data.len() != w * h * 12 {
        return Err(format!("{} bytes of pixels for {w}x{h}", data.len()));
    }
    let float = |i: usize| f32::from_le_bytes(data[4 * i..4 * i + 4].try_into().unwrap());
    let mut pixels = vec![Vec3::ZERO; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = 3 * ((h - 1 - y) * w + x);
            pixels[y * w + x] = Vec3::new(float(i), float(i + 1), float(i + 2));
        }
    }
    let mut image = Image::new(w as u32, h as u32);
    image.set_rgb(COLOUR, pixels.into_iter());
    Ok(image)
}

/// An image's colour, a pixel after another.
fn colour(image: &Image) -> impl Iterator<Item = DVec3> + '_ {
    let c = image.rgb(COLOUR).expect("a colour read");
    (0..image.pixels()).map(move |i| c.at_f64(i))
}

/// The largest and the root-mean-square difference, over channels and whole blocks, of the
/// block means of two images of one size.
fn block_difference(a: &Image, b: &Image, block: usize) -> (f64, f64) {
    let (w, h) = (a.width() as usize, a.height() as usize);
    let mean = |img: &Image, bx: usize, by: usize| {
        let c = img.rgb(COLOUR).expect("a colour read");
        let mut sum = DVec3::ZERO;
        for y in by * block..(by + 1) * block {
            for x in bx * block..(bx + 1) * block {
                sum += c.at_f64(y * w + x);
            }
        }
        sum / (block * block) as f64
    };
    let (mut max, mut sum_sq, mut n) = (0.0f64, 0.0, 0usize);
    for by in 0..h / block {
        for bx in 0..w / block {
            let d = (mean(a, bx, by) - mean(b, bx, by)).abs();
            max = max.max(d.max_element());
            sum_sq += d.length_squared();
            n += 3;
        }
    }
    (max, (sum_sq / n.max(1) as f64).sqrt())
}
