//! A deterministic corpus of bad files: small valid OBJ, glTF, GLB and BVH files and
//! mutations of them (truncation at every length, bit flips, random bytes from a fixed-seed
//! PCG, hostile size and count fields, hostile tokens), replayed in CI by
//! `tests/files.rs` through the checks of [`crate::fuzzing`]. The same valid files seed the
//! cargo-fuzz corpus (`fuzz/corpus/<target>/`).

use sahara_builders::{registry, BuildInput, CostModel};
use sahara_geom::rng::Pcg32;

use crate::fuzzing::fixture_triangles;

/// Which loader an input is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Target {
    /// [`crate::fuzzing::check_obj`].
    Obj,
    /// [`crate::fuzzing::check_gltf`] (glTF JSON and GLB).
    Gltf,
    /// [`crate::fuzzing::check_bvh_file`].
    Bvh,
    /// [`crate::fuzzing::check_scene_bytes`].
    Scene,
    /// [`crate::expand::check_big_scene`] (scenes expanded from a few bytes).
    BigScene,
}

impl Target {
    /// Every target.
    pub const ALL: [Target; 5] = [
        Target::Obj,
        Target::Gltf,
        Target::Bvh,
        Target::Scene,
        Target::BigScene,
    ];

    /// The cargo-fuzz target name (`obj`, `gltf`, `bvh_file`, `scene_bytes`, `big_scene`).
    pub fn name(self) -> &'static str {
        match self {
            Target::Obj => "obj",
            Target::Gltf => "gltf",
            Target::Bvh => "bvh_file",
            Target::Scene => "scene_bytes",
            Target::BigScene => "big_scene",
        }
    }

    /// Runs the target's check.
    pub fn check(self, data: &[u8]) -> Result<(), String> {
        match self {
            Target::Obj => crate::fuzzing::check_obj(data),
            Target::Gltf => crate::fuzzing::check_gltf(data),
            Target::Bvh => crate::fuzzing::check_bvh_file(data),
            Target::Scene => crate::fuzzing::check_scene_bytes(data),
            Target::BigScene => crate::expand::check_big_scene(data),
        }
    }
}

/// One corpus input.
#[derive(Clone, Debug)]
pub struct Input {
    /// The loader it is for.
    pub target: Target,
    /// How it was made (`truncate 17`, `flip bit 83`, `random 12`, `huge chunk length`, ...).
    pub name: String,
    /// The bytes.
    pub data: Vec<u8>,
}

// ---------------------------------------------------------------------------------------------
// Valid files

/// A small valid OBJ: a cube with a quad face, a polygon, relative indices, texture and
/// normal references, comments, groups and a line continuation.
pub fn valid_obj() -> Vec<u8> {
    b"# cube\r\nmtllib x.mtl\no cube\nv -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\n\
v -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1 1.0\nvt 0 0\nvn 0 0 1\ng bottom\n\
f 1 4 3 2\nf 5/1 6/1 7/1 8/1\nf 1//1 2//1 6//1\nf -8 -3 -7\nusemtl m\ns off\n\
f 2 3 7 \\\n 6\nf 3 4 8 7\nf 4 1 5 8\n"
        .to_vec()
}

fn base64(data: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in data.chunks(3) {
        let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// The binary buffer of the glTF fixtures: 4 positions (a tetrahedron) then 12 `u16`
/// indices.
fn gltf_bin() -> Vec<u8> {
    let mut b = Vec::new();
    for p in [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ] {
        for c in p {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

/// The fields of the glTF fixture that the mutations vary.
#[derive(Clone, Debug)]
struct GltfParams {
    pos_count: String,
    idx_count: String,
    idx_component: String,
    pos_view_offset: String,
    pos_view_length: String,
    idx_view_length: String,
    stride: Option<String>,
    acc_offset: String,
    buffer_length: String,
    mode: String,
    nodes: String,
    scene_nodes: String,
    extra: String,
}

impl Default for GltfParams {
    fn default() -> Self {
        Self {
            pos_count: "4".into(),
            idx_count: "12".into(),
            idx_component: "5123".into(),
            pos_view_offset: "0".into(),
            pos_view_length: "48".into(),
            idx_view_length: "24".into(),
            stride: None,
            acc_offset: "0".into(),
            buffer_length: "72".into(),
            mode: "4".into(),
            nodes: r#"[{"mesh":0,"translation":[1,2,3]}]"#.into(),
            scene_nodes: "[0]".into(),
            extra: String::new(),
        }
    }
}

fn gltf_json(p: &GltfParams, uri: Option<&str>) -> String {
    let uri = uri.map(|u| format!(r#","uri":"{u}""#)).unwrap_or_default();
    let stride = p
        .stride
        .as_ref()
        .map(|s| format!(r#","byteStride":{s}"#))
        .unwrap_or_default();
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":{sn}}}],"nodes":{nodes},"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":{mode}}}]}}],"accessors":[{{"bufferView":0,"byteOffset":{ao},"componentType":5126,"count":{pc},"type":"VEC3","min":[0,0,0],"max":[1,1,1]}},{{"bufferView":1,"componentType":{ic},"count":{icount},"type":"SCALAR"}}],"bufferViews":[{{"buffer":0,"byteOffset":{pvo},"byteLength":{pvl}{stride}}},{{"buffer":0,"byteOffset":48,"byteLength":{ivl}}}],"buffers":[{{"byteLength":{bl}{uri}}}]{extra}}}"#,
        sn = p.scene_nodes,
        nodes = p.nodes,
        mode = p.mode,
        ao = p.acc_offset,
        pc = p.pos_count,
        ic = p.idx_component,
        icount = p.idx_count,
        pvo = p.pos_view_offset,
        pvl = p.pos_view_length,
        ivl = p.idx_view_length,
        bl = p.buffer_length,
        extra = p.extra,
    )
}

/// A GLB container: header, JSON chunk (space-padded), optional BIN chunk (zero-padded).
pub fn glb(json: &str, bin: Option<&[u8]>) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut body = Vec::new();
    body.extend_from_slice(&(j.len() as u32).to_le_bytes());
    body.extend_from_slice(b"JSON");
    body.extend_from_slice(&j);
    if let Some(bin) = bin {
        let mut b = bin.to_vec();
        while b.len() % 4 != 0 {
            b.push(0);
        }
        body.extend_from_slice(&(b.len() as u32).to_le_bytes());
        body.extend_from_slice(b"BIN\0");
        body.extend_from_slice(&b);
    }
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + body.len()) as u32).to_le_bytes());
    out.extend_from_slice(&body);
    out
}

/// A small valid GLB: a tetrahedron (4 triangles) under a translated node.
pub fn valid_glb() -> Vec<u8> {
    glb(&gltf_json(&GltfParams::default(), None), Some(&gltf_bin()))
}

/// A small valid glTF JSON with its buffer embedded as a `data:` URI.
pub fn valid_gltf() -> Vec<u8> {
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64(&gltf_bin())
    );
    gltf_json(&GltfParams::default(), Some(&uri)).into_bytes()
}

/// A small valid BVH file: the `binned` tree over [`fixture_triangles`].
pub fn valid_bvh() -> Vec<u8> {
    bvh_file_of("binned")
}

fn bvh_file_of(builder: &str) -> Vec<u8> {
    let tris = fixture_triangles();
    let input = BuildInput::new(&tris, CostModel::default()).expect("finite fixture");
    let bvh = registry::by_name(builder)
        .expect("registered builder")
        .build(&input)
        .expect("fixture builds");
    let mut out = Vec::new();
    bvh.save(&mut out).expect("writing to a Vec");
    out
}

/// FNV-1a 64, the checksum of the BVH file format (for mutations that keep the checksum
/// right, so that they reach the structural checks).
fn fnv1a(data: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in data {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Rewrites the checksum field of a BVH file for its (possibly mutated) payload.
pub fn fix_bvh_checksum(file: &mut [u8]) {
    if file.len() >= 40 {
        let sum = fnv1a(&file[40..]);
        file[32..40].copy_from_slice(&sum.to_le_bytes());
    }
}

// ---------------------------------------------------------------------------------------------
// Mutations

fn push(v: &mut Vec<Input>, target: Target, name: impl Into<String>, data: Vec<u8>) {
    v.push(Input {
        target,
        name: name.into(),
        data,
    });
}

/// Every prefix, single-bit flips (every bit, or `max_flips` deterministic ones), byte
/// substitutions with boundary values, and random bytes.
fn generic(v: &mut Vec<Input>, t: Target, tag: &str, valid: &[u8], max_flips: usize, seed: u64) {
    push(v, t, format!("{tag}: valid"), valid.to_vec());
    for len in 0..valid.len() {
        push(
            v,
            t,
            format!("{tag}: truncate {len}"),
            valid[..len].to_vec(),
        );
    }
    let bits = valid.len() * 8;
    let mut rng = Pcg32::new(seed, 1);
    let flips: Vec<usize> = if bits <= max_flips {
        (0..bits).collect()
    } else {
        (0..max_flips)
            .map(|_| rng.below(bits as u32) as usize)
            .collect()
    };
    for bit in flips {
        let mut d = valid.to_vec();
        d[bit / 8] ^= 1 << (bit % 8);
        push(v, t, format!("{tag}: flip bit {bit}"), d);
    }
    for i in 0..valid.len().min(512) {
        if i % 3 != 0 {
            continue;
        }
        for b in [0x00u8, 0xff, 0x7f, 0x80] {
            let mut d = valid.to_vec();
            d[i] = b;
            push(v, t, format!("{tag}: byte {i} = {b:#04x}"), d);
        }
    }
    for k in 0..64 {
        let len = rng.below(2 * valid.len() as u32 + 8) as usize;
        let d: Vec<u8> = (0..len).map(|_| rng.next_u32() as u8).collect();
        push(v, t, format!("{tag}: random {k}"), d);
        // Random bytes after a valid prefix.
        let cut = rng.below(valid.len() as u32) as usize;
        let mut d = valid[..cut].to_vec();
        d.extend((0..len / 2).map(|_| rng.next_u32() as u8));
        push(v, t, format!("{tag}: prefix {cut} + random {k}"), d);
    }
}

/// Hostile OBJ inputs: special numbers, out-of-range and malformed indices, huge polygons,
/// long lines, continuation chains, binary garbage.
fn obj_specials(v: &mut Vec<Input>) {
    let t = Target::Obj;
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases: Vec<(&str, String)> = vec![
        ("empty", String::new()),
        ("only vertices", tri.to_string()),
        (
            "nan vertex",
            "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".into(),
        ),
        (
            "inf vertex",
            "v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".into(),
        ),
        (
            "overflowing vertex",
            "v 1e39 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".into(),
        ),
        (
            "huge exponent",
            "v 1e99999999999 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".into(),
        ),
        (
            "underflowing vertex",
            "v 1e-50 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".into(),
        ),
        (
            "hex vertex",
            "v 0x10 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".into(),
        ),
        (
            "two coordinates",
            "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".into(),
        ),
        ("index 0", format!("{tri}f 0 1 2\n")),
        ("index past end", format!("{tri}f 1 2 4\n")),
        ("index u32 max", format!("{tri}f 1 2 4294967295\n")),
        ("index u32 max + 1", format!("{tri}f 1 2 4294967296\n")),
        (
            "index i64 overflow",
            format!("{tri}f 1 2 99999999999999999999999\n"),
        ),
        ("negative index too far", format!("{tri}f -1 -2 -4\n")),
        (
            "negative i64 min",
            format!("{tri}f 1 2 -9223372036854775808\n"),
        ),
        ("index with sign only", format!("{tri}f 1 2 -\n")),
        ("index slashes only", format!("{tri}f 1 2 //\n")),
        ("index trailing slash", format!("{tri}f 1/ 2/ 3/\n")),
        ("index four parts", format!("{tri}f 1/1/1/1 2 3\n")),
        ("face of two", format!("{tri}f 1 2\n")),
        ("face of one", format!("{tri}f 1\n")),
        ("bare f", format!("{tri}f\n")),
        ("continuation at end", format!("{tri}f 1 2 3 \\")),
        (
            "continuation chain",
            format!("{tri}f 1 \\\n\\\n\\\n\\\n 2 3\n"),
        ),
        ("nul bytes", format!("{tri}f 1 2 3\0\n\0\0")),
        ("only comments", "# a\n# b\n".into()),
        ("crlf", format!("{tri}f 1 2 3\r\n").replace('\n', "\r\n")),
        ("cr only", format!("{tri}f 1 2 3\r").replace('\n', "\r")),
        ("tabs", "v\t0\t0\t0\nv 1 0 0\nv 0 1 0\nf\t1\t2\t3\n".into()),
        ("bom", format!("\u{feff}{tri}f 1 2 3\n")),
        ("bom twice", format!("\u{feff}\u{feff}{tri}f 1 2 3\n")),
        ("unicode keyword", format!("{tri}ƒ 1 2 3\nf 1 2 3\n")),
    ];
    for (name, s) in cases {
        push(v, t, format!("obj special: {name}"), s.into_bytes());
    }
    // Invalid UTF-8 in several places.
    push(
        v,
        t,
        "obj special: invalid utf-8 line",
        b"v 0 0 0\nv 1 0 0\xff\xfe\nv 0 1 0\nf 1 2 3\n".to_vec(),
    );
    push(
        v,
        t,
        "obj special: invalid utf-8 comment",
        b"# \xff\xfe\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
    );
    // A polygon of 100 000 vertices (a fan of 99 998 triangles): proportional work.
    let mut big = String::from(tri);
    big.push('f');
    for i in 0..100_000 {
        big.push_str(if i % 3 == 0 {
            " 1"
        } else if i % 3 == 1 {
            " 2"
        } else {
            " 3"
        });
    }
    big.push('\n');
    push(v, t, "obj special: 100k-vertex polygon", big.into_bytes());
    // A 1 MB line.
    let mut long = format!("{tri}f 1 2 3");
    long.push_str(&" ".repeat(1 << 20));
    long.push('\n');
    push(v, t, "obj special: 1 MB line", long.into_bytes());
    // 10 000 faces referencing one vertex with negative indices.
    let mut neg = String::from(tri);
    for _ in 0..10_000 {
        neg.push_str("f -1 -2 -3\n");
    }
    push(v, t, "obj special: 10k relative faces", neg.into_bytes());
}

/// Hostile glTF/GLB inputs: size fields claiming gigabytes, counts past the data, offsets
/// overflowing, strides, node cycles and shared nodes, external and malformed URIs.
/// The glTF `nodes` array of `levels` nodes, each listing the next one `fan_out` times as its
/// children, then the mesh's node.
fn node_levels(levels: usize, fan_out: usize) -> String {
    let mut nodes = String::from("[");
    for i in 0..levels {
        let next = vec![(i + 1).to_string(); fan_out].join(",");
        nodes.push_str(&format!(r#"{{"children":[{next}]}},"#));
    }
    nodes.push_str(r#"{"mesh":0}]"#);
    nodes
}

fn gltf_specials(v: &mut Vec<Input>) {
    let t = Target::Gltf;
    let bin = gltf_bin();
    let valid = valid_glb();
    let json_len = u32::from_le_bytes([valid[12], valid[13], valid[14], valid[15]]) as usize;
    // Header fields.
    for (name, offset, value) in [
        ("total length 4 GB", 8usize, u32::MAX),
        ("total length 0", 8, 0),
        ("total length 12", 8, 12),
        ("version 1", 4, 1),
        ("version 3", 4, 3),
        ("JSON chunk 4 GB", 12, u32::MAX),
        ("JSON chunk 4 GB - 8", 12, u32::MAX - 8),
        ("JSON chunk 0", 12, 0),
        ("JSON chunk type", 16, 0x1234_5678),
        ("BIN chunk 4 GB", 20 + json_len, u32::MAX),
        ("BIN chunk 2 GB", 20 + json_len, 1 << 31),
        ("BIN chunk 0", 20 + json_len, 0),
        ("BIN chunk type", 24 + json_len, 0x1234_5678),
    ] {
        let mut d = valid.clone();
        d[offset..offset + 4].copy_from_slice(&value.to_le_bytes());
        push(v, t, format!("glb header: {name}"), d);
    }
    // A GLB whose header claims 4 GB and whose file is padded to look consistent up to
    // the chunk header.
    let mut d = valid.clone();
    d[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
    d[12..16].copy_from_slice(&(u32::MAX - 20).to_le_bytes());
    push(v, t, "glb header: 4 GB total and JSON chunk", d);
    push(v, t, "glb header: magic only", b"glTF".to_vec());
    push(v, t, "glb header: 12 bytes", valid[..12].to_vec());
    push(
        v,
        t,
        "glb: no BIN chunk",
        glb(&gltf_json(&GltfParams::default(), None), None),
    );
    push(v, t, "glb: three chunks", {
        let mut d = glb(&gltf_json(&GltfParams::default(), None), Some(&bin));
        d.extend_from_slice(&4u32.to_le_bytes());
        d.extend_from_slice(b"XTRA");
        d.extend_from_slice(&[0; 4]);
        let len = d.len() as u32;
        d[8..12].copy_from_slice(&len.to_le_bytes());
        d
    });

    // JSON fields.
    let huge = [
        "4294967295",
        "18446744073709551615",
        "1e300",
        "-1",
        "0",
        "1.5",
        "\"4\"",
        "null",
    ];
    let mut variants: Vec<(String, GltfParams)> = Vec::new();
    for h in huge {
        let p = GltfParams::default();
        variants.push((
            format!("POSITION count {h}"),
            GltfParams {
                pos_count: h.into(),
                ..p.clone()
            },
        ));
        variants.push((
            format!("index count {h}"),
            GltfParams {
                idx_count: h.into(),
                ..p.clone()
            },
        ));
        variants.push((
            format!("view offset {h}"),
            GltfParams {
                pos_view_offset: h.into(),
                ..p.clone()
            },
        ));
        variants.push((
            format!("view length {h}"),
            GltfParams {
                pos_view_length: h.into(),
                ..p.clone()
            },
        ));
        variants.push((
            format!("accessor offset {h}"),
            GltfParams {
                acc_offset: h.into(),
                ..p.clone()
            },
        ));
        variants.push((
            format!("buffer length {h}"),
            GltfParams {
                buffer_length: h.into(),
                ..p.clone()
            },
        ));
        variants.push((
            format!("stride {h}"),
            GltfParams {
                stride: Some(h.into()),
                ..p.clone()
            },
        ));
        variants.push((
            format!("mode {h}"),
            GltfParams {
                mode: h.into(),
                ..p
            },
        ));
    }
    for (name, value) in [
        ("u8", "5121"),
        ("u32", "5125"),
        ("f32", "5126"),
        ("i16", "5122"),
        ("bogus", "1"),
    ] {
        variants.push((
            format!("index component {name}"),
            GltfParams {
                idx_component: value.into(),
                ..Default::default()
            },
        ));
    }
    for m in ["0", "1", "5", "6", "7"] {
        variants.push((
            format!("mode {m}"),
            GltfParams {
                mode: m.into(),
                ..Default::default()
            },
        ));
    }
    for (name, nodes, scene) in [
        (
            "node cycle",
            r#"[{"mesh":0,"children":[1]},{"children":[0]}]"#,
            "[0]",
        ),
        ("self child", r#"[{"mesh":0,"children":[0]}]"#, "[0]"),
        (
            "shared node",
            r#"[{"children":[2,2,2,2]},{"children":[0,0,0,0]},{"mesh":0}]"#,
            "[1]",
        ),
        (
            "node index out of range",
            r#"[{"mesh":0,"children":[7]}]"#,
            "[0]",
        ),
        ("scene node out of range", r#"[{"mesh":0}]"#, "[3]"),
        ("mesh out of range", r#"[{"mesh":5}]"#, "[0]"),
        (
            "nan translation",
            r#"[{"mesh":0,"translation":[1e400,0,0]}]"#,
            "[0]",
        ),
        ("zero scale", r#"[{"mesh":0,"scale":[0,0,0]}]"#, "[0]"),
        (
            "huge scale",
            r#"[{"mesh":0,"scale":[1e38,1e38,1e38]}]"#,
            "[0]",
        ),
        (
            "singular matrix",
            r#"[{"mesh":0,"matrix":[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0]}]"#,
            "[0]",
        ),
        (
            "bad quaternion",
            r#"[{"mesh":0,"rotation":[0,0,0,0]}]"#,
            "[0]",
        ),
        ("no scene nodes", r#"[{"mesh":0}]"#, "[]"),
    ] {
        variants.push((
            name.to_string(),
            GltfParams {
                nodes: nodes.into(),
                scene_nodes: scene.into(),
                ..Default::default()
            },
        ));
    }
    for (name, nodes) in [
        // A node DAG: each level lists the next twice, 2^20 paths to the mesh from 21 nodes.
        ("node DAG 2^20 paths", node_levels(20, 2)),
        // A chain of 5000 nodes (deep hierarchy).
        ("node chain 5000", node_levels(5000, 1)),
    ] {
        variants.push((
            name.into(),
            GltfParams {
                nodes,
                ..Default::default()
            },
        ));
    }
    variants.push((
        "required extension".into(),
        GltfParams { extra: r#","extensionsRequired":["KHR_draco_mesh_compression"],"extensionsUsed":["KHR_draco_mesh_compression"]"#.into(), ..Default::default() },
    ));
    for (name, p) in variants {
        push(
            v,
            t,
            format!("glb json: {name}"),
            glb(&gltf_json(&p, None), Some(&bin)),
        );
    }
    // Buffers by URI.
    let b64 = base64(&bin);
    for (name, uri) in [
        ("external file", "missing.bin".to_string()),
        ("absolute path", "/etc/passwd".to_string()),
        ("parent path", "../../../../etc/passwd".to_string()),
        ("http", "http://127.0.0.1:9/x.bin".to_string()),
        (
            "bad base64",
            "data:application/octet-stream;base64,@@@@".to_string(),
        ),
        (
            "short base64",
            format!("data:application/octet-stream;base64,{}", &b64[..16]),
        ),
        (
            "no base64 marker",
            "data:application/octet-stream,AAAA".to_string(),
        ),
        ("empty data", "data:".to_string()),
    ] {
        push(
            v,
            t,
            format!("gltf uri: {name}"),
            gltf_json(&GltfParams::default(), Some(&uri)).into_bytes(),
        );
    }
    let huge_len = GltfParams {
        buffer_length: "4294967295".into(),
        ..Default::default()
    };
    let uri = format!("data:application/octet-stream;base64,{b64}");
    push(
        v,
        t,
        "gltf uri: data shorter than 4 GB byteLength",
        gltf_json(&huge_len, Some(&uri)).into_bytes(),
    );
    // JSON oddities.
    for (name, s) in [
        ("empty", String::new()),
        ("null", "null".to_string()),
        ("array", "[]".to_string()),
        ("empty object", "{}".to_string()),
        ("asset only", r#"{"asset":{"version":"2.0"}}"#.to_string()),
        (
            "deep nesting",
            format!("{}{}", "[".repeat(100_000), "]".repeat(100_000)),
        ),
        (
            "deep object",
            format!(
                r#"{{"asset":{{"version":"2.0"}},"extras":{}1{}}}"#,
                r#"{"a":"#.repeat(10_000),
                "}".repeat(10_000)
            ),
        ),
        ("version 1.0", r#"{"asset":{"version":"1.0"}}"#.to_string()),
        ("utf-16", "\u{feff}{}".to_string()),
    ] {
        push(v, t, format!("gltf json: {name}"), s.into_bytes());
    }
}

/// Hostile BVH files: counts claiming terabytes, counts that overflow, payload mutations with
/// a recomputed checksum (so they reach the structural checks), spatial flag changes.
fn bvh_specials(v: &mut Vec<Input>) {
    let t = Target::Bvh;
    let valid = valid_bvh();
    for (name, offset, value) in [
        ("node count u64::MAX", 16usize, u64::MAX),
        ("node count 2^59", 16, 1 << 59),
        ("node count 2^40", 16, 1 << 40),
        ("node count 0", 16, 0),
        ("reference count u64::MAX", 24, u64::MAX),
        ("reference count 2^62", 24, 1 << 62),
        ("reference count 2^36", 24, 1 << 36),
        ("reference count 0", 24, 0),
    ] {
        let mut d = valid.clone();
        d[offset..offset + 8].copy_from_slice(&value.to_le_bytes());
        push(v, t, format!("bvh header: {name}"), d.clone());
        fix_bvh_checksum(&mut d);
        push(v, t, format!("bvh header: {name} (checksum fixed)"), d);
    }
    for (name, offset, value) in [
        ("version 0", 8usize, 0u32),
        ("version 2", 8, 2),
        ("flags spatial", 12, 1),
        ("flags unknown", 12, 2),
    ] {
        let mut d = valid.clone();
        d[offset..offset + 4].copy_from_slice(&value.to_le_bytes());
        push(v, t, format!("bvh header: {name}"), d);
    }
    // Payload mutations with the checksum fixed: every 32-bit word of the payload replaced
    // by boundary values (node indices, counts, NaN and infinite bounds...).
    let words = (valid.len() - 40) / 4;
    let specials = [
        0u32,
        1,
        2,
        u32::MAX,
        u32::MAX - 1,
        0x8000_0000,
        f32::NAN.to_bits(),
        f32::INFINITY.to_bits(),
        f32::NEG_INFINITY.to_bits(),
        (-0.0f32).to_bits(),
        1e30f32.to_bits(),
        (-1e30f32).to_bits(),
    ];
    for w in 0..words {
        for (k, &s) in specials.iter().enumerate() {
            if (w + k) % 2 == 1 {
                continue;
            }
            let mut d = valid.clone();
            let o = 40 + 4 * w;
            d[o..o + 4].copy_from_slice(&s.to_le_bytes());
            fix_bvh_checksum(&mut d);
            push(
                v,
                t,
                format!("bvh payload: word {w} = {s:#x} (checksum fixed)"),
                d,
            );
        }
    }
    // Bit flips with the checksum fixed.
    let mut rng = Pcg32::new(99, 2);
    for _ in 0..400 {
        let bit = 320 + rng.below(((valid.len() - 40) * 8) as u32) as usize;
        let mut d = valid.clone();
        d[bit / 8] ^= 1 << (bit % 8);
        fix_bvh_checksum(&mut d);
        push(
            v,
            t,
            format!("bvh payload: flip bit {bit} (checksum fixed)"),
            d,
        );
    }
    // The spatial-split tree of the same triangles, and trees of other builders.
    for b in ["sweep", "sbvh"] {
        push(v, t, format!("bvh: valid {b} tree"), bvh_file_of(b));
    }
    // Trailing data, and a tree of another scene.
    let mut d = valid.clone();
    d.extend_from_slice(&[0; 7]);
    push(v, t, "bvh: trailing bytes", d);
}

/// Scene-bytes inputs: random scenes and rays whose floats come from a palette of boundary
/// values (zeros of both signs, denormals, infinities, NaN, huge and tiny values, small
/// integers) or random bits.
fn scene_specials(v: &mut Vec<Input>, count: usize) {
    let palette = [
        0.0f32,
        -0.0,
        1.0,
        -1.0,
        0.5,
        2.0,
        3.0,
        -2.0,
        1e-40,
        -1e-45,
        f32::MIN_POSITIVE,
        1e-30,
        1e30,
        -1e30,
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::EPSILON,
        1.0 + f32::EPSILON,
        1e7,
        16_777_217.0,
    ];
    let mut rng = Pcg32::new(2024, 3);
    for k in 0..count {
        let n_tris = 1 + rng.below(15) as usize;
        let n_rays = 1 + rng.below(16) as usize;
        // Triangles mostly finite (else the input is rejected up front).
        let mode = rng.below(4);
        let tris: Vec<f32> = (0..9 * n_tris)
            .map(|_| match (mode, rng.below(4)) {
                (_, 0) | (0, _) => rng.below(7) as f32 - 3.0,
                (1, _) => palette[rng.below(16) as usize],
                (2, _) => rng.range_f32(-1.0, 1.0),
                _ => palette[rng.below(palette.len() as u32) as usize],
            })
            .collect();
        let mut values = tris.clone();
        for _ in 0..n_rays {
            if rng.below(2) == 0 {
                // Aimed at a vertex or an edge midpoint, ending on it (tmax = 1) or not.
                let t = rng.below(n_tris as u32) as usize;
                let vertex = |k: u32| [0, 1, 2].map(|a| tris[9 * t + 3 * k as usize + a]);
                let (a, b) = (vertex(rng.below(3)), vertex(rng.below(3)));
                let origin = [0, 1, 2].map(|_| rng.below(9) as f32 - 4.0);
                let tmax = match rng.below(3) {
                    0 => 1.0,
                    1 => f32::INFINITY,
                    _ => palette[rng.below(palette.len() as u32) as usize],
                };
                values.extend(origin);
                values.extend((0..3).map(|i| 0.5 * a[i] + 0.5 * b[i] - origin[i]));
                values.extend([0.0, tmax]);
            } else {
                values.extend((0..8).map(|_| match rng.below(3) {
                    0 => f32::from_bits(rng.next_u32()),
                    1 => rng.range_f32(-4.0, 4.0),
                    _ => palette[rng.below(palette.len() as u32) as usize],
                }));
            }
        }
        let mut d = vec![n_tris as u8];
        for x in values {
            d.extend_from_slice(&x.to_le_bytes());
        }
        push(v, Target::Scene, format!("scene bytes {k}"), d);
    }
}

/// The whole deterministic corpus of a target (a few thousand inputs; replayed in CI).
pub fn corpus(target: Target) -> Vec<Input> {
    let mut v = Vec::new();
    match target {
        Target::Obj => {
            generic(&mut v, target, "obj", &valid_obj(), 4096, 1);
            obj_specials(&mut v);
        }
        Target::Gltf => {
            generic(&mut v, target, "glb", &valid_glb(), 2048, 2);
            generic(&mut v, target, "gltf", &valid_gltf(), 2048, 3);
            gltf_specials(&mut v);
        }
        Target::Bvh => {
            generic(&mut v, target, "bvh", &valid_bvh(), 1024, 4);
            bvh_specials(&mut v);
        }
        Target::Scene => scene_specials(&mut v, 3000),
        Target::BigScene => v.extend(
            crate::expand::replay_inputs()
                .into_iter()
                .map(|(name, data)| Input { target, name, data }),
        ),
    }
    v
}

/// Seed files for `fuzz/corpus/<target>/` (small valid inputs, the hard-case suite's small
/// cases as scene bytes, and the `big_scene` seeds of [`crate::expand::seeds`]).
pub fn seeds() -> Vec<(Target, String, Vec<u8>)> {
    let mut scene = vec![2u8];
    for x in [
        -1.0f32,
        -1.0,
        2.0,
        1.0,
        -1.0,
        2.0,
        0.0,
        1.0,
        2.0, // triangle 0
        -1.0,
        -1.0,
        3.0,
        1.0,
        -1.0,
        3.0,
        0.0,
        1.0,
        3.0, // triangle 1
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
        f32::INFINITY, // a ray that hits
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        f32::NAN,
        0.0,
        f32::INFINITY, // an invalid ray
    ] {
        scene.extend_from_slice(&x.to_le_bytes());
    }
    let mut v = vec![
        (Target::Obj, "cube.obj".to_string(), valid_obj()),
        (Target::Gltf, "tetra.glb".to_string(), valid_glb()),
        (Target::Gltf, "tetra.gltf".to_string(), valid_gltf()),
        (Target::Bvh, "fixture-binned.bvh".to_string(), valid_bvh()),
        (
            Target::Bvh,
            "fixture-sbvh.bvh".to_string(),
            bvh_file_of("sbvh"),
        ),
        (
            Target::Scene,
            "two-triangles-two-rays.bin".to_string(),
            scene,
        ),
    ];
    // The hard-case suite's small cases (at most 15 triangles) as scene bytes, 64 rays each.
    for case in crate::cases(crate::Level::Fast) {
        if case.triangles.len() > 15 {
            continue;
        }
        let mut d = vec![case.triangles.len() as u8];
        let tris = case.triangles.iter().flat_map(|t| t.v);
        let rays = case.rays.iter().take(64).flat_map(|r| {
            let (o, dir) = (r.origin, r.direction());
            [o.x, o.y, o.z, dir.x, dir.y, dir.z, r.tmin, r.tmax]
        });
        for x in tris.flat_map(|p| p.to_array()).chain(rays) {
            d.extend_from_slice(&x.to_le_bytes());
        }
        let name = case.name.replace(['/', '@', ' '], "-");
        v.push((Target::Scene, format!("hardcase-{name}.bin"), d));
    }
    for (name, d) in crate::expand::seeds() {
        v.push((Target::BigScene, format!("{name}.bin"), d));
    }
    v
}
