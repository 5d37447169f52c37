//! What a run shows while it works: progress bars on a terminal's stderr, and lines on stdout.

use std::io::IsTerminal;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Prints a line to stdout. A closed stdout (`raytrace render ... | head -1`) is not an error:
/// the lines are for whoever reads them, and the frames are still rendered and written.
pub(crate) fn print_line(text: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stdout().lock(), "{text}");
}

/// Progress bars on a terminal's stderr, and one summary line per frame on stdout.
pub(crate) struct Progress {
    multi: MultiProgress,
    frames: ProgressBar,
    quiet: bool,
}

impl Progress {
    pub(crate) fn new(frames: u64, quiet: bool) -> Progress {
        let target = if quiet || !std::io::stderr().is_terminal() {
            ProgressDrawTarget::hidden()
        } else {
            ProgressDrawTarget::stderr()
        };
        let multi = MultiProgress::with_draw_target(target);
        let bar = multi.add(ProgressBar::new(frames));
        bar.set_style(
            ProgressStyle::with_template(
                "frames {pos}/{len} [{wide_bar}] {elapsed_precise} eta {eta_precise}",
            )
            .expect("valid template"),
        );
        Progress {
            multi,
            frames: bar,
            quiet,
        }
    }

    /// A bar for one frame's samples; without a planned count (a budget), a spinner.
    pub(crate) fn start_frame(&self, frame: u32, planned: Option<u64>) -> ProgressBar {
        let (bar, template) = match planned {
            Some(samples) => (
                ProgressBar::new(samples),
                "frame {msg} [{wide_bar}] {percent}% {per_sec} eta {eta}",
            ),
            None => (
                ProgressBar::no_length(),
                "frame {msg} {spinner} {human_pos} samples {per_sec} {elapsed}",
            ),
        };
        let bar = self.multi.add(bar);
        bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
        bar.set_message(frame.to_string());
        bar
    }

    pub(crate) fn frame_done(&self) {
        self.frames.inc(1);
    }

    pub(crate) fn line(&self, text: &str) {
        if !self.quiet {
            self.multi.suspend(|| print_line(text));
        }
    }

    pub(crate) fn finish(&self) {
        self.frames.finish_and_clear();
    }
}
