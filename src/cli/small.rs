//! `RAYTRACE_DOCS_SMALL=1`: every command's work shrunk to a thumbnail, so the test that runs
//! the documentation's commands (`tests/integration/docs.rs`) runs them all in seconds. It
//! caps the parsed arguments once, before any command runs, and only where the variable is
//! exactly `1`: without it [`Small::from_env`] is `None` and nothing is touched, so normal
//! output cannot change. It is no user feature and the docs do not show it.

use super::args::{BudgetArgs, Command, ConvergeArgs, GenerateArgs, RenderArgs, SceneArgs};

/// The environment variable that shrinks every command.
pub(crate) const VARIABLE: &str = "RAYTRACE_DOCS_SMALL";

/// The caps: a frame of at most 32x18 pixels and a few samples, a generated scene or point
/// cache of at most 2000 spheres or points.
const WIDTH: u32 = 32;
const HEIGHT: u32 = 18;
const SAMPLES: u32 = 4;
/// Under a noise threshold: the 16 uniform samples come before adaptive rounds
/// (`docs/convergence.md`), so 16 still reaches an adaptive round.
const MAX_SAMPLES: u32 = 16;
const REFERENCE_SAMPLES: u32 = 16;
const SEEDS: u32 = 2;
const GENERATED: u64 = 2000;

/// The shrinking, present only where [`VARIABLE`] is `1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Small;

impl Small {
    /// `Some` where the environment asks for thumbnails.
    pub(crate) fn from_env() -> Option<Small> {
        Small::from_value(std::env::var_os(VARIABLE).as_deref())
    }

    /// `Some` where the variable's value is exactly `1`.
    fn from_value(value: Option<&std::ffi::OsStr>) -> Option<Small> {
        (value == Some(std::ffi::OsStr::new("1"))).then_some(Small)
    }

    /// Caps a parsed command's sizes, samples and counts.
    pub(crate) fn apply(self, command: &mut Command) {
        match command {
            Command::Render(args) => shrink_render(args),
            Command::Converge(args) => shrink_converge(args),
            Command::Generate(args) => shrink_generate(args),
            Command::Check(_) | Command::Clip(_) | Command::Preview(_) => {}
        }
    }
}

/// `min(given, cap)`, or the cap where nothing was given.
fn capped<T: Ord + Copy>(given: Option<T>, cap: T) -> Option<T> {
    Some(given.map_or(cap, |v| v.min(cap)))
}

fn shrink_size(args: &mut SceneArgs) {
    args.width = capped(args.width, WIDTH);
    args.height = capped(args.height, HEIGHT);
}

fn shrink_render(args: &mut RenderArgs) {
    shrink_size(&mut args.scene_args);
    let BudgetArgs {
        time_limit,
        noise_threshold,
        max_samples,
    } = &mut args.budget;
    if time_limit.is_none() && noise_threshold.is_none() {
        args.samples = capped(args.samples, SAMPLES);
    } else {
        *max_samples = capped(*max_samples, MAX_SAMPLES);
    }
}

fn shrink_converge(args: &mut ConvergeArgs) {
    shrink_size(&mut args.scene_args);
    if args.reference.is_empty() {
        args.reference_samples = capped(args.reference_samples, REFERENCE_SAMPLES);
    }
    args.max_samples = capped(args.max_samples, SAMPLES);
    args.seeds = capped(args.seeds, SEEDS);
    args.repeats = Some(1);
}

fn shrink_generate(args: &mut GenerateArgs) {
    args.spheres = args.spheres.min(GENERATED);
    args.points = args.points.min(GENERATED);
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    fn parsed(line: &str) -> Command {
        super::super::Cli::parse_from(line.split_whitespace()).command
    }

    #[test]
    fn only_the_value_1_shrinks() {
        use std::ffi::OsStr;
        assert_eq!(Small::from_value(None), None);
        assert_eq!(Small::from_value(Some(OsStr::new("0"))), None);
        assert_eq!(Small::from_value(Some(OsStr::new(""))), None);
        assert_eq!(Small::from_value(Some(OsStr::new("1"))), Some(Small));
    }

    #[test]
    fn a_render_is_capped_and_a_small_one_kept() {
        let mut c = parsed("raytrace render s.toml --width 1920 --samples 64");
        Small.apply(&mut c);
        let Command::Render(r) = c else { panic!() };
        assert_eq!(
            (r.scene_args.width, r.scene_args.height),
            (Some(32), Some(18))
        );
        assert_eq!(r.samples, Some(4));
        let mut c = parsed("raytrace render s.toml --width 8 --noise-threshold 0.01");
        Small.apply(&mut c);
        let Command::Render(r) = c else { panic!() };
        assert_eq!((r.scene_args.width, r.samples), (Some(8), None));
        assert_eq!(r.budget.max_samples, Some(16));
    }

    #[test]
    fn converge_and_generate_are_capped() {
        let mut c = parsed("raytrace converge s.toml --reference-samples 4096 --max-samples 256");
        Small.apply(&mut c);
        let Command::Converge(a) = c else { panic!() };
        assert_eq!((a.reference_samples, a.max_samples), (Some(16), Some(4)));
        assert_eq!((a.seeds, a.repeats), (Some(2), Some(1)));
        let mut c = parsed("raytrace generate -o f.ply --points 10000000 --spheres 5");
        Small.apply(&mut c);
        let Command::Generate(g) = c else { panic!() };
        assert_eq!((g.points, g.spheres), (2000, 5));
    }
}
