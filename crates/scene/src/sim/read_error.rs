//! What goes wrong reading a simulation file.

/// A reading's error: bad input (a message naming the line and what is wrong), or the
/// system's.
#[derive(Debug)]
pub(crate) enum ReadError {
    Bad(String),
    Io(std::io::Error),
}

impl From<std::io::Error> for ReadError {
    fn from(e: std::io::Error) -> Self {
        ReadError::Io(e)
    }
}
