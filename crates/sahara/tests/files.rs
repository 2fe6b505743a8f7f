//! Mesh files to built structures (`Accel::build_from_file`, `SceneBuilder::add_file`): a
//! procedural OBJ written to a temporary file builds the same tree as the same mesh given in
//! memory, and every missing or broken file is a typed error naming it, never a panic.

use std::path::PathBuf;

use sahara::sahara_scene::SceneError as FileError;
use sahara::{Accel, Error, Quality, Ray, SceneBuilder, Vec3A, ALL_MASK};

/// A file in the temporary directory, removed when dropped.
struct TempFile(PathBuf);

impl TempFile {
    fn new(name: &str, contents: &str) -> TempFile {
        let path = std::env::temp_dir().join(format!("sahara-files-{}-{name}", std::process::id()));
        std::fs::write(&path, contents).unwrap();
        TempFile(path)
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// A wavy 24 × 24 height field as OBJ text, in quads (the loader fans them into two
/// triangles each), with its positions and triangles as the loader should read them.
fn height_field() -> (String, Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let n = 24u32;
    let mut obj = String::from("# procedural height field\no field\n");
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f32 / 8.0 - 1.5, j as f32 / 8.0 - 1.5);
            let z = 0.25 * (3.0 * x).sin() * (2.0 * y).cos();
            obj.push_str(&format!("v {x} {y} {z}\n"));
            positions.push([x, y, z]);
        }
    }
    let mut indices = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 2, a + n + 1);
            obj.push_str(&format!("f {} {} {} {}\n", a + 1, b + 1, c + 1, d + 1));
            indices.push([a, b, c]);
            indices.push([a, c, d]);
        }
    }
    (obj, positions, indices)
}

fn rays() -> Vec<Ray> {
    (0..900)
        .map(|k| {
            let (x, y) = ((k % 30) as f32 / 12.5 - 1.2, (k / 30) as f32 / 12.5 - 1.2);
            Ray::new(
                Vec3A::new(x, y, 3.0),
                Vec3A::new(0.1, -0.05, -1.0),
                0.0,
                9.0,
            )
        })
        .collect()
}

#[test]
fn an_obj_file_builds_what_its_mesh_builds_in_memory() {
    let (obj, positions, indices) = height_field();
    let file = TempFile::new("field.obj", &obj);
    let rays = rays();
    for q in [Quality::Fast, Quality::Medium, Quality::High] {
        let loaded = Accel::build_from_file(&file.0, q).unwrap();
        let direct = Accel::build_indexed(&positions, &indices, q).unwrap();
        assert_eq!(loaded.triangles(), direct.triangles(), "{q}");
        assert_eq!(loaded.bvh(), direct.bvh(), "{q}");
        let hits = loaded.closest_hits(&rays);
        assert_eq!(hits, direct.closest_hits(&rays), "{q}");
        assert!(
            hits.iter().all(Option::is_some),
            "{q}: the field covers every ray"
        );
        for (ray, hit) in rays.iter().zip(&hits) {
            assert_eq!(*hit, loaded.brute_closest_hit(ray), "{q}");
        }
    }
    // The same file as one geometry of a scene, next to another.
    let mut b = SceneBuilder::new();
    let other = b.add_indexed(
        &[[0.0f32, 0.0, 5.0], [1.0, 0.0, 5.0], [0.0, 1.0, 5.0]],
        &[[0, 1, 2]],
    );
    let field = b.add_file(&file.0).unwrap();
    let scene = b.build(Quality::Medium).unwrap();
    assert_eq!(scene.geometry_len(field), Some(indices.len()));
    assert_ne!(Some(field), other.ok());
    for ray in &rays {
        let hit = scene.closest_hit(ray, ALL_MASK).unwrap();
        assert_eq!(hit.geometry, field);
        assert_eq!(Some(hit), scene.brute_closest_hit(ray, ALL_MASK, None));
    }
}

/// Whether an error is the expected variant.
type Expected = fn(&FileError) -> bool;

#[test]
fn missing_and_broken_files_are_typed_errors() {
    let file_error = |r: Result<Accel, Error>| match r {
        Err(Error::File(e)) => e,
        other => panic!("expected a file error, got {other:?}"),
    };
    // Missing.
    let missing =
        std::env::temp_dir().join(format!("sahara-files-{}-missing.obj", std::process::id()));
    let e = file_error(Accel::build_from_file(&missing, Quality::Fast));
    assert!(
        matches!(e, FileError::Io { ref file, .. } if *file == missing),
        "{e}"
    );
    assert!(e.to_string().contains("missing.obj"), "{e}");
    // A directory of that name is not a file either.
    let dir = std::env::temp_dir().join(format!("sahara-files-{}-dir.obj", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let e = file_error(Accel::build_from_file(&dir, Quality::Fast));
    std::fs::remove_dir(&dir).unwrap();
    assert!(matches!(e, FileError::Io { .. }), "{e}");
    // Broken contents.
    let cases: [(&str, &str, Expected); 6] = [
        ("syntax.obj", "v 0 0 0\nv 1 2 abc\n", |e| {
            matches!(e, FileError::Parse { .. })
        }),
        ("nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", |e| {
            matches!(
                e,
                FileError::NonFinite {
                    vertex_index: 1,
                    ..
                }
            )
        }),
        ("index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", |e| {
            matches!(e, FileError::IndexOutOfRange { index: 4, .. })
        }),
        ("empty.obj", "# nothing\nv 0 0 0\n", |e| {
            matches!(e, FileError::Empty { .. })
        }),
        ("binary.glb", "glTF\u{2}\0\0\0garbage", |e| {
            matches!(e, FileError::Parse { .. })
        }),
        ("mesh.ply", "ply\n", |e| {
            matches!(e, FileError::UnsupportedFormat { .. })
        }),
    ];
    for (name, contents, expected) in cases {
        let file = TempFile::new(name, contents);
        let e = file_error(Accel::build_from_file(&file.0, Quality::Fast));
        assert!(expected(&e), "{name}: {e}");
        assert!(
            e.to_string().contains(name),
            "{name}: the message names the file: {e}"
        );
        // The scene builder refuses it the same way and adds nothing.
        let mut b = SceneBuilder::new();
        assert!(matches!(b.add_file(&file.0), Err(Error::File(_))), "{name}");
        assert_eq!(
            b.build(Quality::Fast).unwrap().geometries().len(),
            0,
            "{name}"
        );
    }
}
