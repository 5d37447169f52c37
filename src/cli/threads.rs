//! The worker threads a command runs on.

use raytrace_core::error::Error;

/// A thread pool of `threads` workers (`None`: one per core) for a command to run in.
pub(super) fn thread_pool(threads: Option<u16>) -> Result<rayon::ThreadPool, Error> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.map_or(0, usize::from))
        .build()
        .map_err(|e| Error::resource(format!("cannot start worker threads: {e}")))
}
