//! # mosaicd
//!
//! Gradient features and pedestrian detections computed **directly on raw Bayer mosaics**, with no
//! ISP in between, following Zhou, Zhang, Gao and Lou, "Gradient-based Feature Extraction From Raw
//! Bayer Pattern Images". Central-difference and Sobel operators applied to a mosaic only ever
//! subtract pixels of one colour (their taps are two pixels apart), and because colour differences
//! vary slowly in natural images the gradient of any one channel approximates the scene gradient.
//!
//! The library holds the algorithms (raw frames, mosaic gradients, super-pixel scale space, HOG,
//! SIFT, detection, the conventional ISP path we compare against, metrics) and the daemon's parts
//! (capture sources, iceoryx2 publishing, MCAP recording, the pipeline). The `mosaicd` binary is a
//! thin CLI over it.
#![warn(missing_docs)]
// Each folder is a facade (detect/ not yet): its files are `pub(crate)` and its `mod.rs` re-exports
// what other crates use. `unreachable_pub` keeps `pub` for what is reachable from outside the crate
// (everything else is `pub(crate)`); `unnameable_types` keeps every type in a public signature
// nameable.
#![warn(unnameable_types)]
#![warn(unreachable_pub)]

pub(crate) mod bounded_read;
pub mod capture;
pub mod clock;
pub mod config;
pub mod data;
pub mod detect;
pub mod eval;
pub mod features;
pub mod geometry;
pub mod image;
pub mod image_io;
pub mod isp;
pub mod kernels;
pub mod metrics;
pub mod npy;
pub mod pipeline;
pub mod pool;
pub mod progress;
pub mod publish;
pub(crate) mod quiet_panic;
pub mod raw;
pub mod record;
pub mod resize;
pub(crate) mod srgb;
pub mod wire;
