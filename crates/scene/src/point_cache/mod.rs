//! Point caches read for a shot: the files a shot's frames need, surveyed once before
//! anything renders ([`ShotPoints::survey`]), and each frame's points read from them when it
//! renders ([`ShotPoints::read_frame`]) into the core's [`raytrace_core::points::FramePoints`].
//!
//! Formats: PLY ([`crate::ply`]), LAMMPS text dumps, extended XYZ and VTK point data
//! ([`crate::sim`]); a cache's file is one file for every frame, a sequence (`#`: a file per
//! frame) or a series (`*`: one file a snapshot, as LAMMPS names them).
//!
//! The rooms: `files` (which snapshot each frame shows, and when), `table` (a file's
//! snapshots in any format: indexing, reading rows), `columns` (which columns mean what),
//! `read` (values read and checked), `motion` (interpolation by id, periodic copies),
//! `survey` (the shot's survey, check's figures), `frame_points` (a frame's points), `load` (what
//! a frame's points hold in memory).

mod columns;
mod files;
mod frame_points;
mod load;
mod message;
mod motion;
mod read;
mod survey;
mod table;

pub use frame_points::read_frame;
pub use load::PointLoad;
pub use survey::{FrameSurvey, Frames, ShotPoints, SurveyDepth, frame_list};
