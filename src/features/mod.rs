//! Feature extraction on mosaics and grey images: gradients, super-pixel scale space, HOG, SIFT
//! (ACF's channel features are the detector's own: `detect::channels`).

pub mod gradient;
pub mod hog;
pub mod sift;
pub mod superpixel;
