//! Re-assembly of the cotangent Laplacian and lumped mass on the moving mesh (thesis §2.3).
//!
//! The operator is the one of `crestflow_nodes_spectral::sparse::laplacian_and_mass`, whose
//! sparsity pattern depends on the triangles only. Smoothing rebuilds the operator at every
//! iteration on new positions: instead of assembling from triplets (a sort of 12 entries per
//! face), the pattern is built once from the mesh's edges and the values are written straight
//! into it through precomputed slots. The per-face terms follow the spectral crate's definition to the bit
//! (intrinsic mollification of the edge lengths, Kahan's Heron formula, triangles with a
//! cotangent beyond `COT_CLAMP` left out, barycentric or mixed Voronoi masses) and the sums
//! run in the same face and corner order, so the result equals `laplacian_and_mass` exactly;
//! a test checks it.

use crestflow_flow::Par;
use crestflow_geom::vec3::V3;
use crestflow_geom::TriMesh;
use crestflow_nodes_spectral::sparse::{
    CsrMatrix, LaplacianOptions, MassKind, OperatorError, SparseError, COT_CLAMP,
};

/// Writes the cotangent stiffness and the lumped mass of new positions into a fixed pattern.
pub struct CotanAssembler {
    opts: LaplacianOptions,
    /// Per face, per corner i: the slots of (j, k), (k, j), (j, j), (k, k) in the CSR values.
    slots: Vec<[usize; 12]>,
}

fn lengths(x: &[V3], t: [u32; 3]) -> [f64; 3] {
    let d = |p: V3, q: V3| {
        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
    };
    let (a, b, c) = (x[t[0] as usize], x[t[1] as usize], x[t[2] as usize]);
    [d(b, c), d(c, a), d(a, b)]
}

/// The length δ added to every edge (intrinsic mollification, Sharp & Crane 2020).
fn mollify_delta(lens: &[[f64; 3]], mollify: f64) -> f64 {
    if mollify == 0.0 {
        return 0.0;
    }
    let mut sum = 0.0;
    let mut count = 0usize;
    for l in lens {
        sum += l[0] + l[1] + l[2];
        count += 3;
    }
    let eps = mollify * sum / count.max(1) as f64;
    let mut delta: f64 = 0.0;
    for l in lens {
        for i in 0..3 {
            let slack = l[(i + 1) % 3] + l[(i + 2) % 3] - l[i];
            delta = delta.max(eps - slack);
        }
    }
    delta
}

/// Corner cotangents and masses of a triangle with side lengths `l` (`l[i]` opposite corner i).
fn face_terms(l: [f64; 3], mass: MassKind) -> ([f64; 3], [f64; 3]) {
    let mut s = l;
    s.sort_by(|x, y| y.total_cmp(x));
    let [a, b, c] = s;
    let prod = (a + (b + c)) * (c - (a - b)) * (c + (a - b)) * (a + (b - c));
    let area = 0.25 * prod.max(0.0).sqrt();
    let sq = [l[0] * l[0], l[1] * l[1], l[2] * l[2]];
    let mut cot = [0.0; 3];
    for i in 0..3 {
        let num = sq[(i + 1) % 3] + sq[(i + 2) % 3] - sq[i];
        cot[i] = if num == 0.0 { 0.0 } else { num / (4.0 * area) };
    }
    // A triangle with an extreme (or undefined) cotangent is left out as a whole, which keeps
    // each triangle's contribution positive semi-definite.
    let dropped = cot.iter().any(|c| c.is_nan() || c.abs() > COT_CLAMP);
    if dropped {
        cot = [0.0; 3];
    }
    let m = match mass {
        MassKind::Barycentric => [area / 3.0; 3],
        MassKind::Voronoi if dropped => [area / 3.0; 3],
        MassKind::Voronoi => {
            match (0..3).find(|&i| sq[(i + 1) % 3] + sq[(i + 2) % 3] - sq[i] < 0.0) {
                Some(o) => {
                    let mut m = [0.25 * area; 3];
                    m[o] = 0.5 * area;
                    m
                }
                None => {
                    let mut m = [0.0; 3];
                    for (i, mi) in m.iter_mut().enumerate() {
                        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                        *mi = (sq[k] * cot[k] + sq[j] * cot[j]) / 8.0;
                    }
                    m
                }
            }
        }
    };
    (cot, m)
}

impl CotanAssembler {
    /// The operator of `mesh` and an assembler for later positions. The pattern is the one
    /// `laplacian_and_mass` produces: every edge and the diagonal of every vertex with a face.
    /// The mesh must have been validated (indices in range, no repeated corner, finite).
    pub fn new(
        mesh: &TriMesh,
        mass: MassKind,
        par: Par,
    ) -> Result<(CotanAssembler, CsrMatrix, Vec<f64>), OperatorError> {
        let opts = LaplacianOptions {
            mass,
            ..LaplacianOptions::default()
        };
        let n = mesh.n_vertices();
        let topo = mesh.topology();
        let mut row_ptr = Vec::with_capacity(n + 1);
        row_ptr.push(0usize);
        let mut col_idx = Vec::with_capacity(2 * topo.edges.len() + n);
        for v in 0..n as u32 {
            let nb = topo.neighbors(v);
            let has_faces = !topo.vertex_faces(v).is_empty();
            let mut diag_done = !has_faces;
            for &u in nb {
                if !diag_done && u > v {
                    col_idx.push(v as usize);
                    diag_done = true;
                }
                col_idx.push(u as usize);
            }
            if !diag_done {
                col_idx.push(v as usize);
            }
            row_ptr.push(col_idx.len());
        }
        let nnz = col_idx.len();
        let mut l = CsrMatrix::from_raw(n, n, row_ptr, col_idx, vec![0.0; nnz])?;
        let (rp, ci) = (l.row_ptr(), l.col_idx());
        let slot = |r: u32, c: u32| -> Result<usize, OperatorError> {
            let (s, e) = (rp[r as usize], rp[r as usize + 1]);
            ci[s..e]
                .binary_search(&(c as usize))
                .map(|k| s + k)
                .map_err(|_| {
                    OperatorError::Sparse(SparseError::Malformed(format!(
                        "entry ({r}, {c}) missing from the Laplacian's pattern"
                    )))
                })
        };
        let mut slots = Vec::with_capacity(mesh.n_faces());
        for t in &mesh.triangles {
            let mut s = [0usize; 12];
            for i in 0..3 {
                let (j, k) = (t[(i + 1) % 3], t[(i + 2) % 3]);
                s[4 * i] = slot(j, k)?;
                s[4 * i + 1] = slot(k, j)?;
                s[4 * i + 2] = slot(j, j)?;
                s[4 * i + 3] = slot(k, k)?;
            }
            slots.push(s);
        }
        let asm = CotanAssembler { opts, slots };
        let mut m = vec![0.0; n];
        asm.assemble(&mesh.triangles, &mesh.positions, &mut l, &mut m, par);
        Ok((asm, l, m))
    }

    /// Overwrites `l`'s values and `mass` with the operator of positions `x` (same triangles).
    pub fn assemble(
        &self,
        tris: &[[u32; 3]],
        x: &[V3],
        l: &mut CsrMatrix,
        mass: &mut [f64],
        par: Par,
    ) {
        let lens = par.map_collect(tris.len(), |f| lengths(x, tris[f]));
        let delta = mollify_delta(&lens, self.opts.mollify);
        let kind = self.opts.mass;
        let terms = par.map_collect(tris.len(), |f| {
            let l = lens[f];
            face_terms([l[0] + delta, l[1] + delta, l[2] + delta], kind)
        });
        let vals = l.values_mut();
        vals.iter_mut().for_each(|v| *v = 0.0);
        mass.iter_mut().for_each(|v| *v = 0.0);
        // Face order, then corner order: the order in which the triplet assembly sums.
        for ((t, (cot, m)), s) in tris.iter().zip(&terms).zip(&self.slots) {
            for i in 0..3 {
                let w = 0.5 * cot[i];
                vals[s[4 * i]] += -w;
                vals[s[4 * i + 1]] += -w;
                vals[s[4 * i + 2]] += w;
                vals[s[4 * i + 3]] += w;
            }
            for i in 0..3 {
                mass[t[i] as usize] += m[i];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crestflow_geom::shapes::ellipsoid;
    use crestflow_nodes_spectral::sparse::laplacian_and_mass;

    #[test]
    fn equals_the_spectral_operator_bit_for_bit() {
        let base = ellipsoid(1.0, 0.7, 0.4, 3, 0.4, 2).unwrap();
        let (asm, mut l, mut m) = CotanAssembler::new(&base, MassKind::Voronoi, Par::Seq).unwrap();
        // The pattern built from the edges and the first values match too.
        let (l0, m0) = laplacian_and_mass(&base, &LaplacianOptions::default(), Par::Seq).unwrap();
        assert_eq!(l, l0);
        assert_eq!(m, m0);
        // New positions, one triangle squashed flat so that mollification kicks in.
        let mut x: Vec<V3> = base
            .positions
            .iter()
            .map(|p| {
                [
                    p[0] * 1.1 + 0.05 * p[1],
                    p[1] * 0.9,
                    p[2] + 0.1 * p[0] * p[0],
                ]
            })
            .collect();
        let t = base.triangles[10];
        let mid = [
            0.5 * (x[t[1] as usize][0] + x[t[2] as usize][0]),
            0.5 * (x[t[1] as usize][1] + x[t[2] as usize][1]),
            0.5 * (x[t[1] as usize][2] + x[t[2] as usize][2]),
        ];
        x[t[0] as usize] = mid;
        let moved = base.with_positions(x.clone());
        for kind in [MassKind::Voronoi, MassKind::Barycentric] {
            let opts = LaplacianOptions {
                mass: kind,
                ..Default::default()
            };
            let asm = CotanAssembler {
                opts,
                slots: asm.slots.clone(),
            };
            asm.assemble(&moved.triangles, &x, &mut l, &mut m, Par::Rayon);
            let (l_ref, m_ref) = laplacian_and_mass(&moved, &opts, Par::Seq).unwrap();
            assert_eq!(l, l_ref, "{kind:?}");
            assert_eq!(m, m_ref, "{kind:?}");
        }
    }
}
