//! Shared input options for the one-frame subcommands (`gradients`, `detect`, `sift`) (in progress).
