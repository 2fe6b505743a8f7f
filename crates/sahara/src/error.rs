//! The façade's typed errors.

pub use sahara_builders::BuildError;
pub use sahara_bvh::ValidationError;

/// Why a build failed.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The builder rejected the input: a non-finite vertex, an invalid cost model, too many
    /// triangles, ...
    #[error(transparent)]
    Build(#[from] BuildError),
    /// A triangle of an indexed mesh names a vertex that does not exist.
    #[error("triangle {triangle} uses vertex {index}, but there are only {vertices} vertices")]
    IndexOutOfRange {
        /// The triangle.
        triangle: usize,
        /// The vertex index it uses.
        index: u32,
        /// The number of vertices.
        vertices: usize,
    },
    /// The builder of a quality level is not in the registry (a build of `sahara-builders`
    /// without it; cannot happen with the version this crate was released with).
    #[error("the builder {0:?} of this quality level is not registered")]
    MissingBuilder(&'static str),
    /// The builder produced a tree that does not fit the triangles (a builder bug: the tree
    /// is checked before it is used, never traced unchecked).
    #[error("the built tree is invalid: {0}")]
    InvalidTree(#[from] ValidationError),
    /// [`Instances::build`](crate::Instances::build) refused a placement (a missing mesh, a
    /// non-finite or singular transform), or an update of
    /// [`Instances::set_transform`](crate::Instances::set_transform) or
    /// [`Instances::set_mask`](crate::Instances::set_mask) did (the same, or an instance index
    /// out of range); the instance set is left unchanged.
    #[error(transparent)]
    Instance(#[from] sahara_traverse::instance::InstanceError),
    /// [`Accel::refit`](crate::Accel::refit) was given a triangle with a NaN or infinite
    /// coordinate (the structure is left unchanged).
    #[error(transparent)]
    Refit(#[from] sahara_bvh::RefitError),
    /// [`Accel::refit`](crate::Accel::refit) was given another number of triangles than the
    /// structure holds.
    #[error("refit needs {expected} triangles (one per triangle of the structure), got {given}")]
    RefitCount {
        /// Triangles in the structure.
        expected: usize,
        /// Triangles given.
        given: usize,
    },
    /// A [`Scene`](crate::Scene) refused its geometries (a non-finite triangle, an invalid
    /// box: the message names the geometry and primitive) or a geometry id of another scene.
    #[error(transparent)]
    Scene(#[from] crate::SceneError),
    /// A mesh file given to [`Accel::build_from_file`](crate::Accel::build_from_file) or
    /// [`SceneBuilder::add_file`](crate::SceneBuilder::add_file) could not be loaded: missing
    /// or unreadable (`Io`), malformed (`Parse`, naming the line or element), a non-finite
    /// vertex, a bad index, no triangle, or an unsupported extension; the message names the
    /// file.
    #[error(transparent)]
    File(#[from] sahara_scene::SceneError),
    /// The thread pool for [`BuildOptions::threads`](crate::BuildOptions::threads) could not
    /// be created.
    #[error("cannot create the build's thread pool: {0}")]
    ThreadPool(String),
}

/// Why a saved structure could not be loaded ([`Accel::load`](crate::Accel::load),
/// [`Instances::load`](crate::Instances::load), [`Scene::load`](crate::Scene::load)).
///
/// Loading never panics and never allocates more than the bytes the reader delivers: a
/// truncated, padded, corrupted or foreign file is one of these.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// Reading failed.
    #[error("reading the acceleration structure failed: {0}")]
    Io(#[from] std::io::Error),
    /// The data does not start with the file's magic bytes.
    #[error("not a sahara acceleration structure (bad magic)")]
    BadMagic,
    /// The file was written by another version of the format.
    #[error("unsupported acceleration structure version {0} (this build reads version {version}, instance sets 1 to {instances}, scenes {scenes})", version = crate::file::VERSION, instances = crate::file::INSTANCES_VERSION, scenes = crate::file::SCENE_VERSION)]
    UnsupportedVersion(u32),
    /// The file ends before the data its header announces.
    #[error("truncated acceleration structure: {expected} bytes announced, {actual} present")]
    Truncated {
        /// Bytes the header announces (header included).
        expected: u64,
        /// Bytes present.
        actual: u64,
    },
    /// There are bytes after the announced data.
    #[error("acceleration structure has {0} unexpected trailing bytes")]
    TrailingData(u64),
    /// The payload does not match its checksum.
    #[error("acceleration structure checksum mismatch (the file is corrupted)")]
    Checksum,
    /// The quality code is unknown.
    #[error("unknown quality code {0}")]
    UnknownQuality(u32),
    /// The stored cost model is not finite and positive.
    #[error("the stored cost model is invalid")]
    InvalidCostModel,
    /// A stored triangle has a NaN or infinite coordinate.
    #[error("stored triangle {0} has a non-finite coordinate")]
    NonFinite(usize),
    /// The embedded tree file is invalid (its own header, checksum or structure).
    #[error("the stored tree: {0}")]
    Tree(#[from] sahara_bvh::LoadError),
    /// A saved instance set's placements are inconsistent: their byte count, a missing mesh
    /// or a non-finite or singular transform (the message says which).
    #[error("the stored instance set is invalid: {0}")]
    InvalidInstances(String),
    /// A saved scene's geometries are inconsistent (their triangle counts do not add up to
    /// the file's, or exceed what a scene can hold; the message says which).
    #[error("the stored scene is invalid: {0}")]
    InvalidScene(String),
    /// The stored tree does not fit the stored triangles.
    #[error("the stored tree does not fit the stored triangles: {0}")]
    InvalidTree(ValidationError),
}
