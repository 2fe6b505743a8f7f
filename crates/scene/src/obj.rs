//! Wavefront OBJ geometry (`v` and `f` records), read by the `tobj` crate behind a strict
//! validation pass of our own.
//!
//! Only positions and faces are read. Polygons are fan-split (`a b c d` gives `a b c` and
//! `a c d`); face vertices may be written `i`, `i/t`, `i//n` or `i/t/n`, with 1-based or
//! negative (relative) indices. Every other record (`vt`, `vn`, `o`, `g`, `s`, `usemtl`,
//! `mtllib`, `l`, `p`, comments, ...) is skipped; a trailing backslash continues a record on
//! the next line. A vertex may carry a fourth value `w` (the coordinates are divided by it,
//! as `tobj` and tinyobjloader do) or three colour values.
//!
//! How it works ([`parse_obj`]): `tobj` reports malformed input as a bare error kind with no
//! position, and accepts some input this crate rejects (faces of one or two vertices, bad
//! numbers in unreferenced vertices). So one cheap pass of our own goes first: it walks the
//! records, checks every face index (zero, past the vertices, overflow) and every coordinate
//! that is not a plain decimal (NaN, infinities, overflow, garbage), and names the line, the
//! vertex or the triangle of the first problem. It parses no plain decimal coordinate (that
//! is `tobj`'s job), which keeps it cheap. When the file passes, `tobj` reads it; if the file
//! holds records `tobj` would act on differently (texture and normal records, objects,
//! groups, materials, vertex colours, line continuations, bytes that are not UTF-8), the pass
//! hands `tobj` a copy holding only the `v` and `f` records (without colours), so the triangles are the file's faces in file
//! order whatever the file's structure. The details and the error list are in
//! `docs/robustness.md`.

use std::io::Read;
use std::path::Path;

use sahara_geom::Vec3A;

use crate::{Mesh, SceneError};

/// Reads an OBJ file (plain text) into a [`Mesh`].
pub fn load_obj(path: impl AsRef<Path>) -> Result<Mesh, SceneError> {
    let path = path.as_ref();
    let data = crate::error::read_file(path)?;
    parse_obj(&data, path)
}

/// Reads a gzip-compressed OBJ file (`.obj.gz`) into a [`Mesh`].
pub fn load_obj_gz(path: impl AsRef<Path>) -> Result<Mesh, SceneError> {
    let path = path.as_ref();
    let compressed = crate::error::read_file(path)?;
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
/// Errors: a `v` record without three numbers, with a token that is not a number, or with
/// a number of values other than 3, 4 (`x y z w`) or 6 (`x y z r g b`), or with `w = 0`
/// ([`SceneError::Parse`]); a NaN or infinite coordinate, also after the division by `w`
/// ([`SceneError::NonFinite`], naming the vertex by the order of the `v` records); a face
/// with fewer than three vertices, a malformed or zero index, or a texture or normal index
/// that is not an integer ([`SceneError::Parse`]); an index past the vertices of the file
/// ([`SceneError::IndexOutOfRange`], naming the triangle); a record whose keyword is not
/// printable ASCII, e.g. a binary file ([`SceneError::Parse`]); and a file without faces
/// ([`SceneError::Empty`]). Parse errors start with `line N:`.
///
/// The mesh's vertices are the vertices the faces use, in the order of first use (that is
/// how `tobj` lays them out); its triangles are the faces in file order, fan-split.
pub fn parse_obj(data: &[u8], file: &Path) -> Result<Mesh, SceneError> {
    let data = data.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(data);
    let plan = validate(data, file)?;
    let copy;
    let text: &[u8] = if plan.needs_copy {
        copy = geometry_records(data);
        &copy
    } else {
        data
    };
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = text;
    let (models, _materials) =
        tobj::load_obj_buf(&mut reader, &options, |_| Ok(Default::default()))
            .map_err(|e| SceneError::parse(file, format!("the OBJ reader (tobj) failed: {e}")))?;
    let mut mesh = Mesh::default();
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3A::new(p[0], p[1], p[2])),
        );
        mesh.indices.extend(
            m.indices
                .chunks_exact(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
    }
    if mesh.indices.len() != plan.triangles {
        return Err(SceneError::parse(
            file,
            format!(
                "the OBJ reader (tobj) read {} triangles where the validation counted {}",
                mesh.indices.len(),
                plan.triangles
            ),
        ));
    }
    // The validation checked every coordinate; this only guards the division by `w`.
    mesh.checked(file)
}

/// What the validation pass learnt about a file that passed it.
struct Plan {
    /// Whether `tobj` must be given only the `v` and `f` records (see the module docs).
    needs_copy: bool,
    /// Triangles after fan-splitting.
    triangles: usize,
}

/// The logical records of an OBJ text (a trailing backslash continues a record on the next
/// line; a trailing `\r` is dropped), each with the number of the line it starts on.
fn for_each_record(
    data: &[u8],
    mut f: impl FnMut(&[u8], usize, bool) -> Result<(), SceneError>,
) -> Result<(), SceneError> {
    let mut pending: Vec<u8> = Vec::new();
    let mut pending_line = 0usize;
    for (n, raw) in data.split(|&b| b == b'\n').enumerate() {
        let line_no = n + 1;
        let line = raw.strip_suffix(b"\r").unwrap_or(raw);
        if let Some(head) = line.strip_suffix(b"\\") {
            if pending.is_empty() {
                pending_line = line_no;
            }
            pending.extend_from_slice(head);
            pending.push(b' ');
            continue;
        }
        if pending.is_empty() {
            f(line, line_no, false)?;
        } else {
            pending.extend_from_slice(line);
            let joined = std::mem::take(&mut pending);
            f(&joined, pending_line, true)?;
        }
    }
    if !pending.is_empty() {
        let joined = std::mem::take(&mut pending);
        f(&joined, pending_line, true)?;
    }
    Ok(())
}

/// The `v` and `f` records of a file that passed [`validate`], one per line.
fn geometry_records(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len());
    let _ = for_each_record(data, |line, _, _| {
        let mut toks = Tokens { rest: line };
        match toks.next() {
            Some(b"f") => out.extend_from_slice(line),
            Some(b"v") => {
                // Vertex colours go (`tobj` needs them on every vertex or none).
                let vals: Vec<&[u8]> = toks.collect();
                out.push(b'v');
                for tok in &vals[..if vals.len() == 6 { 3 } else { vals.len() }] {
                    out.push(b' ');
                    out.extend_from_slice(tok);
                }
            }
            _ => return Ok(()),
        }
        out.push(b'\n');
        Ok(())
    });
    out
}

/// The validation pass: the first problem of the file, named by line, vertex or triangle.
fn validate(data: &[u8], file: &Path) -> Result<Plan, SceneError> {
    let mut v = Validator {
        file,
        vertices: 0,
        triangles: 0,
        forward: Vec::new(),
        needs_copy: std::str::from_utf8(data).is_err(),
    };
    for_each_record(data, |line, line_no, continued| {
        v.needs_copy |= continued;
        v.line(line, line_no)
    })?;
    for &(triangle, index) in &v.forward {
        if index > v.vertices as i64 {
            return Err(SceneError::IndexOutOfRange {
                file: file.to_path_buf(),
                triangle,
                index,
                vertex_count: v.vertices,
            });
        }
    }
    if v.triangles == 0 {
        return Err(SceneError::Empty {
            file: file.to_path_buf(),
        });
    }
    Ok(Plan {
        needs_copy: v.needs_copy,
        triangles: v.triangles,
    })
}

struct Validator<'a> {
    file: &'a Path,
    /// `v` records so far.
    vertices: usize,
    /// Triangles so far (after fan-splitting).
    triangles: usize,
    /// Face indices past the vertices defined so far (forward references, resolved at the
    /// end): the triangle they first appear in and the index as written.
    forward: Vec<(usize, i64)>,
    needs_copy: bool,
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

/// Whether `tok` is a plain decimal `[+-]digits[.digits]` (at least one digit, at most 38
/// before the point): a number Rust's `f32` parser (and so `tobj`) reads as a finite value,
/// so the validation need not parse it.
#[inline]
fn is_plain_decimal(tok: &[u8]) -> bool {
    let body = match tok.first() {
        Some(b'-' | b'+') => &tok[1..],
        _ => tok,
    };
    let (int, frac) = match body.iter().position(|&b| b == b'.') {
        Some(p) => (&body[..p], &body[p + 1..]),
        None => (body, &body[body.len()..]),
    };
    (!int.is_empty() || !frac.is_empty())
        && int.len() <= 38
        && int.iter().all(u8::is_ascii_digit)
        && frac.iter().all(u8::is_ascii_digit)
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

impl Validator<'_> {
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
            // Records `tobj` acts on (texture coordinates and normals, whose indices it
            // checks; objects, groups and materials, which split its output; lines, which
            // it reads as faces): `tobj` gets the `v` and `f` records only.
            b"vt" | b"vn" | b"o" | b"g" | b"usemtl" | b"mtllib" | b"l" => {
                self.needs_copy = true;
                Ok(())
            }
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

    fn number(&self, tok: &[u8], line_no: usize, what: &str) -> Result<f32, SceneError> {
        parse_f32(tok).ok_or_else(|| self.err(line_no, format!("invalid {what} `{}`", show(tok))))
    }

    fn vertex(&mut self, toks: Tokens<'_>, line_no: usize) -> Result<(), SceneError> {
        let mut vals: [&[u8]; 6] = [&[]; 6];
        let mut n = 0usize;
        for tok in toks {
            if let Some(slot) = vals.get_mut(n) {
                *slot = tok;
            }
            n += 1;
        }
        let weighted = n == 4;
        let mut xyz = [0f32; 3];
        for (k, c) in xyz.iter_mut().enumerate() {
            if k >= n {
                return Err(self.err(line_no, format!("vertex has {n} coordinates, 3 are needed")));
            }
            // A plain decimal is finite: `tobj` parses it. The division by w needs them all.
            if weighted || !is_plain_decimal(vals[k]) {
                *c = self.number(vals[k], line_no, "vertex coordinate")?;
            }
        }
        match n {
            3 => {}
            4 => {
                let w = self.number(vals[3], line_no, "vertex weight w")?;
                if w == 0.0 {
                    return Err(self.err(line_no, "vertex weight w is 0".to_string()));
                }
                xyz = xyz.map(|c| c / w);
            }
            6 => {
                for tok in &vals[3..6] {
                    self.number(tok, line_no, "vertex colour")?;
                }
                self.needs_copy = true;
            }
            n => {
                return Err(self.err(
                    line_no,
                    format!(
                        "vertex has {n} values: expected 3 (x y z), 4 (x y z w) or 6 (x y z r g b)"
                    ),
                ))
            }
        }
        if !Vec3A::from_array(xyz).is_finite() {
            if !weighted {
                // Only the coordinates that were not plain decimals were parsed.
                for (c, tok) in xyz.iter_mut().zip(vals) {
                    *c = parse_f32(tok).unwrap_or(f32::NAN);
                }
            }
            return Err(SceneError::NonFinite {
                file: self.file.to_path_buf(),
                vertex_index: self.vertices,
                value: xyz,
            });
        }
        self.vertices += 1;
        Ok(())
    }

    fn face(&mut self, toks: Tokens<'_>, line_no: usize) -> Result<(), SceneError> {
        let n = self.vertices as i64;
        let mut count = 0usize;
        for tok in toks {
            let mut parts = tok.split(|&b| b == b'/');
            let vpart = parts.next().unwrap_or(tok);
            let idx = parse_index(vpart)
                .ok_or_else(|| self.err(line_no, format!("invalid face vertex `{}`", show(tok))))?;
            // Texture and normal indices are skipped, but must be integers (`tobj` parses
            // them), and there are at most two.
            for (k, part) in parts.enumerate() {
                let ok = k < 2
                    && (part.is_empty()
                        || std::str::from_utf8(part)
                            .ok()
                            .is_some_and(|s| s.parse::<isize>().is_ok()));
                if !ok {
                    return Err(self.err(line_no, format!("invalid face vertex `{}`", show(tok))));
                }
            }
            // The triangle of the fan this vertex first appears in.
            let triangle = self.triangles + count.saturating_sub(2);
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
                    triangle,
                    index: idx,
                    vertex_count: n as usize,
                });
            }
            if resolved >= n {
                self.forward.push((triangle, idx));
            }
            count += 1;
        }
        if count < 3 {
            return Err(self.err(
                line_no,
                format!("face has {count} vertices, at least 3 are needed"),
            ));
        }
        self.triangles += count - 2;
        Ok(())
    }
}
#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Mesh, SceneError> {
        parse_obj(s.as_bytes(), Path::new("t.obj"))
    }

    /// Asserts that `e` reports a non-finite coordinate of vertex `vertex`.
    fn assert_non_finite(e: &SceneError, vertex: usize) {
        assert!(
            matches!(e, SceneError::NonFinite { vertex_index, .. } if *vertex_index == vertex),
            "{e}"
        );
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
        assert_non_finite(&e, 1);
        assert!(matches!(
            parse("# nothing\n"),
            Err(SceneError::Empty { .. })
        ));
        assert!(parse_obj(b"\x00\x01\x02 junk\n", Path::new("b.obj")).is_err());
    }

    #[test]
    fn records_tobj_acts_on_keep_the_faces_in_file_order() {
        // Groups, objects, materials, texture/normal records, colours, a continuation and a
        // non-UTF-8 comment: `tobj` gets the `v` and `f` records only, one model, in order.
        let plain = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 4 3 2\nf 1 2 4\n")
            .unwrap()
            .triangles();
        let rich = parse_obj(
            b"# \xff\nmtllib a.mtl\nv 0 0 0 1 0 0\nv 1 0 0\nvt 0 0\nvn 0 0 1\no a\nv 0 1 0\n\
              usemtl m\nf 1/1/1 2/1/1 3/1/1\ng b\nv 1 1 0 0.5 0.5 0.5\nl 1 2 3\nf 4 \\\n 3 2\n\
              usemtl\no c\nf -4 -3 -1\n",
            Path::new("t.obj"),
        )
        .unwrap()
        .triangles();
        assert_eq!(plain, rich);
    }

    #[test]
    fn weights_divide_and_bad_vertex_records_name_the_line() {
        let m = parse("v 2 4 6 2\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert_eq!(m.positions[0], Vec3A::new(1.0, 2.0, 3.0));
        let e = parse("v 0 0 0\nv 1 0 0 0\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("w is 0"), "{e}");
        let e = parse("v 0 0 0 1 1\n").unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("5 values"), "{e}");
        let e = parse("v 1e30 0 0 1e-30\nf 1 1 1\n").unwrap_err();
        assert_non_finite(&e, 0);
        // Unreferenced vertices are checked too, including overflowing plain decimals.
        let long = format!(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv {}0 0 0\nf 1 2 3\n",
            "9".repeat(39)
        );
        let e = parse(&long).unwrap_err();
        assert_non_finite(&e, 3);
        let e = parse("v 0 0 0\nv 1.2.3 0 0\nf 1 1 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("1.2.3"), "{e}");
        let e = parse("v 0 0 0\nf 1/x 1 1\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("1/x"), "{e}");
        let e = parse("v 0 0 0\nf 1/1/1/1 1 1\n").unwrap_err().to_string();
        assert!(e.contains("line 2"), "{e}");
        // A forward reference past the end names the triangle of the fan it falls in.
        let e = parse("f 1 2 3 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap_err();
        assert!(
            matches!(
                e,
                SceneError::IndexOutOfRange {
                    triangle: 1,
                    index: 9,
                    vertex_count: 3,
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn plain_decimals_are_exactly_the_fast_path() {
        for ok in ["0", "-1", "+2.5", ".5", "5.", "-.25", &"9".repeat(38)] {
            assert!(is_plain_decimal(ok.as_bytes()), "{ok}");
            assert!(parse_f32(ok.as_bytes()).unwrap().is_finite(), "{ok}");
        }
        for no in [
            "",
            ".",
            "-",
            "+.",
            "1e5",
            "nan",
            "inf",
            "1.2.3",
            "0x10",
            &"9".repeat(39),
        ] {
            assert!(!is_plain_decimal(no.as_bytes()), "{no}");
        }
    }
}
