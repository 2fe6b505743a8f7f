//! Scenes for the sahara BVH toolkit: loaders, procedural scenes and a catalog.
//!
//! * [`Mesh`]: an indexed triangle mesh (positions and index triples), with
//!   [`Mesh::triangles`], [`Mesh::bounds`] and [`Mesh::stats`] (degenerate triangles counted,
//!   zero-area and index-degenerate separately);
//! * loaders: [`load_mesh`] by extension, or [`load_obj`], [`load_obj_gz`], [`load_gltf`]
//!   (`.gltf` and `.glb`), and the in-memory [`parse_obj`], [`parse_gltf`], [`parse_mesh`].
//!   The OBJ reader is `tobj` behind a strict validation pass of this crate; malformed input
//!   is a [`SceneError`] naming the file and the line, vertex or triangle, never a panic;
//! * procedural scenes ([`Procedural`], [`sphere_in_box`], [`soup`], [`teapot_stadium`],
//!   [`hairball`], [`city`], [`clustered`]), deterministic from a seed and an approximate
//!   triangle count, and closed shapes for tests ([`closed_box`], [`tessellated_sphere`],
//!   [`uv_sphere`], [`torus`]);
//! * [`Catalog`]: procedural scenes plus the scene files of the repository's `scenes/`, of
//!   the folders in `SAHARA_SCENES` and of `../shared/scenes`, by name, with expected
//!   triangle counts and checksums from each folder's `manifest.tsv`, and cameras from each
//!   folder's `cameras.tsv` over those of the named scenes (the repository's
//!   `scenes/cameras.tsv`, [`named_cameras`]);
//! * [`Scene`]: a named mesh with its [`SceneSource`] and a default [`Camera`] (the
//!   workspace's one camera, `sahara_geom::Camera`, re-exported here with [`UpAxis`] and
//!   [`CameraSpecError`]).
//!
//! ```
//! use sahara_scene::{Catalog, Procedural, SceneError};
//!
//! // A procedural scene by name, at its default size...
//! let catalog = Catalog::procedural();
//! let scene = catalog.load("sphere_in_box")?;
//! assert!(scene.triangle_count() > 10_000);
//! let stats = scene.mesh.stats();
//! assert_eq!(stats.zero_area + stats.index_degenerate, 0);
//!
//! // ... or at another size and seed, bit-identical on every machine.
//! let a = catalog.load("soup:5000:42")?;
//! let b = Procedural::Soup.scene(5000, 42);
//! assert_eq!(a.triangles(), b.triangles());
//!
//! // Files: malformed input is an error naming the file and the line.
//! let err = sahara_scene::parse_obj(b"v 0 0 0\nv 1 2 abc\n", "bad.obj".as_ref()).unwrap_err();
//! assert_eq!(err.to_string(), "bad.obj: line 2: invalid vertex coordinate `abc`");
//! # Ok::<(), SceneError>(())
//! ```
#![warn(missing_docs)]

mod catalog;
mod error;
mod gltf_load;
mod load;
mod mesh;
mod obj;
mod procedural;
mod scene;
mod shapes;

pub use catalog::{
    default_camera, named_cameras, parse_cameras, parse_manifest, search_dirs, sha256_file,
    workspace_root, Catalog, CatalogEntry, CatalogWarning, EntryKind, ManifestRow, Origin,
    EMBEDDED_CAMERAS, SCENES_ENV,
};
pub use error::SceneError;
pub use gltf_load::{load_gltf, parse_gltf};
pub use load::{load_mesh, parse_mesh, Format};
pub use mesh::{Mesh, MeshStats};
pub use obj::{load_obj, load_obj_gz, parse_obj, read_obj};
pub use procedural::{
    city, clustered, hairball, soup, sphere_in_box, teapot_stadium, Procedural, DEFAULT_SEED,
};
pub use sahara_geom::camera::{Camera, CameraSpecError, UpAxis};
pub use scene::{CameraSource, Scene, SceneSource};
pub use shapes::{closed_box, revolve, tessellated_sphere, torus, uv_sphere};

pub use sahara_geom::{Aabb, Triangle, Vec3A};

/// The README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
