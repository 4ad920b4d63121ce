//! A buffer pool: steady-state frames reuse buffers instead of allocating.
//!
//! [`BufferPool::take`] hands out a recycled buffer or allocates one (counted);
//! [`BufferPool::give`] returns it. After warm-up (at most `max_in_flight + queue_depth` buffers
//! live at once) the allocation count stops growing — a test checks it.
//!
//! ```
//! use mosaicd::pool::BufferPool;
//! let pool: BufferPool<Vec<u8>> = BufferPool::new(4);
//! let a = pool.take(|| vec![0u8; 16]);
//! pool.give(a);
//! let _b = pool.take(|| vec![0u8; 16]);
//! assert_eq!(pool.allocations(), 1);
//! ```

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// A shared pool of reusable buffers (cheap to clone: a handle).
pub struct BufferPool<T> {
    inner: Arc<Inner<T>>,
}

struct Inner<T> {
    free: Mutex<Vec<T>>,
    max_free: usize,
    allocations: AtomicU64,
}

impl<T> Clone for BufferPool<T> {
    fn clone(&self) -> Self {
        Self {
            inner: self.inner.clone(),
        }
    }
}

impl<T> std::fmt::Debug for BufferPool<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "BufferPool(allocations: {})", self.allocations())
    }
}

impl<T> BufferPool<T> {
    /// A pool keeping at most `max_free` idle buffers (extra returns are freed).
    pub fn new(max_free: usize) -> Self {
        Self {
            inner: Arc::new(Inner {
                free: Mutex::new(Vec::with_capacity(max_free)),
                max_free,
                allocations: AtomicU64::new(0),
            }),
        }
    }

    /// A recycled buffer, or a new one from `alloc` (counted).
    pub fn take(&self, alloc: impl FnOnce() -> T) -> T {
        let recycled = self.inner.free.lock().unwrap_or_else(|e| e.into_inner()).pop();
        recycled.unwrap_or_else(|| {
            self.inner.allocations.fetch_add(1, Ordering::Relaxed);
            alloc()
        })
    }

    /// Return a buffer for reuse.
    pub fn give(&self, buf: T) {
        let mut free = self.inner.free.lock().unwrap_or_else(|e| e.into_inner());
        if free.len() < self.inner.max_free {
            free.push(buf);
        }
    }

    /// Buffers allocated so far.
    pub fn allocations(&self) -> u64 {
        self.inner.allocations.load(Ordering::Relaxed)
    }
}
