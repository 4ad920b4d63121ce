//! Pedestrian detection: linear SVM models, multi-scale sliding windows, non-maximum suppression,
//! training.

pub mod detector;
mod kernels;
pub mod model;
pub mod nms;
pub mod pyramid;
pub mod score;
pub mod svm;
pub mod train;
pub mod types;

pub use detector::{DetectError, DetectStats, Detector, DetectorOptions, NmsMethod, StageProfile};
pub use model::{Domain, LinearModel};
pub use score::ScorePrecision;
pub use types::Detection;
