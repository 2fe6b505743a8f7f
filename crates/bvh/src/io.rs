//! The BVH file format.
//!
//! ```text
//! offset  size  field
//! 0       8     magic "SAHARBVH"
//! 8       4     version (u32, little endian)
//! 12      4     flags (bit 0: spatial splits)
//! 16      8     node count (u64)
//! 24      8     reference count (u64)
//! 32      8     FNV-1a 64 checksum of everything after the header
//! 40      32·n  nodes (Node, little endian)
//! ...     4·r   references (u32)
//! ```
//!
//! Loading reads the header first and never allocates more than the bytes actually present;
//! a truncated, oversized or corrupted file is a [`LoadError`], and the loaded tree passes
//! [`Bvh::validate_structure`] so traversing it cannot read out of bounds.

use crate::{Bvh, Node, ValidationError};
use std::io::{Read, Write};

/// First eight bytes of every BVH file.
pub const FILE_MAGIC: [u8; 8] = *b"SAHARBVH";
/// Current version of the file format.
pub const FILE_VERSION: u32 = 1;
const HEADER_LEN: usize = 40;

/// Why a BVH file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// Reading failed.
    #[error("reading the BVH file failed: {0}")]
    Io(#[from] std::io::Error),
    /// The file does not start with [`FILE_MAGIC`].
    #[error("not a sahara BVH file (bad magic)")]
    BadMagic,
    /// The file was written by another version of the format.
    #[error("unsupported BVH file version {0} (this build reads version {FILE_VERSION})")]
    UnsupportedVersion(u32),
    /// The file ends before the data its header announces.
    #[error("truncated BVH file: header announces {expected} bytes, file has {actual}")]
    Truncated {
        /// Bytes the header announces.
        expected: u64,
        /// Bytes present.
        actual: u64,
    },
    /// There are bytes after the announced data.
    #[error("BVH file has {0} unexpected trailing bytes")]
    TrailingData(u64),
    /// The payload does not match the checksum.
    #[error("BVH file checksum mismatch (file is corrupted)")]
    Checksum,
    /// Unknown flag bits are set.
    #[error("BVH file has unknown flags {0:#x}")]
    UnknownFlags(u32),
    /// The data is intact but does not form a valid tree.
    #[error("BVH file holds an invalid tree: {0}")]
    Invalid(#[from] ValidationError),
}

fn fnv1a(data: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in data {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

impl Bvh {
    /// Writes the tree in the versioned format described in the module docs.
    pub fn save<W: Write>(&self, w: &mut W) -> std::io::Result<()> {
        let mut payload = Vec::with_capacity(self.nodes.len() * 32 + self.prim_indices.len() * 4);
        for n in &self.nodes {
            for v in n.min {
                payload.extend_from_slice(&v.to_le_bytes());
            }
            payload.extend_from_slice(&n.index.to_le_bytes());
            for v in n.max {
                payload.extend_from_slice(&v.to_le_bytes());
            }
            payload.extend_from_slice(&n.count.to_le_bytes());
        }
        for p in &self.prim_indices {
            payload.extend_from_slice(&p.to_le_bytes());
        }
        let mut header = Vec::with_capacity(HEADER_LEN);
        header.extend_from_slice(&FILE_MAGIC);
        header.extend_from_slice(&FILE_VERSION.to_le_bytes());
        header.extend_from_slice(&(self.spatial_splits as u32).to_le_bytes());
        header.extend_from_slice(&(self.nodes.len() as u64).to_le_bytes());
        header.extend_from_slice(&(self.prim_indices.len() as u64).to_le_bytes());
        header.extend_from_slice(&fnv1a(&payload).to_le_bytes());
        w.write_all(&header)?;
        w.write_all(&payload)
    }

    /// Reads a tree written by [`Bvh::save`]. Checks the magic, version, flags, sizes,
    /// checksum and the tree's structure; never panics and never allocates more than the bytes
    /// the reader actually delivers.
    pub fn load<R: Read>(r: &mut R) -> Result<Bvh, LoadError> {
        let mut header = [0u8; HEADER_LEN];
        let mut got = 0;
        while got < HEADER_LEN {
            match r.read(&mut header[got..])? {
                0 => break,
                k => got += k,
            }
        }
        if got < 8 || header[..8] != FILE_MAGIC {
            return Err(if got < 8 {
                LoadError::Truncated {
                    expected: HEADER_LEN as u64,
                    actual: got as u64,
                }
            } else {
                LoadError::BadMagic
            });
        }
        if got < HEADER_LEN {
            return Err(LoadError::Truncated {
                expected: HEADER_LEN as u64,
                actual: got as u64,
            });
        }
        let u32_at = |o: usize| u32::from_le_bytes(header[o..o + 4].try_into().unwrap());
        let u64_at = |o: usize| u64::from_le_bytes(header[o..o + 8].try_into().unwrap());
        let version = u32_at(8);
        if version != FILE_VERSION {
            return Err(LoadError::UnsupportedVersion(version));
        }
        let flags = u32_at(12);
        if flags & !1 != 0 {
            return Err(LoadError::UnknownFlags(flags));
        }
        let (n_nodes, n_refs, checksum) = (u64_at(16), u64_at(24), u64_at(32));
        let expected = n_nodes
            .checked_mul(32)
            .and_then(|a| n_refs.checked_mul(4).and_then(|b| a.checked_add(b)));
        // Read at most what the header announces (plus one byte to detect trailing data):
        // the allocation grows with the bytes present, not with the size fields.
        let limit = expected.unwrap_or(u64::MAX).saturating_add(1);
        let mut payload = Vec::new();
        r.take(limit).read_to_end(&mut payload)?;
        let actual = payload.len() as u64;
        let Some(expected) = expected else {
            return Err(LoadError::Truncated {
                expected: u64::MAX,
                actual,
            });
        };
        if actual < expected {
            return Err(LoadError::Truncated { expected, actual });
        }
        if actual > expected {
            let mut rest = Vec::new();
            r.take(1 << 20).read_to_end(&mut rest)?;
            return Err(LoadError::TrailingData(
                actual - expected + rest.len() as u64,
            ));
        }
        if fnv1a(&payload) != checksum {
            return Err(LoadError::Checksum);
        }
        let (node_bytes, ref_bytes) = payload.split_at(n_nodes as usize * 32);
        let word = |b: &[u8], i: usize| u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
        let nodes = node_bytes
            .chunks_exact(32)
            .map(|c| Node {
                min: [0, 1, 2].map(|k| f32::from_bits(word(c, k))),
                index: word(c, 3),
                max: [4, 5, 6].map(|k| f32::from_bits(word(c, k))),
                count: word(c, 7),
            })
            .collect();
        let prim_indices = ref_bytes.chunks_exact(4).map(|c| word(c, 0)).collect();
        let bvh = Bvh {
            nodes,
            prim_indices,
            spatial_splits: flags & 1 != 0,
        };
        bvh.validate_structure()?;
        Ok(bvh)
    }

    /// Saves to a file path.
    pub fn save_to_path(&self, path: &std::path::Path) -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
        self.save(&mut w)?;
        w.flush()
    }

    /// Loads from a file path.
    pub fn load_from_path(path: &std::path::Path) -> Result<Bvh, LoadError> {
        let mut f = std::io::BufReader::new(std::fs::File::open(path)?);
        Self::load(&mut f)
    }
}
