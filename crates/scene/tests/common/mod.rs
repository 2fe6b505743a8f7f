//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// A fresh temporary folder for one test.
pub fn temp_dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sahara-scene-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A GLB file from a JSON document and a binary buffer (both padded as the format requires).
pub fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F_534Au32.to_le_bytes()); // "JSON"
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes()); // "BIN\0"
    out.extend_from_slice(&b);
    out
}

/// The binary buffer of one triangle: three float VEC3 positions then three u16 indices.
pub fn triangle_bin(p: [[f32; 3]; 3], idx: [u16; 3]) -> Vec<u8> {
    let mut bin = Vec::new();
    for v in p {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in idx {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    bin
}

/// glTF JSON for one indexed triangle (positions at byte 0, indices at byte 36), with the
/// given node list (node 0 is the root of the scene, the mesh is mesh 0).
pub fn triangle_json(nodes: &str, indexed: bool) -> String {
    let (prim, extra_view, extra_acc) = if indexed {
        (
            r#"{"attributes":{"POSITION":0},"indices":1}"#,
            r#",{"buffer":0,"byteOffset":36,"byteLength":6}"#,
            r#",{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}"#,
        )
    } else {
        (r#"{"attributes":{"POSITION":0}}"#, "", "")
    };
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":{nodes},
"meshes":[{{"primitives":[{prim}]}}],
"buffers":[{{"byteLength":44}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}}{extra_view}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}{extra_acc}]}}"#
    )
}

/// The shared scene folder (`<workspace>/../shared/scenes`), if it exists.
pub fn shared_scenes() -> Option<PathBuf> {
    let root = sahara_scene::workspace_root()?;
    let d = root.parent()?.join("shared").join("scenes");
    d.join("manifest.tsv").is_file().then_some(d)
}

/// The cameras of the named scenes as they were hard-coded in `src/camera.rs` before they
/// moved to the repository's `scenes/cameras.tsv`: the evaluation's rays depend on them, so
/// the table must keep giving exactly these, bit for bit.
pub fn old_cameras() -> Vec<(&'static str, sahara_scene::Camera)> {
    use sahara_scene::{Camera, Vec3A};
    vec![
        (
            "sponza_dabrovic",
            Camera::new(
                Vec3A::new(-14.0, 2.5, 0.0),
                Vec3A::new(0.0, 5.0, 0.0),
                Vec3A::Y,
                60.0,
            ),
        ),
        (
            "sibenik",
            Camera::new(
                Vec3A::new(-18.0, -10.0, 0.0),
                Vec3A::new(0.0, -8.0, 0.0),
                Vec3A::Y,
                60.0,
            ),
        ),
        (
            "san_francisco_osm",
            Camera::new(
                Vec3A::new(102.6, -1000.0, 600.0),
                Vec3A::new(102.6, -4.2, 0.0),
                Vec3A::Z,
                45.0,
            ),
        ),
    ]
}

/// The bits of a camera's ten numbers (so that `-0.0` and `0.0` differ).
pub fn camera_bits(c: &sahara_scene::Camera) -> Vec<u32> {
    [c.eye.to_array(), c.target.to_array(), c.up.to_array()]
        .concat()
        .into_iter()
        .chain([c.fov_y_degrees])
        .map(f32::to_bits)
        .collect()
}
