//! Loaders on malformed and small hand-made files: errors name the file and the problem,
//! and nothing panics.

mod common;

use std::path::Path;

use common::{glb, temp_dir, triangle_bin, triangle_json};
use sahara_geom::rng::Pcg32;
use sahara_scene::{
    load_mesh, parse_gltf, parse_mesh, parse_obj, Format, Scene, SceneError, Vec3A,
};

const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

fn write(dir: &Path, name: &str, data: &[u8]) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, data).unwrap();
    p
}

/// The error of loading `data` written to `dir/name`.
fn load_error(dir: &Path, name: &str, data: &[u8]) -> SceneError {
    load_mesh(write(dir, name, data)).unwrap_err()
}

/// The triangle, index and vertex count of a [`SceneError::IndexOutOfRange`].
fn out_of_range(e: &SceneError) -> Option<(usize, i64, usize)> {
    match *e {
        SceneError::IndexOutOfRange {
            triangle,
            index,
            vertex_count,
            ..
        } => Some((triangle, index, vertex_count)),
        _ => None,
    }
}

/// The vertex of a [`SceneError::NonFinite`].
fn non_finite_vertex(e: &SceneError) -> Option<usize> {
    match *e {
        SceneError::NonFinite { vertex_index, .. } => Some(vertex_index),
        _ => None,
    }
}

#[test]
fn malformed_obj_names_file_and_line() {
    let dir = temp_dir("malformed");
    let e = load_error(
        &dir,
        "broken.obj",
        b"v 0 0 0\nv 1 0 0\nv 1 2 abc\nf 1 2 3\n",
    );
    assert!(matches!(e, SceneError::Parse { .. }), "{e:?}");
    let msg = e.to_string();
    assert!(msg.contains("broken.obj"), "{msg}");
    assert!(msg.contains("line 3") && msg.contains("abc"), "{msg}");

    // A face referencing vertices that do not exist.
    let e = load_error(&dir, "missing.obj", b"v 0 0 0\nv 1 0 0\nf 1 2 3\n");
    let msg = e.to_string();
    assert_eq!(out_of_range(&e), Some((0, 3, 2)), "{msg}");
    assert!(
        msg.contains("missing.obj") && msg.contains("triangle 0"),
        "{msg}"
    );

    // A face with two vertices.
    let msg = load_error(&dir, "short.obj", b"v 0 0 0\nv 1 0 0\nf 1 2\n").to_string();
    assert!(msg.contains("short.obj") && msg.contains("line 3"), "{msg}");
}

#[test]
fn nan_vertex_is_an_error() {
    let dir = temp_dir("nan");
    let e = load_error(&dir, "nan.obj", b"v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n");
    assert_eq!(non_finite_vertex(&e), Some(2), "{e:?}");
    let msg = e.to_string();
    assert!(msg.contains("nan.obj") && msg.contains("vertex 2") && msg.contains("non-finite"));
}

#[test]
fn out_of_range_index_is_an_error() {
    let dir = temp_dir("range");
    let e = load_error(
        &dir,
        "range.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n",
    );
    let msg = e.to_string();
    assert_eq!(out_of_range(&e), Some((1, 7, 3)), "{msg}");
    assert!(
        msg.contains("range.obj") && msg.contains("out of range"),
        "{msg}"
    );
}

#[test]
fn obj_gz_round_trip() {
    use std::io::Write;
    let dir = temp_dir("gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n")
        .unwrap();
    let p = write(&dir, "quad.obj.gz", &enc.finish().unwrap());
    let s = Scene::from_file(&p).unwrap();
    assert_eq!(s.name, "quad");
    assert_eq!(s.triangle_count(), 2);
    let msg = load_error(&dir, "bad.obj.gz", b"\x1f\x8b\x08garbage").to_string();
    assert!(msg.contains("bad.obj.gz") && msg.contains("gzip"), "{msg}");
}

#[test]
fn glb_loads_with_transforms_and_truncated_glb_fails() {
    let json = triangle_json(r#"[{"mesh":0,"translation":[1,0,0]}]"#, true);
    let data = glb(&json, &triangle_bin(TRI, [0, 1, 2]));
    let dir = temp_dir("glb");
    let p = write(&dir, "tri.glb", &data);
    let m = load_mesh(&p).unwrap();
    assert_eq!(m.triangle_count(), 1);
    assert_eq!(m.positions[0], Vec3A::new(1.0, 0.0, 0.0));
    assert_eq!(m.positions[2], Vec3A::new(1.0, 1.0, 0.0));

    let half = write(&dir, "half.glb", &data[..data.len() / 2]);
    let e = load_mesh(&half).unwrap_err();
    assert!(matches!(e, SceneError::Parse { .. }), "{e:?}");
    let msg = e.to_string();
    assert!(
        msg.contains("half.glb") && msg.contains("truncated"),
        "{msg}"
    );

    // Every prefix is an error, never a panic.
    for n in 0..data.len() {
        assert!(
            parse_gltf(&data[..n], Path::new("prefix.glb"), None).is_err(),
            "prefix {n}"
        );
    }
}

#[test]
fn gltf_hierarchy_and_non_indexed_primitives() {
    // Root scales by 2 and rotates 90° about z; its child translates by (1, 0, 0).
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let nodes = format!(
        r#"[{{"children":[1],"scale":[2,2,2],"rotation":[0,0,{s},{s}]}},{{"mesh":0,"translation":[1,0,0]}}]"#
    );
    let json = triangle_json(&nodes, false);
    let m = parse_gltf(
        &glb(&json, &triangle_bin(TRI, [0, 1, 2])),
        Path::new("h.glb"),
        None,
    )
    .unwrap();
    assert_eq!(m.indices, vec![[0, 1, 2]]);
    // p -> R(2 (p + (1,0,0))) with R: (x, y) -> (-y, x).
    let expect = [[0.0, 2.0, 0.0], [0.0, 4.0, 0.0], [-2.0, 2.0, 0.0]];
    for (p, e) in m.positions.iter().zip(expect) {
        assert!((*p - Vec3A::from_array(e)).length() < 1e-5, "{p} vs {e:?}");
    }
}

#[test]
fn gltf_errors_name_the_element() {
    // Index 5 of a 3-vertex primitive.
    let json = triangle_json(r#"[{"mesh":0}]"#, true);
    let e = parse_gltf(
        &glb(&json, &triangle_bin(TRI, [0, 5, 2])),
        Path::new("idx.glb"),
        None,
    )
    .unwrap_err();
    assert_eq!(out_of_range(&e), Some((0, 5, 3)), "{e:?}");
    // NaN coordinate.
    let mut t = TRI;
    t[1][2] = f32::NAN;
    let e = parse_gltf(
        &glb(&json, &triangle_bin(t, [0, 1, 2])),
        Path::new("nan.glb"),
        None,
    )
    .unwrap_err();
    assert_eq!(non_finite_vertex(&e), Some(1), "{e:?}");
    // A buffer shorter than declared.
    let bin = triangle_bin(TRI, [0, 1, 2]);
    let msg = parse_gltf(&glb(&json, &bin[..20]), Path::new("short.glb"), None)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("short.glb"), "{msg}");
    // An accessor past the end of its view.
    let bad = json.replace(r#""count":3,"type":"VEC3""#, r#""count":4,"type":"VEC3""#);
    let msg = parse_gltf(&glb(&bad, &bin), Path::new("acc.glb"), None)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("acc.glb") && msg.contains("accessor 0"),
        "{msg}"
    );
    // Garbage.
    assert!(parse_gltf(b"{not json", Path::new("g.gltf"), None).is_err());
    assert!(parse_gltf(b"glTF\x02\0\0\0\x05\0\0\0", Path::new("g.glb"), None).is_err());
}

#[test]
fn random_corruption_never_panics() {
    let json = triangle_json(r#"[{"mesh":0,"translation":[1,0,0]}]"#, true);
    let data = glb(&json, &triangle_bin(TRI, [0, 1, 2]));
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\nf -1 -2 -3\n".to_vec();
    let mut r = Pcg32::new(7, 1);
    for _ in 0..2000 {
        for (src, format) in [(&data, Format::Glb), (&obj, Format::Obj)] {
            let mut d = src.clone();
            for _ in 0..1 + r.below(4) {
                let i = r.below(d.len() as u32) as usize;
                d[i] = r.next_u32() as u8;
            }
            if let Ok(m) = parse_mesh(&d, format, Path::new("fuzz")) {
                m.validate(Path::new("fuzz")).unwrap();
            }
        }
    }
    for n in 0..200 {
        let garbage: Vec<u8> = (0..n * 7).map(|_| r.next_u32() as u8).collect();
        for format in Format::ALL {
            let _ = parse_mesh(&garbage, format, Path::new("garbage"));
        }
    }
    assert!(parse_obj(&[0xff, 0xfe, b'v', b'\n'], Path::new("b.obj")).is_err());
}

#[test]
fn unsupported_format_and_missing_file() {
    let e = load_mesh("scene.ply").unwrap_err();
    assert!(matches!(e, SceneError::UnsupportedFormat { .. }));
    assert!(e.to_string().contains("scene.ply"));
    let e = load_mesh("/definitely/not/here.obj").unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }));
    assert!(e.to_string().contains("here.obj"));
}

#[test]
fn gltf_with_bad_external_uri_is_an_error() {
    // The `gltf` crate unwraps the percent-decoding of relative URIs; the loader turns that
    // panic into an error.
    let dir = temp_dir("uri");
    let json = triangle_json(r#"[{"mesh":0}]"#, true).replace(
        r#"{"byteLength":44}"#,
        r#"{"byteLength":44,"uri":"%FF%FE.bin"}"#,
    );
    let msg = load_error(&dir, "uri.gltf", json.as_bytes()).to_string();
    assert!(msg.contains("uri.gltf"), "{msg}");
    // A missing external buffer.
    let json = triangle_json(r#"[{"mesh":0}]"#, true).replace(
        r#"{"byteLength":44}"#,
        r#"{"byteLength":44,"uri":"missing.bin"}"#,
    );
    let msg = load_error(&dir, "ext.gltf", json.as_bytes()).to_string();
    assert!(msg.contains("ext.gltf") && msg.contains("buffers"), "{msg}");
    // And a present one loads.
    std::fs::write(dir.join("tri.bin"), triangle_bin(TRI, [0, 1, 2])).unwrap();
    let json = triangle_json(r#"[{"mesh":0}]"#, true).replace(
        r#"{"byteLength":44}"#,
        r#"{"byteLength":42,"uri":"tri.bin"}"#,
    );
    let p = write(&dir, "ok.gltf", json.as_bytes());
    assert_eq!(load_mesh(&p).unwrap().triangle_count(), 1);
}

#[test]
fn distinct_files_list_each_model_once() {
    let dir = temp_dir("distinct");
    for f in ["a.obj", "a.glb", "b.obj.gz", "c.gltf"] {
        write(&dir, f, b"");
    }
    let mut c = sahara_scene::Catalog::procedural();
    c.add_dir(&dir, sahara_scene::Origin::Dir);
    let all: Vec<&str> = c
        .entries()
        .iter()
        .filter(|e| e.path().is_some())
        .map(|e| e.name.as_str())
        .collect();
    assert_eq!(all.len(), 4, "{all:?}");
    let distinct: Vec<&str> = c.distinct_files().iter().map(|e| e.name.as_str()).collect();
    // `a.glb` is `a.obj`'s model in another format: listed once, under the first entry.
    assert_eq!(distinct.len(), 3, "{distinct:?}");
    assert!(distinct.contains(&"a") && distinct.contains(&"b") && distinct.contains(&"c"));
    assert!(!distinct.iter().any(|n| n.starts_with("a_")));
}
