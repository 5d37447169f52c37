//! (stub until the output module lands)
use crate::error::Error;
use std::path::{Path, PathBuf};
pub struct FrameInfo {
    pub frame: u32,
    pub fps: f64,
    pub shutter_open: f64,
    pub shutter_close: f64,
    pub samples: u32,
    pub seed: u64,
    pub extra: Vec<(String, f64)>,
}
pub fn pattern_has_frame_number(p: &str) -> bool {
    p.contains('#')
}
pub fn frame_path(p: &str, f: u32) -> PathBuf {
    PathBuf::from(p.replace("####", &format!("{f:04}")))
}
pub fn format_for(_p: &Path) -> Result<(), String> {
    Ok(())
}
pub fn remove_stale_temp_files(_p: &Path) {}
pub fn write_frame(path: &Path, w: u32, h: u32, rgb: &[f32], _i: &FrameInfo) -> Result<(), Error> {
    let mut s = format!("P3\n{w} {h}\n255\n");
    for v in rgb {
        let x = (v.clamp(0.0, 1.0).sqrt() * 255.0) as u32;
        s.push_str(&format!("{x} "));
    }
    std::fs::write(path, s).map_err(|e| Error::io(path, e))
}
