//! `raytrace preview`'s room: a live page of a shot that re-renders when its files change.
//!
//! - [`live`]: the preview started: its board, worker and server;
//! - [`server`]: the HTTP server (the page, its event streams, its choices; Host and Origin
//!   checked);
//! - [`slots`]: the connections it holds, none kept waiting by connections that send nothing;
//! - [`board`]: what the pages are shown and ask for, shared under one lock;
//! - [`worker`]: reading the shot when its files change, and the passes rendered next;
//! - [`render`]: the one call into the renderer;
//! - [`views`]: a rendered frame's colour and passes as the page's PNGs;
//! - [`timeline`]: the shot's frames and exposures as the page's timeline draws them;
//! - [`watch`]: the scene file and its point caches watched;
//! - `page.html`: the page, compiled in.
//!
//! This file only declares and re-exports: the children import each other directly.

mod board;
mod live;
mod render;
mod server;
mod slots;
mod timeline;
mod views;
mod watch;
mod worker;

pub(crate) use live::run;
pub(crate) use server::bind;
pub(crate) use timeline::MAX_TIMELINE_FRAMES;
pub(crate) use worker::{Frames, Setup};
