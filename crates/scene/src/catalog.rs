//! The scene catalog: procedural scenes plus the scene files found in known folders.

use std::collections::HashSet;
use std::io::Read;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use crate::{
    load_mesh, Camera, Format, Procedural, Scene, SceneError, SceneSource, UpAxis, DEFAULT_SEED,
};
use sahara_geom::{Aabb, Vec3A};

/// The environment variable naming extra scene folders (a path list, `:`-separated on Unix).
pub const SCENES_ENV: &str = "SAHARA_SCENES";

/// The cameras of the named scenes as this crate was built with them, for a program run
/// outside the repository ([`named_cameras`]). The canonical table is the crate's own
/// `cameras.tsv` (inside the package, so the crate builds from its published archive); the
/// repository's `scenes/cameras.tsv` is a byte-identical copy (pinned by
/// `tests/cameras.rs`) that the catalog reads over it at run time.
pub const EMBEDDED_CAMERAS: &str = include_str!("../cameras.tsv");

/// A problem met while reading a scene folder's `manifest.tsv` or `cameras.tsv`. The catalog
/// still uses the folder, without the offending part ([`Catalog::warnings`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum CatalogWarning {
    /// The file could not be read; it is ignored.
    #[error("{}: cannot read: {message}", file.display())]
    Unreadable {
        /// The index file.
        file: PathBuf,
        /// The I/O error.
        message: String,
    },
    /// The header lacks a required column; the file is ignored.
    #[error("{}: header must name the columns {}", file.display(), required.join(", "))]
    MissingColumns {
        /// The index file.
        file: PathBuf,
        /// Every required column.
        required: &'static [&'static str],
    },
    /// A row with a missing or invalid field. A camera row is skipped; a manifest row is
    /// skipped if its `name` or `file` is missing, and read without its triangle count if
    /// only that is invalid.
    #[error("{}: line {line}: invalid or missing `{column}`: `{value}`", file.display())]
    MalformedRow {
        /// The index file.
        file: PathBuf,
        /// 1-based line number in the file.
        line: usize,
        /// The column whose field is wrong.
        column: &'static str,
        /// The field as written (empty if missing).
        value: String,
    },
    /// A camera row for a name listed earlier in the same `cameras.tsv`: skipped, the first
    /// row is used.
    #[error("{}: line {line}: `{name}` has a camera already; this row is ignored", file.display())]
    DuplicateCamera {
        /// The `cameras.tsv`.
        file: PathBuf,
        /// 1-based line number of the ignored row.
        line: usize,
        /// The scene name.
        name: String,
    },
    /// A manifest row names a file of an unsupported format; skipped.
    #[error("{}: `{listed}`: unsupported format", manifest.display())]
    UnsupportedFormat {
        /// The `manifest.tsv`.
        manifest: PathBuf,
        /// The file as listed.
        listed: String,
    },
    /// A manifest row names a file that does not exist; skipped.
    #[error("{}: `{listed}` is listed but missing", manifest.display())]
    MissingFile {
        /// The `manifest.tsv`.
        manifest: PathBuf,
        /// The file as listed.
        listed: String,
    },
    /// A scene of a later folder has the name of an earlier entry; the earlier one is kept.
    #[error("{}: `{name}` is shadowed by an earlier scene of the same name", dir.display())]
    Shadowed {
        /// The folder of the shadowed scene.
        dir: PathBuf,
        /// The name.
        name: String,
    },
}

/// Where a catalog entry was found.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Origin {
    /// Built in ([`Procedural`]).
    Procedural,
    /// The repository's `scenes/` folder.
    Repository,
    /// A folder named by [`SCENES_ENV`].
    Env,
    /// `../shared/scenes` next to the workspace.
    Shared,
    /// A folder given to [`Catalog::add_dir`].
    Dir,
}

impl std::fmt::Display for Origin {
    /// `procedural`, `scenes`, `SAHARA_SCENES`, `shared` or `dir`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Origin::Procedural => "procedural",
            Origin::Repository => "scenes",
            Origin::Env => SCENES_ENV,
            Origin::Shared => "shared",
            Origin::Dir => "dir",
        })
    }
}

/// What a catalog entry loads.
#[derive(Clone, Debug, PartialEq)]
pub enum EntryKind {
    /// A procedural scene at its default size and seed.
    Procedural(Procedural),
    /// A file.
    File {
        /// The file.
        path: PathBuf,
        /// Its format.
        format: Format,
    },
}

/// One scene of the [`Catalog`].
#[derive(Clone, Debug, PartialEq)]
pub struct CatalogEntry {
    /// The unique name.
    pub name: String,
    /// What it loads.
    pub kind: EntryKind,
    /// Where it was found.
    pub origin: Origin,
    /// The number of triangles: exact for procedural scenes (at the default size), from
    /// `manifest.tsv` for files listed there, `None` for other files (unknown until loaded).
    pub triangles: Option<usize>,
    /// The expected SHA-256 (lowercase hex) from `manifest.tsv`, if listed.
    pub sha256: Option<String>,
    /// The licence from `manifest.tsv`, if listed.
    pub license: Option<String>,
    /// The camera: for a file, the row of its own folder's `cameras.tsv`, else the row of
    /// the named scenes' table ([`named_cameras`]) for its name, else `None` (the scene is
    /// then framed when loaded, [`default_camera`]); for a procedural scene, its
    /// generator's camera.
    pub camera: Option<Camera>,
}

impl CatalogEntry {
    /// The file, for file entries.
    pub fn path(&self) -> Option<&Path> {
        match &self.kind {
            EntryKind::File { path, .. } => Some(path),
            EntryKind::Procedural(_) => None,
        }
    }

    /// `procedural` for procedural scenes, else the path of the file: the `source` column of
    /// `cargo xtask scenes`.
    pub fn source_label(&self) -> String {
        match &self.kind {
            EntryKind::Procedural(_) => "procedural".to_string(),
            EntryKind::File { path, .. } => path.display().to_string(),
        }
    }
}

/// The catalog of scenes: names → procedural generators or files.
///
/// [`Catalog::discover`] lists, in this order (the first entry of a name wins):
///
/// 1. the [`Procedural`] scenes, by their plain names (`sphere_in_box`, `soup`, ...);
/// 2. the repository's `scenes/` folder (the workspace root is found by walking up from the
///    current directory to a `Cargo.toml` with a `[workspace]` table, falling back to this
///    crate's own workspace);
/// 3. the folders in the `SAHARA_SCENES` environment variable;
/// 4. `<workspace root>/../shared/scenes`, where it exists.
///
/// In each folder, the rows of `manifest.tsv` (tab-separated, with a header naming at least
/// the columns `name` and `file`, and optionally `triangles`, `sha256`, `license`) give
/// names, expected triangle counts and checksums; other `.obj`, `.obj.gz`, `.gltf` and `.glb`
/// files are listed by file stem (or by file name with `.` replaced by `_`, if the stem is
/// taken). An optional `cameras.tsv` ([`parse_cameras`]) sets the cameras of the folder's
/// scenes. A file scene without a row there gets the camera of its name from the named
/// scenes' table, the repository's `scenes/cameras.tsv` ([`named_cameras`]), whatever folder
/// it is in. Folders that do not exist are skipped; problems with the index files are kept
/// in [`Catalog::warnings`].
#[derive(Clone, Debug, Default)]
pub struct Catalog {
    entries: Vec<CatalogEntry>,
    dirs: Vec<(PathBuf, Origin)>,
    warnings: Vec<CatalogWarning>,
    /// The named scenes' cameras, read by the first [`Catalog::add_dir`].
    named: Option<NamedCameras>,
}

impl Catalog {
    /// The procedural scenes and the scenes of every known folder.
    pub fn discover() -> Catalog {
        let mut c = Catalog::procedural();
        for (dir, origin) in search_dirs() {
            c.add_dir(&dir, origin);
        }
        c
    }

    /// Only the procedural scenes.
    pub fn procedural() -> Catalog {
        let mut c = Catalog::default();
        for p in Procedural::ALL {
            let (mesh, camera) = p.generate(p.default_size(), DEFAULT_SEED);
            c.entries.push(CatalogEntry {
                name: p.name().to_string(),
                kind: EntryKind::Procedural(p),
                origin: Origin::Procedural,
                triangles: Some(mesh.triangle_count()),
                sha256: None,
                license: None,
                camera: Some(camera),
            });
        }
        c
    }

    /// Adds the scenes of `dir` (skipping names already in the catalog). A folder that does
    /// not exist, or was added before, adds nothing.
    pub fn add_dir(&mut self, dir: &Path, origin: Origin) {
        if !dir.is_dir() {
            return;
        }
        if self.named.is_none() {
            let (named, warnings) = NamedCameras::read();
            self.warnings.extend(warnings);
            self.named = Some(named);
        }
        let canon = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
        if self.dirs.iter().any(|(d, _)| *d == canon) {
            return;
        }
        self.dirs.push((canon.clone(), origin.clone()));
        let mut found: Vec<CatalogEntry> = Vec::new();
        let mut listed_files: HashSet<String> = HashSet::new();

        let manifest = canon.join("manifest.tsv");
        if manifest.is_file() {
            match std::fs::read_to_string(&manifest) {
                Ok(text) => {
                    let (rows, warnings) = parse_manifest(&text, &manifest);
                    self.warnings.extend(warnings);
                    for row in rows {
                        let path = canon.join(&row.file);
                        listed_files.insert(row.file.clone());
                        let Some(format) = Format::from_path(&path) else {
                            self.warnings.push(CatalogWarning::UnsupportedFormat {
                                manifest: manifest.clone(),
                                listed: row.file,
                            });
                            continue;
                        };
                        if !path.is_file() {
                            self.warnings.push(CatalogWarning::MissingFile {
                                manifest: manifest.clone(),
                                listed: row.file,
                            });
                            continue;
                        }
                        found.push(CatalogEntry {
                            name: row.name,
                            kind: EntryKind::File { path, format },
                            origin: origin.clone(),
                            triangles: row.triangles,
                            sha256: row.sha256,
                            license: row.license,
                            camera: None,
                        });
                    }
                }
                Err(e) => self.warnings.push(CatalogWarning::Unreadable {
                    file: manifest.clone(),
                    message: e.to_string(),
                }),
            }
        }

        let mut others: Vec<(PathBuf, Format)> = std::fs::read_dir(&canon)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.is_file())
            .filter(|p| {
                let name = p.file_name().unwrap_or_default().to_string_lossy();
                !listed_files.contains(name.as_ref())
            })
            .filter_map(|p| Format::from_path(&p).map(|f| (p, f)))
            .collect();
        others.sort_by(|a, b| a.0.cmp(&b.0));
        for (path, format) in others {
            let stem = format.stem(&path);
            let name = if found.iter().any(|e| e.name == stem) {
                path.file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .replace('.', "_")
            } else {
                stem
            };
            found.push(CatalogEntry {
                name,
                kind: EntryKind::File { path, format },
                origin: origin.clone(),
                triangles: None,
                sha256: None,
                license: None,
                camera: None,
            });
        }

        // The folder's own cameras first, then the named scenes' table. (The repository's
        // `scenes/cameras.tsv` is that table: it was read, and its warnings kept, already.)
        let cameras = canon.join("cameras.tsv");
        let named = self.named.as_ref().expect("read above");
        if cameras.is_file() && !named.is_read_from(&cameras) {
            match std::fs::read_to_string(&cameras) {
                Ok(text) => {
                    let (cams, warnings) = parse_cameras(&text, &cameras);
                    self.warnings.extend(warnings);
                    for (name, cam) in cams {
                        if let Some(e) = found.iter_mut().find(|e| e.name == name) {
                            e.camera = Some(cam);
                        }
                    }
                }
                Err(e) => self.warnings.push(CatalogWarning::Unreadable {
                    file: cameras.clone(),
                    message: e.to_string(),
                }),
            }
        }
        for e in found.iter_mut().filter(|e| e.camera.is_none()) {
            e.camera = named.get(&e.name);
        }

        for e in found {
            if self.get(&e.name).is_some() {
                self.warnings.push(CatalogWarning::Shadowed {
                    dir: canon.clone(),
                    name: e.name,
                });
            } else {
                self.entries.push(e);
            }
        }
    }

    /// Every entry, in catalog order.
    pub fn entries(&self) -> &[CatalogEntry] {
        &self.entries
    }

    /// The file entries, one per model: a file in the same folder and with the same stem as
    /// an earlier file entry (the same model in another format, such as an `.obj` and its
    /// `.glb`) is left out, so that a sweep over the scene files visits each model once.
    /// Catalog order.
    pub fn distinct_files(&self) -> Vec<&CatalogEntry> {
        let mut seen = HashSet::new();
        self.entries
            .iter()
            .filter(|e| match &e.kind {
                EntryKind::File { path, format } => {
                    seen.insert((path.parent().map(Path::to_path_buf), format.stem(path)))
                }
                EntryKind::Procedural(_) => false,
            })
            .collect()
    }

    /// The entry named `name`.
    pub fn get(&self, name: &str) -> Option<&CatalogEntry> {
        self.entries.iter().find(|e| e.name == name)
    }

    /// The names of every entry, in catalog order.
    pub fn names(&self) -> Vec<&str> {
        self.entries.iter().map(|e| e.name.as_str()).collect()
    }

    /// The folders searched (canonical paths) and where each came from.
    pub fn dirs(&self) -> &[(PathBuf, Origin)] {
        &self.dirs
    }

    /// Problems met while reading `manifest.tsv` and `cameras.tsv` files (malformed rows,
    /// missing files, shadowed names), including the named scenes' table ([`named_cameras`]).
    pub fn warnings(&self) -> &[CatalogWarning] {
        &self.warnings
    }

    /// Loads a scene by catalog name, procedural specification or path.
    ///
    /// `name_or_path` is, in this order of precedence:
    ///
    /// * a catalog name (`sphere_in_box`, `utah_teapot`, ...);
    /// * a procedural scene with a size and optionally a seed, `name:size[:seed]`, where
    ///   size may use `_` separators and a `k` or `m` suffix (`soup:100k`, `city:1m:7`);
    /// * a path to a `.obj`, `.obj.gz`, `.gltf` or `.glb` file.
    ///
    /// Files listed in a manifest must load with the manifest's triangle count
    /// ([`SceneError::TriangleCountMismatch`] otherwise); checksums are only checked by
    /// [`Catalog::verify`].
    pub fn load(&self, name_or_path: &str) -> Result<Scene, SceneError> {
        if let Some(entry) = self.get(name_or_path) {
            return self.load_entry(entry);
        }
        if let Some((gen, rest)) = name_or_path.split_once(':') {
            if let Some(p) = Procedural::from_name(gen) {
                let (size, seed) = parse_spec(name_or_path, rest)?;
                return Ok(p.scene(size, seed));
            }
        }
        let path = Path::new(name_or_path);
        if path.is_file() {
            return Scene::from_file(path);
        }
        if Format::from_path(path).is_some() {
            // Report the missing file itself.
            return Scene::from_file(path);
        }
        Err(SceneError::UnknownScene {
            name: name_or_path.to_string(),
            known: self.names().join(", "),
        })
    }

    /// Loads the scene of an entry (of this or another catalog).
    pub fn load_entry(&self, entry: &CatalogEntry) -> Result<Scene, SceneError> {
        match &entry.kind {
            EntryKind::Procedural(p) => {
                let mut s = p.default_scene();
                s.name = entry.name.clone();
                if let Some(c) = entry.camera {
                    s.camera = c;
                }
                Ok(s)
            }
            EntryKind::File { path, format } => {
                let mesh = load_mesh(path)?;
                if let Some(expected) = entry.triangles {
                    if mesh.triangle_count() != expected {
                        return Err(SceneError::TriangleCountMismatch {
                            file: path.clone(),
                            expected,
                            actual: mesh.triangle_count(),
                        });
                    }
                }
                let bounds = mesh.bounds();
                let known = entry
                    .camera
                    .or_else(|| self.named.as_ref().and_then(|n| n.get(&entry.name)));
                let (camera, camera_source) = match known {
                    Some(c) => (c, crate::CameraSource::Table),
                    None => match &self.named {
                        Some(named) => (
                            named.camera(&entry.name, &bounds),
                            crate::CameraSource::Framing,
                        ),
                        None => {
                            let c = default_camera(&entry.name, &bounds);
                            let source = if named_cameras().0.iter().any(|(n, _)| *n == entry.name)
                            {
                                crate::CameraSource::Table
                            } else {
                                crate::CameraSource::Framing
                            };
                            (c, source)
                        }
                    },
                };
                Ok(Scene {
                    name: entry.name.clone(),
                    mesh,
                    source: SceneSource::File {
                        path: path.clone(),
                        format: *format,
                    },
                    camera,
                    camera_source,
                })
            }
        }
    }

    /// Checks the SHA-256 of the file of entry `name` against its manifest: `Ok(true)` when
    /// it matches, `Ok(false)` when there is nothing to check (procedural scene, or file
    /// without a checksum), [`SceneError::ChecksumMismatch`] when it differs and
    /// [`SceneError::UnknownScene`] for an unknown name. Reads the whole file.
    pub fn verify(&self, name: &str) -> Result<bool, SceneError> {
        let entry = self.get(name).ok_or_else(|| SceneError::UnknownScene {
            name: name.to_string(),
            known: self.names().join(", "),
        })?;
        let (Some(path), Some(expected)) = (entry.path(), entry.sha256.as_deref()) else {
            return Ok(false);
        };
        let actual = sha256_file(path)?;
        if actual.eq_ignore_ascii_case(expected) {
            Ok(true)
        } else {
            Err(SceneError::ChecksumMismatch {
                file: path.to_path_buf(),
                expected: expected.to_ascii_lowercase(),
                actual,
            })
        }
    }

    /// [`Catalog::verify`] for every entry.
    pub fn verify_all(&self) -> Vec<(String, Result<bool, SceneError>)> {
        self.entries
            .iter()
            .map(|e| (e.name.clone(), self.verify(&e.name)))
            .collect()
    }
}

/// The folders [`Catalog::discover`] searches, in order (they may not exist): the
/// repository's `scenes/`, the folders of `SAHARA_SCENES`, and `../shared/scenes` next to
/// the workspace.
pub fn search_dirs() -> Vec<(PathBuf, Origin)> {
    let mut dirs = Vec::new();
    let root = workspace_root();
    if let Some(root) = &root {
        dirs.push((root.join("scenes"), Origin::Repository));
    }
    if let Some(v) = std::env::var_os(SCENES_ENV) {
        for d in std::env::split_paths(&v) {
            if !d.as_os_str().is_empty() {
                dirs.push((d, Origin::Env));
            }
        }
    }
    if let Some(root) = &root {
        if let Some(parent) = root.parent() {
            dirs.push((parent.join("shared").join("scenes"), Origin::Shared));
        }
    }
    dirs
}

fn is_workspace_root(dir: &Path) -> bool {
    std::fs::read_to_string(dir.join("Cargo.toml"))
        .map(|t| t.lines().any(|l| l.trim() == "[workspace]"))
        .unwrap_or(false)
}

/// The root of the Cargo workspace: the first ancestor of the current directory with a
/// `Cargo.toml` that has a `[workspace]` table, else the workspace this crate was built in
/// (if it still exists).
pub fn workspace_root() -> Option<PathBuf> {
    if let Ok(cwd) = std::env::current_dir() {
        if let Some(root) = cwd.ancestors().find(|d| is_workspace_root(d)) {
            return Some(root.to_path_buf());
        }
    }
    let built = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    if is_workspace_root(&built) {
        return Some(built.canonicalize().unwrap_or(built));
    }
    None
}

/// The named scenes' cameras: the rows of [`EMBEDDED_CAMERAS`], replaced or added to by the
/// rows of the workspace's `scenes/cameras.tsv` when there is one.
#[derive(Clone, Debug, Default)]
struct NamedCameras {
    /// One camera per name, in file order.
    cameras: Vec<(String, Camera)>,
    /// The workspace's `scenes/cameras.tsv` (canonical path), if it was read.
    file: Option<PathBuf>,
}

impl NamedCameras {
    fn read() -> (NamedCameras, Vec<CatalogWarning>) {
        let embedded = Path::new("scenes/cameras.tsv (embedded)");
        let (mut cameras, mut warnings) = parse_cameras(EMBEDDED_CAMERAS, embedded);
        let mut file = None;
        let path = workspace_root().map(|r| r.join("scenes").join("cameras.tsv"));
        if let Some(path) = path.filter(|p| p.is_file()) {
            let path = path.canonicalize().unwrap_or(path);
            match std::fs::read_to_string(&path) {
                Ok(text) => {
                    let (rows, w) = parse_cameras(&text, &path);
                    warnings.extend(w);
                    for (name, cam) in rows {
                        match cameras.iter_mut().find(|(n, _)| *n == name) {
                            Some(slot) => slot.1 = cam,
                            None => cameras.push((name, cam)),
                        }
                    }
                    file = Some(path);
                }
                Err(e) => warnings.push(CatalogWarning::Unreadable {
                    file: path,
                    message: e.to_string(),
                }),
            }
        }
        (NamedCameras { cameras, file }, warnings)
    }

    fn get(&self, name: &str) -> Option<Camera> {
        self.cameras
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, c)| *c)
    }

    /// The camera of `name`, else a framing of `bounds` with y up.
    fn camera(&self, name: &str, bounds: &Aabb) -> Camera {
        self.get(name)
            .unwrap_or_else(|| Camera::framing(bounds, UpAxis::Y))
    }

    /// Whether `path` is the workspace file this table was read from.
    fn is_read_from(&self, path: &Path) -> bool {
        let canon = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        self.file.as_deref() == Some(canon.as_path())
    }
}

/// The cameras of the named scenes, one per name, and the problems met reading them.
///
/// They are the rows of the repository's `scenes/cameras.tsv`: the copy embedded in this
/// crate when it was built ([`EMBEDDED_CAMERAS`]), with the rows of the workspace's
/// `scenes/cameras.tsv` ([`workspace_root`]) replacing rows of the same name or added after
/// them, when that file exists. The [`Catalog`] gives these cameras to file scenes of these
/// names in every folder, unless the scene's own folder has a `cameras.tsv` row for it.
pub fn named_cameras() -> (Vec<(String, Camera)>, Vec<CatalogWarning>) {
    let (named, warnings) = NamedCameras::read();
    (named.cameras, warnings)
}

/// The default camera of a scene file named `name` with bounds `bounds`: its camera in
/// [`named_cameras`] (the interiors `sponza_dabrovic` and `sibenik` from inside the nave,
/// `san_francisco_osm` from above), else [`Camera::framing`] of `bounds` with y up (the
/// convention of OBJ and glTF). Procedural scenes get their cameras from their generators
/// instead.
pub fn default_camera(name: &str, bounds: &Aabb) -> Camera {
    NamedCameras::read().0.camera(name, bounds)
}

/// The SHA-256 of a file, as lowercase hexadecimal.
pub fn sha256_file(path: &Path) -> Result<String, SceneError> {
    let io = |source| SceneError::Io {
        file: path.to_path_buf(),
        source,
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = file.read(&mut buf).map_err(io)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hasher
        .finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect())
}

/// One row of a `manifest.tsv`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ManifestRow {
    /// Catalog name.
    pub name: String,
    /// File name, relative to the manifest's folder.
    pub file: String,
    /// Expected triangle count.
    pub triangles: Option<usize>,
    /// Expected SHA-256, lowercase hex.
    pub sha256: Option<String>,
    /// Licence identifier.
    pub license: Option<String>,
}

/// Parses the text of a `manifest.tsv` (tab-separated; the first non-comment line is a
/// header naming the columns; `name` and `file` are required, `triangles`, `sha256` and
/// `license` optional; lines starting with `#` are comments). Returns the rows and
/// warnings about malformed lines (which are skipped); `file` names the manifest in them.
pub fn parse_manifest(text: &str, file: &Path) -> (Vec<ManifestRow>, Vec<CatalogWarning>) {
    let mut rows = Vec::new();
    let mut warnings = Vec::new();
    let Some((cols, lines)) = tsv(text) else {
        return (rows, warnings);
    };
    let Some([name_col, file_col]) = required(&cols, &["name", "file"], file, &mut warnings) else {
        return (rows, warnings);
    };
    let col = |name: &str| cols.iter().position(|c| c == name);
    let (tri_col, sha_col, lic_col) = (col("triangles"), col("sha256"), col("license"));
    for (n, fields) in lines {
        let get = |c: Option<usize>| {
            c.and_then(|c| fields.get(c))
                .filter(|s| !s.is_empty())
                .map(|s| s.to_string())
        };
        let malformed = |column, value: Option<String>| CatalogWarning::MalformedRow {
            file: file.to_path_buf(),
            line: n + 1,
            column,
            value: value.unwrap_or_default(),
        };
        let (Some(name), Some(f)) = (get(Some(name_col)), get(Some(file_col))) else {
            let column = if get(Some(name_col)).is_none() {
                "name"
            } else {
                "file"
            };
            warnings.push(malformed(column, None));
            continue;
        };
        let triangles = match get(tri_col) {
            None => None,
            Some(t) => match t.replace([',', '_'], "").parse::<usize>() {
                Ok(t) => Some(t),
                Err(_) => {
                    warnings.push(malformed("triangles", Some(t)));
                    None
                }
            },
        };
        rows.push(ManifestRow {
            name,
            file: f,
            triangles,
            sha256: get(sha_col).map(|s| s.to_ascii_lowercase()),
            license: get(lic_col),
        });
    }
    (rows, warnings)
}

/// A data line of a tab-separated catalog file: its index in the file and its trimmed fields.
type TsvRow<'a> = (usize, Vec<&'a str>);

/// A tab-separated catalog file: the header's column names (trimmed, lower case) and each
/// later line's index and trimmed fields; blank lines and lines starting with `#` are
/// skipped. `None` without a header line.
fn tsv(text: &str) -> Option<(Vec<String>, Vec<TsvRow<'_>>)> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'));
    let (_, header) = lines.next()?;
    let cols = header
        .split('\t')
        .map(|c| c.trim().to_ascii_lowercase())
        .collect();
    let rows = lines
        .map(|(n, l)| (n, l.split('\t').map(str::trim).collect()))
        .collect();
    Some((cols, rows))
}

/// The positions of the `names` columns, or `None` with a [`CatalogWarning::MissingColumns`]
/// pushed when one is missing.
fn required<const N: usize>(
    cols: &[String],
    names: &'static [&'static str; N],
    file: &Path,
    warnings: &mut Vec<CatalogWarning>,
) -> Option<[usize; N]> {
    let found = names.map(|name| cols.iter().position(|c| c == name));
    if found.iter().all(Option::is_some) {
        return Some(found.map(Option::unwrap_or_default));
    }
    warnings.push(CatalogWarning::MissingColumns {
        file: file.to_path_buf(),
        required: names,
    });
    None
}

fn parse_vec3(s: &str) -> Option<Vec3A> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .ok()?;
    (v.len() == 3 && v.iter().all(|x| x.is_finite())).then(|| Vec3A::new(v[0], v[1], v[2]))
}

/// Parses a `cameras.tsv`: tab-separated; lines starting with `#` are comments; the first
/// other line is a header naming the columns `name`, `eye`, `target`, `up` and
/// `fov_y_degrees` in any order (other columns are ignored); each row after it is one
/// camera ([`Camera`]), vectors written `x,y,z` (finite `f32`s, read as Rust parses them, so
/// a camera written with enough digits is read back bit for bit) and the field of view in
/// degrees, strictly between 0 and 180. Returns the cameras by name, in file order, and
/// warnings ([`CatalogWarning`]) about malformed rows and repeated names, which are skipped
/// (the first row of a name is used); `file` names the file in them.
pub fn parse_cameras(text: &str, file: &Path) -> (Vec<(String, Camera)>, Vec<CatalogWarning>) {
    let mut out = Vec::new();
    let mut warnings = Vec::new();
    let Some((cols, lines)) = tsv(text) else {
        return (out, warnings);
    };
    const COLUMNS: [&str; 5] = ["name", "eye", "target", "up", "fov_y_degrees"];
    let Some([name, eye, target, up, fov]) = required(&cols, &COLUMNS, file, &mut warnings) else {
        return (out, warnings);
    };
    for (n, f) in lines {
        let get = |c: usize| f.get(c).copied().unwrap_or("");
        let malformed = |column: &'static str, c: usize| CatalogWarning::MalformedRow {
            file: file.to_path_buf(),
            line: n + 1,
            column,
            value: get(c).to_string(),
        };
        let cam = (|| {
            if get(name).is_empty() {
                return Err(malformed("name", name));
            }
            let vec = |column, c| parse_vec3(get(c)).ok_or_else(|| malformed(column, c));
            let fov_y = get(fov)
                .parse::<f32>()
                .ok()
                .filter(|x| *x > 0.0 && *x < 180.0)
                .ok_or_else(|| malformed("fov_y_degrees", fov))?;
            Ok(Camera::new(
                vec("eye", eye)?,
                vec("target", target)?,
                vec("up", up)?,
                fov_y,
            ))
        })();
        match cam {
            Ok(_) if out.iter().any(|(nm, _)| nm == get(name)) => {
                warnings.push(CatalogWarning::DuplicateCamera {
                    file: file.to_path_buf(),
                    line: n + 1,
                    name: get(name).to_string(),
                })
            }
            Ok(c) => out.push((get(name).to_string(), c)),
            Err(w) => warnings.push(w),
        }
    }
    (out, warnings)
}

fn parse_count(s: &str) -> Option<usize> {
    let s = s.trim().replace('_', "").to_ascii_lowercase();
    let (digits, mult) = if let Some(d) = s.strip_suffix('k') {
        (d, 1_000)
    } else if let Some(d) = s.strip_suffix('m') {
        (d, 1_000_000)
    } else {
        (s.as_str(), 1)
    };
    digits.parse::<usize>().ok()?.checked_mul(mult)
}

/// Parses the `size[:seed]` part of a procedural specification.
fn parse_spec(spec: &str, rest: &str) -> Result<(usize, u64), SceneError> {
    let err = |message: &str| SceneError::InvalidSpec {
        spec: spec.to_string(),
        message: message.to_string(),
    };
    let mut parts = rest.split(':');
    let size = parts
        .next()
        .and_then(parse_count)
        .filter(|&s| s > 0)
        .ok_or_else(|| err("the size must be a positive integer (e.g. 100000, 100k, 1m)"))?;
    let seed = match parts.next() {
        None => DEFAULT_SEED,
        Some(s) => s
            .trim()
            .parse::<u64>()
            .map_err(|_| err("the seed must be an unsigned integer"))?,
    };
    if parts.next().is_some() {
        return Err(err("expected name:size or name:size:seed"));
    }
    Ok((size, seed))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifest_rows_and_warnings() {
        let text = "name\tfile\ttriangles\tsha256\tlicense\n\
                    a\ta.obj\t12\tABCD\tCC0\n\
                    b\tb.glb\t\t\t\n\
                    \tc.obj\t1\tx\ty\n\
                    d\td.obj\tmany\t\t\n";
        let (rows, w) = parse_manifest(text, Path::new("m.tsv"));
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[0].triangles, Some(12));
        assert_eq!(rows[0].sha256.as_deref(), Some("abcd"));
        assert_eq!(rows[1].license, None);
        assert_eq!(rows[2].triangles, None);
        assert_eq!(w.len(), 2, "{w:?}");
        // Columns in another order and case are found; a missing one is one warning.
        let (rows, w) = parse_manifest("# c\nFile\tName\nx.obj\tx\n", Path::new("m.tsv"));
        assert_eq!(
            (rows[0].name.as_str(), rows[0].file.as_str()),
            ("x", "x.obj")
        );
        assert!(w.is_empty(), "{w:?}");
        let (rows, w) = parse_manifest("name\tpath\nx\tx.obj\n", Path::new("m.tsv"));
        assert!(rows.is_empty());
        assert!(
            matches!(&w[..], [CatalogWarning::MissingColumns { required, .. }] if required == &["name", "file"]),
            "{w:?}"
        );
    }

    #[test]
    fn cameras_file() {
        let text = "name\teye\ttarget\tup\tfov_y_degrees\n\
                    a\t1,2,3\t0,0,0\t0,1,0\t50\n\
                    b\t1,2\t0,0,0\t0,1,0\t50\n";
        let (cams, w) = parse_cameras(text, Path::new("c.tsv"));
        assert_eq!(cams.len(), 1);
        assert_eq!(cams[0].1.eye, Vec3A::new(1.0, 2.0, 3.0));
        assert_eq!(cams[0].1.fov_y_degrees, 50.0);
        assert_eq!(w.len(), 1);
    }

    #[test]
    fn specs() {
        assert_eq!(parse_spec("s", "100k").unwrap(), (100_000, DEFAULT_SEED));
        assert_eq!(parse_spec("s", "1_000:9").unwrap(), (1000, 9));
        assert_eq!(parse_spec("s", "2m").unwrap(), (2_000_000, DEFAULT_SEED));
        assert!(parse_spec("s", "0").is_err());
        assert!(parse_spec("s", "x").is_err());
        assert!(parse_spec("s", "1:2:3").is_err());
        let c = Catalog::procedural();
        let s = c.load("soup:2000:5").unwrap();
        assert_eq!(s.name, "soup:2000:5");
        assert_eq!(s.triangle_count(), 2000);
        assert!(matches!(
            c.load("no_such_scene"),
            Err(SceneError::UnknownScene { .. })
        ));
        assert!(matches!(
            c.load("soup:abc"),
            Err(SceneError::InvalidSpec { .. })
        ));
    }
}
