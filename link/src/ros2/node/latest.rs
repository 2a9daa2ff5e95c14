//! The newest message of a subscription not yet taken by the node's loop
//! (latest wins: a flood is one slot, never a queue), written by Zenoh's
//! threads: `cmd_vel`'s twists and the position fixes.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// One slot, and what it counted.
pub(super) struct Latest<T> {
    latest: Mutex<Option<T>>,
    /// Messages replaced by a newer one before they were taken.
    pub(super) superseded: AtomicU64,
    /// Messages refused (not their type's CDR, or not what the node takes).
    pub(super) refused: AtomicU64,
}

impl<T> Default for Latest<T> {
    fn default() -> Self {
        Self {
            latest: Mutex::new(None),
            superseded: AtomicU64::new(0),
            refused: AtomicU64::new(0),
        }
    }
}

impl<T> Latest<T> {
    /// Keeps `v`, counting the one it replaces.
    pub(super) fn put(&self, v: T) {
        let mut slot = self.latest.lock().unwrap_or_else(|p| p.into_inner());
        if slot.replace(v).is_some() {
            self.superseded.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// The newest, if one came since the last take.
    pub(super) fn take(&self) -> Option<T> {
        self.latest.lock().unwrap_or_else(|p| p.into_inner()).take()
    }

    /// Counts a refused message; true for the first (to say it once).
    pub(super) fn refuse(&self) -> bool {
        self.refused.fetch_add(1, Ordering::Relaxed) == 0
    }
}
