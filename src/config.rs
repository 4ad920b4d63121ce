//! Typed daemon configuration, validated once at start-up.
