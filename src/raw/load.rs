//! (in progress — owned by the raw-loaders work)
