//! The command line: its arguments ([`args`], clap) and one module per command (`render`,
//! `check`, `clip`, `converge`, `generate`, `preview`). `main.rs` parses the arguments into [`Cli`] and
//! calls [`run`]; the commands use the parsed argument structs as they are.
//!
//! A command module parses nothing more, calls the library and prints; no command imports
//! another. What several commands share lives in helper modules: the shots and frames of a
//! run ([`jobs`], [`frames`]), progress and printed lines ([`progress`]), interrupts
//! ([`interrupt`]), worker threads ([`threads`]); [`small`] shrinks every command for the
//! test that runs the docs' commands. `converge --flicker` measures a sequence
//! in a module of its own ([`flicker`]).

mod args;
mod check;
mod clip;
mod converge;
mod flicker;
mod frames;
mod generate;
mod interrupt;
mod jobs;
mod preview;
mod progress;
mod render;
mod seeds;
mod small;
mod threads;

pub(crate) use args::{Cli, Command};
pub(crate) use small::Small;

use raytrace_core::error::Error;

/// Runs a parsed command line. SIGINT and SIGTERM stop it (see [`interrupt`]).
pub(crate) fn run(cli: &Cli) -> Result<(), Error> {
    interrupt::install()?;
    match &cli.command {
        Command::Render(args) => render::render(args).map(|_| ()),
        Command::Converge(args) => match &args.flicker {
            Some(spec) => flicker::measure_flicker(args, spec).map(|_| ()),
            None => converge::converge(args).map(|_| ()),
        },
        Command::Check(args) => check::check(args).map(|s| progress::print_line(s.trim_end())),
        Command::Clip(args) => clip::clip(args),
        Command::Preview(args) => preview::preview(args),
        Command::Generate(args) => generate::generate(args).map(|s| {
            if !s.is_empty() {
                progress::print_line(&s)
            }
        }),
    }
}
