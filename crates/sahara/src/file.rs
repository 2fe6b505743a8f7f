//! The file format of a saved [`Accel`].
//!
//! ```text
//! offset  size   field
//! 0       8      magic "SAHARACC"
//! 8       4      version (u32, little endian; this is version 1)
//! 12      4      quality code (0 fast, 1 medium, 2 high, 3 best)
//! 16      4      c_t (f32 bits)
//! 20      4      c_i (f32 bits)
//! 24      8      triangle count n (u64)
//! 32      8      tree length t in bytes (u64)
//! 40      8      FNV-1a 64 checksum of bytes 8..40 and of everything after the header
//! 48      36·n   triangles: 9 f32 each (vertex a, b, c; x, y, z), little endian
//! ...     t      the binary tree: a complete `sahara-bvh` file (`Bvh::save`), with its own
//!                header, version and checksum
//! ```
//!
//! The wide layout is **not** stored: it is rebuilt on load by the same deterministic
//! collapse that built it (it depends on the binary tree only, not on the CPU), so the file
//! does not change when the layout's internal format does, and a file written on one machine
//! loads on any other. Loading is not free: on the example's 9 218 triangles it took 53 ms
//! (checksums, validation, collapse) against 18 ms for a `Medium` build and 1.3 s for `High`
//! (one run, loaded machine), so caching pays for `High` and `Best`.
//!
//! An instance set ([`crate::Instances`]) has a file of its own:
//!
//! ```text
//! offset  size   field
//! 0       8      magic "SAHARINS"
//! 8       4      version (u32; this is version 2, version 1 is still read)
//! 12      4      quality code of the top level
//! 16      4      c_t (f32 bits)
//! 20      4      c_i (f32 bits)
//! 24      8      mesh count m (u64)
//! 32      8      placement count p (u64)
//! 40      8      payload length in bytes (u64)
//! 48      8      FNV-1a 64 checksum of bytes 8..48 and of the payload
//! 56      ...    payload: m meshes, each a u64 length and a complete `SAHARACC` file;
//!                then p placements of 52 bytes: mesh index (u32) and the transform's
//!                12 f32 (the 3×3 matrix column by column, then the translation)
//!                (the transforms as moved by `Instances::set_transform`);
//!                then, since version 2, p masks (u32 each, in placement order)
//! ```
//!
//! A version 1 file has no masks: every instance loads with all mask bits set.
//!
//! The top level is not stored: loading rebuilds it with the stored quality level's builder
//! over the placements' world boxes, which gives the same tree (builders are deterministic).
//!
//! A [`Scene`] of triangle geometries ([`Scene::save`];
//! user primitives cannot be saved: their callbacks are code) has a file of its own:
//!
//! ```text
//! offset  size   field
//! 0       8      magic "SAHARSCN"
//! 8       4      version (u32; this is version 1)
//! 12      4      quality code
//! 16      4      c_t (f32 bits)
//! 20      4      c_i (f32 bits)
//! 24      8      geometry count g (u64)
//! 32      8      triangle count n (u64)
//! 40      8      tree length t in bytes (u64)
//! 48      8      FNV-1a 64 checksum of bytes 8..48 and of everything after the header
//! 56      8·g    per geometry, in index order: its mask (u32) and its triangle count (u32)
//! ...     36·n   the triangles of all geometries in index order, as in an Accel file
//! ...     t      the scene's binary tree: a complete `sahara-bvh` file
//! ```
//!
//! As for an `Accel`, the 8-wide layout is rebuilt on load, and the loaded scene's tree and
//! layout equal the saved one's.

use std::io::{Read, Write};

use sahara_bvh::Bvh;
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::CostModel;

use crate::{Accel, Affine3A, BuildOptions, Error, Instances, LoadError, Quality, Scene};

/// The first eight bytes of every saved acceleration structure.
pub const MAGIC: [u8; 8] = *b"SAHARACC";
/// The version of the format this build writes and reads.
pub const VERSION: u32 = 1;
const HEADER_LEN: usize = 48;
const TRIANGLE_BYTES: u64 = 36;

/// FNV-1a 64 over the header's fields (bytes 8..40) and the payload.
fn checksum(fields: &[u8], payload: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in fields.iter().chain(payload) {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

pub(crate) fn save<W: Write>(accel: &Accel, w: &mut W) -> std::io::Result<()> {
    let mut payload = Vec::with_capacity(accel.triangles.len() * TRIANGLE_BYTES as usize);
    push_triangles(&mut payload, &accel.triangles);
    let mut tree = Vec::new();
    accel.bvh.save(&mut tree)?;
    payload.extend_from_slice(&tree);
    let mut header = Vec::with_capacity(HEADER_LEN);
    header.extend_from_slice(&MAGIC);
    header.extend_from_slice(&VERSION.to_le_bytes());
    header.extend_from_slice(&accel.quality.code().to_le_bytes());
    header.extend_from_slice(&accel.cost.traversal.to_le_bytes());
    header.extend_from_slice(&accel.cost.intersection.to_le_bytes());
    header.extend_from_slice(&(accel.triangles.len() as u64).to_le_bytes());
    header.extend_from_slice(&(tree.len() as u64).to_le_bytes());
    let sum = checksum(&header[8..40], &payload);
    header.extend_from_slice(&sum.to_le_bytes());
    w.write_all(&header)?;
    w.write_all(&payload)
}

/// Appends the triangles, 36 bytes each (vertex a, b, c; x, y, z; f32 little endian).
fn push_triangles(payload: &mut Vec<u8>, triangles: &[Triangle]) {
    for t in triangles {
        for v in t.v {
            for x in v.to_array() {
                payload.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
}

/// The triangles of [`push_triangles`]' bytes (a multiple of 36), checked finite.
fn read_triangles(bytes: &[u8]) -> Result<Vec<Triangle>, LoadError> {
    let f = |c: &[u8], i: usize| {
        f32::from_le_bytes([c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]])
    };
    let triangles: Vec<Triangle> = bytes
        .chunks_exact(TRIANGLE_BYTES as usize)
        .map(|c| {
            let v = |k: usize| Vec3A::new(f(c, 3 * k), f(c, 3 * k + 1), f(c, 3 * k + 2));
            Triangle::new(v(0), v(1), v(2))
        })
        .collect();
    match triangles.iter().position(|t| !t.is_finite()) {
        Some(i) => Err(LoadError::NonFinite(i)),
        None => Ok(triangles),
    }
}

/// The stored quality code and cost model (`c_t` and `c_i` as f32 bits), checked.
fn quality_and_cost(code: u32, c_t: u32, c_i: u32) -> Result<(Quality, CostModel), LoadError> {
    let quality = Quality::from_code(code).ok_or(LoadError::UnknownQuality(code))?;
    let cost = CostModel {
        traversal: f32::from_bits(c_t),
        intersection: f32::from_bits(c_i),
    };
    if !(cost.traversal.is_finite()
        && cost.intersection.is_finite()
        && cost.traversal >= 0.0
        && cost.intersection > 0.0)
    {
        return Err(LoadError::InvalidCostModel);
    }
    Ok((quality, cost))
}

/// The little-endian u32 at byte `o` of `h`.
fn u32_at(h: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]])
}

/// The little-endian u64 at byte `o` of `h`.
fn u64_at(h: &[u8], o: usize) -> u64 {
    u64::from(u32_at(h, o)) | u64::from(u32_at(h, o + 4)) << 32
}

/// Reads a header of `N` bytes that starts with `magic` and this build's [`VERSION`] (bytes
/// 8..12): a foreign, short or other-version header is a typed error.
fn read_header<R: Read, const N: usize>(
    r: &mut R,
    magic: &[u8; 8],
    versions: &[u32],
) -> Result<[u8; N], LoadError> {
    let mut header = [0u8; N];
    let mut got = 0;
    while got < N {
        match r.read(&mut header[got..]) {
            Ok(0) => break,
            Ok(k) => got += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.into()),
        }
    }
    if got >= magic.len() && header[..magic.len()] != magic[..] {
        return Err(LoadError::BadMagic);
    }
    if got < N {
        return Err(LoadError::Truncated {
            expected: N as u64,
            actual: got as u64,
        });
    }
    let version = u32_at(&header, 8);
    if !versions.contains(&version) {
        return Err(LoadError::UnsupportedVersion(version));
    }
    Ok(header)
}

/// Reads the payload after a header of `header_len` bytes: exactly `expected` bytes (`None`
/// when the header's size fields overflow). At most the announced bytes plus one are read
/// (to detect trailing data), so the allocation grows with the bytes present, never with the
/// size fields.
fn read_payload<R: Read>(
    r: &mut R,
    expected: Option<u64>,
    header_len: usize,
) -> Result<Vec<u8>, LoadError> {
    let limit = expected.unwrap_or(u64::MAX).saturating_add(1);
    let mut payload = Vec::new();
    r.take(limit).read_to_end(&mut payload)?;
    let actual = payload.len() as u64;
    let total = |n: u64| n.saturating_add(header_len as u64);
    let Some(expected) = expected else {
        return Err(LoadError::Truncated {
            expected: u64::MAX,
            actual: total(actual),
        });
    };
    if actual < expected {
        return Err(LoadError::Truncated {
            expected: total(expected),
            actual: total(actual),
        });
    }
    if actual > expected {
        let mut rest = Vec::new();
        r.take(1 << 20).read_to_end(&mut rest)?;
        return Err(LoadError::TrailingData(
            actual - expected + rest.len() as u64,
        ));
    }
    Ok(payload)
}

pub(crate) fn load<R: Read>(r: &mut R) -> Result<Accel, LoadError> {
    let header: [u8; HEADER_LEN] = read_header(r, &MAGIC, &[VERSION])?;
    let u32_at = |o: usize| u32_at(&header, o);
    let u64_at = |o: usize| u64_at(&header, o);
    let (n_tris, tree_len, sum) = (u64_at(24), u64_at(32), u64_at(40));
    let expected = n_tris
        .checked_mul(TRIANGLE_BYTES)
        .and_then(|a| a.checked_add(tree_len));
    let payload = read_payload(r, expected, HEADER_LEN)?;
    if checksum(&header[8..40], &payload) != sum {
        return Err(LoadError::Checksum);
    }
    let (quality, cost) = quality_and_cost(u32_at(12), u32_at(16), u32_at(20))?;
    // The sizes were checked against the bytes present, so they fit in memory.
    let (tri_bytes, mut tree_bytes) = payload.split_at((n_tris * TRIANGLE_BYTES) as usize);
    let triangles = read_triangles(tri_bytes)?;
    let bvh = Bvh::load(&mut tree_bytes)?;
    bvh.validate(&triangles).map_err(LoadError::InvalidTree)?;
    Ok(Accel::assemble(triangles, bvh, quality, cost))
}

/// The first eight bytes of a saved instance set.
pub const INSTANCES_MAGIC: [u8; 8] = *b"SAHARINS";
/// The version of the instance-set format this build writes (it reads this one and 1).
///
/// ```
/// assert_eq!(sahara::file::INSTANCES_VERSION, 2);
/// ```
pub const INSTANCES_VERSION: u32 = 2;
const INSTANCES_HEADER_LEN: usize = 56;
const PLACEMENT_BYTES: usize = 52;

pub(crate) fn save_instances<W: Write>(set: &Instances, w: &mut W) -> std::io::Result<()> {
    let mut payload = Vec::new();
    for mesh in set.meshes() {
        let mut bytes = Vec::new();
        save(mesh, &mut bytes)?;
        payload.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
        payload.extend_from_slice(&bytes);
    }
    for &(mesh, m) in set.placements() {
        payload.extend_from_slice(&(mesh as u32).to_le_bytes());
        for x in m.to_cols_array() {
            payload.extend_from_slice(&x.to_le_bytes());
        }
    }
    for &mask in set.set().masks() {
        payload.extend_from_slice(&mask.to_le_bytes());
    }
    let options = set.options();
    let mut header = Vec::with_capacity(INSTANCES_HEADER_LEN);
    header.extend_from_slice(&INSTANCES_MAGIC);
    header.extend_from_slice(&INSTANCES_VERSION.to_le_bytes());
    header.extend_from_slice(&options.quality.code().to_le_bytes());
    header.extend_from_slice(&options.cost.traversal.to_le_bytes());
    header.extend_from_slice(&options.cost.intersection.to_le_bytes());
    header.extend_from_slice(&(set.meshes().len() as u64).to_le_bytes());
    header.extend_from_slice(&(set.placements().len() as u64).to_le_bytes());
    header.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    let sum = checksum(&header[8..48], &payload);
    header.extend_from_slice(&sum.to_le_bytes());
    w.write_all(&header)?;
    w.write_all(&payload)
}

pub(crate) fn load_instances<R: Read>(r: &mut R) -> Result<Instances, LoadError> {
    let header: [u8; INSTANCES_HEADER_LEN] = read_header(r, &INSTANCES_MAGIC, &[1, 2])?;
    let per_placement = if u32_at(&header, 8) >= 2 {
        PLACEMENT_BYTES + 4
    } else {
        PLACEMENT_BYTES
    };
    let u32_at = |o: usize| u32_at(&header, o);
    let u64_at = |o: usize| u64_at(&header, o);
    let (n_meshes, n_placements, expected, sum) = (u64_at(24), u64_at(32), u64_at(40), u64_at(48));
    let payload = read_payload(r, Some(expected), INSTANCES_HEADER_LEN)?;
    let actual = payload.len() as u64;
    let total = |n: u64| n.saturating_add(INSTANCES_HEADER_LEN as u64);
    if checksum(&header[8..48], &payload) != sum {
        return Err(LoadError::Checksum);
    }
    let quality = Quality::from_code(u32_at(12)).ok_or(LoadError::UnknownQuality(u32_at(12)))?;
    let cost = CostModel {
        traversal: f32::from_bits(u32_at(16)),
        intersection: f32::from_bits(u32_at(20)),
    };
    // The payload is consumed front to back; a count or length that runs past its end is
    // a truncation of the inner data.
    let mut rest: &[u8] = &payload;
    let short = || LoadError::Truncated {
        expected: u64::MAX,
        actual: total(actual),
    };
    let mut meshes = Vec::new();
    for _ in 0..n_meshes {
        if rest.len() < 8 {
            return Err(short());
        }
        let (len, tail) = rest.split_at(8);
        let len = u64::from_le_bytes(len.try_into().expect("8 bytes"));
        if len > tail.len() as u64 {
            return Err(short());
        }
        let (mut bytes, tail) = tail.split_at(len as usize);
        meshes.push(load(&mut bytes)?);
        rest = tail;
    }
    let placement_bytes = n_placements.checked_mul(per_placement as u64);
    if placement_bytes != Some(rest.len() as u64) {
        return Err(LoadError::InvalidInstances(format!(
            "{} placements announced, {} bytes left for them",
            n_placements,
            rest.len()
        )));
    }
    let (rest, mask_bytes) = rest.split_at(n_placements as usize * PLACEMENT_BYTES);
    let placements: Vec<(usize, Affine3A)> = rest
        .chunks_exact(PLACEMENT_BYTES)
        .map(|c| {
            let f = |i: usize| {
                let o = 4 + 4 * i;
                f32::from_le_bytes([c[o], c[o + 1], c[o + 2], c[o + 3]])
            };
            let mesh = u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as usize;
            let m: [f32; 12] = std::array::from_fn(f);
            (mesh, Affine3A::from_cols_array(&m))
        })
        .collect();
    let options = BuildOptions {
        quality,
        cost,
        threads: None,
    };
    let mut set = Instances::build(meshes, &placements, options).map_err(|e| match e {
        Error::Build(_) => LoadError::InvalidCostModel,
        other => LoadError::InvalidInstances(other.to_string()),
    })?;
    for (i, m) in mask_bytes.chunks_exact(4).enumerate() {
        let mask = u32::from_le_bytes([m[0], m[1], m[2], m[3]]);
        set.set_mask(i, mask)
            .map_err(|e| LoadError::InvalidInstances(e.to_string()))?;
    }
    Ok(set)
}

/// The first eight bytes of a saved [`Scene`].
///
/// ```
/// assert_eq!(&sahara::file::SCENE_MAGIC, b"SAHARSCN");
/// ```
pub const SCENE_MAGIC: [u8; 8] = *b"SAHARSCN";
/// The version of the scene format this build writes and reads.
///
/// ```
/// assert_eq!(sahara::file::SCENE_VERSION, 1);
/// ```
pub const SCENE_VERSION: u32 = 1;
const SCENE_HEADER_LEN: usize = 56;
const GEOMETRY_BYTES: u64 = 8;

pub(crate) fn save_scene<W: Write>(scene: &Scene, w: &mut W) -> std::io::Result<()> {
    let parts = scene
        .saved_parts()
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::Unsupported, e))?;
    let mut payload = Vec::with_capacity(
        parts.geometries.len() * GEOMETRY_BYTES as usize
            + parts.triangles.len() * TRIANGLE_BYTES as usize,
    );
    for &(mask, len) in &parts.geometries {
        payload.extend_from_slice(&mask.to_le_bytes());
        payload.extend_from_slice(&len.to_le_bytes());
    }
    push_triangles(&mut payload, parts.triangles);
    let mut tree = Vec::new();
    parts.bvh.save(&mut tree)?;
    payload.extend_from_slice(&tree);
    let mut header = Vec::with_capacity(SCENE_HEADER_LEN);
    header.extend_from_slice(&SCENE_MAGIC);
    header.extend_from_slice(&SCENE_VERSION.to_le_bytes());
    header.extend_from_slice(&parts.quality.code().to_le_bytes());
    header.extend_from_slice(&parts.cost.traversal.to_le_bytes());
    header.extend_from_slice(&parts.cost.intersection.to_le_bytes());
    header.extend_from_slice(&(parts.geometries.len() as u64).to_le_bytes());
    header.extend_from_slice(&(parts.triangles.len() as u64).to_le_bytes());
    header.extend_from_slice(&(tree.len() as u64).to_le_bytes());
    let sum = checksum(&header[8..48], &payload);
    header.extend_from_slice(&sum.to_le_bytes());
    w.write_all(&header)?;
    w.write_all(&payload)
}

pub(crate) fn load_scene<R: Read>(r: &mut R) -> Result<Scene, LoadError> {
    let header: [u8; SCENE_HEADER_LEN] = read_header(r, &SCENE_MAGIC, &[SCENE_VERSION])?;
    let field = |o: usize| u32_at(&header, o);
    let u64_at = |o: usize| u64_at(&header, o);
    let (n_geometries, n_tris, tree_len, sum) = (u64_at(24), u64_at(32), u64_at(40), u64_at(48));
    let expected = n_geometries
        .checked_mul(GEOMETRY_BYTES)
        .and_then(|g| n_tris.checked_mul(TRIANGLE_BYTES)?.checked_add(g))
        .and_then(|a| a.checked_add(tree_len));
    let payload = read_payload(r, expected, SCENE_HEADER_LEN)?;
    if checksum(&header[8..48], &payload) != sum {
        return Err(LoadError::Checksum);
    }
    let (quality, cost) = quality_and_cost(field(12), field(16), field(20))?;
    // The sizes were checked against the bytes present, so they fit in memory.
    let (geo_bytes, rest) = payload.split_at((n_geometries * GEOMETRY_BYTES) as usize);
    let (tri_bytes, mut tree_bytes) = rest.split_at((n_tris * TRIANGLE_BYTES) as usize);
    let geometries: Vec<(u32, u32)> = geo_bytes
        .chunks_exact(GEOMETRY_BYTES as usize)
        .map(|c| (u32_at(c, 0), u32_at(c, 4)))
        .collect();
    let total: u64 = geometries.iter().map(|&(_, len)| u64::from(len)).sum();
    if total != n_tris {
        return Err(LoadError::InvalidScene(format!(
            "the geometries hold {total} triangles, the file {n_tris}"
        )));
    }
    if n_tris >= u64::from(u32::MAX) {
        return Err(LoadError::InvalidScene(format!(
            "{n_tris} triangles exceed 2^32 - 1"
        )));
    }
    let triangles = read_triangles(tri_bytes)?;
    let bvh = Bvh::load(&mut tree_bytes)?;
    bvh.validate(&triangles).map_err(LoadError::InvalidTree)?;
    Ok(Scene::from_saved(geometries, triangles, bvh, quality, cost))
}
