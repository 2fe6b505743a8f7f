//! Loading a mesh from a file of any supported format.

use std::path::Path;

use crate::{gltf_load, obj, Mesh, SceneError};

/// A supported scene file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// Wavefront OBJ text (`.obj`).
    Obj,
    /// Gzip-compressed Wavefront OBJ (`.obj.gz`).
    ObjGz,
    /// glTF 2.0 JSON (`.gltf`), with embedded or external buffers.
    Gltf,
    /// Binary glTF 2.0 (`.glb`).
    Glb,
}

impl Format {
    /// Every format.
    pub const ALL: [Format; 4] = [Format::Obj, Format::ObjGz, Format::Gltf, Format::Glb];

    /// The format of a file, from its extension (case-insensitive), if supported.
    pub fn from_path(path: &Path) -> Option<Format> {
        let name = path.file_name()?.to_str()?.to_ascii_lowercase();
        Format::ALL
            .into_iter()
            .find(|f| name.len() > f.extension().len() && name.ends_with(f.extension()))
    }

    /// The file extension, with its leading dot (`.obj`, `.obj.gz`, `.gltf`, `.glb`).
    pub fn extension(self) -> &'static str {
        match self {
            Format::Obj => ".obj",
            Format::ObjGz => ".obj.gz",
            Format::Gltf => ".gltf",
            Format::Glb => ".glb",
        }
    }

    /// The file name without this format's extension (`a/b/dragon.obj.gz` → `dragon`).
    pub fn stem(self, path: &Path) -> String {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let cut = name.len().saturating_sub(self.extension().len());
        if name.is_char_boundary(cut) && name[cut..].eq_ignore_ascii_case(self.extension()) {
            name[..cut].to_string()
        } else {
            name
        }
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Format::Obj => "obj",
            Format::ObjGz => "obj.gz",
            Format::Gltf => "gltf",
            Format::Glb => "glb",
        })
    }
}

/// Loads the mesh of a `.obj`, `.obj.gz`, `.gltf` or `.glb` file (chosen by extension).
///
/// The result is valid ([`Mesh::validate`]) and has at least one triangle.
pub fn load_mesh(path: impl AsRef<Path>) -> Result<Mesh, SceneError> {
    let path = path.as_ref();
    match Format::from_path(path) {
        Some(Format::Obj) => obj::load_obj(path),
        Some(Format::ObjGz) => obj::load_obj_gz(path),
        Some(Format::Gltf | Format::Glb) => gltf_load::load_gltf(path),
        None => Err(SceneError::UnsupportedFormat {
            file: path.to_path_buf(),
        }),
    }
}

/// Parses an in-memory file of the given format; `file` names it in errors. glTF external
/// buffers cannot be resolved from memory: only embedded ones (GLB, `data:` URIs) work.
pub fn parse_mesh(data: &[u8], format: Format, file: &Path) -> Result<Mesh, SceneError> {
    match format {
        Format::Obj => obj::parse_obj(data, file),
        Format::ObjGz => obj::parse_obj(&obj::gunzip(data, file)?, file),
        Format::Gltf | Format::Glb => gltf_load::parse_gltf(data, file, None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_by_extension() {
        assert_eq!(Format::from_path(Path::new("a/B.OBJ")), Some(Format::Obj));
        assert_eq!(
            Format::from_path(Path::new("d.obj.gz")),
            Some(Format::ObjGz)
        );
        assert_eq!(Format::from_path(Path::new("x.glb")), Some(Format::Glb));
        assert_eq!(Format::from_path(Path::new("x.gltf")), Some(Format::Gltf));
        assert_eq!(Format::from_path(Path::new("x.ply")), None);
        assert_eq!(Format::from_path(Path::new(".obj")), None);
        assert_eq!(Format::ObjGz.stem(Path::new("s/dragon.obj.gz")), "dragon");
        assert!(matches!(
            load_mesh("nope.ply"),
            Err(SceneError::UnsupportedFormat { .. })
        ));
    }
}
