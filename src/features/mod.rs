//! Feature extraction on mosaics and grey images: gradients, super-pixel scale space, HOG, SIFT,
//! aggregated channel features (ACF).

pub mod channels;
pub mod gradient;
pub mod hog;
pub mod sift;
pub mod superpixel;
