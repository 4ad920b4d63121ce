//! Pedestrian detection: linear SVM models, multi-scale sliding windows, non-maximum suppression,
//! training.
//!
//! The files are private behind this facade: what other crates use is re-exported here.

pub(crate) mod acf;
pub(crate) mod boost;
pub(crate) mod channels;
pub(crate) mod detector;
pub(crate) mod input;
mod kernels;
pub(crate) mod model;
pub(crate) mod nms;
pub(crate) mod people;
pub(crate) mod score;
pub(crate) mod shipped;
pub(crate) mod svm;
pub(crate) mod train;

pub use crate::geometry::Detection;
pub use acf::{AcfDetector, AcfError, AcfModel, AcfOptions, AcfStats, FeatureSet, CASC_THR};
pub use boost::{train_adaboost, BoostError, BoostOptions, BoostedTrees, TraceOptions, Tree, TreeOptions};
pub use channels::{
    channels, pyramid, ChannelInput, ChannelOptions, ChannelPyramid, ChannelSpec, Channels, ChannelsError,
    Level as ChannelLevel, PyramidOptions, N_CHANNELS,
};
pub use detector::{
    DetectError, DetectStats, Detector, DetectorOptions, DetectorSpec, Level as HogLevel, NmsMethod,
    StageProfile,
};
pub use input::MosaicPrep;
pub use model::{Domain, LinearModel, ModelError};
pub use nms::{greedy_nms, iou};
pub use people::{DetectorKind, PeopleDetector, PeopleError, PeopleInput, PeopleModel, PeopleStats};
pub use score::{window_scores, window_scores_i8, ScoreError, ScorePrecision, ScoreWeights, ScoreWeightsI8};
pub use shipped::{load_named, NamedModelError, ShippedModel, DEFAULT_APPROX_LEVELS, DEFAULT_MODEL, SHIPPED};
pub use svm::{train_linear_svm, SvmOptions};
pub use train::acf::{
    calibrate_cascade, evaluate_acf_windows, positive_windows, set_trace, train_acf, AcfTrainOptions,
};
pub use train::{
    evaluate_windows_via, inner_split, inner_val_fraction, list_negative_dirs, photo_prefix, select_c,
    split_data, train_on, CCandidate, InputPipeline, Split, TrainError, TrainOptions, WindowEval,
    WindowScores,
};

/// The name of OpenCV's default people detector in configs and on the command line.
pub const OPENCV_DEFAULT: &str = "opencv-default";

/// Path of the `opencv-default` model inside the shared data directory.
pub const OPENCV_DEFAULT_MODEL: &str = "opencv_hog/default_people_detector_64x128.npy";
