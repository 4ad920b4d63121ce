//! The daemon pipeline: scheduling, ordering, drop policy, stats, shutdown.
