//! Pedestrian detection: linear SVM models, multi-scale sliding windows, non-maximum suppression,
//! training.

pub mod types;

pub use types::Detection;
