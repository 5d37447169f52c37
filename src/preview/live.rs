//! The preview started: an empty board, the worker on threads of its own, and the server on
//! the calling thread.

use std::net::TcpListener;
use std::sync::Arc;

use super::board::Board;
use super::server::serve;
use super::worker::{Setup, start};
use raytrace_core::error::Error;

/// Serves the preview of `setup`'s shot on `listener` (bound already) for ever.
pub(crate) fn run(listener: TcpListener, setup: Setup) -> Result<(), Error> {
    let board = Arc::new(Board::new());
    start(Arc::clone(&board), setup)?;
    serve(listener, board)
}
