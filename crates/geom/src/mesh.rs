//! Triangle meshes with lazily built connectivity.
//!
//! Positions and triangles are the stored data; [`Topology`] (vertex-face incidence, unique
//! edges with their faces, one-rings, boundaries) is derived on first use and never serialised,
//! so cache entries stay small and equality means "same geometry".

use std::ops::{Index, IndexMut};
use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

use crate::vec3::{self, V3};

/// Index of a vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct VertexId(pub u32);

/// Index of a face.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct FaceId(pub u32);

/// One value per vertex, indexed by [`VertexId`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VertexData<T>(pub Vec<T>);

/// One value per face, indexed by [`FaceId`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FaceData<T>(pub Vec<T>);

impl<T> Index<VertexId> for VertexData<T> {
    type Output = T;
    fn index(&self, i: VertexId) -> &T {
        &self.0[i.0 as usize]
    }
}
impl<T> IndexMut<VertexId> for VertexData<T> {
    fn index_mut(&mut self, i: VertexId) -> &mut T {
        &mut self.0[i.0 as usize]
    }
}
impl<T> Index<FaceId> for FaceData<T> {
    type Output = T;
    fn index(&self, i: FaceId) -> &T {
        &self.0[i.0 as usize]
    }
}
impl<T> IndexMut<FaceId> for FaceData<T> {
    fn index_mut(&mut self, i: FaceId) -> &mut T {
        &mut self.0[i.0 as usize]
    }
}

/// Marks "no face" in [`Topology::edge_faces`].
pub const NO_FACE: u32 = u32::MAX;

/// Connectivity derived from the triangles.
#[derive(Clone, Debug, Default)]
pub struct Topology {
    /// Unique undirected edges, `a < b`, sorted.
    pub edges: Vec<[u32; 2]>,
    /// The (up to) two faces of each edge; `NO_FACE` where missing. Edges with more than two
    /// faces are listed in `nonmanifold_edges` and keep their first two here.
    pub edge_faces: Vec<[u32; 2]>,
    /// For face f, the edge index of its side i = `(tri[i], tri[(i+1) % 3])`.
    pub face_edges: Vec<[u32; 3]>,
    /// Edges with more than two incident faces.
    pub nonmanifold_edges: Vec<u32>,
    vf_offsets: Vec<u32>,
    vf_faces: Vec<u32>,
    vv_offsets: Vec<u32>,
    vv_verts: Vec<u32>,
    /// Whether each vertex lies on a boundary edge (an edge with one face).
    pub is_boundary_vertex: Vec<bool>,
}

/// The sides of the faces as `(min, max, h)` (corner indices, `h = 3 f + i` for side
/// `(t[i], t[(i + 1) % 3])`), sorted: the two sides of an edge come out next to each other.
/// A counting sort by the smaller corner, then each vertex's few sides by `(max, h)`: linear
/// time, where sorting all triples at once took most of the set-up of large meshes. Corners
/// must be below `n_vertices`.
pub(crate) fn sorted_sides(n_vertices: usize, triangles: &[[u32; 3]]) -> Vec<(u32, u32, u32)> {
    let mut start = vec![0u32; n_vertices + 1];
    for t in triangles {
        for i in 0..3 {
            start[t[i].min(t[(i + 1) % 3]) as usize + 1] += 1;
        }
    }
    for v in 0..n_vertices {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut out = vec![(0u32, 0u32, 0u32); 3 * triangles.len()];
    // Placed in increasing h within each bucket.
    for (f, t) in triangles.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            let slot = &mut fill[a.min(b) as usize];
            out[*slot as usize] = (a.min(b), a.max(b), 3 * f as u32 + i as u32);
            *slot += 1;
        }
    }
    for v in 0..n_vertices {
        let bucket = &mut out[start[v] as usize..start[v + 1] as usize];
        // Insertion sort: buckets hold a handful of sides, and it keeps equal keys in order.
        for k in 1..bucket.len() {
            let x = bucket[k];
            let mut j = k;
            while j > 0 && bucket[j - 1] > x {
                bucket[j] = bucket[j - 1];
                j -= 1;
            }
            bucket[j] = x;
        }
    }
    out
}

/// The faces at each vertex as compressed rows: the faces of vertex v are
/// `faces[offsets[v]..offsets[v + 1]]`, in increasing face order (a counting sort of the
/// corners; a face that repeats a vertex is listed once per corner). Indices must be below
/// `n_vertices`.
pub fn vertex_faces_csr(n_vertices: usize, triangles: &[[u32; 3]]) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; n_vertices + 1];
    for t in triangles {
        for &v in t {
            offsets[v as usize + 1] += 1;
        }
    }
    for i in 0..n_vertices {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut faces = vec![0u32; offsets[n_vertices] as usize];
    for (f, t) in triangles.iter().enumerate() {
        for &v in t {
            faces[fill[v as usize] as usize] = f as u32;
            fill[v as usize] += 1;
        }
    }
    (offsets, faces)
}

impl Topology {
    fn build(n_vertices: usize, triangles: &[[u32; 3]]) -> Topology {
        let (vf_offsets, vf_faces) = vertex_faces_csr(n_vertices, triangles);

        // Half-edges keyed by (min, max), sorted, give unique edges deterministically.
        let half: Vec<(u32, u32, u32, u8)> = sorted_sides(n_vertices, triangles)
            .into_iter()
            .map(|(a, b, h)| (a, b, h / 3, (h % 3) as u8))
            .collect();
        let mut edges: Vec<[u32; 2]> = Vec::with_capacity(half.len() / 2 + 1);
        let mut edge_faces: Vec<[u32; 2]> = Vec::with_capacity(half.len() / 2 + 1);
        let mut face_edges = vec![[0u32; 3]; triangles.len()];
        let mut nonmanifold_edges = Vec::new();
        let mut i = 0;
        while i < half.len() {
            let (a, b) = (half[i].0, half[i].1);
            let e = edges.len() as u32;
            edges.push([a, b]);
            let mut faces = [NO_FACE; 2];
            let mut count = 0;
            while i < half.len() && half[i].0 == a && half[i].1 == b {
                let (_, _, f, side) = half[i];
                face_edges[f as usize][side as usize] = e;
                if count < 2 {
                    faces[count] = f;
                }
                count += 1;
                i += 1;
            }
            if count > 2 {
                nonmanifold_edges.push(e);
            }
            edge_faces.push(faces);
        }

        // Vertex -> neighbouring vertices, CSR, sorted by index.
        let mut vv_offsets = vec![0u32; n_vertices + 1];
        for e in &edges {
            vv_offsets[e[0] as usize + 1] += 1;
            vv_offsets[e[1] as usize + 1] += 1;
        }
        for i in 0..n_vertices {
            vv_offsets[i + 1] += vv_offsets[i];
        }
        let mut fill = vv_offsets.clone();
        let mut vv_verts = vec![0u32; vv_offsets[n_vertices] as usize];
        for e in &edges {
            vv_verts[fill[e[0] as usize] as usize] = e[1];
            fill[e[0] as usize] += 1;
            vv_verts[fill[e[1] as usize] as usize] = e[0];
            fill[e[1] as usize] += 1;
        }
        for v in 0..n_vertices {
            vv_verts[vv_offsets[v] as usize..vv_offsets[v + 1] as usize].sort_unstable();
        }

        let mut is_boundary_vertex = vec![false; n_vertices];
        for (e, faces) in edges.iter().zip(&edge_faces) {
            if faces[1] == NO_FACE {
                is_boundary_vertex[e[0] as usize] = true;
                is_boundary_vertex[e[1] as usize] = true;
            }
        }

        Topology {
            edges,
            edge_faces,
            face_edges,
            nonmanifold_edges,
            vf_offsets,
            vf_faces,
            vv_offsets,
            vv_verts,
            is_boundary_vertex,
        }
    }

    /// Faces around vertex `v` (in face index order).
    pub fn vertex_faces(&self, v: u32) -> &[u32] {
        &self.vf_faces
            [self.vf_offsets[v as usize] as usize..self.vf_offsets[v as usize + 1] as usize]
    }
    /// Vertices sharing an edge with `v` (in index order).
    pub fn neighbors(&self, v: u32) -> &[u32] {
        &self.vv_verts
            [self.vv_offsets[v as usize] as usize..self.vv_offsets[v as usize + 1] as usize]
    }
    /// Whether edge `e` has exactly one face.
    pub fn is_boundary_edge(&self, e: u32) -> bool {
        self.edge_faces[e as usize][1] == NO_FACE
    }
    /// The index of edge (a, b) in `edges`, if it exists.
    pub fn find_edge(&self, a: u32, b: u32) -> Option<u32> {
        let key = [a.min(b), a.max(b)];
        self.edges.binary_search(&key).ok().map(|i| i as u32)
    }
    /// Number of boundary edges.
    pub fn boundary_edge_count(&self) -> usize {
        self.edge_faces.iter().filter(|f| f[1] == NO_FACE).count()
    }
}

/// What [`TriMesh::check_data`] finds wrong with a mesh built outside the loaders (which
/// validate already). Algorithms map it into their own error type.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum MeshDefect {
    #[error("vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFinitePosition { vertex: usize, position: V3 },
    #[error("face {face} references vertex {index} but the mesh has {n_vertices} vertices")]
    IndexOutOfRange {
        face: usize,
        index: u32,
        n_vertices: usize,
    },
}

/// A triangle mesh: positions and triangles (counter-clockwise seen from outside), with
/// connectivity built on first use.
#[derive(Debug, Default, Serialize, Deserialize)]
pub struct TriMesh {
    pub positions: Vec<V3>,
    pub triangles: Vec<[u32; 3]>,
    #[serde(skip)]
    topology: OnceLock<Topology>,
}

impl Clone for TriMesh {
    fn clone(&self) -> Self {
        TriMesh::new(self.positions.clone(), self.triangles.clone())
    }
}

impl PartialEq for TriMesh {
    fn eq(&self, other: &Self) -> bool {
        self.positions == other.positions && self.triangles == other.triangles
    }
}

impl TriMesh {
    /// A mesh from raw arrays. No validation here: loaders validate (see `io`), and code that
    /// builds meshes itself is trusted to index correctly.
    pub fn new(positions: Vec<V3>, triangles: Vec<[u32; 3]>) -> Self {
        TriMesh {
            positions,
            triangles,
            topology: OnceLock::new(),
        }
    }
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }
    pub fn n_faces(&self) -> usize {
        self.triangles.len()
    }
    /// The first non-finite position, else the first face index out of range. Every algorithm
    /// that indexes positions through triangles relies on this.
    pub fn check_data(&self) -> Result<(), MeshDefect> {
        for (vertex, p) in self.positions.iter().enumerate() {
            if !p.iter().all(|c| c.is_finite()) {
                return Err(MeshDefect::NonFinitePosition {
                    vertex,
                    position: *p,
                });
            }
        }
        let n = self.positions.len();
        for (face, t) in self.triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= n) {
                return Err(MeshDefect::IndexOutOfRange {
                    face,
                    index,
                    n_vertices: n,
                });
            }
        }
        Ok(())
    }
    /// Connectivity, built on first call.
    pub fn topology(&self) -> &Topology {
        self.topology
            .get_or_init(|| Topology::build(self.positions.len(), &self.triangles))
    }
    /// Replaces positions keeping the triangles (and connectivity).
    pub fn with_positions(&self, positions: Vec<V3>) -> TriMesh {
        let m = TriMesh::new(positions, self.triangles.clone());
        if let Some(t) = self.topology.get() {
            let _ = m.topology.set(t.clone());
        }
        m
    }
    /// The three corner positions of face `f`.
    pub fn face_points(&self, f: usize) -> [V3; 3] {
        let t = self.triangles[f];
        [
            self.positions[t[0] as usize],
            self.positions[t[1] as usize],
            self.positions[t[2] as usize],
        ]
    }
    /// Unnormalised face normal (length = 2 × area).
    pub fn face_normal_raw(&self, f: usize) -> V3 {
        let [a, b, c] = self.face_points(f);
        vec3::cross(vec3::sub(b, a), vec3::sub(c, a))
    }
    /// Unit face normals (zero for degenerate faces).
    pub fn face_normals(&self) -> Vec<V3> {
        (0..self.n_faces())
            .map(|f| vec3::normalize(self.face_normal_raw(f)))
            .collect()
    }
    pub fn face_area(&self, f: usize) -> f64 {
        0.5 * vec3::norm(self.face_normal_raw(f))
    }
    pub fn total_area(&self) -> f64 {
        (0..self.n_faces()).map(|f| self.face_area(f)).sum()
    }
    /// Angle-weighted unit vertex normals (Thürmer–Wüthrich); zero for isolated vertices.
    pub fn vertex_normals(&self) -> Vec<V3> {
        let mut acc = vec![[0.0; 3]; self.n_vertices()];
        for f in 0..self.n_faces() {
            let t = self.triangles[f];
            let n = vec3::normalize(self.face_normal_raw(f));
            let p = self.face_points(f);
            for i in 0..3 {
                let u = vec3::sub(p[(i + 1) % 3], p[i]);
                let w = vec3::sub(p[(i + 2) % 3], p[i]);
                let ang = corner_angle(u, w);
                let a = &mut acc[t[i] as usize];
                *a = vec3::add(*a, vec3::scale(n, ang));
            }
        }
        acc.into_iter().map(vec3::normalize).collect()
    }
    /// Barycentric vertex areas (a third of each incident face's area).
    pub fn vertex_areas(&self) -> Vec<f64> {
        let mut area = vec![0.0; self.n_vertices()];
        for f in 0..self.n_faces() {
            let a = self.face_area(f) / 3.0;
            for &v in &self.triangles[f] {
                area[v as usize] += a;
            }
        }
        area
    }
    /// Lengths of the unique edges, in [`Topology::edges`] order.
    pub fn edge_lengths(&self) -> Vec<f64> {
        self.topology()
            .edges
            .iter()
            .map(|e| vec3::dist(self.positions[e[0] as usize], self.positions[e[1] as usize]))
            .collect()
    }
    /// Mean length of the unique edges (0 for a mesh without edges).
    pub fn mean_edge_length(&self) -> f64 {
        let l = self.edge_lengths();
        if l.is_empty() {
            0.0
        } else {
            l.iter().sum::<f64>() / l.len() as f64
        }
    }
    /// Axis-aligned bounding box (min, max); zeros for an empty mesh.
    pub fn bbox(&self) -> (V3, V3) {
        if self.positions.is_empty() {
            return ([0.0; 3], [0.0; 3]);
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }
    /// Length of the bounding box diagonal.
    pub fn bbox_diagonal(&self) -> f64 {
        let (lo, hi) = self.bbox();
        vec3::dist(lo, hi)
    }
}

/// The angle between `u` and `w` in radians (robust near 0 and π).
pub fn corner_angle(u: V3, w: V3) -> f64 {
    vec3::norm(vec3::cross(u, w)).atan2(vec3::dot(u, w))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> TriMesh {
        TriMesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        )
    }

    #[test]
    fn tetra_topology() {
        let m = tetra();
        let t = m.topology();
        assert_eq!(t.edges.len(), 6);
        assert!(t.edge_faces.iter().all(|f| f[1] != NO_FACE));
        assert_eq!(t.neighbors(0), &[1, 2, 3]);
        assert_eq!(t.vertex_faces(3), &[1, 2, 3]);
        assert_eq!(t.boundary_edge_count(), 0);
        assert!(t.nonmanifold_edges.is_empty());
        // Every face side maps to the edge with the same endpoints.
        for (f, tri) in m.triangles.iter().enumerate() {
            for i in 0..3 {
                let e = t.edges[t.face_edges[f][i] as usize];
                let (a, b) = (tri[i], tri[(i + 1) % 3]);
                assert_eq!(e, [a.min(b), a.max(b)]);
            }
        }
    }

    #[test]
    fn tetra_measures() {
        let m = tetra();
        let area: f64 = m.total_area();
        let expected = 1.5 + 3f64.sqrt() / 2.0;
        assert!((area - expected).abs() < 1e-12);
        assert!((m.vertex_areas().iter().sum::<f64>() - expected).abs() < 1e-12);
        assert!((m.bbox_diagonal() - 3f64.sqrt()).abs() < 1e-12);
        // The normal at the origin corner points into the negative octant.
        let n = m.vertex_normals()[0];
        assert!(n.iter().all(|&c| c < 0.0));
    }

    #[test]
    fn check_data_names_the_first_defect() {
        let mut m = tetra();
        assert_eq!(m.check_data(), Ok(()));
        m.triangles[2] = [0, 9, 2];
        assert_eq!(
            m.check_data(),
            Err(MeshDefect::IndexOutOfRange {
                face: 2,
                index: 9,
                n_vertices: 4
            })
        );
        m.positions[1][2] = f64::NAN;
        assert!(matches!(
            m.check_data(),
            Err(MeshDefect::NonFinitePosition { vertex: 1, .. })
        ));
    }

    #[test]
    fn open_and_nonmanifold_edges() {
        // Three triangles sharing edge (0, 1): one non-manifold edge, six boundary edges.
        let m = TriMesh::new(
            vec![
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, -1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
        );
        let t = m.topology();
        assert_eq!(t.nonmanifold_edges.len(), 1);
        assert_eq!(t.edges[t.nonmanifold_edges[0] as usize], [0, 1]);
        assert_eq!(t.boundary_edge_count(), 6);
        assert!(t.is_boundary_vertex[2]);
    }
}
