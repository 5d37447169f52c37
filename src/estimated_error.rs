//! A rendered frame's estimated error as the lines state it: `render`'s frame and summary
//! lines, and the preview's line of a pass.

use raytrace_core::renderer::FrameResult;

/// An estimated relative error as a percentage (`1.234%`), or why there is none (`unknown
/// (1 sample)`).
pub(crate) fn relative_error_percent(relative_error: f64) -> String {
    if relative_error.is_finite() {
        format!("{:.3}%", relative_error * 100.0)
    } else {
        "unknown (1 sample)".to_string()
    }
}

/// A frame's estimated error as its line states it: `1.234%`, `unknown (1 sample)`, or for a
/// denoised frame `1.234% denoised (3.456% before)`.
pub(crate) fn frame_error_note(result: &FrameResult) -> String {
    let st = &result.stats;
    match &result.denoised {
        Some(_) => format!(
            "{} denoised ({} before)",
            relative_error_percent(st.relative_error),
            relative_error_percent(st.noisy_relative_error)
        ),
        None => relative_error_percent(st.relative_error),
    }
}
