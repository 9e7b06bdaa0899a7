//! A spatially coherent numbering of a triangle mesh, for algorithms that walk neighbourhoods
//! in index order (e.g. the collapse sweeps of isotropic remeshing).
//!
//! Faces are sorted along a Morton (Z-order) curve through their centroids, and vertices are
//! numbered in the order the sorted faces first use them (vertices no face uses keep their
//! relative order after all others). Neighbouring elements then sit close in memory: scanned
//! meshes often come with faces and vertices in acquisition or subdivision order, where the
//! three corners of a face lie thousands of indices apart and every one-ring walk misses the
//! cache. The numbering depends only on the mesh (ties in the curve go by the old face
//! index), so it is the same on every run and at every thread count.

use rayon::prelude::*;

use crate::vec3::V3;
use crate::{FeatureCurveNetwork, SurfacePoint, TriMesh};

/// A renumbered copy of a mesh and the maps between the two numberings.
#[derive(Debug, Clone)]
pub struct Reordered {
    /// The same surface with faces and vertices renumbered; each face keeps its corner order.
    pub mesh: TriMesh,
    /// New index of each old vertex.
    pub new_vertex: Vec<u32>,
    /// Old index of each new face.
    pub old_face: Vec<u32>,
}

impl Reordered {
    /// `net` with its surface locations in the new numbering. Out-of-range indices stay as
    /// they are, so that whoever checks them reports the index the user gave.
    pub fn network(&self, net: &FeatureCurveNetwork) -> FeatureCurveNetwork {
        let nv = self.new_vertex.len() as u32;
        let mut new_face = vec![0u32; self.old_face.len()];
        for (new, &old) in self.old_face.iter().enumerate() {
            new_face[old as usize] = new as u32;
        }
        let v = |x: u32| {
            if x < nv {
                self.new_vertex[x as usize]
            } else {
                x
            }
        };
        let mut out = net.clone();
        for fv in &mut out.vertices {
            fv.location = match fv.location {
                SurfacePoint::Vertex(x) => SurfacePoint::Vertex(v(x)),
                SurfacePoint::Edge { a, b, t } => SurfacePoint::Edge {
                    a: v(a),
                    b: v(b),
                    t,
                },
                SurfacePoint::Face { f, bary } => SurfacePoint::Face {
                    f: new_face.get(f as usize).copied().unwrap_or(f),
                    bary,
                },
                SurfacePoint::Free => SurfacePoint::Free,
            };
        }
        out
    }
}

/// Bits per axis of the Morton code (3 × 21 = 63 bits).
const BITS: u32 = 21;

/// Spreads the low 21 bits of `x` to every third bit.
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | (x << 32)) & 0x1f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x1f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

/// Indices of `points` sorted along a Morton (Z-order) curve through their bounding box (of
/// the finite points; a non-finite coordinate counts as the box's low side), ties by index:
/// consecutive indices are near in space. The same on every run.
pub fn morton_order(points: &[V3]) -> Vec<u32> {
    morton_order_with(points, false)
}

/// [`morton_order`], with the codes and the sort on the current rayon pool when `parallel`.
/// The order is the same: no two (code, index) keys are equal, so any sort gives it.
pub fn morton_order_with(points: &[V3], parallel: bool) -> Vec<u32> {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for c in points.iter().filter(|c| c.iter().all(|x| x.is_finite())) {
        for k in 0..3 {
            lo[k] = lo[k].min(c[k]);
            hi[k] = hi[k].max(c[k]);
        }
    }
    let cells = ((1u64 << BITS) - 1) as f64;
    let scale: [f64; 3] = std::array::from_fn(|k| {
        let extent = hi[k] - lo[k];
        if extent > 0.0 && extent.is_finite() {
            cells / extent
        } else {
            0.0
        }
    });
    // Non-finite points land in cell 0 (`as` saturates, NaN becomes 0).
    let key = |(i, c): (usize, &V3)| -> (u64, u32) {
        let code = (0..3)
            .map(|k| spread(((c[k] - lo[k]) * scale[k]).clamp(0.0, cells) as u64) << k)
            .fold(0, |a, b| a | b);
        (code, i as u32)
    };
    if parallel {
        let mut order: Vec<(u64, u32)> = points.par_iter().enumerate().map(key).collect();
        order.par_sort_unstable();
        order.into_par_iter().map(|(_, i)| i).collect()
    } else {
        let mut order: Vec<(u64, u32)> = points.iter().enumerate().map(key).collect();
        order.sort_unstable();
        order.into_iter().map(|(_, i)| i).collect()
    }
}

/// Median over the faces of the index distance between their first and last corner: how far
/// apart in memory a face's vertices sit (0 for a mesh without faces).
pub fn median_corner_spread(mesh: &TriMesh) -> u32 {
    let mut spread: Vec<u32> = mesh
        .triangles
        .iter()
        .map(|t| t.iter().max().unwrap_or(&0) - t.iter().min().unwrap_or(&0))
        .collect();
    if spread.is_empty() {
        return 0;
    }
    let mid = spread.len() / 2;
    *spread.select_nth_unstable(mid).1
}

/// `mesh` renumbered along a Morton curve (module docs); `None` when a face has a corner
/// index out of range (the caller keeps the mesh as it is and reports the defect itself).
pub fn spatially_ordered(mesh: &TriMesh) -> Option<Reordered> {
    spatially_ordered_with(mesh, false)
}

/// [`spatially_ordered`], with the per-face and per-vertex work on the current rayon pool
/// when `parallel` (the same numbering).
pub fn spatially_ordered_with(mesh: &TriMesh, parallel: bool) -> Option<Reordered> {
    let nv = mesh.positions.len();
    if mesh
        .triangles
        .iter()
        .any(|t| t.iter().any(|&c| c as usize >= nv))
    {
        return None;
    }
    let centroid = |t: &[u32; 3]| -> V3 {
        let p = t.map(|c| mesh.positions[c as usize]);
        [0, 1, 2].map(|k| (p[0][k] + p[1][k] + p[2][k]) / 3.0)
    };
    let centroids: Vec<V3> = if parallel {
        mesh.triangles.par_iter().map(centroid).collect()
    } else {
        mesh.triangles.iter().map(centroid).collect()
    };
    let order = morton_order_with(&centroids, parallel);
    drop(centroids);

    // The first use along the sorted faces numbers the vertices: a sequential pass.
    let mut new_vertex = vec![u32::MAX; nv];
    let mut next = 0u32;
    for &f in &order {
        for c in mesh.triangles[f as usize] {
            if new_vertex[c as usize] == u32::MAX {
                new_vertex[c as usize] = next;
                next += 1;
            }
        }
    }
    for slot in new_vertex.iter_mut().filter(|s| **s == u32::MAX) {
        *slot = next;
        next += 1;
    }
    let mut positions = vec![[0.0; 3]; nv];
    for (old, &new) in new_vertex.iter().enumerate() {
        positions[new as usize] = mesh.positions[old];
    }
    let renumber = |&f: &u32| mesh.triangles[f as usize].map(|c| new_vertex[c as usize]);
    let triangles = if parallel {
        order.par_iter().map(renumber).collect()
    } else {
        order.iter().map(renumber).collect()
    };
    Some(Reordered {
        mesh: TriMesh::new(positions, triangles),
        new_vertex,
        old_face: order,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::sphere;

    #[test]
    fn morton_order_follows_a_line_and_breaks_ties_by_index() {
        // Points on a line, listed out of order: the curve visits them along the line.
        let xs = [5.0, 0.0, 3.0, 9.0, 1.0, 7.0];
        let points: Vec<V3> = xs.iter().map(|&x| [x, 2.0, -1.0]).collect();
        assert_eq!(morton_order(&points), vec![1, 4, 2, 0, 5, 3]);
        // Equal points keep their index order; a NaN point counts as the low corner.
        let points = vec![
            [1.0, 1.0, 1.0],
            [0.0; 3],
            [1.0, 1.0, 1.0],
            [f64::NAN, 0.0, 0.0],
        ];
        assert_eq!(morton_order(&points), vec![1, 3, 0, 2]);
        assert_eq!(morton_order_with(&points, true), vec![1, 3, 0, 2]);
    }

    #[test]
    fn spread_puts_bits_three_apart() {
        assert_eq!(spread(0b1011), 0b1_000_001_001);
        assert_eq!(spread(0x1f_ffff), 0x1249_2492_4924_9249);
    }

    #[test]
    fn renumbering_keeps_the_surface_and_brings_corners_together() {
        let m = sphere(1.0, 5).unwrap();
        // Scramble the vertex numbering the way subdivision and scans do.
        let nv = m.positions.len() as u32;
        let old_of_new: Vec<u32> = (0..nv).map(|i| (i * 7919) % nv).collect();
        let mut new_of_old = vec![0u32; nv as usize];
        for (n, &o) in old_of_new.iter().enumerate() {
            new_of_old[o as usize] = n as u32;
        }
        let scrambled = TriMesh::new(
            old_of_new
                .iter()
                .map(|&o| m.positions[o as usize])
                .collect(),
            m.triangles
                .iter()
                .rev()
                .map(|t| t.map(|c| new_of_old[c as usize]))
                .collect(),
        );
        let r = spatially_ordered(&scrambled).unwrap();
        assert_eq!(r.mesh.n_vertices(), scrambled.n_vertices());
        assert_eq!(r.mesh.n_faces(), scrambled.n_faces());
        // Every face is the old face with its corners renamed, in the same corner order.
        for (new_f, t) in r.mesh.triangles.iter().enumerate() {
            let old = scrambled.triangles[r.old_face[new_f] as usize];
            assert_eq!(*t, old.map(|c| r.new_vertex[c as usize]));
            for k in 0..3 {
                assert_eq!(
                    r.mesh.positions[t[k] as usize],
                    scrambled.positions[old[k] as usize]
                );
            }
        }
        let spread_of = |mesh: &TriMesh| {
            mesh.triangles
                .iter()
                .map(|t| (t.iter().max().unwrap() - t.iter().min().unwrap()) as f64)
                .sum::<f64>()
                / mesh.n_faces() as f64
        };
        let (before, after) = (spread_of(&scrambled), spread_of(&r.mesh));
        assert!(
            after * 8.0 < before,
            "mean corner spread {before} -> {after}"
        );
        // The same numbering on a second call, and on the pool.
        let again = spatially_ordered(&scrambled).unwrap();
        assert_eq!(again.new_vertex, r.new_vertex);
        assert_eq!(again.old_face, r.old_face);
        let pooled = spatially_ordered_with(&scrambled, true).unwrap();
        assert_eq!(pooled.new_vertex, r.new_vertex);
        assert_eq!(pooled.old_face, r.old_face);
        assert_eq!(pooled.mesh.triangles, r.mesh.triangles);
    }

    #[test]
    fn median_corner_spread_of_a_strip() {
        // Faces (2k, 2k+1, 2k+2) and (2k+1, 2k+3, 2k+2): spreads 2; one far face: 50.
        let p: Vec<V3> = (0..60).map(|i| [i as f64, (i % 2) as f64, 0.0]).collect();
        let mut t: Vec<[u32; 3]> = (0..10)
            .flat_map(|k| {
                [
                    [2 * k, 2 * k + 1, 2 * k + 2],
                    [2 * k + 1, 2 * k + 3, 2 * k + 2],
                ]
            })
            .collect();
        t.push([0, 50, 1]);
        assert_eq!(median_corner_spread(&TriMesh::new(p.clone(), t)), 2);
        assert_eq!(median_corner_spread(&TriMesh::new(p, vec![])), 0);
    }

    #[test]
    fn unused_vertices_go_last_and_bad_indices_are_refused() {
        let p = vec![
            [9.0, 9.0, 9.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let m = TriMesh::new(p.clone(), vec![[1, 2, 3]]);
        let r = spatially_ordered(&m).unwrap();
        assert_eq!(r.new_vertex, vec![3, 0, 1, 2]);
        assert_eq!(r.mesh.positions[3], [9.0, 9.0, 9.0]);
        assert!(spatially_ordered(&TriMesh::new(p, vec![[1, 2, 4]])).is_none());
    }
}
