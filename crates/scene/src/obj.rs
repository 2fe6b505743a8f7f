//! A strict, fast Wavefront OBJ reader for geometry (`v` and `f` records).
//!
//! Only positions and faces are read. Polygons are fan-split (`a b c d` gives `a b c` and
//! `a c d`); face vertices may be written `i`, `i/t`, `i//n` or `i/t/n`, with 1-based or
//! negative (relative) indices. Every other record (`vt`, `vn`, `o`, `g`, `s`, `usemtl`,
//! `mtllib`, `l`, `p`, comments, ...) is skipped; a trailing backslash continues a record on
//! the next line. Unlike lenient readers, malformed `v` and `f` records are errors that name
//! the line.

use std::io::Read;
use std::path::Path;

use sahara_geom::Vec3A;

use crate::{Mesh, SceneError};

/// Reads an OBJ file (plain text) into a [`Mesh`].
pub fn load_obj(path: impl AsRef<Path>) -> Result<Mesh, SceneError> {
    let path = path.as_ref();
    let data = std::fs::read(path).map_err(|source| SceneError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    parse_obj(&data, path)
}

/// Reads a gzip-compressed OBJ file (`.obj.gz`) into a [`Mesh`].
pub fn load_obj_gz(path: impl AsRef<Path>) -> Result<Mesh, SceneError> {
    let path = path.as_ref();
    let compressed = std::fs::read(path).map_err(|source| SceneError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    let data = gunzip(&compressed, path)?;
    parse_obj(&data, path)
}

/// Decompresses a gzip stream (possibly several concatenated members).
pub(crate) fn gunzip(compressed: &[u8], file: &Path) -> Result<Vec<u8>, SceneError> {
    let mut data = Vec::with_capacity(compressed.len().saturating_mul(4));
    flate2::read::MultiGzDecoder::new(compressed)
        .read_to_end(&mut data)
        .map_err(|e| SceneError::parse(file, format!("invalid gzip stream: {e}")))?;
    Ok(data)
}

/// Reads OBJ text from a reader (e.g. a decompressor) into a [`Mesh`]; `file` names the
/// source in errors.
pub fn read_obj(mut reader: impl Read, file: &Path) -> Result<Mesh, SceneError> {
    let mut data = Vec::new();
    reader
        .read_to_end(&mut data)
        .map_err(|source| SceneError::Io {
            file: file.to_path_buf(),
            source,
        })?;
    parse_obj(&data, file)
}

/// Parses OBJ text into a [`Mesh`]; `file` names the source in errors.
///
/// Errors: a `v` record without three numbers or with a token that is not a number
/// ([`SceneError::Parse`]), a NaN or infinite coordinate ([`SceneError::NonFinite`]), a face
/// with fewer than three vertices or a malformed or zero index ([`SceneError::Parse`]), an
/// index past the vertices of the file ([`SceneError::IndexOutOfRange`]), a line that is not
/// text ([`SceneError::Parse`]), and a file without faces ([`SceneError::Empty`]).
pub fn parse_obj(data: &[u8], file: &Path) -> Result<Mesh, SceneError> {
    let data = data.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(data);
    let mut p = Parser {
        file,
        mesh: Mesh::default(),
        face: Vec::with_capacity(8),
    };
    let mut pending: Vec<u8> = Vec::new();
    let mut pending_line = 0usize;
    for (n, raw) in data.split(|&b| b == b'\n').enumerate() {
        let line_no = n + 1;
        let line = raw.strip_suffix(b"\r").unwrap_or(raw);
        if let Some(head) = line.strip_suffix(b"\\") {
            // Continued on the next line.
            if pending.is_empty() {
                pending_line = line_no;
            }
            pending.extend_from_slice(head);
            pending.push(b' ');
            continue;
        }
        if pending.is_empty() {
            p.line(line, line_no)?;
        } else {
            pending.extend_from_slice(line);
            let joined = std::mem::take(&mut pending);
            p.line(&joined, pending_line)?;
        }
    }
    if !pending.is_empty() {
        let joined = std::mem::take(&mut pending);
        p.line(&joined, pending_line)?;
    }
    p.finish()
}

struct Parser<'a> {
    file: &'a Path,
    mesh: Mesh,
    face: Vec<u32>,
}

#[inline]
fn is_space(b: u8) -> bool {
    b == b' ' || b == b'\t' || b == b'\x0c' || b == b'\x0b'
}

/// Splits at ASCII blanks.
struct Tokens<'a> {
    rest: &'a [u8],
}

impl<'a> Iterator for Tokens<'a> {
    type Item = &'a [u8];
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let start = self.rest.iter().position(|&b| !is_space(b))?;
        let rest = &self.rest[start..];
        let end = rest.iter().position(|&b| is_space(b)).unwrap_or(rest.len());
        self.rest = &rest[end..];
        Some(&rest[..end])
    }
}

fn show(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(tok);
    if s.chars().count() > 40 {
        format!("{}...", s.chars().take(40).collect::<String>())
    } else {
        s.into_owned()
    }
}

#[inline]
fn parse_f32(tok: &[u8]) -> Option<f32> {
    std::str::from_utf8(tok).ok()?.parse::<f32>().ok()
}

/// Parses an optionally signed decimal integer; `None` if malformed. Saturates on overflow
/// (such an index is out of range anyway).
#[inline]
fn parse_index(tok: &[u8]) -> Option<i64> {
    let (neg, digits) = match tok.first()? {
        b'-' => (true, &tok[1..]),
        b'+' => (false, &tok[1..]),
        _ => (false, tok),
    };
    if digits.is_empty() {
        return None;
    }
    let mut v: i64 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        v = v.saturating_mul(10).saturating_add(i64::from(d - b'0'));
    }
    Some(if neg { -v } else { v })
}

impl Parser<'_> {
    fn err(&self, line: usize, message: String) -> SceneError {
        SceneError::parse(self.file, format!("line {line}: {message}"))
    }

    fn line(&mut self, line: &[u8], line_no: usize) -> Result<(), SceneError> {
        let mut toks = Tokens { rest: line };
        let Some(key) = toks.next() else {
            return Ok(());
        };
        match key {
            b"v" => self.vertex(toks, line_no),
            b"f" => self.face(toks, line_no),
            _ if key[0] == b'#' => Ok(()),
            _ if key.iter().all(|b| b.is_ascii_graphic()) => Ok(()),
            _ => Err(self.err(
                line_no,
                format!(
                    "not an OBJ record (`{}`): is this a text OBJ file?",
                    show(key)
                ),
            )),
        }
    }

    fn vertex(&mut self, mut toks: Tokens<'_>, line_no: usize) -> Result<(), SceneError> {
        let mut xyz = [0f32; 3];
        for (k, c) in xyz.iter_mut().enumerate() {
            let tok = toks.next().ok_or_else(|| {
                self.err(line_no, format!("vertex has {k} coordinates, 3 are needed"))
            })?;
            *c = parse_f32(tok).ok_or_else(|| {
                self.err(
                    line_no,
                    format!("invalid vertex coordinate `{}`", show(tok)),
                )
            })?;
        }
        // Optional w, or r g b (vertex colours): must still be numbers.
        for (extra, tok) in toks.enumerate() {
            if extra >= 4 || parse_f32(tok).is_none() {
                return Err(self.err(
                    line_no,
                    format!("unexpected token `{}` in vertex record", show(tok)),
                ));
            }
        }
        let p = Vec3A::from_array(xyz);
        if !p.is_finite() {
            return Err(SceneError::NonFinite {
                file: self.file.to_path_buf(),
                vertex_index: self.mesh.positions.len(),
                value: xyz,
            });
        }
        self.mesh.positions.push(p);
        Ok(())
    }

    fn face(&mut self, toks: Tokens<'_>, line_no: usize) -> Result<(), SceneError> {
        self.face.clear();
        let n = self.mesh.positions.len() as i64;
        for tok in toks {
            let vpart = tok.split(|&b| b == b'/').next().unwrap_or(tok);
            let idx = parse_index(vpart)
                .ok_or_else(|| self.err(line_no, format!("invalid face vertex `{}`", show(tok))))?;
            let resolved = if idx > 0 {
                idx - 1
            } else if idx < 0 {
                n + idx
            } else {
                return Err(self.err(
                    line_no,
                    "vertex index 0 is invalid (OBJ indices start at 1)".to_string(),
                ));
            };
            if resolved < 0 || resolved > i64::from(u32::MAX) - 1 {
                return Err(SceneError::IndexOutOfRange {
                    file: self.file.to_path_buf(),
                    triangle: self.mesh.indices.len() + self.face.len().saturating_sub(2),
                    index: idx,
                    vertex_count: n as usize,
                });
            }
            self.face.push(resolved as u32);
        }
        if self.face.len() < 3 {
            return Err(self.err(
                line_no,
                format!(
                    "face has {} vertices, at least 3 are needed",
                    self.face.len()
                ),
            ));
        }
        let a = self.face[0];
        for w in self.face[1..].windows(2) {
            self.mesh.indices.push([a, w[0], w[1]]);
        }
        Ok(())
    }

    fn finish(self) -> Result<Mesh, SceneError> {
        let n = self.mesh.positions.len();
        for (t, tri) in self.mesh.indices.iter().enumerate() {
            for &i in tri {
                if i as usize >= n {
                    return Err(SceneError::IndexOutOfRange {
                        file: self.file.to_path_buf(),
                        triangle: t,
                        index: i64::from(i) + 1,
                        vertex_count: n,
                    });
                }
            }
        }
        if self.mesh.indices.is_empty() {
            return Err(SceneError::Empty {
                file: self.file.to_path_buf(),
            });
        }
        Ok(self.mesh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Mesh, SceneError> {
        parse_obj(s.as_bytes(), Path::new("t.obj"))
    }

    #[test]
    fn polygons_slashes_negative_and_continuations() {
        let m = parse(
            "# comment\r\nv 0 0 0\nv 1 0 0 1.0\nv 1 1 0\nv 0 1 0 0.5 0.5 0.5\n\
             vt 0 0\ng x\nf 1/1 2/1/1 3//1 4\nf -4 -3 \\\n -2\n",
        )
        .unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
    }

    #[test]
    fn forward_references_resolve_at_the_end() {
        let m = parse("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse("v 0 0 0\nv 1 2 abc\n").unwrap_err().to_string();
        assert!(
            e.contains("t.obj") && e.contains("line 2") && e.contains("abc"),
            "{e}"
        );
        let e = parse("v 0 0 0\nv 1 2\n").unwrap_err().to_string();
        assert!(e.contains("line 2"), "{e}");
        let e = parse("v 0 0 0\nv 1 0 0\nf 1 2\n").unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("at least 3"), "{e}");
        let e = parse("v 0 0 0\nf 1 0 1\n").unwrap_err().to_string();
        assert!(e.contains("index 0"), "{e}");
        let e = parse("v 0 0 0\nf 1 x 1\n").unwrap_err().to_string();
        assert!(e.contains("`x`"), "{e}");
        let e = parse("v 0 0 0\nf 1 -2 1\n").unwrap_err();
        assert!(
            matches!(e, SceneError::IndexOutOfRange { index: -2, .. }),
            "{e}"
        );
        let e = parse("v 0 0 0\nf 1 1 99999999999999999999999\n").unwrap_err();
        assert!(matches!(e, SceneError::IndexOutOfRange { .. }), "{e}");
        let e = parse("v 0 0 0\nv inf 0 0\nf 1 2 1\n").unwrap_err();
        assert!(
            matches!(
                e,
                SceneError::NonFinite {
                    vertex_index: 1,
                    ..
                }
            ),
            "{e}"
        );
        assert!(matches!(
            parse("# nothing\n"),
            Err(SceneError::Empty { .. })
        ));
        assert!(parse_obj(b"\x00\x01\x02 junk\n", Path::new("b.obj")).is_err());
    }
}
