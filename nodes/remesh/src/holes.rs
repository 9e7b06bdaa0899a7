//! Holes below the scale of the target (thesis §5.1.1 keeps boundaries; this is where a
//! boundary cannot be kept at the scale).
//!
//! A hole bounded by three edges, each much shorter than the target length L, cannot be
//! resampled at L: its loop already has the fewest edges a loop can have, no collapse may
//! shorten it, and the triangles that meet it at the scale of L are slivers (a scan of the
//! Chinese dragon has two such holes 0.003 L across, and its remesh had triangles of 0.15°
//! there). Such a hole is closed by one triangle before remeshing; larger holes, and loops
//! of more edges, are resampled as boundaries.

use crestflow_geom::mesh::{TriMesh, NO_FACE};
use crestflow_geom::vec3;

/// `mesh` with every hole of three boundary edges, each shorter than `max_edge`, closed by a
/// triangle (oriented like its neighbours), and the number closed; `None` when there is none.
/// A loop that is the boundary of a single triangle (a lone triangle, or a strip's end) is
/// left open, and so is a loop through a vertex with more than one boundary edge leaving it.
pub fn close_small_triangular_holes(mesh: &TriMesh, max_edge: f64) -> Option<(TriMesh, usize)> {
    let topo = mesh.topology();
    // Each boundary edge as the side of its face: from `tri[i]` to `tri[i + 1]`.
    let mut out_of: std::collections::HashMap<u32, Option<(u32, u32)>> = Default::default();
    for (e, faces) in topo.edge_faces.iter().enumerate() {
        if faces[1] != NO_FACE || faces[0] == NO_FACE {
            continue;
        }
        let f = faces[0];
        let t = mesh.triangles[f as usize];
        let Some(i) = (0..3).find(|&i| topo.face_edges[f as usize][i] == e as u32) else {
            continue;
        };
        let (a, b) = (t[i], t[(i + 1) % 3]);
        out_of
            .entry(a)
            .and_modify(|x| *x = None)
            .or_insert(Some((b, f)));
    }
    if out_of.is_empty() {
        return None;
    }
    let step = |a: u32| out_of.get(&a).copied().flatten();
    let mut starts: Vec<u32> = out_of.keys().copied().collect();
    starts.sort_unstable();
    let mut added = Vec::new();
    for a in starts {
        let Some((b, f0)) = step(a) else { continue };
        let Some((c, f1)) = step(b) else { continue };
        let Some((back, f2)) = step(c) else { continue };
        // Each loop once, from its smallest vertex.
        if back != a || a > b || a > c || f0 == f1 || f1 == f2 || f0 == f2 {
            continue;
        }
        let p = [a, b, c].map(|v| mesh.positions[v as usize]);
        let longest = (0..3)
            .map(|i| vec3::dist(p[i], p[(i + 1) % 3]))
            .fold(0.0, f64::max);
        if longest < max_edge {
            // The boundary runs a → b → c in the faces beside it; the new face runs back.
            added.push([b, a, c]);
        }
    }
    if added.is_empty() {
        return None;
    }
    let n = added.len();
    let mut triangles = mesh.triangles.clone();
    triangles.extend(added);
    Some((TriMesh::new(mesh.positions.clone(), triangles), n))
}

#[cfg(test)]
#[path = "holes_test.rs"]
mod tests;
