//! The BVH file format.
//!
//! ```text
//! offset  size  field
//! 0       8     magic "SAHARBVH"
//! 8       4     version (u32, little endian): 1, or 2 with cut records
//! 12      4     flags (bit 0: spatial splits; bit 1, version 2 only: cut records follow)
//! 16      8     node count (u64)
//! 24      8     reference count (u64)
//! 32      8     FNV-1a 64 checksum of everything after the header
//! 40      8     version 2 only: cut count c (u64)
//! ...     32·n  nodes (Node, little endian)
//! ...     4·r   references (u32)
//! ...     4·(r+1) version 2 with bit 1 only: start of each reference's cuts, then the end
//! ...     8·c   version 2 with bit 1 only: cuts (position's bits, axis | keep << 2)
//! ```
//!
//! A tree without cut records ([`Bvh::ref_cuts`]) is written as version 1, byte for byte as
//! before version 2 existed; a tree with them as version 2. Both versions load; a version-1
//! file gives a tree without cut records, which refits with whole triangle boxes.
//!
//! Loading reads the header first and never allocates more than the bytes actually present;
//! a truncated, oversized or corrupted file is a [`LoadError`], and the loaded tree passes
//! [`Bvh::validate_structure`] so traversing it cannot read out of bounds.

use crate::{Bvh, Cut, Node, RefCuts, ValidationError};
use std::io::{Read, Write};

/// First eight bytes of every BVH file.
pub const FILE_MAGIC: [u8; 8] = *b"SAHARBVH";
/// Current version of the file format (trees without cut records are still written as
/// version 1).
pub const FILE_VERSION: u32 = 2;
const HEADER_LEN: usize = 40;
/// Flag bit 0: spatial splits.
const FLAG_SPATIAL: u32 = 1;
/// Flag bit 1: cut records follow the references (version 2).
const FLAG_CUTS: u32 = 2;

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
    #[error("unsupported BVH file version {0} (this build reads versions 1 to {FILE_VERSION})")]
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
        let mut flags = self.spatial_splits as u32;
        if let Some(cuts) = &self.ref_cuts {
            flags |= FLAG_CUTS;
            for s in cuts.starts() {
                payload.extend_from_slice(&s.to_le_bytes());
            }
            for c in cuts.cuts() {
                for w in c.to_words() {
                    payload.extend_from_slice(&w.to_le_bytes());
                }
            }
        }
        let version: u32 = if self.ref_cuts.is_some() { 2 } else { 1 };
        let mut header = Vec::with_capacity(HEADER_LEN + 8);
        header.extend_from_slice(&FILE_MAGIC);
        header.extend_from_slice(&version.to_le_bytes());
        header.extend_from_slice(&flags.to_le_bytes());
        header.extend_from_slice(&(self.nodes.len() as u64).to_le_bytes());
        header.extend_from_slice(&(self.prim_indices.len() as u64).to_le_bytes());
        header.extend_from_slice(&fnv1a(&payload).to_le_bytes());
        if let Some(cuts) = &self.ref_cuts {
            header.extend_from_slice(&(cuts.cut_count() as u64).to_le_bytes());
        }
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
        if !(1..=FILE_VERSION).contains(&version) {
            return Err(LoadError::UnsupportedVersion(version));
        }
        let flags = u32_at(12);
        let known = if version >= 2 {
            FLAG_SPATIAL | FLAG_CUTS
        } else {
            FLAG_SPATIAL
        };
        if flags & !known != 0 {
            return Err(LoadError::UnknownFlags(flags));
        }
        let (n_nodes, n_refs, checksum) = (u64_at(16), u64_at(24), u64_at(32));
        let has_cuts = flags & FLAG_CUTS != 0;
        let mut n_cuts = 0u64;
        if version >= 2 {
            let mut extra = [0u8; 8];
            let mut got = 0;
            while got < 8 {
                match r.read(&mut extra[got..])? {
                    0 => break,
                    k => got += k,
                }
            }
            if got < 8 {
                return Err(LoadError::Truncated {
                    expected: HEADER_LEN as u64 + 8,
                    actual: (HEADER_LEN + got) as u64,
                });
            }
            n_cuts = u64::from_le_bytes(extra);
        }
        // Version 2 without bit 1 announces no cuts.
        let cut_bytes = if has_cuts {
            n_refs
                .checked_add(1)
                .and_then(|s| s.checked_mul(4))
                .and_then(|s| n_cuts.checked_mul(8).and_then(|c| s.checked_add(c)))
        } else if n_cuts == 0 {
            Some(0)
        } else {
            None
        };
        let expected = n_nodes.checked_mul(32).and_then(|a| {
            n_refs
                .checked_mul(4)
                .and_then(|b| a.checked_add(b))
                .and_then(|ab| cut_bytes.and_then(|c| ab.checked_add(c)))
        });
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
        let (node_bytes, rest) = payload.split_at(n_nodes as usize * 32);
        let (ref_bytes, cut_bytes) = rest.split_at(n_refs as usize * 4);
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
        let ref_cuts = if has_cuts {
            let (start_bytes, cut_bytes) = cut_bytes.split_at((n_refs as usize + 1) * 4);
            let starts = start_bytes.chunks_exact(4).map(|c| word(c, 0)).collect();
            let cuts: Option<Vec<Cut>> = cut_bytes
                .chunks_exact(8)
                .map(|c| Cut::from_words([word(c, 0), word(c, 1)]))
                .collect();
            let bad = ValidationError::BadCuts { reference: 0 };
            let cuts = cuts.ok_or(bad.clone())?;
            Some(RefCuts::from_parts(starts, cuts).ok_or(bad)?)
        } else {
            None
        };
        let bvh = Bvh {
            nodes,
            prim_indices,
            spatial_splits: flags & FLAG_SPATIAL != 0,
            ref_cuts,
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
