//! STL (ascii and binary) through stl_io. STL stores every triangle with its own three corners,
//! so coincident corners are welded into one vertex. "Coincident" means closer than
//! [`WELD_TOLERANCE`] times the bounding-box diagonal: far below the precision of the 32-bit
//! floats STL stores (about 1e-7 relative), so distinct points never merge, while the noise CAD
//! exporters leave at zero (0.0 next to -2.7e-16) does not cut the surface open.
//!
//! Binary or ascii is decided by size, not by the leading `solid` (many binary exporters start
//! their 80-byte header with `solid` too): a file of exactly 84 + 50·n bytes, n being the count
//! at byte 80, is binary.

use std::collections::HashMap;

use crate::vec3::{self, V3};
use std::io::Cursor;
use std::path::Path;

use super::{MeshError, RawMesh};

pub(crate) fn read(bytes: &[u8], path: &Path) -> Result<RawMesh, MeshError> {
    let binary_count = (bytes.len() >= 84)
        .then(|| u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64)
        .filter(|&n| 84 + 50 * n == bytes.len() as u64);
    let starts_solid = bytes.trim_ascii_start().starts_with(b"solid");
    let mut data: Vec<u8>;
    let format;
    match binary_count {
        Some(_) => {
            format = "stl-binary";
            data = bytes.to_vec();
            // stl_io treats a leading "solid " as ascii; blank the header it does not need.
            data[..80].fill(b' ');
        }
        None if starts_solid => {
            format = "stl-ascii";
            // stl_io wants "solid " with a space and at the very start.
            let text = bytes.trim_ascii_start();
            let rest = text
                .iter()
                .position(|&b| b == b'\n')
                .map_or(&[][..], |p| &text[p..]);
            data = b"solid x".to_vec();
            data.extend_from_slice(rest);
        }
        None => {
            if bytes.len() >= 84 {
                let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
                let got = (bytes.len() - 84) / 50;
                if got < n {
                    // A binary file cut short (or binary garbage announcing too much).
                    return Err(MeshError::Truncated {
                        path: path.to_path_buf(),
                        what: "triangles".into(),
                        expected: n,
                        got,
                    });
                }
            }
            return Err(MeshError::Parse {
                path: path.to_path_buf(),
                line: None,
                message: format!(
                    "neither ascii STL (no leading `solid`) nor binary STL ({} bytes is not \
                     84 + 50 x the triangle count at byte 80)",
                    bytes.len()
                ),
            });
        }
    }

    let mut cursor = Cursor::new(&data[..]);
    let triangles = stl_io::create_stl_reader(&mut cursor).map_err(|e| MeshError::Parse {
        path: path.to_path_buf(),
        line: None,
        message: e.to_string(),
    })?;
    let mut corners: Vec<[f64; 3]> = Vec::new();
    for (t, tri) in triangles.enumerate() {
        let tri = tri.map_err(|e| MeshError::Parse {
            path: path.to_path_buf(),
            line: None,
            message: format!("triangle {t}: {e}"),
        })?;
        corners.extend(
            tri.vertices
                .iter()
                .map(|v| [v[0] as f64, v[1] as f64, v[2] as f64]),
        );
    }
    let mut raw = RawMesh::new(format);
    let ids = weld(&corners, &mut raw.positions);
    for t in ids.chunks_exact(3) {
        raw.push_face(t.iter().copied());
    }
    let corners = corners.len();
    raw.vertices_welded = corners - raw.positions.len();
    raw.file_faces = raw.n_polygons();
    Ok(raw)
}

/// Corners closer than this fraction of the bounding-box diagonal are one vertex.
pub const WELD_TOLERANCE: f64 = 1e-9;

/// Welds `corners` into `positions`; returns the vertex of each corner. A corner joins the
/// lowest-numbered earlier vertex within the tolerance (found through a grid of cells of the
/// tolerance's size), so the result depends only on the corner order. Non-finite corners are
/// never welded (validation reports them).
fn weld(corners: &[V3], positions: &mut Vec<V3>) -> Vec<u32> {
    let finite = corners.iter().filter(|p| p.iter().all(|c| c.is_finite()));
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in finite {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let eps = WELD_TOLERANCE * vec3::dist(lo, hi);
    let cell_of = |p: &V3| -> [i64; 3] {
        // Relative to the box corner, so the cell numbers stay below 1/WELD_TOLERANCE.
        [0, 1, 2].map(|k| {
            if eps > 0.0 {
                ((p[k] - lo[k]) / eps).floor() as i64
            } else {
                0
            }
        })
    };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut ids = Vec::with_capacity(corners.len());
    for p in corners {
        if !p.iter().all(|c| c.is_finite()) {
            ids.push(positions.len() as u32);
            positions.push(*p);
            continue;
        }
        let c = cell_of(p);
        let mut found: Option<u32> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                        continue;
                    };
                    for &v in list {
                        let q = positions[v as usize];
                        let near = if eps > 0.0 {
                            vec3::dist(*p, q) <= eps
                        } else {
                            *p == q
                        };
                        if near && found.is_none_or(|f| v < f) {
                            found = Some(v);
                        }
                    }
                }
            }
        }
        let id = match found {
            Some(v) => v,
            None => {
                let v = positions.len() as u32;
                positions.push(*p);
                grid.entry(c).or_default().push(v);
                v
            }
        };
        ids.push(id);
    }
    ids
}
