//! The paper's experiments as library functions the CLI calls.
pub mod sift;
