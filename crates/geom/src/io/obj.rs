//! Wavefront OBJ: `v` positions and `f` polygons; everything else (normals, texture
//! coordinates, groups, materials, lines, points) is ignored.
//!
//! Parsed here rather than with tobj because tobj re-indexes every group (`g`/`o`/`usemtl`)
//! separately: vertices shared by two groups would be duplicated (cutting the surface along
//! group borders), unreferenced vertices would vanish uncounted, and an out-of-range index
//! would be reported without the face or the index. The tests cross-check this reader against
//! tobj on the shared OBJ files.

use std::path::Path;

use super::{line_str, parse_err, text_lines, MeshError, RawMesh};

pub(crate) fn read(bytes: &[u8], path: &Path) -> Result<RawMesh, MeshError> {
    let mut raw = RawMesh::new("obj");
    // Line of each face, for index errors found after all vertices are known.
    let mut face_lines: Vec<usize> = Vec::new();
    // Raw (possibly relative) indices are resolved when read: a negative index counts back
    // from the vertices defined so far.
    let mut pending: Vec<i64> = Vec::new();
    let mut joined = String::new();
    let mut joined_start = 0;
    for (no, line) in text_lines(bytes) {
        let text = line_str(line, no, path)?;
        // A trailing backslash continues the statement on the next line.
        if let Some(head) = text.strip_suffix('\\') {
            if joined.is_empty() {
                joined_start = no;
            }
            joined.push_str(head);
            joined.push(' ');
            continue;
        }
        let (stmt, stmt_line) = if joined.is_empty() {
            (text, no)
        } else {
            joined.push_str(text);
            (joined.as_str(), joined_start)
        };
        let stmt = stmt.split('#').next().unwrap_or("");
        let mut tok = stmt.split_ascii_whitespace();
        match tok.next() {
            Some("v") => {
                let mut p = [0.0; 3];
                for (k, c) in p.iter_mut().enumerate() {
                    let t = tok.next().ok_or_else(|| {
                        parse_err(
                            path,
                            stmt_line,
                            format!("vertex has {k} coordinates, needs 3"),
                        )
                    })?;
                    *c = t.parse::<f64>().map_err(|_| {
                        parse_err(path, stmt_line, format!("`{t}` is not a number"))
                    })?;
                }
                raw.positions.push(p);
            }
            Some("f") => {
                let n_so_far = raw.positions.len() as i64;
                pending.clear();
                for t in tok {
                    // `v`, `v/vt`, `v//vn`, `v/vt/vn`: only the position index matters.
                    let v = t.split('/').next().unwrap_or("");
                    let i: i64 = v.parse().map_err(|_| {
                        parse_err(path, stmt_line, format!("`{t}` is not a face index"))
                    })?;
                    let resolved = match i {
                        0 => {
                            return Err(parse_err(
                                path,
                                stmt_line,
                                "face index 0 (OBJ indices start at 1)",
                            ))
                        }
                        i if i > 0 => i - 1,
                        i => n_so_far + i,
                    };
                    pending.push(resolved);
                }
                let face = raw.n_polygons();
                for &i in &pending {
                    if i < 0 || i > u32::MAX as i64 {
                        return Err(MeshError::IndexOutOfRange {
                            path: path.to_path_buf(),
                            face,
                            index: i,
                            n_vertices: raw.positions.len(),
                            line: Some(stmt_line),
                        });
                    }
                }
                raw.push_face(pending.iter().map(|&i| i as u32));
                face_lines.push(stmt_line);
            }
            _ => {}
        }
        joined.clear();
    }
    // Positive indices may (against the spec, but harmlessly) point at vertices defined later;
    // check them against the final count.
    let n = raw.positions.len();
    for (f, &line) in face_lines.iter().enumerate() {
        for &i in &raw.indices[raw.offsets[f]..raw.offsets[f + 1]] {
            if i as usize >= n {
                return Err(MeshError::IndexOutOfRange {
                    path: path.to_path_buf(),
                    face: f,
                    index: i as i64,
                    n_vertices: n,
                    line: Some(line),
                });
            }
        }
    }
    raw.file_faces = raw.n_polygons();
    Ok(raw)
}
