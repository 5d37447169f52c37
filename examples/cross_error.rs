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
//! noise (docs/performance.md, docs/denoising.md). Also prints one reference's own relative
//! error: half the relative mean square of their difference (its expectation is the sum of
//! the two references' squared errors).

use std::process::ExitCode;

use raytrace_io::read_exr_rgb;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 3 {
        eprintln!("usage: cross_error IMAGE.exr REFERENCE_A.exr REFERENCE_B.exr");
        return ExitCode::from(2);
    }
    let mut images = Vec::new();
    for path in &args {
        match read_exr_rgb(std::path::Path::new(path)) {
            Ok(image) => images.push(image),
            Err(e) => {
                eprintln!("{path}: {e}");
                return ExitCode::from(2);
            }
        }
    }
    let size = (images[0].0, images[0].1);
    if images.iter().any(|(w, h, _)| (*w, *h) != size) {
        eprintln!("the images differ in size");
        return ExitCode::from(2);
    }
    let (x, a, b) = (&images[0].2, &images[1].2, &images[2].2);
    let (mut rel, mut mse, mut own) = (0.0, 0.0, 0.0);
    for i in 0..x.len() {
        let r = (a[i] + b[i]) * 0.5 + 0.01;
        let cross = (x[i] - a[i]) * (x[i] - b[i]);
        rel += (cross / (r * r)).element_sum();
        mse += cross.element_sum();
        let d = a[i] - b[i];
        own += (d * d / (r * r)).element_sum() / 2.0;
    }
    let n = (3 * x.len()) as f64;
    let root = |v: f64| v.max(0.0).sqrt();
    println!("relative error {:.4}%", 100.0 * root(rel / n));
    println!("RMSE {:.6e}", root(mse / n));
    println!(
        "one reference's own relative error {:.4}%",
        100.0 * root(own / n)
    );
    ExitCode::SUCCESS
}
