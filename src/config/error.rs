//! [`ConfigError`]: what a config file can get wrong, each naming its key.

use std::path::PathBuf;

/// Errors from loading or validating a configuration. Each names the offending key.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read config {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// The TOML did not parse or a key is unknown or of the wrong type (the message names the key).
    #[error("config {origin}: {message}")]
    Parse {
        /// File name or `<string>`.
        origin: String,
        /// The parser's message (names the key and line).
        message: String,
    },
    /// A value is outside its allowed range.
    #[error("config key `{key}` = {value} is out of range: allowed {allowed}")]
    OutOfRange {
        /// Dotted key, e.g. `daemon.threads` or `camera[0].width`.
        key: String,
        /// The value found.
        value: String,
        /// The allowed range, in words.
        allowed: String,
    },
    /// A key the chosen source needs is missing.
    #[error("config key `{key}` is required when {when}")]
    Missing {
        /// Dotted key.
        key: String,
        /// The condition that makes it required.
        when: String,
    },
    /// Two cameras share a name.
    #[error("config key `camera[{index}].name` = {name:?} is used twice: camera names must be unique")]
    DuplicateCamera {
        /// Index of the second camera with the name.
        index: usize,
        /// The name.
        name: String,
    },
}
