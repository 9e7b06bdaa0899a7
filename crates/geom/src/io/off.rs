//! Object File Format (OFF), parsed by hand: a header keyword (`OFF`, or `COFF`, `NOFF`,
//! `CNOFF`, `STOFF`… whose extra per-vertex values are ignored), the counts `V F E`, then one
//! vertex per line (the first three numbers are the position) and one face per line
//! (`n i1 … in`, optionally followed by a colour). `#` starts a comment.
//!
//! The 4D (`4OFF`), n-dimensional (`nOFF`) and binary variants are rejected as unsupported.

use std::path::Path;

use super::{bounded_capacity, line_str, parse_err, text_lines, MeshError, RawMesh};

pub(crate) fn read(bytes: &[u8], path: &Path) -> Result<RawMesh, MeshError> {
    let mut raw = RawMesh::new("off");
    // Non-empty, comment-free lines with their numbers.
    let mut lines = text_lines(bytes).filter_map(|(no, l)| {
        let l = match l.iter().position(|&b| b == b'#') {
            Some(p) => &l[..p],
            None => l,
        };
        if l.iter().all(|b| b.is_ascii_whitespace()) {
            None
        } else {
            Some((no, l))
        }
    });

    let Some((no, first)) = lines.next() else {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
            vertices: 0,
            faces: 0,
        });
    };
    let first = line_str(first, no, path)?;
    let mut tok = first.split_ascii_whitespace();
    let keyword = tok.next().unwrap_or("");
    if !keyword.ends_with("OFF") {
        return Err(parse_err(
            path,
            no,
            format!("expected the OFF keyword, found `{keyword}`"),
        ));
    }
    let prefix = &keyword[..keyword.len() - 3];
    if prefix.contains('4') || prefix.contains('n') {
        return Err(MeshError::UnsupportedFormat {
            path: path.to_path_buf(),
            reason: format!("`{keyword}` (4D or n-dimensional OFF) is not supported"),
        });
    }
    if prefix.chars().any(|c| !matches!(c, 'S' | 'T' | 'C' | 'N')) {
        return Err(parse_err(
            path,
            no,
            format!("unknown OFF variant `{keyword}`"),
        ));
    }
    // The counts may follow the keyword on the same line or sit on the next one.
    let mut counts: Vec<&str> = tok.collect();
    let mut counts_line = no;
    let owned;
    if counts.is_empty() {
        let Some((n2, l2)) = lines.next() else {
            return Err(parse_err(path, no, "missing the vertex and face counts"));
        };
        owned = line_str(l2, n2, path)?;
        counts = owned.split_ascii_whitespace().collect();
        counts_line = n2;
    }
    if counts.first() == Some(&"BINARY") {
        return Err(MeshError::UnsupportedFormat {
            path: path.to_path_buf(),
            reason: "binary OFF is not supported".into(),
        });
    }
    let count = |k: usize, what: &str| -> Result<usize, MeshError> {
        let t = counts
            .get(k)
            .ok_or_else(|| parse_err(path, counts_line, format!("missing the {what} count")))?;
        t.parse::<usize>()
            .map_err(|_| parse_err(path, counts_line, format!("`{t}` is not a {what} count")))
    };
    let n_vertices = count(0, "vertex")?;
    let n_faces = count(1, "face")?;

    raw.positions
        .reserve(bounded_capacity(n_vertices, bytes.len(), 6));
    for got in 0..n_vertices {
        let Some((no, line)) = lines.next() else {
            return Err(MeshError::Truncated {
                path: path.to_path_buf(),
                what: "vertices".into(),
                expected: n_vertices,
                got,
            });
        };
        let text = line_str(line, no, path)?;
        let mut tok = text.split_ascii_whitespace();
        let mut p = [0.0; 3];
        for (k, c) in p.iter_mut().enumerate() {
            let t = tok.next().ok_or_else(|| {
                parse_err(
                    path,
                    no,
                    format!("vertex {got} has {k} coordinates, needs 3"),
                )
            })?;
            *c = t
                .parse::<f64>()
                .map_err(|_| parse_err(path, no, format!("`{t}` is not a number")))?;
        }
        raw.positions.push(p);
    }

    raw.offsets
        .reserve(bounded_capacity(n_faces, bytes.len(), 6));
    raw.indices
        .reserve(bounded_capacity(3 * n_faces, bytes.len(), 2));
    for face in 0..n_faces {
        let Some((no, line)) = lines.next() else {
            return Err(MeshError::Truncated {
                path: path.to_path_buf(),
                what: "faces".into(),
                expected: n_faces,
                got: face,
            });
        };
        let text = line_str(line, no, path)?;
        let mut tok = text.split_ascii_whitespace();
        let t = tok.next().unwrap_or("");
        let n: usize = t
            .parse()
            .map_err(|_| parse_err(path, no, format!("`{t}` is not a corner count")))?;
        let start = raw.indices.len();
        for k in 0..n {
            let t = tok.next().ok_or_else(|| {
                parse_err(
                    path,
                    no,
                    format!("face {face} announces {n} corners but has {k}"),
                )
            })?;
            let i: i64 = t
                .parse()
                .map_err(|_| parse_err(path, no, format!("`{t}` is not a vertex index")))?;
            if i < 0 || i as u64 >= n_vertices as u64 {
                raw.indices.truncate(start);
                return Err(MeshError::IndexOutOfRange {
                    path: path.to_path_buf(),
                    face,
                    index: i,
                    n_vertices,
                    line: Some(no),
                });
            }
            raw.indices.push(i as u32);
        }
        // Anything after the corners is a colour: ignored.
        raw.offsets.push(raw.indices.len());
    }
    raw.file_faces = n_faces;
    Ok(raw)
}
