//! The paper's experiments as library functions the CLI calls, and the shared plotting helper.
//!
//! [`plot`] draws the PNG figures (DET / PR curves, distributions, box plots) for every experiment.

pub mod plot;
