//! Pedestrian detection: linear SVM models, multi-scale sliding windows, non-maximum suppression,
//! training.

pub mod acf;
pub mod boost;
pub mod channels;
pub mod detector;
pub mod input;
mod kernels;
pub mod model;
pub mod nms;
pub mod people;
pub mod score;
pub mod shipped;
pub mod svm;
pub mod train;

pub use crate::geometry::Detection;
pub use detector::{DetectError, DetectStats, Detector, DetectorOptions, NmsMethod, StageProfile};
pub use model::{Domain, LinearModel};
pub use score::ScorePrecision;
pub use shipped::{load_named, NamedModelError, DEFAULT_APPROX_LEVELS, DEFAULT_MODEL};

/// The name of OpenCV's default people detector in configs and on the command line.
pub const OPENCV_DEFAULT: &str = "opencv-default";

/// Path of the `opencv-default` model inside the shared data directory.
pub const OPENCV_DEFAULT_MODEL: &str = "opencv_hog/default_people_detector_64x128.npy";
