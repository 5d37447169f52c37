//! The connections the preview server holds: at most a fixed number, and a new one is never
//! kept waiting for a slot by connections that send nothing. When every slot is taken, the
//! connection that has waited longest for a request (one that never sent a whole request,
//! or one kept alive between requests) is closed and its slot given to the new one; a
//! connection inside a request, or streaming a page's events, keeps its slot.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, MutexGuard};

use tokio::task::AbortHandle;

/// The server's connection slots.
pub(crate) struct Slots {
    most: usize,
    state: Mutex<State>,
}

#[derive(Default)]
struct State {
    /// Ids in the order the connections came (the oldest first).
    open: BTreeMap<u64, Entry>,
    next: u64,
}

#[derive(Default)]
struct Entry {
    /// Inside a request, or streaming events: not closed for a newcomer.
    busy: bool,
    /// How to close the connection (its task), once it is running.
    task: Option<AbortHandle>,
}

/// One connection's slot, given back when dropped.
pub(crate) struct Slot {
    slots: Arc<Slots>,
    id: u64,
}

impl Slots {
    /// Slots for at most `most` connections.
    pub(crate) fn new(most: usize) -> Arc<Slots> {
        Arc::new(Slots {
            most,
            state: Mutex::new(State::default()),
        })
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// A slot for a new connection: a free one, or the slot of the connection that has
    /// waited longest for a request, which is closed. `None` when every connection is busy.
    pub(crate) fn admit(self: &Arc<Slots>) -> Option<Slot> {
        let mut s = self.lock();
        if s.open.len() >= self.most {
            let idle = s
                .open
                .iter()
                .find(|(_, e)| !e.busy && e.task.is_some())
                .map(|(&id, _)| id)?;
            if let Some(task) = s.open.remove(&idle).and_then(|e| e.task) {
                task.abort();
            }
        }
        let id = s.next;
        s.next += 1;
        s.open.insert(id, Entry::default());
        Some(Slot {
            slots: Arc::clone(self),
            id,
        })
    }

    /// How many connections hold a slot.
    #[cfg(test)]
    fn open(&self) -> usize {
        self.lock().open.len()
    }
}

impl Slot {
    /// Gives the slot the task serving its connection, which closing it ends.
    pub(crate) fn serving(&self, task: AbortHandle) {
        if let Some(e) = self.slots.lock().open.get_mut(&self.id) {
            e.task = Some(task);
        }
    }

    /// Marks the connection inside a request (`true`) or waiting for one (`false`).
    pub(crate) fn set_busy(&self, busy: bool) {
        if let Some(e) = self.slots.lock().open.get_mut(&self.id) {
            e.busy = busy;
        }
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        self.slots.lock().open.remove(&self.id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(flavor = "current_thread")]
    async fn a_full_server_closes_its_longest_idle_connection_for_a_new_one() {
        let slots = Slots::new(2);
        let task = || tokio::spawn(std::future::pending::<()>());
        let (a, ta) = (slots.admit().unwrap(), task());
        a.serving(ta.abort_handle());
        let (b, tb) = (slots.admit().unwrap(), task());
        b.serving(tb.abort_handle());
        // Both idle: the oldest, a, is closed.
        let c = slots.admit().unwrap();
        c.serving(task().abort_handle());
        assert!(ta.await.unwrap_err().is_cancelled());
        assert_eq!(slots.open(), 2);
        // b busy, c idle: c goes.
        b.set_busy(true);
        let _d = slots.admit().unwrap();
        assert!(!tb.is_finished());
        // b busy, d not yet serving: no slot.
        assert!(slots.admit().is_none());
        drop(b);
        assert_eq!(slots.open(), 1);
        assert!(slots.admit().is_some());
    }
}
