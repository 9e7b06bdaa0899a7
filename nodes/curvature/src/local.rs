//! Helpers shared by the curvature estimators: input checks, tangent frames, n-ring gathering
//! and the small symmetric eigenproblems of 2×2 shape operators.

use std::cell::RefCell;

use crestflow_geom::mesh::Topology;
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{MeshDefect, TriMesh};

/// Why a mesh cannot be processed by a curvature estimator.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshInputError {
    #[error("face {face} references vertex {index} but the mesh has {n_vertices} vertices")]
    IndexOutOfRange {
        face: usize,
        index: u32,
        n_vertices: usize,
    },
    #[error("vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFinite { vertex: usize, position: V3 },
}

/// Checks what the estimators rely on: triangle indices in range and finite positions.
/// (Meshes from the loaders are validated already; meshes built in code may not be.)
pub fn check_mesh(mesh: &TriMesh) -> Result<(), MeshInputError> {
    mesh.check_data().map_err(|d| match d {
        MeshDefect::NonFinitePosition { vertex, position } => {
            MeshInputError::NonFinite { vertex, position }
        }
        MeshDefect::IndexOutOfRange {
            face,
            index,
            n_vertices,
        } => MeshInputError::IndexOutOfRange {
            face,
            index,
            n_vertices,
        },
    })
}

/// Unit vertex normals weighted by face area (the sum of the incident faces' cross
/// products); zero for vertices without a non-degenerate face. Cheaper than angle weights; used
/// where the normal only orients a local frame that a fit corrects.
pub fn area_weighted_normals(mesh: &TriMesh) -> Vec<V3> {
    let mut acc = vec![[0.0; 3]; mesh.n_vertices()];
    for (f, t) in mesh.triangles.iter().enumerate() {
        let n = mesh.face_normal_raw(f);
        for &v in t {
            acc[v as usize] = vec3::add(acc[v as usize], n);
        }
    }
    acc.into_iter().map(vec3::normalize).collect()
}

/// Unit vertex normals with the weights of Max 1999 ("Weights for computing vertex normals
/// from facet normals"): each incident face's cross product at the vertex divided by the
/// squared lengths of its two edges there, exact for vertices of a sphere. Zero for vertices
/// without a non-degenerate face.
pub fn max_weighted_normals(mesh: &TriMesh) -> Vec<V3> {
    let mut acc = vec![[0.0; 3]; mesh.n_vertices()];
    for t in &mesh.triangles {
        let p = [t[0], t[1], t[2]].map(|i| mesh.positions[i as usize]);
        for i in 0..3 {
            let a = vec3::sub(p[(i + 1) % 3], p[i]);
            let b = vec3::sub(p[(i + 2) % 3], p[i]);
            let w = vec3::dot(a, a) * vec3::dot(b, b);
            if w > 0.0 {
                let v = t[i] as usize;
                acc[v] = vec3::add(acc[v], vec3::scale(vec3::cross(a, b), 1.0 / w));
            }
        }
    }
    acc.into_iter().map(vec3::normalize).collect()
}

/// An orthonormal tangent pair (e1, e2) with e1 × e2 = n for unit `n`, without branches on
/// the normal's direction except its z sign (the construction of Frisvad, revised by
/// Duff et al. 2017).
#[inline]
pub fn tangent_basis(n: V3) -> (V3, V3) {
    let sign = 1f64.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    let e1 = [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]];
    let e2 = [b, sign + n[1] * n[1] * a, -n[1]];
    (e1, e2)
}

/// The minimal rotation taking unit `from` to unit `to`, applied to `x`
/// (R = I + \[v\]× + \[v\]×² / (1 + c), v = from × to, c = from · to). Opposite normals: `-x`.
#[inline]
pub fn rotate_between(from: V3, to: V3, x: V3) -> V3 {
    let c = vec3::dot(from, to);
    if c <= -1.0 + 1e-12 {
        return vec3::scale(x, -1.0);
    }
    let v = vec3::cross(from, to);
    let vx = vec3::cross(v, x);
    let vvx = vec3::cross(v, vx);
    vec3::add(x, vec3::add(vx, vec3::scale(vvx, 1.0 / (1.0 + c))))
}

/// Reusable visit marks for n-ring gathering: `mark[v] == stamp` means "seen in this query".
/// One per worker thread (see [`with_scratch`]); results never depend on its contents.
#[derive(Default)]
pub struct Scratch {
    mark: Vec<u32>,
    stamp: u32,
    /// Gathered vertices of the current query.
    pub ring: Vec<u32>,
}

impl Scratch {
    fn begin(&mut self, n: usize) {
        if self.mark.len() < n {
            self.mark.resize(n, 0);
        }
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.mark.iter_mut().for_each(|m| *m = 0);
            self.stamp = 1;
        }
        self.ring.clear();
    }

    /// Starts a query at `v`: clears the gathered set and adds `v`'s one-ring.
    /// Returns the start of the outermost ring in `ring`.
    pub fn start(&mut self, topo: &Topology, n: usize, v: u32) -> usize {
        self.begin(n);
        self.mark[v as usize] = self.stamp;
        for &w in topo.neighbors(v) {
            if self.mark[w as usize] != self.stamp {
                self.mark[w as usize] = self.stamp;
                self.ring.push(w);
            }
        }
        0
    }

    /// Adds the next ring around the set gathered so far (the neighbours of the outermost ring,
    /// which starts at `outer`). Returns the start of the new outermost ring.
    pub fn grow(&mut self, topo: &Topology, outer: usize) -> usize {
        let end = self.ring.len();
        for i in outer..end {
            let u = self.ring[i];
            for &w in topo.neighbors(u) {
                if self.mark[w as usize] != self.stamp {
                    self.mark[w as usize] = self.stamp;
                    self.ring.push(w);
                }
            }
        }
        end
    }
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// Runs `f` with this thread's scratch space.
pub fn with_scratch<R>(f: impl FnOnce(&mut Scratch) -> R) -> R {
    SCRATCH.with(|s| f(&mut s.borrow_mut()))
}

/// Eigenvalues and I-orthonormal eigenvectors of the symmetric-definite pencil (II, I) of 2×2
/// matrices given as (xx, xy, yy): II v = k I v. Returns (k_max, v_max, k_min, v_min) with
/// vᵀ I v = 1. Used for graphs z = f(x, y) whose slope at the origin is not zero.
pub fn pencil_eigen2(ii: [f64; 3], i: [f64; 3]) -> (f64, [f64; 2], f64, [f64; 2]) {
    // Cholesky I = L Lᵀ, then M = L⁻¹ II L⁻ᵀ is symmetric.
    let l11 = i[0].sqrt();
    let l21 = i[1] / l11;
    let l22 = (i[2] - l21 * l21).sqrt();
    // L⁻¹ = [[1/l11, 0], [-l21/(l11 l22), 1/l22]]
    let (a, b, c) = (1.0 / l11, -l21 / (l11 * l22), 1.0 / l22);
    // M = L⁻¹ II L⁻ᵀ with L⁻¹ = [[a, 0], [b, c]].
    let m11 = a * a * ii[0];
    let m12 = a * (b * ii[0] + c * ii[1]);
    let m22 = b * b * ii[0] + 2.0 * b * c * ii[1] + c * c * ii[2];
    let (k_max, k_min, cs, sn) = crestflow_geom::shapes::sym2_eigen(m11, m12, m22);
    // v = L⁻ᵀ u, L⁻ᵀ = [[a, b], [0, c]].
    let v_max = [a * cs + b * sn, c * sn];
    let v_min = [a * -sn + b * cs, c * cs];
    (k_max, v_max, k_min, v_min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangent_basis_is_orthonormal_and_right_handed() {
        for n in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.3, -0.4, 0.866],
        ] {
            let n = vec3::normalize(n);
            let (e1, e2) = tangent_basis(n);
            assert!((vec3::norm(e1) - 1.0).abs() < 1e-12);
            assert!((vec3::norm(e2) - 1.0).abs() < 1e-12);
            assert!(vec3::dot(e1, n).abs() < 1e-12 && vec3::dot(e2, n).abs() < 1e-12);
            assert!(vec3::dist(vec3::cross(e1, e2), n) < 1e-12);
        }
    }

    #[test]
    fn rotation_maps_normal_and_keeps_lengths() {
        let a = vec3::normalize([0.1, 0.2, 1.0]);
        let b = vec3::normalize([-0.5, 0.3, 0.7]);
        assert!(vec3::dist(rotate_between(a, b, a), b) < 1e-12);
        let x = [0.3, -1.0, 2.0];
        assert!((vec3::norm(rotate_between(a, b, x)) - vec3::norm(x)).abs() < 1e-12);
    }

    #[test]
    fn pencil_matches_plain_eigen_for_identity_and_solves_general_case() {
        let (k1, v1, k2, v2) = pencil_eigen2([3.0, 1.0, 1.0], [1.0, 0.0, 1.0]);
        assert!((k1 - (2.0 + 2f64.sqrt())).abs() < 1e-12);
        assert!((k2 - (2.0 - 2f64.sqrt())).abs() < 1e-12);
        assert!((v1[0] * v2[0] + v1[1] * v2[1]).abs() < 1e-12);
        // General pencil: residual of II v − k I v vanishes, vᵀ I v = 1.
        let ii = [2.0, 0.5, -1.0];
        let im = [1.2, 0.1, 1.05];
        let (k1, v1, k2, v2) = pencil_eigen2(ii, im);
        for (k, v) in [(k1, v1), (k2, v2)] {
            let r0 = ii[0] * v[0] + ii[1] * v[1] - k * (im[0] * v[0] + im[1] * v[1]);
            let r1 = ii[1] * v[0] + ii[2] * v[1] - k * (im[1] * v[0] + im[2] * v[1]);
            assert!(r0.abs() < 1e-12 && r1.abs() < 1e-12);
            let norm = im[0] * v[0] * v[0] + 2.0 * im[1] * v[0] * v[1] + im[2] * v[1] * v[1];
            assert!((norm - 1.0).abs() < 1e-12);
        }
        assert!(k1 > k2);
    }
}
