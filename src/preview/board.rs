//! The board: what the pages are shown and what they ask for, shared under one lock by the
//! server's connections, the file watcher and the render worker.
//!
//! Everything a page is shown carries the board's version at which it last changed (its
//! stamp); a page's stream remembers the version it has caught up with and sends only what
//! is newer, always the latest of it. So a slow page skips images rather than queueing them,
//! and what the server holds does not grow with the pages: one image per frame and view,
//! shared by every page, within [`MAX_IMAGE_BYTES`].

use std::collections::{BTreeMap, BTreeSet};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use hyper::body::Bytes;
use tokio::sync::watch;

/// Most pages with an open stream at once; the next is refused until one closes.
pub(crate) const MAX_PAGES: usize = 16;

/// Most bytes of images the board keeps (every frame and view, as sent). Past it the frames
/// farthest from the chosen one are dropped, and no other frame is started.
pub(crate) const MAX_IMAGE_BYTES: usize = 256 << 20;

/// A value with the board version at which it last changed.
pub(crate) struct Stamped<T> {
    pub(crate) stamp: u64,
    pub(crate) value: T,
}

/// The latest images of one frame: every view, as `image` events ready to send.
pub(crate) struct FrameImages {
    /// The render generation they belong to (see `worker`): older ones stay shown until
    /// replaced.
    pub(crate) generation: u64,
    pub(crate) samples: u32,
    /// One `image` event per view, by the view's name.
    pub(crate) events: Vec<(&'static str, Bytes)>,
}

impl FrameImages {
    fn bytes(&self) -> usize {
        self.events.iter().map(|(_, e)| e.len()).sum()
    }
}

/// The frame and view the pages show.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Chosen {
    /// `None` until a shot has been read.
    pub(crate) frame: Option<u32>,
    pub(crate) view: &'static str,
}

/// A pass in flight on one of the worker's lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Running {
    pub(crate) generation: u64,
    pub(crate) frame: u32,
    pub(crate) samples: u32,
    pub(crate) lane: usize,
}

/// What the board holds.
pub(crate) struct State {
    version: u64,
    /// The `shot` event of the shot rendered now.
    pub(crate) shot: Option<Stamped<Bytes>>,
    /// The `error` event: the scene's message, or none.
    error: Stamped<Bytes>,
    pub(crate) chosen: Stamped<Chosen>,
    pub(crate) frames: BTreeMap<u32, Stamped<FrameImages>>,
    image_bytes: usize,
    /// The open pages, each with the size (in device pixels) its image may take.
    pages: BTreeMap<u64, (u32, u32)>,
    next_page: u64,
    /// When the watched files last changed, until the worker has read them again.
    pub(crate) changed_at: Option<Instant>,
    pub(crate) running: Vec<Running>,
    /// The render generation whose passes the board keeps (see `worker`).
    pub(crate) generation: u64,
    /// The frames whose pass failed in a generation, not tried again in it.
    pub(crate) failed: BTreeSet<(u64, u32)>,
    /// The frames of the shot rendered now and its views: what a page may choose.
    pub(crate) selectable: (Arc<[u32]>, Vec<&'static str>),
}

/// The shared board.
pub(crate) struct Board {
    state: Mutex<State>,
    /// Wakes the worker: a page opened or closed, a frame chosen, files changed, a pass ended.
    worker: Condvar,
    /// The board's version, which the pages' streams wait on.
    version: watch::Sender<u64>,
}

/// An `event: NAME` with `data` (one line: JSON) as server-sent events frame it.
pub(crate) fn event(name: &str, data: &str) -> Bytes {
    Bytes::from(format!("event: {name}\ndata: {data}\n\n"))
}

impl Board {
    /// An empty board: no shot, no error, no page; the files count as changed (to be read).
    pub(crate) fn new() -> Board {
        Board {
            state: Mutex::new(State {
                version: 1,
                shot: None,
                error: Stamped {
                    stamp: 1,
                    value: event("problem", r#"{"message":null}"#),
                },
                chosen: Stamped {
                    stamp: 1,
                    value: Chosen {
                        frame: None,
                        view: "colour",
                    },
                },
                frames: BTreeMap::new(),
                image_bytes: 0,
                pages: BTreeMap::new(),
                next_page: 0,
                changed_at: Some(Instant::now()),
                running: Vec::new(),
                generation: 0,
                failed: BTreeSet::new(),
                selectable: (Arc::from([]), vec!["colour"]),
            }),
            worker: Condvar::new(),
            version: watch::Sender::new(1),
        }
    }

    /// The board, locked. A thread that panicked holding the lock left nothing half-done
    /// that a page could not show, so a poisoned lock is taken as it is.
    pub(crate) fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Waits (at most `timeout`) until something wakes the worker.
    pub(crate) fn wait<'a>(
        &self,
        guard: MutexGuard<'a, State>,
        timeout: Duration,
    ) -> MutexGuard<'a, State> {
        match self.worker.wait_timeout(guard, timeout) {
            Ok((g, _)) => g,
            Err(e) => e.into_inner().0,
        }
    }

    /// Wakes the worker and tells the pages what `state` now holds.
    pub(crate) fn changed(&self, state: &State) {
        self.worker.notify_all();
        self.version.send_replace(state.version);
    }

    /// A receiver of the board's version, for a page's stream.
    pub(crate) fn subscribe(&self) -> watch::Receiver<u64> {
        self.version.subscribe()
    }

    /// The watched files changed: read them again soon.
    pub(crate) fn files_changed(&self) {
        let mut s = self.lock();
        s.changed_at = Some(Instant::now());
        self.changed(&s);
    }

    /// Registers a page whose image may take `size`; `None` when [`MAX_PAGES`] are open.
    /// The page is open while the returned guard lives.
    pub(crate) fn open_page(self: &Arc<Board>, size: (u32, u32)) -> Option<PageGuard> {
        let mut s = self.lock();
        if s.pages.len() >= MAX_PAGES {
            return None;
        }
        let id = s.next_page;
        s.next_page += 1;
        s.pages.insert(id, size);
        self.changed(&s);
        Some(PageGuard {
            board: Arc::clone(self),
            id,
        })
    }

    /// Chooses the frame and view the pages show; an error names what is not in the shot.
    pub(crate) fn choose(&self, frame: Option<u32>, view: Option<&str>) -> Result<(), String> {
        let mut s = self.lock();
        let (frames, views) = &s.selectable;
        if let Some(f) = frame
            && frames.binary_search(&f).is_err()
        {
            return Err(format!("frame {f} is not one of the shot's frames shown"));
        }
        let view = match view {
            Some(v) => *views.iter().find(|n| **n == v).ok_or_else(|| {
                format!(
                    "the shot has no view \"{}\"",
                    raytrace_core::error::elide(v)
                )
            })?,
            None => s.chosen.value.view,
        };
        let chosen = Chosen {
            frame: frame.or(s.chosen.value.frame),
            view,
        };
        if chosen != s.chosen.value {
            let stamp = s.bump();
            if chosen.view != s.chosen.value.view {
                // Every frame is sent again, in the new view.
                for f in s.frames.values_mut() {
                    f.stamp = stamp;
                }
            }
            s.chosen = Stamped {
                stamp,
                value: chosen,
            };
            self.changed(&s);
        }
        Ok(())
    }

    /// The events newer than version `seen`, for a page, and the version they bring it to:
    /// the shot, the error, the choice, then each changed frame's image in the chosen view
    /// (the chosen frame first).
    pub(crate) fn catch_up(&self, seen: u64) -> (Vec<Bytes>, u64) {
        let s = self.lock();
        let mut out = Vec::new();
        if let Some(shot) = s.shot.as_ref().filter(|x| x.stamp > seen) {
            out.push(shot.value.clone());
        }
        if s.error.stamp > seen {
            out.push(s.error.value.clone());
        }
        if s.chosen.stamp > seen {
            let c = &s.chosen.value;
            let data = serde_json::json!({"frame": c.frame, "view": c.view});
            out.push(event("view", &data.to_string()));
        }
        let chosen = s.chosen.value.frame;
        let first = chosen.and_then(|f| s.frames.get(&f).map(|i| (f, i)));
        let rest = s.frames.iter().filter(|(f, _)| Some(**f) != chosen);
        for (_, images) in first.into_iter().chain(rest.map(|(f, i)| (*f, i))) {
            if images.stamp > seen {
                out.push(s.image_event(&images.value));
            }
        }
        (out, s.version)
    }
}

impl State {
    /// A new version, for a change.
    pub(crate) fn bump(&mut self) -> u64 {
        self.version += 1;
        self.version
    }

    /// The pages open now.
    pub(crate) fn pages(&self) -> usize {
        self.pages.len()
    }

    /// The largest size an open page's image may take, if any page said.
    pub(crate) fn page_size(&self) -> Option<(u32, u32)> {
        self.pages
            .values()
            .copied()
            .reduce(|a, b| (a.0.max(b.0), a.1.max(b.1)))
    }

    /// Sets the error shown (a scene's message), or clears it.
    pub(crate) fn set_error(&mut self, message: Option<&str>) {
        let data = serde_json::json!({ "message": message }).to_string();
        let value = event("problem", &data);
        if value != self.error.value {
            let stamp = self.bump();
            self.error = Stamped { stamp, value };
        }
    }

    /// Shows a new shot (its `shot` event), with the frames and views a page may choose; the
    /// chosen frame stays if the shot still has it, else the first is chosen.
    pub(crate) fn set_shot(&mut self, shot: Bytes, frames: Arc<[u32]>, views: Vec<&'static str>) {
        let stamp = self.bump();
        self.shot = Some(Stamped { stamp, value: shot });
        let c = &self.chosen.value;
        let chosen = Chosen {
            frame: c
                .frame
                .filter(|f| frames.binary_search(f).is_ok())
                .or(frames.first().copied()),
            view: views
                .iter()
                .copied()
                .find(|v| *v == c.view)
                .unwrap_or("colour"),
        };
        if chosen != self.chosen.value {
            self.chosen = Stamped {
                stamp,
                value: chosen,
            };
        }
        // Frames no longer shown are dropped; the others stay shown until replaced.
        let dropped: Vec<u32> = (self.frames.keys())
            .filter(|f| frames.binary_search(f).is_err())
            .copied()
            .collect();
        for f in dropped {
            self.remove_frame(f);
        }
        self.selectable = (frames, views);
    }

    /// Keeps `images` as `frame`'s latest, dropping the frames farthest from the chosen one
    /// while the images would pass [`MAX_IMAGE_BYTES`].
    pub(crate) fn set_frame(&mut self, frame: u32, images: FrameImages) {
        self.remove_frame(frame);
        let chosen = self.chosen.value.frame.unwrap_or(frame);
        while self.image_bytes + images.bytes() > MAX_IMAGE_BYTES {
            let farthest = (self.frames.keys())
                .copied()
                .max_by_key(|f| f.abs_diff(chosen));
            match farthest {
                Some(f) if f.abs_diff(chosen) > frame.abs_diff(chosen) => self.remove_frame(f),
                // The new one is the farthest: it is not kept.
                _ => return,
            }
        }
        self.image_bytes += images.bytes();
        let stamp = self.bump();
        self.frames.insert(
            frame,
            Stamped {
                stamp,
                value: images,
            },
        );
    }

    /// Whether another frame's images would still fit beside those kept (judged by the
    /// largest kept).
    pub(crate) fn room_for_another(&self) -> bool {
        let largest = self.frames.values().map(|f| f.value.bytes()).max();
        self.image_bytes + largest.unwrap_or(0) <= MAX_IMAGE_BYTES
    }

    fn remove_frame(&mut self, frame: u32) {
        if let Some(old) = self.frames.remove(&frame) {
            self.image_bytes -= old.value.bytes();
        }
    }

    /// The `image` event of `images` in the chosen view (the colour when the frame lacks it).
    fn image_event(&self, images: &FrameImages) -> Bytes {
        let view = self.chosen.value.view;
        let pick = |name: &str| images.events.iter().find(|(n, _)| *n == name);
        pick(view)
            .or_else(|| pick("colour"))
            .map(|(_, e)| e.clone())
            .unwrap_or_default()
    }
}

/// An open page: closed (and the worker told) when dropped.
pub(crate) struct PageGuard {
    board: Arc<Board>,
    id: u64,
}

impl Drop for PageGuard {
    fn drop(&mut self) {
        let mut s = self.board.lock();
        s.pages.remove(&self.id);
        self.board.changed(&s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn images(generation: u64, bytes: usize) -> FrameImages {
        FrameImages {
            generation,
            samples: 1,
            events: vec![
                ("colour", Bytes::from(vec![b'c'; bytes])),
                ("depth", Bytes::from(vec![b'd'; bytes])),
            ],
        }
    }

    #[test]
    fn a_page_is_sent_only_what_changed_since_it_caught_up() {
        let board = Board::new();
        {
            let mut s = board.lock();
            s.set_shot(
                event("shot", "{}"),
                Arc::from([1, 2, 3]),
                vec!["colour", "depth"],
            );
            s.set_frame(2, images(1, 4));
        }
        let (all, seen) = board.catch_up(0);
        // The shot, the (empty) error, the choice (frame 1, chosen for the new shot) and
        // frame 2's colour.
        assert_eq!(all.len(), 4);
        assert_eq!(all[3], Bytes::from(vec![b'c'; 4]));
        assert!(board.catch_up(seen).0.is_empty());
        board.lock().set_frame(3, images(1, 4));
        assert_eq!(board.catch_up(seen).0, [Bytes::from(vec![b'c'; 4])]);
        // Another view: every frame again, in it.
        board.choose(None, Some("depth")).unwrap();
        let (again, _) = board.catch_up(seen);
        assert_eq!(again.len(), 3);
        assert_eq!(again[1], Bytes::from(vec![b'd'; 4]));
        assert!(board.choose(Some(4), None).is_err());
        assert!(board.choose(None, Some("normal")).is_err());
    }

    #[test]
    fn images_stay_within_their_bound_dropping_the_farthest_frames() {
        let board = Board::new();
        let mut s = board.lock();
        s.set_shot(event("shot", "{}"), Arc::from([1, 2, 3, 4]), vec!["colour"]);
        let quarter = MAX_IMAGE_BYTES / 4;
        // Two views of a quarter each: two frames fill the board.
        s.set_frame(1, images(1, quarter / 2));
        s.set_frame(4, images(1, quarter / 2));
        s.set_frame(2, images(1, quarter + 1));
        assert!(s.image_bytes <= MAX_IMAGE_BYTES);
        // Frame 1 is chosen: frame 4, the farthest, went.
        assert_eq!(s.frames.keys().copied().collect::<Vec<_>>(), [1, 2]);
        assert!(!s.room_for_another());
        // A frame farther than every kept one is not kept.
        s.set_frame(3, images(1, quarter));
        assert_eq!(s.frames.keys().copied().collect::<Vec<_>>(), [1, 2]);
    }
}
