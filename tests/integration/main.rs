//! The integration tests, in one binary (a binary a file would each link the whole renderer
//! again): a module per subject, sharing the helpers of [`common`]. They run the `raytrace`
//! binary as a user would, and the library crates where a test needs their values.
//!
//! ```sh
//! cargo test --release --test integration            # all of them (what .ci/run runs)
//! cargo test --release --test integration -- cli::   # one module
//! ```

mod common;

mod architecture;
mod batch;
mod budget;
mod bundle;
mod cli;
mod clip;
mod converge;
mod cpu;
mod denoise;
mod denoise_estimate;
mod docs;
mod flicker;
mod gpu;
mod gpu_cache;
mod gpu_check;
mod hostile;
mod hostile_gpu_memory;
mod hostile_messages;
mod hostile_moved_binary;
mod hostile_ply;
mod hostile_points;
mod hostile_scenes;
mod hostile_sim;
mod kill_resume;
mod lammps;
mod motion_blur;
mod passes;
mod points;
mod preview;
mod shutter;
mod simulations;
mod slurm;
mod stability;
