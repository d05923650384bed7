//! Locks whose poisoning is not an error.

use std::sync::{Mutex, MutexGuard, PoisonError};

/// `mutex`'s guard, a poisoned one's too. For data that a panic cannot leave half-written:
/// every writer replaces the value whole, or nothing panics while the lock is held.
pub(crate) fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}
