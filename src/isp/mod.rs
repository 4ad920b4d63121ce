//! The conventional ISP path we compare against: demosaicing, grey conversion, reverse ISP, noise.

pub mod grey;
