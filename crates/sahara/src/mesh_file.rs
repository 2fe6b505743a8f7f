//! A short route from a mesh file to a built structure: `.obj`, `.obj.gz`, `.gltf` and
//! `.glb` through the loaders of [`sahara_scene`].

use std::path::Path;

use crate::{Accel, BuildOptions, Error, GeometryId, SceneBuilder};

/// Reads the mesh of a file with [`sahara_scene::load_mesh`] (format by extension).
fn read(path: &Path) -> Result<sahara_scene::Mesh, Error> {
    Ok(sahara_scene::load_mesh(path)?)
}

impl Accel {
    /// Loads the triangle mesh of a `.obj`, `.obj.gz`, `.gltf` or `.glb` file (the format
    /// chosen by the extension; a glTF file's meshes are flattened into world space) and
    /// builds over it, as [`Accel::build_indexed`] over its positions and index triples: hits
    /// report the triangle's position in the file's order (polygons fanned into triangles).
    ///
    /// Not to be confused with [`Accel::load_from_path`], which reads a structure written by
    /// [`Accel::save`].
    ///
    /// Fails with [`Error::File`] when the file is missing or unreadable
    /// ([`sahara_scene::SceneError::Io`]), malformed (`Parse`, naming the line or element),
    /// has a non-finite vertex (`NonFinite`), a bad index (`IndexOutOfRange`), no triangle
    /// (`Empty`) or an unknown extension (`UnsupportedFormat`); never panics on its bytes.
    ///
    /// ```
    /// use sahara::{Accel, Error, Quality, Ray, Vec3A};
    /// let path = std::env::temp_dir().join(format!("sahara-doc-{}.obj", std::process::id()));
    /// std::fs::write(&path, "v 0 0 2\nv 1 0 2\nv 0 1 2\nf 1 2 3\n")?;
    /// let accel = Accel::build_from_file(&path, Quality::Medium)?;
    /// std::fs::remove_file(&path)?;
    /// let hit = accel.closest_hit(&Ray::new(Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z, 0.0, 9.0));
    /// assert_eq!(hit.map(|h| (h.prim, h.t)), Some((0, 2.0)));
    /// assert!(matches!(Accel::build_from_file(&path, Quality::Fast), Err(Error::File(_))));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn build_from_file(
        path: impl AsRef<Path>,
        options: impl Into<BuildOptions>,
    ) -> Result<Accel, Error> {
        let mesh = read(path.as_ref())?;
        Accel::build_indexed(&mesh.positions, &mesh.indices, options)
    }
}

impl SceneBuilder {
    /// Adds the triangle mesh of a `.obj`, `.obj.gz`, `.gltf` or `.glb` file as one geometry
    /// (as [`SceneBuilder::add_indexed`] over its positions and index triples; a glTF file's
    /// meshes are flattened into world space, one geometry for the whole file). Nothing is
    /// added on an error: [`Error::File`] as for [`Accel::build_from_file`].
    ///
    /// ```
    /// use sahara::{Error, Quality, Ray, SceneBuilder, Vec3A, ALL_MASK};
    /// let path = std::env::temp_dir().join(format!("sahara-doc-scene-{}.obj", std::process::id()));
    /// std::fs::write(&path, "v 0 0 2\nv 1 0 2\nv 0 1 2\nf 1 2 3\n")?;
    /// let mut b = SceneBuilder::new();
    /// let mesh = b.add_file(&path)?;
    /// std::fs::remove_file(&path)?;
    /// assert!(matches!(b.add_file(&path), Err(Error::File(_)))); // gone now
    /// let scene = b.build(Quality::Fast)?;
    /// let hit = scene.closest_hit(&Ray::new(Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z, 0.0, 9.0), ALL_MASK);
    /// assert_eq!(hit.map(|h| h.geometry), Some(mesh));
    /// assert_eq!(scene.geometries().len(), 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn add_file(&mut self, path: impl AsRef<Path>) -> Result<GeometryId, Error> {
        let mesh = read(path.as_ref())?;
        self.add_indexed(&mesh.positions, &mesh.indices)
    }
}
