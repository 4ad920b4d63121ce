//! RGB → grey conversion (in progress).
