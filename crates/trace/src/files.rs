//! Ray files and hit files (`docs/command-line.md`, "Ray and hit files"): flat arrays of
//! little-endian records, so that any two tracers can be compared ray by ray.
//!
//! * ray record, 32 bytes: `[ox, oy, oz, tmin, dx, dy, dz, tmax]` as `f32`;
//! * hit record, 16 bytes: `[t, prim, u, v]`, `t` an `f32` (`+inf` for a miss), `prim` a
//!   `u32` (`u32::MAX` for a miss), `u`, `v` `f32`.
//!
//! There is no header: the number of records is the file length divided by the record size.
//! Reading a file whose length is not a multiple of the record size, or that cannot be read,
//! is a [`TraceError`] naming the file. Values are stored bit for bit (NaNs included); the
//! reciprocal direction of a ray is recomputed on reading.

use crate::TraceError;
use sahara_geom::{Ray, Vec3A};
use sahara_traverse::Hit;
use std::io::Write;
use std::path::Path;

/// Size of a ray record in bytes.
pub const RAY_RECORD_BYTES: usize = 32;
/// Size of a hit record in bytes.
pub const HIT_RECORD_BYTES: usize = 16;

#[inline]
fn f32_at(b: &[u8], i: usize) -> f32 {
    f32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]])
}

#[inline]
fn u32_at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]])
}

/// The bytes of a ray file holding `rays`.
pub fn encode_rays(rays: &[Ray]) -> Vec<u8> {
    let mut out = Vec::with_capacity(rays.len() * RAY_RECORD_BYTES);
    for r in rays {
        let o = r.origin;
        let d = r.direction();
        for x in [o.x, o.y, o.z, r.tmin, d.x, d.y, d.z, r.tmax] {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out
}

/// The rays of a ray file's bytes, or `None` when the length is not a multiple of
/// [`RAY_RECORD_BYTES`].
pub fn decode_rays(bytes: &[u8]) -> Option<Vec<Ray>> {
    decode(bytes, RAY_RECORD_BYTES, |b| {
        let f = |i| f32_at(b, i);
        Ray::new(
            Vec3A::new(f(0), f(1), f(2)),
            Vec3A::new(f(4), f(5), f(6)),
            f(3),
            f(7),
        )
    })
}

/// The bytes of a hit file holding `hits`.
pub fn encode_hits(hits: &[Hit]) -> Vec<u8> {
    let mut out = Vec::with_capacity(hits.len() * HIT_RECORD_BYTES);
    for h in hits {
        out.extend_from_slice(&h.t.to_le_bytes());
        out.extend_from_slice(&h.prim.to_le_bytes());
        out.extend_from_slice(&h.u.to_le_bytes());
        out.extend_from_slice(&h.v.to_le_bytes());
    }
    out
}

/// The hits of a hit file's bytes, or `None` when the length is not a multiple of
/// [`HIT_RECORD_BYTES`].
pub fn decode_hits(bytes: &[u8]) -> Option<Vec<Hit>> {
    decode(bytes, HIT_RECORD_BYTES, |b| Hit {
        t: f32_at(b, 0),
        prim: u32_at(b, 1),
        u: f32_at(b, 2),
        v: f32_at(b, 3),
    })
}

/// `f` of every record of `record` bytes, or `None` when the length of `bytes` is not a
/// multiple of `record`.
fn decode<T>(bytes: &[u8], record: usize, f: impl Fn(&[u8]) -> T) -> Option<Vec<T>> {
    if !bytes.len().is_multiple_of(record) {
        return None;
    }
    Some(bytes.chunks_exact(record).map(f).collect())
}

/// Reads the file at `path` and decodes its records of `record` bytes each (`what` names them
/// in a [`TraceError::BadLength`]).
fn read_records<T>(
    path: &Path,
    decode: fn(&[u8]) -> Option<Vec<T>>,
    record: usize,
    what: &'static str,
) -> Result<Vec<T>, TraceError> {
    let bytes = std::fs::read(path).map_err(|source| TraceError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode(&bytes).ok_or_else(|| TraceError::BadLength {
        path: path.to_path_buf(),
        len: bytes.len() as u64,
        record,
        what,
    })
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), TraceError> {
    let io = |source| TraceError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut f = std::fs::File::create(path).map_err(io)?;
    f.write_all(bytes).map_err(io)?;
    f.flush().map_err(io)
}

/// Reads a ray file.
///
/// # Errors
///
/// [`TraceError::Io`] when the file cannot be read, [`TraceError::BadLength`] when its length
/// is not a multiple of 32 bytes.
pub fn read_rays(path: impl AsRef<Path>) -> Result<Vec<Ray>, TraceError> {
    read_records(path.as_ref(), decode_rays, RAY_RECORD_BYTES, "ray")
}

/// Writes a ray file (created or truncated).
///
/// # Errors
///
/// [`TraceError::Io`] when the file cannot be created or written.
pub fn write_rays(path: impl AsRef<Path>, rays: &[Ray]) -> Result<(), TraceError> {
    write_file(path.as_ref(), &encode_rays(rays))
}

/// Reads a hit file.
///
/// # Errors
///
/// [`TraceError::Io`] when the file cannot be read, [`TraceError::BadLength`] when its length
/// is not a multiple of 16 bytes.
pub fn read_hits(path: impl AsRef<Path>) -> Result<Vec<Hit>, TraceError> {
    read_records(path.as_ref(), decode_hits, HIT_RECORD_BYTES, "hit")
}

/// Writes a hit file (created or truncated).
///
/// # Errors
///
/// [`TraceError::Io`] when the file cannot be created or written.
pub fn write_hits(path: impl AsRef<Path>, hits: &[Hit]) -> Result<(), TraceError> {
    write_file(path.as_ref(), &encode_hits(hits))
}
