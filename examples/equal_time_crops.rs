//! Side-by-side crops of EXR frames, for the equal-time comparison in docs/convergence.md.
//!
//! ```sh
//! cargo run --release --example equal_time_crops -- OUT.png X Y W H ZOOM A.exr B.exr ...
//! ```
//! Crops the W x H region at (X, Y) of every EXR, converts it to sRGB, enlarges it ZOOM times
//! (nearest pixel, so the noise stays visible) and writes the crops side by side, 8 pixels apart.
//! Prints each image's MSE against the first (the reference), over the whole image and over
//! the crop.

use std::process::ExitCode;

use std::path::Path;

use image::{Rgb, RgbImage};
use raytrace_core::image::{COLOUR, Image};
use raytrace_core::metrics::mse;
use raytrace_io::{linear_to_srgb8, read_exr_colour};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 7 {
        eprintln!("usage: equal_time_crops OUT.png X Y W H ZOOM A.exr [B.exr ...]");
        return ExitCode::from(2);
    }
    let num = |i: usize| -> u32 {
        args[i]
            .parse()
            .unwrap_or_else(|_| panic!("not a number: {}", args[i]))
    };
    let (x0, y0, w, h, zoom) = (num(1), num(2), num(3), num(4), num(5));
    let inputs = &args[6..];
    let gap = 8;
    let n = inputs.len() as u32;
    let mut out = RgbImage::from_pixel(n * w * zoom + (n - 1) * gap, h * zoom, Rgb([255; 3]));
    // The crop of an image.
    let crop = |image: &Image| -> Image {
        let c = image.rgb(COLOUR).expect("a colour read");
        let width = image.width() as usize;
        let mut crop = Image::new(w, h);
        crop.set_rgb(
            COLOUR,
            (y0..y0 + h)
                .flat_map(|y| (x0..x0 + w).map(move |x| (x, y)))
                .map(|(x, y)| c.at(y as usize * width + x as usize)),
        );
        crop
    };
    let mut reference: Option<Image> = None;
    for (k, path) in inputs.iter().enumerate() {
        let image = read_exr_colour(Path::new(path)).unwrap_or_else(|e| panic!("{path}: {e}"));
        match &reference {
            None => reference = Some(image.clone()),
            Some(r) => println!(
                "{path}: MSE {:.4e} (crop {:.4e})",
                mse(&image, r),
                mse(&crop(&image), &crop(r))
            ),
        }
        let (width, colour) = (image.width(), image.rgb(COLOUR).expect("a colour read"));
        let left = k as u32 * (w * zoom + gap);
        for y in 0..h * zoom {
            for x in 0..w * zoom {
                let p = colour.at(((y0 + y / zoom) * width + (x0 + x / zoom)) as usize);
                out.put_pixel(left + x, y, Rgb(p.to_array().map(linear_to_srgb8)));
            }
        }
    }
    out.save(&args[0]).expect("write the crops");
    ExitCode::SUCCESS
}
