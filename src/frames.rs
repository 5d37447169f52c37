//! (stub until the frame-spec module lands)
pub fn parse_frames(_spec: &str, _first: u32, _last: u32) -> Result<Vec<u32>, String> {
    Err("todo".into())
}
pub fn chunk(frames: &[u32], _size: usize, _index: usize) -> Result<&[u32], String> {
    Ok(frames)
}
pub fn chunk_count(_n: usize, _size: usize) -> usize {
    0
}
