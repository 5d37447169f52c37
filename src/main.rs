//! The `raytrace` command line: parses arguments and calls the library.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use raytrace::app::{self, RenderOptions};

#[derive(Parser)]
#[command(
    name = "raytrace",
    version,
    about = "Render animation sequences of moving spheres with motion and defocus blur",
    after_help = "Examples:
  raytrace render scenes/quick.toml                 # every frame of the shot
  raytrace render shot.toml --frames 1-48:4 -o renders/shot_####.exr
  raytrace check shot.toml                          # validate and summarise a scene
  raytrace generate --spheres 100000 -o big.toml    # a large random test scene

Scene format: docs/scene-format.md. Farm rendering: docs/farm.md."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render frames of a scene to EXR or PNG files.
    #[command(after_help = "Examples:
  raytrace render scenes/quick.toml
  raytrace render shot.toml --frames 1-48:4 --output renders/shot_####.exr
  raytrace render shot.toml --frames 12 --samples 256 --width 1920 --height 1080
  raytrace render shot.toml --skip-existing          # resume an interrupted render
  raytrace render shot.toml --chunk-size 5 --chunk 2 # frames 11-15 of a farm job array

Exit status: 0 success, 2 bad arguments or bad scene (nothing written), 1 any other failure.")]
    Render {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Frames to render: `12`, `1-48`, `1-48:4` (every 4th) or a comma list of those.
        /// Without a value, or absent: every frame of the shot.
        #[arg(long, num_args = 0..=1, default_missing_value = "")]
        frames: Option<String>,
        /// Output path pattern; runs of `#` become the zero-padded frame number; `.exr` or `.png`.
        #[arg(long, short)]
        output: Option<String>,
        /// Samples per pixel.
        #[arg(long)]
        samples: Option<u32>,
        /// Image width in pixels.
        #[arg(long)]
        width: Option<u32>,
        /// Image height in pixels.
        #[arg(long)]
        height: Option<u32>,
        /// Random seed.
        #[arg(long)]
        seed: Option<u64>,
        /// Worker threads (default: one per core).
        #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
        threads: Option<u16>,
        /// Leave frames whose file already exists untouched (resume).
        #[arg(long)]
        skip_existing: bool,
        /// Print nothing but errors.
        #[arg(long, short)]
        quiet: bool,
        /// Also print, per frame, the preparation and render times, rays traced, rays and
        /// samples per second, and peak memory.
        #[arg(long)]
        stats: bool,
        /// Split the selected frames into chunks of this many consecutive frames (with --chunk).
        #[arg(long, requires = "chunk")]
        chunk_size: Option<usize>,
        /// Render only this chunk (0-based) of the selected frames (with --chunk-size).
        #[arg(long, requires = "chunk_size")]
        chunk: Option<usize>,
    },
    /// Validate a scene and print a summary of it.
    #[command(after_help = "Examples:
  raytrace check scenes/turntable.toml
  raytrace check shot.toml --chunk-size 5   # prints the chunk count for a job array")]
    Check {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Also print how many chunks of this many frames the shot makes.
        #[arg(long)]
        chunk_size: Option<usize>,
    },
    /// Write a large test scene: random spheres in a cube, some of them moving.
    #[command(after_help = "Examples:
  raytrace generate --spheres 1000000 --moving 0.5 --seed 1 -o big.toml
  raytrace generate --spheres 10000 --moving 0 -o still.toml --frames 48")]
    Generate {
        /// Number of spheres.
        #[arg(long, default_value_t = 10000)]
        spheres: usize,
        /// Fraction of the spheres that move, 0 to 1.
        #[arg(long, default_value_t = 0.5)]
        moving: f64,
        /// Seed of the spheres' random numbers.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Frames in the shot.
        #[arg(long, default_value_t = 1)]
        frames: u32,
        /// The scene file to write.
        #[arg(long, short)]
        output: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            // clap uses 2 for usage errors and 0 for --help/--version.
            return ExitCode::from(e.exit_code() as u8);
        }
    };
    let result = match cli.command {
        Command::Render {
            scene,
            frames,
            output,
            samples,
            width,
            height,
            seed,
            threads,
            skip_existing,
            quiet,
            stats,
            chunk_size,
            chunk,
        } => {
            let opts = RenderOptions {
                scene,
                frames,
                output,
                samples,
                width,
                height,
                seed,
                threads: threads.map(usize::from),
                skip_existing,
                quiet,
                stats,
                chunk: chunk_size.zip(chunk),
            };
            app::render(&opts).map(|_| ())
        }
        Command::Check { scene, chunk_size } => {
            app::check(&scene, chunk_size).map(|s| print!("{s}"))
        }
        Command::Generate {
            spheres,
            moving,
            seed,
            frames,
            output,
        } => raytrace::generate::generate(
            &raytrace::generate::GenerateOptions {
                spheres,
                moving,
                seed,
                frames,
            },
            &output,
        ),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
