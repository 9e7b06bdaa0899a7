//! Which mesh vertices a feature curve network pins down (thesis §5.1.3: "exclude edges lying
//! on a reasonable set of feature curves from the update procedure and treat these as fixed
//! boundary vertices").
//!
//! Curve vertices traced on a mesh sit at vertices, on edges or inside faces
//! ([`SurfacePoint`]). Each gives weights to the corners of its element: 1 for a `Vertex`,
//! `(1 − t, t)` for an `Edge { a, b, t }`, the barycentric coordinates for a `Face`. The rule:
//! **fix every corner whose weight is at least `min_weight`, and always the corner with the
//! largest weight.** With the default `min_weight = 0.25` an edge point with t in
//! [0.25, 0.75] fixes both ends of its edge (a crest running through the middle of an edge is
//! held from both sides), otherwise only the nearer end; a face point near the centre fixes
//! all three corners. A `Free` point (not tied to the mesh, e.g. a copied template point)
//! fixes the mesh vertex nearest to its position.
//!
//! Only network vertices that some curve uses count.

use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{FeatureCurveNetwork, SurfacePoint, TriMesh};

/// A curve vertex whose location does not fit the mesh.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConstraintError {
    #[error(
        "curve vertex {vertex} lies on mesh vertex {index} but the mesh has {n_vertices} vertices"
    )]
    VertexOutOfRange {
        vertex: usize,
        index: u32,
        n_vertices: usize,
    },
    #[error("curve vertex {vertex} lies on mesh face {face} but the mesh has {n_faces} faces")]
    FaceOutOfRange {
        vertex: usize,
        face: u32,
        n_faces: usize,
    },
    #[error("curve vertex {vertex} has a non-finite location parameter ({what} = {value})")]
    NonFinite {
        vertex: usize,
        what: &'static str,
        value: f64,
    },
    #[error("curve {curve} uses network vertex {index} but the network has {n_vertices} vertices")]
    CurveIndex {
        curve: usize,
        index: u32,
        n_vertices: usize,
    },
}

/// The corners and weights of one surface point (module docs).
fn corner_weights(
    vertex: usize,
    loc: &SurfacePoint,
    mesh: &TriMesh,
) -> Result<Vec<(u32, f64)>, ConstraintError> {
    let n = mesh.n_vertices();
    let check_v = |index: u32| {
        if (index as usize) < n {
            Ok(index)
        } else {
            Err(ConstraintError::VertexOutOfRange {
                vertex,
                index,
                n_vertices: n,
            })
        }
    };
    Ok(match *loc {
        SurfacePoint::Vertex(v) => vec![(check_v(v)?, 1.0)],
        SurfacePoint::Edge { a, b, t } => {
            if !t.is_finite() {
                return Err(ConstraintError::NonFinite {
                    vertex,
                    what: "t",
                    value: t,
                });
            }
            let t = t.clamp(0.0, 1.0);
            vec![(check_v(a)?, 1.0 - t), (check_v(b)?, t)]
        }
        SurfacePoint::Face { f, bary } => {
            let Some(tri) = mesh.triangles.get(f as usize) else {
                return Err(ConstraintError::FaceOutOfRange {
                    vertex,
                    face: f,
                    n_faces: mesh.n_faces(),
                });
            };
            let mut out = Vec::with_capacity(3);
            for i in 0..3 {
                if !bary[i].is_finite() {
                    return Err(ConstraintError::NonFinite {
                        vertex,
                        what: "barycentric coordinate",
                        value: bary[i],
                    });
                }
                out.push((check_v(tri[i])?, bary[i]));
            }
            out
        }
        SurfacePoint::Free => Vec::new(),
    })
}

/// A uniform grid of the mesh vertices for nearest-vertex queries of `Free` points.
struct VertexGrid<'m> {
    positions: &'m [V3],
    lo: V3,
    cell: f64,
    dims: [usize; 3],
    /// CSR: vertices of cell c are `items[starts[c]..starts[c + 1]]`, in index order.
    starts: Vec<u32>,
    items: Vec<u32>,
}

impl<'m> VertexGrid<'m> {
    fn new(mesh: &'m TriMesh) -> Self {
        let (lo, hi) = mesh.bbox();
        let n = mesh.n_vertices().max(1);
        let ext = vec3::sub(hi, lo);
        // About one vertex per cell on a surface: cell ≈ mean edge length, grown until the
        // grid has at most ~8 cells per vertex (flat or sparse meshes).
        let h = mesh.mean_edge_length();
        let mut cell = if h > 0.0 && h.is_finite() { h } else { 1.0 };
        let limit = 8 * n + 64;
        let dims_for = |cell: f64| [0, 1, 2].map(|k| (ext[k] / cell).floor() as usize + 1);
        let mut dims = dims_for(cell);
        while dims[0].saturating_mul(dims[1]).saturating_mul(dims[2]) > limit {
            cell *= 1.5;
            dims = dims_for(cell);
        }
        let ncell = dims[0] * dims[1] * dims[2];
        let mut starts = vec![0u32; ncell + 1];
        let cells: Vec<usize> = mesh
            .positions
            .iter()
            .map(|&p| Self::cell_of(lo, cell, dims, p))
            .collect();
        for &c in &cells {
            starts[c + 1] += 1;
        }
        for c in 0..ncell {
            starts[c + 1] += starts[c];
        }
        let mut fill = starts.clone();
        let mut items = vec![0u32; n.min(mesh.n_vertices())];
        for (v, &c) in cells.iter().enumerate() {
            items[fill[c] as usize] = v as u32;
            fill[c] += 1;
        }
        VertexGrid {
            positions: &mesh.positions,
            lo,
            cell,
            dims,
            starts,
            items,
        }
    }

    fn coord(lo: V3, cell: f64, dims: [usize; 3], p: V3, k: usize) -> usize {
        let x = ((p[k] - lo[k]) / cell).floor();
        if x.is_nan() || x < 0.0 {
            0
        } else {
            (x as usize).min(dims[k] - 1)
        }
    }

    fn cell_of(lo: V3, cell: f64, dims: [usize; 3], p: V3) -> usize {
        let c = [0, 1, 2].map(|k| Self::coord(lo, cell, dims, p, k));
        (c[2] * dims[1] + c[1]) * dims[0] + c[0]
    }

    /// The nearest vertex (smallest index among equals), searching rings of cells outwards.
    fn nearest(&self, p: V3) -> Option<u32> {
        if self.positions.is_empty() {
            return None;
        }
        let c = [0, 1, 2].map(|k| Self::coord(self.lo, self.cell, self.dims, p, k) as i64);
        let mut best: Option<(f64, u32)> = None;
        let max_r = *self.dims.iter().max().unwrap_or(&1) as i64;
        for r in 0..=max_r {
            // Every point outside the cube of radius r lies at least r cells from p's cell.
            if let Some((d, _)) = best {
                let reach = (r - 1).max(0) as f64 * self.cell;
                if reach * reach > d {
                    break;
                }
            }
            for z in (c[2] - r)..=(c[2] + r) {
                for y in (c[1] - r)..=(c[1] + r) {
                    for x in (c[0] - r)..=(c[0] + r) {
                        let on_shell =
                            (x - c[0]).abs() == r || (y - c[1]).abs() == r || (z - c[2]).abs() == r;
                        if !on_shell
                            || x < 0
                            || y < 0
                            || z < 0
                            || x >= self.dims[0] as i64
                            || y >= self.dims[1] as i64
                            || z >= self.dims[2] as i64
                        {
                            continue;
                        }
                        let cell =
                            ((z as usize * self.dims[1]) + y as usize) * self.dims[0] + x as usize;
                        let s = self.starts[cell] as usize;
                        let e = self.starts[cell + 1] as usize;
                        for &v in &self.items[s..e] {
                            let d = vec3::sub(self.positions[v as usize], p);
                            let d2 = vec3::dot(d, d);
                            if best.is_none_or(|(bd, bv)| d2 < bd || (d2 == bd && v < bv)) {
                                best = Some((d2, v));
                            }
                        }
                    }
                }
            }
        }
        best.map(|(_, v)| v)
    }
}

/// Marks the mesh vertices that the curves of `net` fix (module docs). Returns the mask and
/// the number of curve vertices that were `Free` (snapped to their nearest mesh vertex).
pub fn curve_fixed_vertices(
    mesh: &TriMesh,
    net: &FeatureCurveNetwork,
    min_weight: f64,
) -> Result<(Vec<bool>, usize), ConstraintError> {
    let mut used = vec![false; net.vertices.len()];
    for (curve, c) in net.curves.iter().enumerate() {
        for &i in &c.vertices {
            match used.get_mut(i as usize) {
                Some(u) => *u = true,
                None => {
                    return Err(ConstraintError::CurveIndex {
                        curve,
                        index: i,
                        n_vertices: net.vertices.len(),
                    })
                }
            }
        }
    }
    let mut fixed = vec![false; mesh.n_vertices()];
    let mut grid: Option<VertexGrid> = None;
    let mut free = 0;
    for (vertex, fv) in net.vertices.iter().enumerate() {
        if !used[vertex] {
            continue;
        }
        if let SurfacePoint::Free = fv.location {
            free += 1;
            if !fv.position.iter().all(|c| c.is_finite()) {
                return Err(ConstraintError::NonFinite {
                    vertex,
                    what: "position",
                    value: fv
                        .position
                        .iter()
                        .cloned()
                        .find(|c| !c.is_finite())
                        .unwrap_or(0.0),
                });
            }
            let g = grid.get_or_insert_with(|| VertexGrid::new(mesh));
            if let Some(v) = g.nearest(fv.position) {
                fixed[v as usize] = true;
            }
            continue;
        }
        let w = corner_weights(vertex, &fv.location, mesh)?;
        let mut top: Option<(u32, f64)> = None;
        for &(v, wt) in &w {
            if wt >= min_weight {
                fixed[v as usize] = true;
            }
            if top.is_none_or(|(_, tw)| wt > tw) {
                top = Some((v, wt));
            }
        }
        if let Some((v, _)) = top {
            fixed[v as usize] = true;
        }
    }
    Ok((fixed, free))
}

#[cfg(test)]
#[path = "constraints_test.rs"]
mod tests;
