//! Re-assembly of the cotangent Laplacian and lumped mass on moving positions (thesis §2.3),
//! for iterative methods such as Laplacian smoothing.
//!
//! The sparsity pattern of [`crate::sparse::laplacian_and_mass`] depends on the triangles
//! only. Instead of gathering and sorting every row's entries again at every step, the
//! pattern is built once from the mesh's edges and the values are written straight into it
//! through precomputed slots. The per-face terms are the same functions, summed in the same
//! face and corner order, so the result equals `laplacian_and_mass` bit for bit (tested).

use crestflow_flow::Par;
use crestflow_geom::vec3::V3;
use crestflow_geom::TriMesh;

use crate::sparse::{
    face_terms, mollify_delta_of_lengths, triangle_lengths, CsrMatrix, LaplacianOptions, MassKind,
    OperatorError, SparseError,
};

/// Writes the cotangent stiffness and the lumped mass of new positions into a fixed pattern.
pub struct CotanAssembler {
    opts: LaplacianOptions,
    /// Per face, per corner i: the slots of (j, k), (k, j), (j, j), (k, k) in the CSR values.
    slots: Vec<[usize; 12]>,
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
        let lens = par.map_collect(tris.len(), |f| triangle_lengths(x, tris[f]));
        let delta = mollify_delta_of_lengths(&lens, self.opts.mollify);
        let kind = self.opts.mass;
        let terms = par.map_collect(tris.len(), |f| {
            let l = lens[f];
            face_terms([l[0] + delta, l[1] + delta, l[2] + delta], kind)
        });
        let vals = l.values_mut();
        vals.iter_mut().for_each(|v| *v = 0.0);
        mass.iter_mut().for_each(|v| *v = 0.0);
        // Face order, then corner order: the order in which the triplet assembly sums.
        for ((t, ft), s) in tris.iter().zip(&terms).zip(&self.slots) {
            for i in 0..3 {
                let w = 0.5 * ft.cot[i];
                vals[s[4 * i]] += -w;
                vals[s[4 * i + 1]] += -w;
                vals[s[4 * i + 2]] += w;
                vals[s[4 * i + 3]] += w;
            }
            for i in 0..3 {
                mass[t[i] as usize] += ft.mass[i];
            }
        }
    }
}

#[cfg(test)]
#[path = "assemble_test.rs"]
mod tests;
