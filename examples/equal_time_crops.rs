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

use exr::prelude::read_first_rgba_layer_from_file;
use image::{Rgb, RgbImage};
use raytrace::output::linear_to_srgb8;

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
    let mut reference: Option<(usize, Vec<[f32; 3]>)> = None;
    for (k, path) in inputs.iter().enumerate() {
        let image = read_first_rgba_layer_from_file(
            path,
            |size, _| (size.width(), vec![[0f32; 3]; size.width() * size.height()]),
            |(width, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *width + pos.x()] = [r, g, b];
            },
        )
        .unwrap_or_else(|e| panic!("{path}: {e}"));
        let (width, pixels) = &image.layer_data.channel_data.pixels;
        let in_crop = |i: usize| {
            let (x, y) = ((i % width) as u32, (i / width) as u32);
            (x0..x0 + w).contains(&x) && (y0..y0 + h).contains(&y)
        };
        match &reference {
            None => reference = Some((*width, pixels.clone())),
            Some((_, r)) => {
                let se = |i: usize| -> f64 {
                    (0..3)
                        .map(|c| (pixels[i][c] as f64 - r[i][c] as f64).powi(2))
                        .sum::<f64>()
                        / 3.0
                };
                let all = (0..pixels.len()).map(se).sum::<f64>() / pixels.len() as f64;
                let crop = (0..pixels.len())
                    .filter(|&i| in_crop(i))
                    .map(se)
                    .sum::<f64>()
                    / (w * h) as f64;
                println!("{path}: MSE {all:.4e} (crop {crop:.4e})");
            }
        }
        let left = k as u32 * (w * zoom + gap);
        for y in 0..h * zoom {
            for x in 0..w * zoom {
                let p = pixels[(y0 + y / zoom) as usize * width + (x0 + x / zoom) as usize];
                out.put_pixel(left + x, y, Rgb(p.map(linear_to_srgb8)));
            }
        }
    }
    out.save(&args[0]).expect("write the crops");
    ExitCode::SUCCESS
}
