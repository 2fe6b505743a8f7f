//! The error type of the crate.

use std::path::PathBuf;

/// What can go wrong reading or writing ray files, hit files and images.
///
/// Every variant names the file involved, so that a tool can report it as is.
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    /// The file could not be opened, read, created or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file's length is not a multiple of its record size (a truncated or foreign file).
    #[error("{path}: length {len} bytes is not a multiple of the {record}-byte {what} record")]
    BadLength {
        /// The file.
        path: PathBuf,
        /// Its length in bytes.
        len: u64,
        /// The record size in bytes (32 for rays, 16 for hits).
        record: usize,
        /// `"ray"` or `"hit"`.
        what: &'static str,
    },
    /// The PNG encoder failed (for example for an image of width or height 0).
    #[error("{path}: cannot write PNG: {source}")]
    Image {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: image::ImageError,
    },
}
