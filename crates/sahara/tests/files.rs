//! Mesh files to built structures (`Accel::build_from_file`, `SceneBuilder::add_file`): a
//! procedural OBJ and the same mesh as a GLB, written to temporary files, build the same tree
//! as the mesh given in memory, and every missing or broken file is a typed error naming it,
//! never a panic.

use std::path::PathBuf;

use sahara::sahara_scene::SceneError as FileError;
use sahara::{Accel, Error, Quality, Ray, SceneBuilder, Vec3A, ALL_MASK};

/// A file in the temporary directory, removed when dropped.
struct TempFile(PathBuf);

impl TempFile {
    fn new(name: &str, contents: impl AsRef<[u8]>) -> TempFile {
        let path = std::env::temp_dir().join(format!("sahara-files-{}-{name}", std::process::id()));
        std::fs::write(&path, contents.as_ref()).unwrap();
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

/// `file` builds, at each level, the triangles, tree and answers of the mesh given in memory.
fn builds_like_memory(
    file: &TempFile,
    positions: &[[f32; 3]],
    indices: &[[u32; 3]],
    levels: &[Quality],
) {
    let rays = rays();
    for &q in levels {
        let loaded = Accel::build_from_file(&file.0, q).unwrap();
        let direct = Accel::build_indexed(positions, indices, q).unwrap();
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
}

#[test]
fn an_obj_file_builds_what_its_mesh_builds_in_memory() {
    let (obj, positions, indices) = height_field();
    let file = TempFile::new("field.obj", &obj);
    let rays = rays();
    builds_like_memory(
        &file,
        &positions,
        &indices,
        &[Quality::Fast, Quality::Medium, Quality::High],
    );
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

/// A GLB file (glTF 2.0, binary) of one mesh: float positions and `u32` indices in one
/// buffer, one node without a transform.
fn glb(positions: &[[f32; 3]], indices: &[[u32; 3]]) -> Vec<u8> {
    let mut bin: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    let index_offset = bin.len();
    bin.extend(indices.iter().flatten().flat_map(|i| i.to_le_bytes()));
    let (lo, hi) = positions
        .iter()
        .fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), p| {
            (
                std::array::from_fn(|a| lo[a].min(p[a])),
                std::array::from_fn(|a| hi[a].max(p[a])),
            )
        });
    let mut json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
"buffers":[{{"byteLength":{}}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{index_offset}}},{{"buffer":0,"byteOffset":{index_offset},"byteLength":{}}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3","min":{lo:?},"max":{hi:?}}},
{{"bufferView":1,"componentType":5125,"count":{},"type":"SCALAR"}}]}}"#,
        bin.len(),
        bin.len() - index_offset,
        positions.len(),
        3 * indices.len(),
    );
    while json.len() % 4 != 0 {
        json.push(' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    for word in [0x4654_6C67, 2, total as u32, json.len() as u32, 0x4E4F_534A] {
        out.extend_from_slice(&u32::to_le_bytes(word)); // "glTF", version, length, "JSON"
    }
    out.extend_from_slice(json.as_bytes());
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes()); // "BIN\0"
    out.extend_from_slice(&bin);
    out
}

#[test]
fn a_glb_file_builds_what_its_mesh_builds_in_memory() {
    let (_, positions, indices) = height_field();
    let data = glb(&positions, &indices);
    let file = TempFile::new("field.glb", &data);
    builds_like_memory(&file, &positions, &indices, &[Quality::Fast, Quality::High]);
    let mut b = SceneBuilder::new();
    let field = b.add_file(&file.0).unwrap();
    let scene = b.build(Quality::Medium).unwrap();
    assert_eq!(scene.geometry_len(field), Some(indices.len()));
    // Cut short, and with an index past the positions: typed errors naming the file.
    let half = TempFile::new("half.glb", &data[..data.len() / 2]);
    match Accel::build_from_file(&half.0, Quality::Fast) {
        Err(Error::File(e)) => assert!(e.to_string().contains("half.glb"), "{e}"),
        other => panic!("expected a file error, got {other:?}"),
    }
    let mut bad = indices.clone();
    bad[7][1] = positions.len() as u32;
    let bad = TempFile::new("index.glb", glb(&positions, &bad));
    assert!(matches!(
        Accel::build_from_file(&bad.0, Quality::Fast),
        Err(Error::File(_))
    ));
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
