//! The bounded capture queue with an explicit drop policy.
//!
//! A live source must never wait for compute: when the queue is full, the OLDEST queued frame is
//! dropped (and returned so the caller counts it). A replay source waits (backpressure) and nothing
//! is dropped, so replay output is deterministic.
//!
//! ```
//! use mosaicd::pipeline::{FrameQueue, Push};
//! use mosaicd::capture::SourceKind;
//! let q = FrameQueue::new(2, SourceKind::Live);
//! assert!(matches!(q.push(1), Push::Queued));
//! assert!(matches!(q.push(2), Push::Queued));
//! assert!(matches!(q.push(3), Push::DroppedOldest(1)));
//! q.close();
//! assert_eq!(q.pop(), Some(2));
//! assert_eq!(q.pop(), Some(3));
//! assert_eq!(q.pop(), None);
//! ```

use std::collections::VecDeque;
use std::sync::{Condvar, Mutex, MutexGuard};

use crate::capture::SourceKind;

/// What happened to a pushed item.
#[derive(Debug, PartialEq, Eq)]
pub enum Push<T> {
    /// Queued.
    Queued,
    /// Queued; the oldest item was dropped to make room (live policy) and is handed back.
    DroppedOldest(T),
    /// The queue is closed; the item is handed back.
    Closed(T),
}

struct State<T> {
    items: VecDeque<T>,
    closed: bool,
}

/// A bounded multi-producer queue with the drop policy of a [`SourceKind`].
pub struct FrameQueue<T> {
    state: Mutex<State<T>>,
    not_empty: Condvar,
    not_full: Condvar,
    capacity: usize,
    kind: SourceKind,
}

impl<T> FrameQueue<T> {
    /// A queue of `capacity` (at least 1) items.
    pub fn new(capacity: usize, kind: SourceKind) -> Self {
        Self {
            state: Mutex::new(State {
                items: VecDeque::with_capacity(capacity.max(1)),
                closed: false,
            }),
            not_empty: Condvar::new(),
            not_full: Condvar::new(),
            capacity: capacity.max(1),
            kind,
        }
    }

    fn lock(&self) -> MutexGuard<'_, State<T>> {
        // A poisoned lock only means another thread panicked while holding it; the queue's state
        // (a VecDeque and a flag) is still consistent.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Push: live drops the oldest when full, replay waits for room.
    pub fn push(&self, item: T) -> Push<T> {
        let mut s = self.lock();
        loop {
            if s.closed {
                return Push::Closed(item);
            }
            if s.items.len() < self.capacity {
                s.items.push_back(item);
                self.not_empty.notify_one();
                return Push::Queued;
            }
            match self.kind {
                SourceKind::Live => {
                    let old = s.items.pop_front().expect("full queue is non-empty");
                    s.items.push_back(item);
                    self.not_empty.notify_one();
                    return Push::DroppedOldest(old);
                }
                SourceKind::Replay => {
                    s = self.not_full.wait(s).unwrap_or_else(|e| e.into_inner());
                }
            }
        }
    }

    /// Pop the oldest item, waiting; `None` once closed and empty.
    pub fn pop(&self) -> Option<T> {
        let mut s = self.lock();
        loop {
            if let Some(item) = s.items.pop_front() {
                self.not_full.notify_one();
                return Some(item);
            }
            if s.closed {
                return None;
            }
            s = self.not_empty.wait(s).unwrap_or_else(|e| e.into_inner());
        }
    }

    /// Close: pushes are refused, pops drain what is queued, then return `None`.
    pub fn close(&self) {
        let mut s = self.lock();
        s.closed = true;
        self.not_empty.notify_all();
        self.not_full.notify_all();
    }

    /// Items queued now.
    pub fn len(&self) -> usize {
        self.lock().items.len()
    }

    /// True when nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn live_drops_oldest_and_keeps_newest() {
        let q = FrameQueue::new(3, SourceKind::Live);
        let mut dropped = vec![];
        for i in 0..10 {
            if let Push::DroppedOldest(d) = q.push(i) {
                dropped.push(d);
            }
        }
        assert_eq!(dropped, (0..7).collect::<Vec<_>>());
        q.close();
        let rest: Vec<_> = std::iter::from_fn(|| q.pop()).collect();
        assert_eq!(rest, vec![7, 8, 9]);
    }

    #[test]
    fn replay_blocks_and_never_drops() {
        let q = Arc::new(FrameQueue::new(2, SourceKind::Replay));
        let producer = {
            let q = q.clone();
            std::thread::spawn(move || {
                for i in 0..100 {
                    assert_eq!(q.push(i), Push::Queued);
                }
                q.close();
            })
        };
        let got: Vec<_> = std::iter::from_fn(|| q.pop()).collect();
        producer.join().unwrap();
        assert_eq!(got, (0..100).collect::<Vec<_>>());
    }

    #[test]
    fn closed_queue_refuses_and_unblocks_a_waiting_producer() {
        let q = Arc::new(FrameQueue::new(1, SourceKind::Replay));
        assert_eq!(q.push(0), Push::Queued);
        let producer = {
            let q = q.clone();
            std::thread::spawn(move || q.push(1))
        };
        std::thread::sleep(std::time::Duration::from_millis(20));
        q.close();
        assert_eq!(producer.join().unwrap(), Push::Closed(1));
        assert_eq!(q.pop(), Some(0));
        assert_eq!(q.pop(), None);
    }
}
