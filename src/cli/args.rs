//! The command line's arguments, as clap parses them. Ranges of flags that do not come from
//! the scene are checked by clap's value parsers here; flags that replace scene values become
//! [`Overrides`] and are checked by the scene's validator, with the file's values. Every
//! numeric flag takes a negative number as its value (`--width -16`), so that the value
//! parser, not the option parser, says what is wrong.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use raytrace_core::renderer::Budget;
use raytrace_core::sampler::SamplerKind;
use raytrace_core::scene::Device;
use raytrace_core::scene::{DenoiseDevice, DenoiseQuality};
use raytrace_scene::scene_file::Overrides;

/// The `raytrace` command line.
#[derive(Parser, Debug)]
#[command(
    name = "raytrace",
    version,
    about = "Render animation sequences of moving spheres with motion and defocus blur",
    after_help = "Examples:
  raytrace render scenes/quick.toml                 # every frame of the shot
  raytrace render shot.toml --frames 1-48:4 -o renders/shot_####.exr
  raytrace render a.toml b.toml -o 'renders/{scene}_####.exr'   # two shots in one run
  raytrace check shot.toml                          # validate and summarise a scene
  raytrace clip shot.toml shot.mp4                  # the rendered frames as a clip
  raytrace converge shot.toml --plot error.png      # error against time, per sampler
  raytrace generate --spheres 100000 -o big.toml    # a large random test scene
  raytrace preview scenes/quick.toml                # a live page that renders on save

Scene format: docs/scene-format.md. Farm rendering: docs/farm.md."
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// The commands.
#[derive(Subcommand, Debug)]
pub(crate) enum Command {
    /// Render frames of one or more scenes to EXR or PNG files.
    #[command(after_help = "Examples:
  raytrace render scenes/quick.toml
  raytrace render scenes/quick.toml scenes/turntable.toml -o 'renders/{scene}_####.png'
  raytrace render shot.toml --clip renders/shot.mp4  # the frames, then a clip of them
  raytrace render shot.toml --frames 1-48:4 --output renders/shot_####.exr
  raytrace render shot.toml --frames 12 --samples 256 --width 1920 --height 1080
  raytrace render shot.toml --skip-existing          # resume an interrupted render
  raytrace render shot.toml --chunk-size 5 --chunk 2 # frames 11-15 of a farm job array
  raytrace render shot.toml --noise-threshold 0.01   # sample each frame to 1% estimated error
  raytrace render shot.toml --time-limit 60          # at most a minute a frame

Exit status: 0 success, 2 bad arguments or bad scene (nothing written), 1 any other failure,
130 on SIGINT and 143 on SIGTERM (finished frames stay, the frame in progress is dropped).")]
    Render(RenderArgs),
    /// Measure how a frame's error falls with render time, for each sampler.
    #[command(
        after_help = "Renders two references of independent seeds (or reads them), then the frame at 1, 2,
4, ... samples per pixel with each sampler (and denoised, and adaptively, if asked), each
point with a few seeds and timed by the median of alternated repeats. Prints each point's
errors against the truth (estimated from both references, free of their noise), the error
the render estimates for itself, mean FLIP, wall and CPU time; fitted log-log slopes; the
time each series takes to 5%, 2% and 1% relative error; and error ratios at equal time.

Examples:
  raytrace converge scenes/defocus.toml --max-samples 256 --plot defocus.png --csv defocus.csv
  raytrace converge shot.toml --frame 12 --reference a.exr b.exr --budget 60
  raytrace converge shot.toml --denoise --thresholds 0.05,0.02,0.01 --seeds 5
  raytrace converge shot.toml --sampler independent --reference-samples 16384"
    )]
    Converge(ConvergeArgs),
    /// Validate scenes and print a summary of each.
    #[command(after_help = "Examples:
  raytrace check scenes/turntable.toml
  raytrace check shot.toml --chunk-size 5   # prints the chunk count for a job array
  raytrace check a.toml b.toml --chunk-size 5   # the chunk count of the batch")]
    Check(CheckArgs),
    /// Assemble a shot's rendered frames into a clip: .mp4, .gif, .apng or a .png contact
    /// sheet.
    #[command(
        after_help = "The frames are found through the scene's output path (or --input) and shown in
frame order at the shot's exact frame rate. .mp4 clips (H.264, yuv420p) are made by the
ffmpeg program; .gif, .apng and .png need no other program. EXR frames are shown as the
PNG output shows them (sRGB), after --exposure stops.

Examples:
  raytrace clip scenes/turntable.toml turntable.mp4
  raytrace clip shot.toml preview.gif --frames 1-48:2
  raytrace clip shot.toml sheet.png --input renders/shot_####.exr --exposure 1

Exit status: 0 success, 2 bad arguments, bad scene or a missing frame (nothing written),
1 any other failure (ffmpeg missing or failing; nothing written)."
    )]
    Clip(ClipArgs),
    /// Serve a live page of a shot that renders the chosen frame progressively, shows the
    /// shot's timeline and renders again when the scene file changes.
    #[command(
        after_help = "Prints `preview: http://ADDR:PORT/` and serves the page there until Ctrl-C.
Only this machine can open it unless --bind says otherwise; from another machine, forward
the port over SSH: `ssh -L 8765:localhost:8765 node`, then open http://localhost:8765/.

Examples:
  raytrace preview scenes/quick.toml
  raytrace preview shot.toml --frames 1-48:4 --port 0   # a free port
  raytrace preview shot.toml --bind 0.0.0.0             # share it on the network

Exit status: 130 on SIGINT (Ctrl-C), 143 on SIGTERM; 2 for bad arguments or a scene file that
cannot be read (a scene that does not validate is shown on the page); 1 when the port cannot
be had."
    )]
    Preview(PreviewArgs),
    /// Write a large test scene: random spheres in a cube, some of them moving.
    #[command(after_help = "Examples:
  raytrace generate --spheres 1000000 --moving 0.5 --seed 1 -o big.toml
  raytrace generate --spheres 10000 --moving 0 -o still.toml --frames 48")]
    Generate(GenerateArgs),
}

/// Scene settings that `render` and `converge` can replace, and the thread count.
#[derive(Args, Clone, Debug, Default)]
pub(crate) struct SceneArgs {
    /// Image width in pixels.
    #[arg(long, allow_negative_numbers = true)]
    pub width: Option<u32>,
    /// Image height in pixels.
    #[arg(long, allow_negative_numbers = true)]
    pub height: Option<u32>,
    /// Random seed, replacing `[render] seed`.
    #[arg(long, allow_negative_numbers = true, value_parser = whole::<u64>)]
    pub seed: Option<u64>,
    /// Worker threads, 1 to 1024 (default: one per core).
    #[arg(long, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u16).range(1..=MAX_THREADS as i64))]
    pub threads: Option<u16>,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
    /// Where paths are traced: `cpu` (default) or `gpu` (through wgpu: Vulkan, Metal or
    /// DirectX 12), replacing `[render] device`.
    #[arg(long)]
    pub device: Option<Device>,
    /// Where denoised frames are denoised: `auto` (default: on the GPU that traces them
    /// when OIDN has a device for it, else on the CPU), `cpu`, or `gpu` (an error without
    /// one).
    #[arg(long, value_name = "DEVICE", value_parser = denoise_device)]
    pub denoise_device: Option<DenoiseDevice>,
}

/// Arguments of `raytrace render`.
#[derive(Args, Clone, Debug, Default)]
pub(crate) struct RenderArgs {
    /// The scene files (TOML), rendered one after another as one run.
    #[arg(required = true, value_name = "SCENE")]
    pub scenes: Vec<PathBuf>,
    /// Frames to render (of each scene): `12`, `1-48`, `1-48:4` (every 4th) or a comma list of those.
    /// Without a value, or absent: every frame of the shot. An empty value (`--frames ''`)
    /// is an error.
    #[arg(long, num_args = 0..=1, value_name = "SPEC", allow_negative_numbers = true)]
    pub frames: Option<Option<String>>,
    /// Output path pattern; runs of `#` become the zero-padded frame number, `{scene}` the
    /// scene file's name without extension (required with several scenes); `.exr` or `.png`.
    #[arg(long, short)]
    pub output: Option<String>,
    /// After rendering, assemble the frames into this clip (`.mp4`, `.gif`, `.apng` or a
    /// `.png` contact sheet; `{scene}` as in --output). Not with --chunk.
    #[arg(long, value_name = "CLIP", conflicts_with = "chunk")]
    pub clip: Option<String>,
    /// Do not make the clip a scene's `[output] clip` asks for: what a chunk of a farm job
    /// array needs (a chunk cannot make the clip; a job after the array's does).
    #[arg(long, conflicts_with = "clip")]
    pub no_clip: bool,
    /// Samples per pixel, exactly (not with --time-limit or --noise-threshold, which decide
    /// the samples themselves: cap them with --max-samples).
    #[arg(long, allow_negative_numbers = true, conflicts_with = "limit")]
    pub samples: Option<u32>,
    /// How samples are placed: `sobol` (default) or `independent`.
    #[arg(long)]
    pub sampler: Option<SamplerKind>,
    #[command(flatten)]
    pub scene_args: SceneArgs,
    /// Leave frames whose file already exists untouched (resume).
    #[arg(long)]
    pub skip_existing: bool,
    /// Also print, per frame, the preparation and render times, rays traced, rays and
    /// samples per second, and peak memory.
    #[arg(long)]
    pub stats: bool,
    /// Split the selected frames (of every scene, in order) into chunks of this many
    /// consecutive frames (with --chunk).
    #[arg(long, requires = "chunk", allow_negative_numbers = true,
          value_parser = whole_from_1)]
    pub chunk_size: Option<u64>,
    /// Render only this chunk (0-based) of the selected frames (with --chunk-size).
    #[arg(long, requires = "chunk_size", allow_negative_numbers = true,
          value_parser = whole::<u64>)]
    pub chunk: Option<u64>,
    #[command(flatten)]
    pub budget: BudgetArgs,
    /// Passes to write beside the colour, replacing the scene's `[output] passes`: a comma
    /// list of alpha, depth, normal, albedo, motion, variance, samples, noisy (a PNG output
    /// takes only alpha; noisy, the colour before denoising, needs --denoise); an empty value
    /// writes colour only.
    #[arg(long, value_name = "LIST", value_parser = pass_list)]
    pub passes: Option<PassList>,
    /// Denoise every frame (Intel Open Image Denoise), as `[output] denoise = true`: the frame
    /// written blends the raw and denoised frames per pixel by their estimated errors, and
    /// the estimated error printed and recorded is that frame's.
    #[arg(long)]
    pub denoise: bool,
    /// The denoiser's quality, replacing `[output] denoise_quality`: fast (the default),
    /// balanced or high.
    #[arg(long, value_name = "QUALITY", value_parser = denoise_quality)]
    pub denoise_quality: Option<DenoiseQuality>,
    /// With denoising: keep the denoised sequence from flickering. Every frame of the shot
    /// takes the same sample pattern (a still region has the same noise in every frame), so
    /// a frame is the same rendered alone, in a sequence or in any chunk.
    #[arg(long)]
    pub temporal: bool,
}

/// Clap's value parser of `--denoise-quality`.
fn denoise_quality(text: &str) -> Result<DenoiseQuality, String> {
    DenoiseQuality::from_name(text).ok_or_else(|| {
        let names: Vec<&str> = DenoiseQuality::ALL.iter().map(|q| q.name()).collect();
        format!("expected one of {}", names.join(", "))
    })
}

/// The passes `--passes` names, in order (duplicates are the scene validator's to name).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct PassList(pub Vec<raytrace_core::pass::Pass>);

/// Clap's value parser of `--denoise-device`.
fn denoise_device(text: &str) -> Result<DenoiseDevice, String> {
    DenoiseDevice::from_name(text).ok_or_else(|| {
        let names: Vec<&str> = DenoiseDevice::ALL.iter().map(|d| d.name()).collect();
        format!("expected one of {}", names.join(", "))
    })
}

/// Clap's value parser of `--passes`: pass names separated by commas.
fn pass_list(text: &str) -> Result<PassList, String> {
    use raytrace_core::pass::Pass;
    if text.trim().is_empty() {
        return Ok(PassList(Vec::new()));
    }
    text.split(',')
        .map(|name| {
            Pass::from_name(name.trim()).ok_or_else(|| {
                let known: Vec<&str> = Pass::ALL.iter().map(|p| p.name()).collect();
                format!(
                    "unknown pass \"{}\" (expected a comma list of {})",
                    raytrace_core::error::elide(name.trim()),
                    known.join(", ")
                )
            })
        })
        .collect::<Result<Vec<_>, _>>()
        .map(PassList)
}

/// When to stop sampling a frame, instead of at exactly its samples.
#[derive(Args, Clone, Debug, Default)]
#[group(skip)]
#[command(group(clap::ArgGroup::new("limit").args(["time_limit", "noise_threshold"]).multiple(true)))]
pub(crate) struct BudgetArgs {
    /// Seconds per frame: sample in passes and stop before this time is exceeded.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true, value_parser = positive)]
    pub time_limit: Option<f64>,
    /// Sample in passes until the estimated relative error of the frame (as printed,
    /// 0.01 = 1%) is at or below this, or until --max-samples (default 65536).
    #[arg(long, value_name = "E", allow_negative_numbers = true, value_parser = positive)]
    pub noise_threshold: Option<f64>,
    /// With --time-limit or --noise-threshold: never more than this many samples per pixel
    /// (default with --noise-threshold: 65536; with --time-limit alone: no cap).
    #[arg(long, value_name = "N", requires = "limit", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub max_samples: Option<u32>,
}

/// Arguments of `raytrace converge`.
#[derive(Args, Clone, Debug, Default)]
pub(crate) struct ConvergeArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// The frame to measure (default: the shot's first).
    #[arg(long, allow_negative_numbers = true)]
    pub frame: Option<u32>,
    /// Two reference images (EXR) of the frame, of independent seeds, instead of rendering
    /// them: each render's error against the truth is estimated from both.
    #[arg(long, num_args = 2, value_names = ["A.exr", "B.exr"], conflicts_with = "reference_samples")]
    pub reference: Vec<PathBuf>,
    /// Samples per pixel of each of the two references rendered first (default 4096).
    #[arg(long, value_name = "N", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub reference_samples: Option<u32>,
    /// Where to write the two rendered references, EXR (default: beside --csv or --plot,
    /// named after the scene).
    #[arg(long, num_args = 2, value_names = ["A.exr", "B.exr"], conflicts_with = "reference")]
    pub write_reference: Vec<PathBuf>,
    /// The largest samples per pixel measured (default: the scene's samples, or no limit
    /// with --budget).
    #[arg(long, value_name = "N", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub max_samples: Option<u32>,
    /// Seconds of rendering per series (sampler, raw or denoised, uniform or adaptive), at
    /// most.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true, value_parser = positive)]
    pub budget: Option<f64>,
    /// A sampler to measure; repeat for several (default: all).
    #[arg(long)]
    pub sampler: Vec<SamplerKind>,
    /// Seeds each point is rendered with: its errors are the means over them (default 3).
    #[arg(long, value_name = "K", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub seeds: Option<u32>,
    /// Renders of each point for its time, at most: it is repeated until the interquartile
    /// range of its times is within 5% of their median (at least 3 renders, and one per
    /// seed), or N times; the median is taken (default 7).
    #[arg(long, value_name = "N", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeats: Option<u32>,
    /// Also measure adaptive renders (`render --noise-threshold E`) at each of these
    /// thresholds, comma-separated (0.02 = 2%).
    #[arg(long, value_name = "E,...", value_delimiter = ',', allow_negative_numbers = true,
          value_parser = threshold)]
    pub thresholds: Vec<f64>,
    /// Write the measurements as CSV, one row per point; the times to error levels go to
    /// the same name with `_levels` before `.csv`.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Draw the relative error against time on log-log axes, to a .png or .svg.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Also measure each point denoised, rendered and timed on its own: its true error, its
    /// estimated error (bias included) and its time with the denoising.
    #[arg(long)]
    pub denoise: bool,
    /// Measure a sequence instead of one frame: these frames (`1-12`, as render's --frames)
    /// rendered at --max-samples (default: the scene's), raw, denoised frame by frame,
    /// denoised with --temporal, and by the routes that carry other frames (history,
    /// accumulated, centred); prints each one's true error and its flicker (its
    /// frame-to-frame change beyond the true change) against references of every frame.
    #[arg(long, value_name = "FRAMES", conflicts_with_all = ["frame", "reference", "write_reference", "budget", "csv", "plot"])]
    pub flicker: Option<String>,
    #[command(flatten)]
    pub scene_args: SceneArgs,
}

/// Arguments of `raytrace check`.
#[derive(Args, Clone, Debug, Default)]
pub(crate) struct CheckArgs {
    /// The scene files (TOML).
    #[arg(required = true, value_name = "SCENE")]
    pub scenes: Vec<PathBuf>,
    /// Also print how many chunks of this many frames the shot (or the batch) makes.
    #[arg(long, allow_negative_numbers = true, value_parser = whole_from_1)]
    pub chunk_size: Option<u64>,
    /// Check the scenes for this device, `cpu` or `gpu`, replacing `[render] device` (the
    /// GPU refuses scenes its 32-bit floats cannot carry, and scenes whose spheres and points
    /// need more than it binds); no GPU is needed to check.
    #[arg(long)]
    pub device: Option<Device>,
}

/// Arguments of `raytrace preview`.
#[derive(Args, Clone, Debug)]
pub(crate) struct PreviewArgs {
    /// The scene file (TOML), watched: saving it renders again.
    #[arg(value_name = "SCENE")]
    pub scene: PathBuf,
    /// The port to serve on; 0 picks a free one (printed).
    #[arg(long, default_value_t = 8765, allow_negative_numbers = true, value_parser = whole::<u16>)]
    pub port: u16,
    /// The address to serve on: loopback (only this machine) unless another is given here,
    /// `0.0.0.0` for every network.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1")]
    pub bind: std::net::IpAddr,
    /// Frames on the timeline: `12`, `1-48`, `1-48:4` or a comma list of those (default: every
    /// frame of the shot).
    #[arg(long, num_args = 0..=1, value_name = "SPEC", allow_negative_numbers = true)]
    pub frames: Option<Option<String>>,
    /// Where paths are traced: `cpu` (default) or `gpu`, replacing `[render] device`.
    #[arg(long)]
    pub device: Option<Device>,
    /// Where denoised frames are denoised: `auto` (default), `cpu` or `gpu`, as `render`'s.
    #[arg(long, value_name = "DEVICE", value_parser = denoise_device)]
    pub denoise_device: Option<DenoiseDevice>,
}

/// Arguments of `raytrace clip`.
#[derive(Args, Clone, Debug, Default)]
pub(crate) struct ClipArgs {
    /// The scene file (TOML) whose frames make the clip.
    pub scene: PathBuf,
    /// The clip to write: `.mp4`, `.gif`, `.apng` or `.png` (a contact sheet); `{scene}`
    /// becomes the scene file's name without extension.
    pub clip: PathBuf,
    /// Frames to show: `12`, `1-48`, `1-48:4` or a comma list (default: every frame).
    #[arg(long, num_args = 0..=1, value_name = "SPEC", allow_negative_numbers = true)]
    pub frames: Option<Option<String>>,
    /// Where the frames are, as a path pattern with `#` for the frame number and `{scene}`
    /// for the scene file's name (default: the scene's output path).
    #[arg(long, value_name = "PATTERN")]
    pub input: Option<String>,
    /// Brighten (or, negative, darken) EXR frames by this many stops before showing them.
    #[arg(long, value_name = "STOPS", allow_negative_numbers = true, value_parser = finite)]
    pub exposure: Option<f64>,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Arguments of `raytrace generate`: a random scene (`.toml`), or a fountain's point cache
/// (`.ply`, a file per frame).
#[derive(Args, Clone, Debug)]
pub(crate) struct GenerateArgs {
    /// Number of spheres (of a .toml scene).
    #[arg(long, default_value_t = 10000, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u64).range(1..=raytrace_scene::scene_file::generate::MAX_SPHERES))]
    pub spheres: u64,
    /// Fraction of the spheres that move, 0 to 1.
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true, value_parser = fraction)]
    pub moving: f64,
    /// Seed of the spheres' (or particles') random numbers.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = whole::<u64>)]
    pub seed: u64,
    /// Particles of the fountain alive at once, about (of a .ply point cache).
    #[arg(long, default_value_t = 2000, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u64).range(1..=raytrace_scene::fountain::MAX_POINTS))]
    pub points: u64,
    /// How a .ply point cache is written.
    #[arg(long, value_enum, default_value_t = PlyEncoding::BinaryLittleEndian)]
    pub encoding: PlyEncoding,
    /// Frames in the shot (or of the point cache, frames 1 to N at 24 fps).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: u32,
    /// The scene file to write (.toml), or the point cache's files (.ply; each run of '#' is
    /// the frame number, needed for more than one frame).
    #[arg(long, short)]
    pub output: PathBuf,
}

/// How a PLY file is written.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PlyEncoding {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

impl PlyEncoding {
    /// The PLY encoding.
    pub(crate) fn encoding(self) -> raytrace_scene::ply::Encoding {
        match self {
            PlyEncoding::Ascii => raytrace_scene::ply::Encoding::Ascii,
            PlyEncoding::BinaryLittleEndian => raytrace_scene::ply::Encoding::BinaryLittleEndian,
            PlyEncoding::BinaryBigEndian => raytrace_scene::ply::Encoding::BinaryBigEndian,
        }
    }
}

impl SceneArgs {
    /// The scene values these arguments replace.
    pub(crate) fn overrides(&self) -> Overrides {
        Overrides {
            width: self.width,
            height: self.height,
            seed: self.seed,
            device: self.device,
            denoise_device: self.denoise_device,
            ..Overrides::default()
        }
    }
}

/// What `--frames` asks for (it takes a value or none): every frame of the shot, or the frames
/// of a spec, which [`Selection::parse`](super::frames::Selection::parse) reads against the
/// shot's frames.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum FramesArg {
    /// `--frames` absent, or given without a value.
    Every,
    /// `--frames SPEC`: `12`, `1-48`, `1-48:4` or a comma list of those (an empty spec is an
    /// error).
    Spec(String),
}

impl FramesArg {
    /// The `--frames` clap read: absent (`None`), given without a value (`Some(None)`), or
    /// with one.
    fn of(frames: &Option<Option<String>>) -> FramesArg {
        match frames {
            None | Some(None) => FramesArg::Every,
            Some(Some(spec)) => FramesArg::Spec(spec.clone()),
        }
    }
}

impl RenderArgs {
    /// The frames `--frames` asks for, of each scene.
    pub(crate) fn frames_arg(&self) -> FramesArg {
        FramesArg::of(&self.frames)
    }

    /// The scene values these arguments replace.
    pub(crate) fn overrides(&self) -> Overrides {
        Overrides {
            output: self.output.clone(),
            samples: self.samples,
            sampler: self.sampler,
            clip: self.clip.clone(),
            passes: self.passes.as_ref().map(|p| p.0.clone()),
            denoise: self.denoise.then_some(true),
            denoise_quality: self.denoise_quality,
            temporal: self.temporal.then_some(true),
            ..self.scene_args.overrides()
        }
    }
}

impl PreviewArgs {
    /// The frames `--frames` puts on the timeline.
    pub(crate) fn frames_arg(&self) -> FramesArg {
        FramesArg::of(&self.frames)
    }
}

impl ClipArgs {
    /// The frames `--frames` puts in the clip.
    pub(crate) fn frames_arg(&self) -> FramesArg {
        FramesArg::of(&self.frames)
    }
}

/// The samples per pixel a frame takes at most under `--noise-threshold` without
/// `--max-samples`: a threshold the frame never reaches (`1e-300`) still ends.
pub(super) const DEFAULT_MAX_SAMPLES_FOR_THRESHOLD: u32 = 65536;

/// The most worker threads `--threads` takes.
pub(super) const MAX_THREADS: u16 = 1024;

impl BudgetArgs {
    /// The budget these arguments give: a noise threshold without `--max-samples` stops at
    /// [`DEFAULT_MAX_SAMPLES_FOR_THRESHOLD`].
    pub(crate) fn budget(&self) -> Budget {
        let default_cap = self
            .noise_threshold
            .map(|_| DEFAULT_MAX_SAMPLES_FOR_THRESHOLD);
        Budget {
            time_limit: self.time_limit,
            noise_threshold: self.noise_threshold,
            max_samples: self.max_samples.or(default_cap),
        }
    }
}

/// Clap's value parser of a whole number `T` (a negative or fractional one is refused with a
/// message that says so).
fn whole<T: std::str::FromStr>(text: &str) -> Result<T, String> {
    let t = text.trim();
    if let Ok(v) = t.parse::<T>() {
        return Ok(v);
    }
    let shown = raytrace_core::error::elide(text);
    if t.starts_with('-') && t[1..].bytes().all(|b| b.is_ascii_digit()) && t.len() > 1 {
        Err(format!("must be a whole number >= 0, got {shown}"))
    } else if !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()) {
        Err(format!("{shown} is too large"))
    } else {
        Err(format!("must be a whole number, got \"{shown}\""))
    }
}

/// Clap's value parser of a whole number from 1.
fn whole_from_1(text: &str) -> Result<u64, String> {
    match whole::<u64>(text)? {
        0 => Err("must be at least 1, got 0".to_string()),
        n => Ok(n),
    }
}

/// Clap's value parser of a finite number above zero.
fn positive(text: &str) -> Result<f64, String> {
    number(
        text,
        |v| v.is_finite() && v > 0.0,
        "a number > 0",
        "a number > 0",
    )
}

/// Clap's value parser of any finite number.
fn finite(text: &str) -> Result<f64, String> {
    number(text, f64::is_finite, "finite", "a finite number")
}

/// Clap's value parser of a noise threshold: a number above 0 and below 1.
fn threshold(text: &str) -> Result<f64, String> {
    number(
        text,
        |v| v > 0.0 && v < 1.0,
        "above 0 and below 1",
        "a number above 0 and below 1",
    )
}

/// Clap's value parser of a number from 0 to 1.
fn fraction(text: &str) -> Result<f64, String> {
    number(
        text,
        |v| (0.0..=1.0).contains(&v),
        "in [0, 1]",
        "a number in [0, 1]",
    )
}

/// A number that `ok` accepts; otherwise a message that it must be `bound` (a number out of
/// range) or `what` (text that is no number).
fn number(text: &str, ok: impl Fn(f64) -> bool, bound: &str, what: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if ok(v) => Ok(v),
        Ok(v) => Err(format!("must be {bound}, got {v}")),
        Err(_) => Err(format!(
            "must be {what}, got \"{}\"",
            raytrace_core::error::elide(text)
        )),
    }
}
