//! The error type of every fallible operation of the crate.

use std::path::{Path, PathBuf};

/// Why a scene could not be loaded, generated or verified.
///
/// Every variant names the file (or the catalog name) it is about, and the element of the
/// file that is wrong (a line, a vertex, a triangle), so that its [`Display`](std::fmt::Display)
/// output alone tells a user what to fix. Loading never panics on malformed input: every
/// problem ends up as one of these variants.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The file could not be read.
    #[error("{}: cannot read file: {source}", file.display())]
    Io {
        /// The file.
        file: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },

    /// The file is not a well-formed file of its format (OBJ syntax error, invalid gzip
    /// stream, invalid or truncated glTF/GLB, unsupported glTF feature, ...).
    ///
    /// `message` names the element: for OBJ it starts with `line N:`, for glTF it names the
    /// mesh, primitive, accessor or node.
    #[error("{}: {message}", file.display())]
    Parse {
        /// The file.
        file: PathBuf,
        /// What is wrong, and where in the file.
        message: String,
    },

    /// A vertex has a NaN or infinite coordinate (after node transforms, for glTF).
    #[error(
        "{}: vertex {vertex_index} has a non-finite coordinate {value:?}",
        file.display()
    )]
    NonFinite {
        /// The file.
        file: PathBuf,
        /// 0-based index of the vertex in the loaded mesh (for OBJ: the order of the `v`
        /// records; for glTF: the order of the flattened mesh).
        vertex_index: usize,
        /// The offending coordinates.
        value: [f32; 3],
    },

    /// A triangle references a vertex that does not exist.
    #[error(
        "{}: triangle {triangle} references vertex index {index}, out of range for {vertex_count} vertices",
        file.display()
    )]
    IndexOutOfRange {
        /// The file.
        file: PathBuf,
        /// 0-based index of the triangle in the loaded mesh (after fan-splitting polygons).
        triangle: usize,
        /// The index as written in the file (OBJ: 1-based, or negative for relative
        /// references; glTF: 0-based within its primitive).
        index: i64,
        /// How many vertices the index could refer to (OBJ: the vertices of the file, or the
        /// vertices defined before the face for a negative index; glTF: the vertices of the
        /// primitive).
        vertex_count: usize,
    },

    /// The file has no triangle at all.
    #[error("{}: the file contains no triangle", file.display())]
    Empty {
        /// The file.
        file: PathBuf,
    },

    /// The file's extension is not one of `.obj`, `.obj.gz`, `.gltf`, `.glb`.
    #[error(
        "{}: unsupported scene format (expected .obj, .obj.gz, .gltf or .glb)",
        file.display()
    )]
    UnsupportedFormat {
        /// The file.
        file: PathBuf,
    },

    /// A name is neither a catalog entry, a procedural scene nor an existing file.
    #[error("unknown scene `{name}` (known scenes: {known})")]
    UnknownScene {
        /// The name that was asked for.
        name: String,
        /// The names the catalog knows, comma-separated.
        known: String,
    },

    /// A procedural scene specification (`name:size[:seed]`) could not be understood.
    #[error("invalid procedural scene specification `{spec}`: {message}")]
    InvalidSpec {
        /// The specification.
        spec: String,
        /// What is wrong with it.
        message: String,
    },

    /// The SHA-256 of a file differs from the one in its folder's `manifest.tsv`.
    #[error(
        "{}: SHA-256 mismatch: manifest says {expected}, file has {actual}",
        file.display()
    )]
    ChecksumMismatch {
        /// The file.
        file: PathBuf,
        /// The digest in the manifest (lowercase hexadecimal).
        expected: String,
        /// The digest of the file (lowercase hexadecimal).
        actual: String,
    },

    /// A file loaded with a different number of triangles than its manifest says.
    #[error(
        "{}: loaded {actual} triangles, but the manifest says {expected}",
        file.display()
    )]
    TriangleCountMismatch {
        /// The file.
        file: PathBuf,
        /// The count in the manifest.
        expected: usize,
        /// The count loaded.
        actual: usize,
    },
}

impl SceneError {
    /// A [`SceneError::Parse`] for `file` with `message`.
    pub fn parse(file: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        SceneError::Parse {
            file: file.into(),
            message: message.into(),
        }
    }
}

/// The bytes of the file at `path`; [`SceneError::Io`] naming it when it cannot be read.
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>, SceneError> {
    std::fs::read(path).map_err(|source| SceneError::Io {
        file: path.to_path_buf(),
        source,
    })
}
