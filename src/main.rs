//! `raytrace`: renders animation sequences of moving spheres, with motion blur and defocus
//! blur, as EXR or PNG frames. This binary is the command line ([`cli`]: one module per
//! command), the live preview ([`preview`]) and `converge`'s analysis ([`analysis`]), with
//! how their lines state a frame's estimated error ([`estimated_error`]) and the processor a
//! build needs ([`cpu`]); the renderer is the workspace's library crates
//! (docs/architecture.md).
#![forbid(unsafe_code)]

mod analysis;
mod cli;
mod cpu;
mod estimated_error;
mod preview;

use std::process::ExitCode;

use clap::Parser;
use cli::Cli;

fn main() -> ExitCode {
    cpu::require();
    let mut cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            // clap uses 2 for usage errors and 0 for --help/--version.
            return ExitCode::from(e.exit_code() as u8);
        }
    };
    if let Some(small) = cli::Small::from_env() {
        small.apply(&mut cli.command);
    }
    match cli::run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "error: {e}");
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
