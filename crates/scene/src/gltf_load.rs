//! glTF 2.0 (`.gltf` with external or embedded buffers, and binary `.glb`) geometry reader.
//!
//! The default scene (or the first scene, or every root node when the file has no scene) is
//! walked from its root nodes down, accumulating node transforms; every primitive of every
//! mesh instance contributes its `POSITION` attribute, transformed to world space, and its
//! triangles. Primitives without indices get sequential ones. Triangle strips and fans are
//! converted to triangles; points and lines are skipped. Materials, normals, texture
//! coordinates, skins and morph targets are ignored.
//!
//! The accessors are read by this module with checked arithmetic (not by the `gltf` crate's
//! reader, which asserts on some malformed inputs), and the whole reader runs under
//! [`std::panic::catch_unwind`] as a last resort, so malformed input gives a
//! [`SceneError`], never a panic.

use std::path::Path;

use glam::{DMat4, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use sahara_geom::Vec3A;

use crate::{Mesh, SceneError};

/// Extensions that change how geometry is stored; files that require them are rejected.
const UNSUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_mesh_quantization",
    "EXT_mesh_gpu_instancing",
];

/// Reads a `.gltf` or `.glb` file into a [`Mesh`] (external buffers are looked up next to
/// the file).
pub fn load_gltf(path: impl AsRef<Path>) -> Result<Mesh, SceneError> {
    let path = path.as_ref();
    let data = crate::error::read_file(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse_gltf(&data, path, Some(base))
}

/// Parses glTF JSON or GLB bytes into a [`Mesh`].
///
/// `file` names the source in errors; `base_dir` is where external buffers (relative URIs)
/// are looked up, `None` to accept only embedded (`data:` URI or GLB) buffers.
pub fn parse_gltf(data: &[u8], file: &Path, base_dir: Option<&Path>) -> Result<Mesh, SceneError> {
    check_glb_header(data, file)?;
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        parse_gltf_inner(data, file, base_dir)
    }));
    match result {
        Ok(r) => r,
        Err(panic) => {
            let msg = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown error".to_string());
            Err(SceneError::parse(
                file,
                format!("malformed glTF (reader failed: {msg})"),
            ))
        }
    }
}

/// Checks the 12-byte GLB header so that the `gltf` crate never sees an inconsistent one.
fn check_glb_header(data: &[u8], file: &Path) -> Result<(), SceneError> {
    if !data.starts_with(b"glTF") {
        return Ok(());
    }
    let word = |i: usize| -> Option<u32> {
        let b = data.get(i..i + 4)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(SceneError::parse(file, "GLB header truncated"));
    };
    if version != 2 {
        return Err(SceneError::parse(
            file,
            format!("GLB version {version} is not supported (expected 2)"),
        ));
    }
    if (length as usize) < 20 || length as usize > data.len() {
        return Err(SceneError::parse(
            file,
            format!(
                "GLB header declares {length} bytes but the file has {} (truncated?)",
                data.len()
            ),
        ));
    }
    let mut pos = 12usize;
    let end = length as usize;
    let mut chunk = 0;
    while pos < end {
        let (Some(len), Some(_ty)) = (word(pos), word(pos + 4)) else {
            return Err(SceneError::parse(
                file,
                format!("GLB chunk {chunk}: header truncated"),
            ));
        };
        let next = pos.checked_add(8).and_then(|p| p.checked_add(len as usize));
        let Some(next) = next.filter(|&n| n <= end) else {
            let msg = format!("GLB chunk {chunk}: length {len} runs past the end of the file");
            return Err(SceneError::parse(file, format!("{msg} (truncated?)")));
        };
        pos = next;
        chunk += 1;
    }
    Ok(())
}

fn parse_gltf_inner(data: &[u8], file: &Path, base_dir: Option<&Path>) -> Result<Mesh, SceneError> {
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice(data)
        .map_err(|e| SceneError::parse(file, format!("invalid glTF: {e}")))?;
    for ext in document.extensions_required() {
        if UNSUPPORTED_EXTENSIONS.contains(&ext) {
            return Err(SceneError::parse(
                file,
                format!("requires the unsupported extension {ext}"),
            ));
        }
    }
    let buffers = gltf::import_buffers(&document, base_dir, blob)
        .map_err(|e| SceneError::parse(file, format!("cannot load buffers: {e}")))?;
    let buffers: Vec<&[u8]> = buffers.iter().map(|b| &b.0[..]).collect();

    // Root nodes: of the default scene, else of the first scene, else every parentless node.
    let roots: Vec<gltf::Node<'_>> = match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => scene.nodes().collect(),
        None => {
            let mut has_parent = vec![false; document.nodes().len()];
            for n in document.nodes() {
                for c in n.children() {
                    has_parent[c.index()] = true;
                }
            }
            document
                .nodes()
                .filter(|n| !has_parent[n.index()])
                .collect()
        }
    };

    let node_count = document.nodes().len();
    let max_visits = node_count.saturating_mul(64).max(1024);
    let mut visits = 0usize;
    let mut mesh = Mesh::default();
    let mut stack: Vec<(gltf::Node<'_>, DMat4, usize)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, DMat4::IDENTITY, 0))
        .collect();
    while let Some((node, parent, depth)) = stack.pop() {
        visits += 1;
        if depth > node_count || visits > max_visits {
            return Err(SceneError::parse(
                file,
                format!(
                    "node {}: the node hierarchy has a cycle or shares nodes between parents",
                    node.index()
                ),
            ));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if let Some(m) = node.mesh() {
            for prim in m.primitives() {
                add_primitive(&mut mesh, &prim, &m, &world, &buffers, file)?;
            }
        }
        let children: Vec<_> = node.children().collect();
        for c in children.into_iter().rev() {
            stack.push((c, world, depth + 1));
        }
    }

    mesh.checked(file)
}

fn describe(mesh: &gltf::Mesh<'_>, prim: &gltf::Primitive<'_>) -> String {
    match mesh.name() {
        Some(name) => format!(
            "mesh {} (`{name}`) primitive {}",
            mesh.index(),
            prim.index()
        ),
        None => format!("mesh {} primitive {}", mesh.index(), prim.index()),
    }
}

fn add_primitive(
    out: &mut Mesh,
    prim: &gltf::Primitive<'_>,
    mesh: &gltf::Mesh<'_>,
    world: &DMat4,
    buffers: &[&[u8]],
    file: &Path,
) -> Result<(), SceneError> {
    let mode = prim.mode();
    if matches!(
        mode,
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
    ) {
        return Ok(());
    }
    let what = || describe(mesh, prim);
    let pos_acc = prim
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| SceneError::parse(file, format!("{}: no POSITION attribute", what())))?;
    if pos_acc.data_type() != DataType::F32 || pos_acc.dimensions() != Dimensions::Vec3 {
        return Err(SceneError::parse(
            file,
            format!(
                "{}: POSITION accessor {} is {:?} {:?}, only float VEC3 is supported",
                what(),
                pos_acc.index(),
                pos_acc.data_type(),
                pos_acc.dimensions()
            ),
        ));
    }
    let raw = read_accessor(&pos_acc, buffers).map_err(|m| {
        SceneError::parse(
            file,
            format!("{}: POSITION accessor {}: {m}", what(), pos_acc.index()),
        )
    })?;
    let vertex_count = pos_acc.count();
    let indices: Vec<u32> = match prim.indices() {
        Some(acc) => {
            if acc.dimensions() != Dimensions::Scalar
                || !matches!(
                    acc.data_type(),
                    DataType::U8 | DataType::U16 | DataType::U32
                )
            {
                return Err(SceneError::parse(
                    file,
                    format!(
                        "{}: index accessor {} is {:?} {:?}, expected unsigned integer SCALAR",
                        what(),
                        acc.index(),
                        acc.data_type(),
                        acc.dimensions()
                    ),
                ));
            }
            let bytes = read_accessor(&acc, buffers).map_err(|m| {
                SceneError::parse(
                    file,
                    format!("{}: index accessor {}: {m}", what(), acc.index()),
                )
            })?;
            match acc.data_type() {
                DataType::U8 => bytes.iter().map(|&b| u32::from(b)).collect(),
                DataType::U16 => bytes
                    .chunks_exact(2)
                    .map(|c| u32::from(u16::from_le_bytes([c[0], c[1]])))
                    .collect(),
                _ => bytes
                    .chunks_exact(4)
                    .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                    .collect(),
            }
        }
        None => {
            let n = u32::try_from(vertex_count)
                .map_err(|_| SceneError::parse(file, format!("{}: too many vertices", what())))?;
            (0..n).collect()
        }
    };

    let tris: Vec<[u32; 3]> = match mode {
        Mode::Triangles => {
            if !indices.len().is_multiple_of(3) {
                return Err(SceneError::parse(
                    file,
                    format!(
                        "{}: {} indices is not a multiple of 3",
                        what(),
                        indices.len()
                    ),
                ));
            }
            indices
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect()
        }
        Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [indices[i], indices[i + 1], indices[i + 2]]
                } else {
                    [indices[i + 1], indices[i], indices[i + 2]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..indices.len().saturating_sub(1))
            .map(|i| [indices[0], indices[i], indices[i + 1]])
            .collect(),
        _ => Vec::new(),
    };

    let base = out.positions.len();
    if base + vertex_count > u32::MAX as usize {
        return Err(SceneError::parse(
            file,
            format!("{}: the scene has more than 2^32 vertices", what()),
        ));
    }
    for (t, tri) in tris.iter().enumerate() {
        for &i in tri {
            if i as usize >= vertex_count {
                return Err(SceneError::IndexOutOfRange {
                    file: file.to_path_buf(),
                    triangle: out.indices.len() + t,
                    index: i64::from(i),
                    vertex_count,
                });
            }
        }
    }
    out.positions.reserve(vertex_count);
    for c in raw.chunks_exact(12) {
        let f = |k: usize| {
            f64::from(f32::from_le_bytes([
                c[4 * k],
                c[4 * k + 1],
                c[4 * k + 2],
                c[4 * k + 3],
            ]))
        };
        let p = world.transform_point3(DVec3::new(f(0), f(1), f(2)));
        out.positions
            .push(Vec3A::new(p.x as f32, p.y as f32, p.z as f32));
    }
    let base = base as u32;
    out.indices.extend(tris.iter().map(|t| t.map(|i| i + base)));
    Ok(())
}

/// The tightly packed bytes of the elements of a (non-sparse) accessor, with every offset
/// and length checked against its buffer view and buffer.
fn read_accessor(acc: &gltf::Accessor<'_>, buffers: &[&[u8]]) -> Result<Vec<u8>, String> {
    if acc.sparse().is_some() {
        return Err("sparse accessors are not supported".to_string());
    }
    let view = acc.view().ok_or_else(|| "has no buffer view".to_string())?;
    let elem = acc.size();
    let count = acc.count();
    if count == 0 {
        return Ok(Vec::new());
    }
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return Err(format!(
            "byte stride {stride} is smaller than the element size {elem}"
        ));
    }
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or_else(|| format!("buffer {} is missing", view.buffer().index()))?;
    let overflow = || "offsets overflow".to_string();
    let view_end = view
        .offset()
        .checked_add(view.length())
        .ok_or_else(overflow)?;
    if view_end > buffer.len() {
        return Err(format!(
            "buffer view {} (bytes {}..{view_end}) runs past the end of buffer {} ({} bytes)",
            view.index(),
            view.offset(),
            view.buffer().index(),
            buffer.len()
        ));
    }
    let start = view
        .offset()
        .checked_add(acc.offset())
        .ok_or_else(overflow)?;
    let end = stride
        .checked_mul(count - 1)
        .and_then(|x| x.checked_add(elem))
        .and_then(|x| x.checked_add(start))
        .ok_or_else(overflow)?;
    if end > view_end {
        return Err(format!(
            "{count} elements of {elem} bytes (stride {stride}) run past the end of buffer view {}",
            view.index()
        ));
    }
    let mut out = Vec::with_capacity(count * elem);
    for i in 0..count {
        let s = start + i * stride;
        out.extend_from_slice(&buffer[s..s + elem]);
    }
    Ok(out)
}
