//! Pedestrian detection: linear SVM models, multi-scale sliding windows, non-maximum suppression,
//! training.

pub mod detector;
pub mod input;
mod kernels;
pub mod model;
pub mod nms;
pub mod pyramid;
pub mod score;
pub mod svm;
pub mod train;

pub use crate::geometry::Detection;
pub use detector::{DetectError, DetectStats, Detector, DetectorOptions, NmsMethod, StageProfile};
pub use model::{Domain, LinearModel};
pub use score::ScorePrecision;

/// The name of OpenCV's default people detector in configs and on the command line.
pub const OPENCV_DEFAULT: &str = "opencv-default";

/// Path of the `opencv-default` model inside the shared data directory.
pub const OPENCV_DEFAULT_MODEL: &str = "opencv_hog/default_people_detector_64x128.npy";

/// The file of the model named `name`: [`OPENCV_DEFAULT`] is OpenCV's weights in the shared data
/// (an error when that data is missing), anything else is a path.
pub fn model_path(name: &str) -> Result<std::path::PathBuf, crate::data::DataMissing> {
    if name == OPENCV_DEFAULT {
        crate::data::data_path(OPENCV_DEFAULT_MODEL)
    } else {
        Ok(std::path::PathBuf::from(name))
    }
}
