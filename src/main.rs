//! The `raytrace` command line: parses arguments and calls the library.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use raytrace::app::{self, RenderOptions};
use raytrace::converge::{self, ConvergeOptions};
use raytrace::render::Budget;
use raytrace::sampler::SamplerKind;

#[derive(Parser)]
#[command(
    name = "raytrace",
    version,
    about = "Render animation sequences of moving spheres with motion and defocus blur",
    after_help = "Examples:
  raytrace render scenes/quick.toml                 # every frame of the shot
  raytrace render shot.toml --frames 1-48:4 -o renders/shot_####.exr
  raytrace check shot.toml                          # validate and summarise a scene
  raytrace converge shot.toml --plot error.png      # error against time, per sampler
  raytrace generate --spheres 100000 -o big.toml    # a large random test scene

Scene format: docs/scene-format.md. Farm rendering: docs/farm.md."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Settings of the scene that `render` and `converge` can override, and the thread count.
#[derive(Args)]
struct Overrides {
    /// Image width in pixels.
    #[arg(long)]
    width: Option<u32>,
    /// Image height in pixels.
    #[arg(long)]
    height: Option<u32>,
    /// Random seed (for `converge`: of the measured renders).
    #[arg(long)]
    seed: Option<u64>,
    /// Worker threads (default: one per core).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    threads: Option<u16>,
}

impl Overrides {
    /// Render options for `scene` with these overrides.
    fn options(self, scene: PathBuf, quiet: bool) -> RenderOptions {
        RenderOptions {
            scene,
            width: self.width,
            height: self.height,
            seed: self.seed,
            threads: self.threads.map(usize::from),
            quiet,
            ..RenderOptions::default()
        }
    }
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
  raytrace render shot.toml --noise-threshold 0.01   # sample each frame to 1% estimated error
  raytrace render shot.toml --time-limit 60          # at most a minute a frame

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
        #[command(flatten)]
        overrides: Overrides,
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
        /// How samples are placed: `sobol` (default) or `independent`.
        #[arg(long)]
        sampler: Option<SamplerKind>,
        /// Seconds per frame: sample in passes and stop before this time is exceeded.
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        time_limit: Option<f64>,
        /// Sample in passes until the estimated relative error of the frame (as printed,
        /// 0.01 = 1%) is at or below this.
        #[arg(long, value_name = "E", allow_negative_numbers = true)]
        noise_threshold: Option<f64>,
        /// With --time-limit or --noise-threshold: never more than this many samples per pixel.
        #[arg(long, value_name = "N")]
        max_samples: Option<u32>,
    },
    /// Measure how a frame's error falls with render time, for each sampler.
    #[command(
        after_help = "Renders a reference (or reads one), then the frame at 1, 2, 4, ... samples per
pixel with each sampler, and prints RMSE, relative MSE, the error estimated from the
samples alone, and efficiency 1/(MSE x seconds); fitted log-log slopes; and the MSE
ratio at equal time.

Examples:
  raytrace converge scenes/defocus.toml --max-samples 256 --plot defocus.png --csv defocus.csv
  raytrace converge shot.toml --frame 12 --reference ref.exr --budget 60
  raytrace converge shot.toml --sampler independent --reference-samples 16384"
    )]
    Converge {
        /// The scene file (TOML).
        scene: PathBuf,
        /// The frame to measure (default: the shot's first).
        #[arg(long)]
        frame: Option<u32>,
        /// A reference image (EXR) of the frame, instead of rendering one.
        #[arg(long, value_name = "FILE.exr", conflicts_with = "reference_samples")]
        reference: Option<PathBuf>,
        /// Samples per pixel of the reference rendered first (default 4096).
        #[arg(long, value_name = "N")]
        reference_samples: Option<u32>,
        /// Where to write the rendered reference (default: beside --csv or --plot, named
        /// after the scene).
        #[arg(long, value_name = "FILE.exr", conflicts_with = "reference")]
        write_reference: Option<PathBuf>,
        /// The largest samples per pixel measured (default: the scene's samples, or no limit
        /// with --budget).
        #[arg(long, value_name = "N")]
        max_samples: Option<u32>,
        /// Seconds of rendering per sampler, at most.
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        budget: Option<f64>,
        /// A sampler to measure; repeat for several (default: all).
        #[arg(long)]
        sampler: Vec<SamplerKind>,
        /// Write the measurements as CSV.
        #[arg(long, value_name = "FILE")]
        csv: Option<PathBuf>,
        /// Draw error against time on log-log axes, to a .png or .svg.
        #[arg(long, value_name = "FILE")]
        plot: Option<PathBuf>,
        #[command(flatten)]
        overrides: Overrides,
        /// Print nothing but errors.
        #[arg(long, short)]
        quiet: bool,
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
            overrides,
            skip_existing,
            quiet,
            stats,
            chunk_size,
            chunk,
            sampler,
            time_limit,
            noise_threshold,
            max_samples,
        } => {
            let opts = RenderOptions {
                frames,
                output,
                samples,
                skip_existing,
                stats,
                chunk: chunk_size.zip(chunk),
                sampler,
                budget: Budget {
                    time_limit,
                    noise_threshold,
                    max_samples,
                },
                ..overrides.options(scene, quiet)
            };
            app::render(&opts).map(|_| ())
        }
        Command::Converge {
            scene,
            frame,
            reference,
            reference_samples,
            write_reference,
            max_samples,
            budget,
            sampler,
            csv,
            plot,
            overrides,
            quiet,
        } => {
            let opts = ConvergeOptions {
                render: overrides.options(scene, quiet),
                frame,
                reference,
                reference_samples,
                write_reference,
                max_samples,
                budget,
                samplers: sampler,
                csv,
                plot,
            };
            converge::converge(&opts).map(|_| ())
        }
        Command::Check { scene, chunk_size } => {
            app::check(&scene, chunk_size).map(|s| app::print_line(s.trim_end()))
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
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "error: {e}");
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
