//! The buffers the detector reuses across levels and frames: a bounded [`Pool`] of level buffers, of lane buffers and of magnified frames.

use std::sync::Mutex;

use super::super::score::ScorerBuffers;
use crate::features::hog::{BlockGrid, MicroGrid, SweepBuffers};
use crate::image::Image;

/// Free buffer sets. A level takes one (or makes one when none is free) and returns it; at most
/// `capacity` are kept, so the memory held is bounded by that many largest-level buffer sets and
/// does not grow from frame to frame. A cloned detector starts with an empty pool.
#[derive(Debug)]
pub(super) struct Pool<T> {
    pub(super) free: Mutex<Vec<T>>,
}

/// The pool of whole level buffers (planes, micro-cells, blocks, scores).
pub(super) type ScratchPool = Pool<LevelScratch>;

impl<T> Default for Pool<T> {
    fn default() -> Self {
        Self {
            free: Mutex::new(Vec::new()),
        }
    }
}

impl<T> Clone for Pool<T> {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl<T: Default> Pool<T> {
    pub(super) fn take(&self) -> T {
        self.free
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .pop()
            .unwrap_or_default()
    }
    pub(super) fn put_bounded(&self, s: T, capacity: usize) {
        let mut free = self.free.lock().unwrap_or_else(|e| e.into_inner());
        if free.len() < capacity {
            free.push(s);
        }
    }
}

impl ScratchPool {
    /// Scratches kept: one per worker thread plus one for a level a blocked worker steals.
    pub(super) fn capacity() -> usize {
        rayon::current_num_threads() + 1
    }
    pub(super) fn put(&self, s: LevelScratch) {
        self.put_bounded(s, Self::capacity())
    }
}

/// The buffers of one lane of approximated levels: the sweep's, one scorer's per level, the scores.
#[derive(Debug, Default)]
pub(super) struct LaneScratch {
    pub(super) sweep: SweepBuffers,
    pub(super) scorers: Vec<ScorerBuffers>,
    pub(super) scores: Vec<f32>,
}

impl Pool<LaneScratch> {
    /// Lanes held: one per worker for each of two frames (or groups) in flight.
    pub(super) fn capacity() -> usize {
        2 * rayon::current_num_threads()
    }
    pub(super) fn put(&self, s: LaneScratch) {
        self.put_bounded(s, Self::capacity())
    }
}

/// The buffers of one pyramid level, reused for the next level and frame (allocating them afresh
/// cost ≈ 40 MB of page faults and zeroing per 1080p level).
#[derive(Debug, Default)]
pub(super) struct LevelScratch {
    /// Resized, gamma-corrected planes (one, or B, G, R).
    pub(super) planes: [Image<f32>; 3],
    /// Micro-cells of the group's exact level (approximate pyramid).
    pub(super) micro: MicroGrid,
    /// Normalised blocks.
    pub(super) blocks: BlockGrid,
    /// Window scores.
    pub(super) scores: Vec<f32>,
}

/// The buffers of one approximated level in [`Detector::stage_profile`]: its blocks (from the
/// group's micro-cells) and scores.
#[derive(Debug, Default)]
pub(super) struct ApproxScratch {
    pub(super) blocks: BlockGrid,
    pub(super) scores: Vec<f32>,
}
