//! An image's true error, measured against two references of independent seeds.
//!
//! ```sh
//! cargo run --release --example cross_error -- IMAGE.exr REFERENCE_A.exr REFERENCE_B.exr
//! ```
//! Prints the image's relative error (the square root of the relative MSE, as `raytrace
//! converge` and a render's `est. error` state it) and its RMSE, each cross-estimated:
//! `mean((x - A)(x - B))`, over `(R + 0.01)^2` for the relative one with `R` the references'
//! mean. The two references' noise is independent of each other's and of the image's, so the
//! estimate is unbiased for the image's error against the truth whatever the references' own
//! noise (docs/performance.md, docs/denoising.md); `raytrace_core::metrics` computes them.
//! Also prints one reference's own relative error: half the relative mean square of A
//! against B (its expectation is the sum of the two references' squared errors).

use std::process::ExitCode;

use raytrace_core::metrics;
use raytrace_io::read_exr_colour;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 3 {
        eprintln!("usage: cross_error IMAGE.exr REFERENCE_A.exr REFERENCE_B.exr");
        return ExitCode::from(2);
    }
    let mut images = Vec::new();
    for path in &args {
        match read_exr_colour(std::path::Path::new(path)) {
            Ok(image) => images.push(image),
            Err(e) => {
                eprintln!("{path}: {e}");
                return ExitCode::from(2);
            }
        }
    }
    let size = |i: &raytrace_core::image::Image| (i.width(), i.height());
    if images.iter().any(|i| size(i) != size(&images[0])) {
        eprintln!("the images differ in size");
        return ExitCode::from(2);
    }
    let (x, a, b) = (&images[0], &images[1], &images[2]);
    let root = |v: f64| v.max(0.0).sqrt();
    println!(
        "relative error {:.4}%",
        100.0 * root(metrics::cross_rel_mse(x, a, b))
    );
    println!("RMSE {:.6e}", root(metrics::cross_mse(x, a, b)));
    // E[(A - B)^2] is twice one reference's error.
    println!(
        "one reference's own relative error {:.4}%",
        100.0 * root(metrics::rel_mse(a, b) / 2.0)
    );
    ExitCode::SUCCESS
}
