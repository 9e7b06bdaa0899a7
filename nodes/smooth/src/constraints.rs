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
mod tests {
    use super::*;
    use crestflow_geom::{CurveLabel, FcnVertex, FeatureCurve};

    fn strip() -> TriMesh {
        // Two triangles: 0-1-2 and 1-3-2.
        TriMesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [1, 3, 2]],
        )
    }

    fn net(locs: &[(SurfacePoint, V3)]) -> FeatureCurveNetwork {
        FeatureCurveNetwork {
            vertices: locs
                .iter()
                .map(|&(location, position)| FcnVertex {
                    position,
                    location,
                    strength: 1.0,
                })
                .collect(),
            curves: vec![FeatureCurve {
                vertices: (0..locs.len() as u32).collect(),
                closed: false,
                label: CurveLabel::Ridge,
            }],
        }
    }

    #[test]
    fn rule_on_each_location_kind() {
        let m = strip();
        let cases: [(SurfacePoint, Vec<bool>); 6] = [
            (SurfacePoint::Vertex(3), vec![false, false, false, true]),
            // Middle of edge (1, 2): both ends.
            (
                SurfacePoint::Edge { a: 1, b: 2, t: 0.5 },
                vec![false, true, true, false],
            ),
            // Near a: only a.
            (
                SurfacePoint::Edge { a: 1, b: 2, t: 0.1 },
                vec![false, true, false, false],
            ),
            // Near b: only b.
            (
                SurfacePoint::Edge { a: 0, b: 1, t: 0.9 },
                vec![false, true, false, false],
            ),
            // Face centre: all three corners.
            (
                SurfacePoint::Face {
                    f: 1,
                    bary: [1.0 / 3.0; 3],
                },
                vec![false, true, true, true],
            ),
            // Close to corner 0 of face 0 (vertex 0): only it.
            (
                SurfacePoint::Face {
                    f: 0,
                    bary: [0.8, 0.1, 0.1],
                },
                vec![true, false, false, false],
            ),
        ];
        for (loc, want) in cases {
            let (got, free) = curve_fixed_vertices(&m, &net(&[(loc, [0.0; 3])]), 0.25).unwrap();
            assert_eq!(got, want, "{loc:?}");
            assert_eq!(free, 0);
        }
        // A free point snaps to the nearest vertex.
        let (got, free) =
            curve_fixed_vertices(&m, &net(&[(SurfacePoint::Free, [0.9, 0.95, 0.1])]), 0.25)
                .unwrap();
        assert_eq!(got, vec![false, false, false, true]);
        assert_eq!(free, 1);
        // min_weight = 1: only the nearest corner even in the middle of an edge.
        let (got, _) = curve_fixed_vertices(
            &m,
            &net(&[(SurfacePoint::Edge { a: 1, b: 2, t: 0.4 }, [0.0; 3])]),
            1.0,
        )
        .unwrap();
        assert_eq!(got, vec![false, true, false, false]);
    }

    #[test]
    fn grid_nearest_equals_brute_force() {
        let m = crestflow_geom::shapes::ellipsoid(1.0, 0.6, 0.4, 3, 0.3, 3).unwrap();
        let g = VertexGrid::new(&m);
        let mut s = 12345u64;
        for _ in 0..300 {
            let mut p = [0.0; 3];
            for c in p.iter_mut() {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                *c = ((s >> 11) as f64 / (1u64 << 53) as f64) * 3.0 - 1.5;
            }
            let want = (0..m.n_vertices() as u32)
                .min_by(|&a, &b| {
                    vec3::dist(m.positions[a as usize], p)
                        .total_cmp(&vec3::dist(m.positions[b as usize], p))
                        .then(a.cmp(&b))
                })
                .unwrap();
            assert_eq!(g.nearest(p), Some(want), "{p:?}");
        }
    }

    #[test]
    fn bad_locations_are_named() {
        let m = strip();
        assert_eq!(
            curve_fixed_vertices(&m, &net(&[(SurfacePoint::Vertex(7), [0.0; 3])]), 0.25)
                .unwrap_err(),
            ConstraintError::VertexOutOfRange {
                vertex: 0,
                index: 7,
                n_vertices: 4
            }
        );
        let e = curve_fixed_vertices(
            &m,
            &net(&[
                (SurfacePoint::Vertex(1), [0.0; 3]),
                (
                    SurfacePoint::Face {
                        f: 2,
                        bary: [0.3; 3],
                    },
                    [0.0; 3],
                ),
            ]),
            0.25,
        )
        .unwrap_err();
        assert!(e.to_string().contains("curve vertex 1 lies on mesh face 2"));
        let e = curve_fixed_vertices(
            &m,
            &net(&[(
                SurfacePoint::Edge {
                    a: 0,
                    b: 1,
                    t: f64::NAN,
                },
                [0.0; 3],
            )]),
            0.25,
        )
        .unwrap_err();
        assert!(matches!(e, ConstraintError::NonFinite { vertex: 0, .. }));
        let mut n = net(&[(SurfacePoint::Vertex(1), [0.0; 3])]);
        n.curves[0].vertices.push(5);
        assert!(matches!(
            curve_fixed_vertices(&m, &n, 0.25).unwrap_err(),
            ConstraintError::CurveIndex {
                curve: 0,
                index: 5,
                ..
            }
        ));
    }
}
