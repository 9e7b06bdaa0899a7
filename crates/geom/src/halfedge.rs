//! A mutable triangle mesh for local re-meshing operations (edge split, collapse, flip), as used
//! by isotropic remeshing (thesis §5.1.1; Botsch & Kobbelt 2004, "A remeshing approach to
//! multiresolution modeling").
//!
//! Storage is a corner table (Rossignac): face `f` owns half-edges `3f`, `3f + 1`, `3f + 2`;
//! half-edge `h` runs from `corner[h]` to the corner of `next(h)`, so `next` and `prev` are
//! arithmetic and only the twin (`opp`) is stored. Boundary edges have `opp == NONE`.
//! Each vertex keeps one outgoing half-edge; on a boundary vertex it is the one without a twin,
//! so a counter-clockwise sweep from it (`opp(prev(h))`) visits the whole fan.
//!
//! Each edge carries a `u32` tag (`NONE` = untagged) that the operations keep consistent: a
//! split edge passes its tag to both halves, a collapse merges the tags of the two edges it
//! fuses, a flipped edge is untagged. Remeshing uses it to mark feature edges.
//!
//! Deleted faces and vertices stay in the arrays until [`HalfEdgeMesh::to_trimesh`] compacts
//! them ("garbage collection").

use crate::mesh::{TriMesh, NO_FACE};
use crate::vec3::{self, V3};

/// "No half-edge / no vertex / no tag".
pub const NONE: u32 = u32::MAX;

/// Why a [`TriMesh`] cannot become a [`HalfEdgeMesh`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HalfEdgeError {
    #[error("face {face} references vertex {index} but the mesh has {n_vertices} vertices")]
    IndexOutOfRange {
        face: usize,
        index: u32,
        n_vertices: usize,
    },
    #[error("face {face} repeats a vertex: {corners:?}")]
    DegenerateFace { face: usize, corners: [u32; 3] },
    #[error("non-manifold edge ({a}, {b}): it has more than two faces (faces {faces:?} and more)")]
    NonManifoldEdge { a: u32, b: u32, faces: [usize; 2] },
    #[error(
        "edge ({a}, {b}): faces {faces:?} run along it in the same direction (inconsistent \
         orientation or a non-manifold edge; `io.load_mesh` with `repair: true` orients the \
         faces coherently)"
    )]
    InconsistentOrientation { a: u32, b: u32, faces: [usize; 2] },
    #[error("non-manifold vertex {vertex}: its faces form {fans} separate fans")]
    NonManifoldVertex { vertex: u32, fans: usize },
    #[error("the mesh has more than 2^30 faces")]
    TooLarge,
}

/// Why a collapse is not allowed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CollapseRejection {
    /// The one-rings share a vertex other than the edge's opposite vertices (link condition).
    LinkCondition,
    /// Both ends are on the boundary but the edge is not: the collapse would pinch the surface.
    BoundaryPinch,
    /// An opposite vertex would be left with too few edges (a tetrahedron, an ear).
    LowValence,
    /// A surviving triangle would flip or lose (almost) all its area.
    Geometry,
}

/// A manifold, consistently oriented triangle mesh with local update operations.
#[derive(Clone, Debug)]
pub struct HalfEdgeMesh {
    positions: Vec<V3>,
    /// Origin vertex of half-edge h (= corner h of face h / 3).
    corner: Vec<u32>,
    opp: Vec<u32>,
    tag: Vec<u32>,
    out: Vec<u32>,
    /// Number of edges at each vertex, kept up to date by every update: the remesher asks
    /// for it in every collapse and flip test, and walking the fan each time was 4–7 % of a
    /// remesh.
    valence: Vec<u32>,
    face_alive: Vec<bool>,
    vertex_alive: Vec<bool>,
    n_live_faces: usize,
    n_live_vertices: usize,
}

#[inline]
pub fn next(h: u32) -> u32 {
    if h % 3 == 2 {
        h - 2
    } else {
        h + 1
    }
}
#[inline]
pub fn prev(h: u32) -> u32 {
    if h.is_multiple_of(3) {
        h + 2
    } else {
        h - 1
    }
}
#[inline]
pub fn face_of(h: u32) -> u32 {
    h / 3
}

impl HalfEdgeMesh {
    /// Builds the corner table. Vertices used by no face are kept but isolated (dropped by
    /// [`HalfEdgeMesh::to_trimesh`]).
    pub fn from_trimesh(mesh: &TriMesh) -> Result<Self, HalfEdgeError> {
        let nv = mesh.n_vertices();
        let nf = mesh.n_faces();
        if nf >= 1 << 30 {
            return Err(HalfEdgeError::TooLarge);
        }
        for (face, t) in mesh.triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= nv) {
                return Err(HalfEdgeError::IndexOutOfRange {
                    face,
                    index,
                    n_vertices: nv,
                });
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(HalfEdgeError::DegenerateFace { face, corners: *t });
            }
        }
        let corner: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
        let nh = corner.len();
        // Twins from the mesh's edge table (built here if not yet; its users, such as the
        // remesher's feature detection, need it anyway): edges in (min, max) order, each with
        // its first two faces in face order, so the first bad edge is the one a sort of the
        // sides would meet first.
        let topo = mesh.topology();
        let mut opp = vec![NONE; nh];
        let mut nonmanifold = topo.nonmanifold_edges.iter().peekable();
        let side = |f: u32, e: u32| {
            let k = topo.face_edges[f as usize].iter().position(|&x| x == e);
            3 * f + k.unwrap_or(0) as u32
        };
        for (e, &[a, b]) in topo.edges.iter().enumerate() {
            let e = e as u32;
            let faces = topo.edge_faces[e as usize];
            if nonmanifold.next_if_eq(&&e).is_some() {
                return Err(HalfEdgeError::NonManifoldEdge {
                    a,
                    b,
                    faces: faces.map(|f| f as usize),
                });
            }
            if faces[1] == NO_FACE {
                continue;
            }
            let (h, g) = (side(faces[0], e), side(faces[1], e));
            if corner[h as usize] == corner[g as usize] {
                return Err(HalfEdgeError::InconsistentOrientation {
                    a,
                    b,
                    faces: faces.map(|f| f as usize),
                });
            }
            opp[h as usize] = g;
            opp[g as usize] = h;
        }
        let mut m = HalfEdgeMesh {
            positions: mesh.positions.clone(),
            corner,
            opp,
            tag: vec![NONE; nh],
            out: vec![NONE; nv],
            valence: Vec::new(),
            face_alive: vec![true; nf],
            vertex_alive: vec![true; nv],
            n_live_faces: nf,
            n_live_vertices: nv,
        };
        let mut corners_at = vec![0u32; nv];
        for h in 0..nh as u32 {
            let v = m.corner[h as usize];
            corners_at[v as usize] += 1;
            if m.out[v as usize] == NONE || m.opp[h as usize] == NONE {
                m.out[v as usize] = h;
            }
        }
        // Manifold vertices: the fan swept from `out` holds every corner of the vertex. The
        // same sweep counts the vertex's edges.
        let mut valence = vec![0u32; nv];
        for v in 0..nv as u32 {
            if m.out[v as usize] == NONE {
                continue;
            }
            let fan;
            (fan, valence[v as usize]) = m.walk_fan(v);
            if fan != corners_at[v as usize] {
                // Count fans: each fan has one start (a boundary half-edge), or is closed.
                let starts = (0..nh as u32)
                    .filter(|&h| m.corner[h as usize] == v && m.opp[h as usize] == NONE)
                    .count();
                return Err(HalfEdgeError::NonManifoldVertex {
                    vertex: v,
                    fans: starts.max(2),
                });
            }
        }
        m.valence = valence;
        Ok(m)
    }

    /// Compacts live vertices and faces into a [`TriMesh`]; also returns, for each old vertex,
    /// its new index (`NONE` for deleted or isolated vertices).
    pub fn to_trimesh(&self) -> (TriMesh, Vec<u32>) {
        let mut map = vec![NONE; self.positions.len()];
        let mut positions = Vec::with_capacity(self.n_live_vertices);
        for (v, m) in map.iter_mut().enumerate() {
            if self.vertex_alive[v] && self.out[v] != NONE {
                *m = positions.len() as u32;
                positions.push(self.positions[v]);
            }
        }
        let mut triangles = Vec::with_capacity(self.n_live_faces);
        for f in 0..self.face_alive.len() {
            if self.face_alive[f] {
                let c = &self.corner[3 * f..3 * f + 3];
                triangles.push([map[c[0] as usize], map[c[1] as usize], map[c[2] as usize]]);
            }
        }
        (TriMesh::new(positions, triangles), map)
    }

    /// Garbage collection in place: drops deleted faces and vertices (and isolated ones),
    /// keeping the order of the others and all tags. Returns, for each old vertex, its new
    /// index (`NONE` when dropped).
    pub fn compact(&mut self) -> Vec<u32> {
        let mut vmap = vec![NONE; self.positions.len()];
        let mut n = 0u32;
        for (v, m) in vmap.iter_mut().enumerate() {
            if self.vertex_alive[v] && self.out[v] != NONE {
                *m = n;
                n += 1;
            }
        }
        let faces: Vec<u32> = (0..self.face_alive.len() as u32)
            .filter(|&f| self.face_alive[f as usize])
            .collect();
        self.rebuild(&faces, vmap, n as usize)
    }

    /// [`HalfEdgeMesh::compact`] that also renumbers: the live vertices in increasing `key`
    /// (one per vertex slot; ties keep their order), the faces in the order of their first
    /// corner in that numbering (ties keep their order). Splits append their vertex at the end
    /// of the arrays, so after refinement one-rings are scattered; a key that puts each new
    /// vertex beside the vertices it came from gathers them again. Returns, for each old
    /// vertex, its new index (`NONE` when dropped).
    pub fn compact_by_key(&mut self, key: &[u64]) -> Vec<u32> {
        let nv = self.positions.len();
        assert_eq!(key.len(), nv, "one key per vertex slot");
        let mut live: Vec<u32> = (0..nv as u32)
            .filter(|&v| self.vertex_alive[v as usize] && self.out[v as usize] != NONE)
            .collect();
        live.sort_by_key(|&v| key[v as usize]);
        let mut vmap = vec![NONE; nv];
        for (i, &v) in live.iter().enumerate() {
            vmap[v as usize] = i as u32;
        }
        let mut faces: Vec<(u32, u32)> = (0..self.face_alive.len() as u32)
            .filter(|&f| self.face_alive[f as usize])
            .map(|f| {
                let first = self.face_vertices(f).map(|v| vmap[v as usize]);
                (first.into_iter().min().unwrap_or(NONE), f)
            })
            .collect();
        faces.sort_unstable();
        let faces: Vec<u32> = faces.into_iter().map(|(_, f)| f).collect();
        self.rebuild(&faces, vmap, live.len())
    }

    /// The mesh of `faces` (live, in their new order) with vertex `v` renumbered `vmap[v]`
    /// (`NONE`: dropped; the others number `0..n`). Returns `vmap`.
    fn rebuild(&mut self, faces: &[u32], vmap: Vec<u32>, n: usize) -> Vec<u32> {
        let mut positions = vec![[0.0; 3]; n];
        for (v, &m) in vmap.iter().enumerate() {
            if m != NONE {
                positions[m as usize] = self.positions[v];
            }
        }
        let mut fmap = vec![NONE; self.face_alive.len()];
        for (i, &f) in faces.iter().enumerate() {
            fmap[f as usize] = i as u32;
        }
        let map_h = |h: u32| {
            if h == NONE {
                NONE
            } else {
                3 * fmap[face_of(h) as usize] + h % 3
            }
        };
        let mut corner = Vec::with_capacity(3 * faces.len());
        let mut opp = Vec::with_capacity(3 * faces.len());
        let mut tag = Vec::with_capacity(3 * faces.len());
        for &f in faces {
            for h in 3 * f as usize..3 * f as usize + 3 {
                corner.push(vmap[self.corner[h] as usize]);
                opp.push(map_h(self.opp[h]));
                tag.push(self.tag[h]);
            }
        }
        let mut out = vec![NONE; n];
        let mut valence = vec![0; n];
        for (v, &m) in vmap.iter().enumerate() {
            if m != NONE {
                out[m as usize] = map_h(self.out[v]);
                valence[m as usize] = self.valence[v];
            }
        }
        let nf = faces.len();
        *self = HalfEdgeMesh {
            positions,
            corner,
            opp,
            tag,
            out,
            valence,
            face_alive: vec![true; nf],
            vertex_alive: vec![true; n],
            n_live_faces: nf,
            n_live_vertices: n,
        };
        // The updates keep the counts; debug builds (the tests) check them at every
        // compaction.
        debug_assert!(
            (0..n as u32).all(|v| self.valence[v as usize] == self.walk_valence(v)),
            "valence out of date"
        );
        vmap
    }

    // ---------------------------------------------------------------- access

    /// Vertex slots (live and deleted).
    pub fn n_vertex_slots(&self) -> usize {
        self.positions.len()
    }
    /// Half-edge slots (3 per face slot, live and deleted).
    pub fn n_halfedge_slots(&self) -> usize {
        self.corner.len()
    }
    pub fn n_live_vertices(&self) -> usize {
        self.n_live_vertices
    }
    pub fn n_live_faces(&self) -> usize {
        self.n_live_faces
    }
    #[inline]
    pub fn position(&self, v: u32) -> V3 {
        self.positions[v as usize]
    }
    #[inline]
    pub fn set_position(&mut self, v: u32, p: V3) {
        self.positions[v as usize] = p;
    }
    /// Exchanges the positions with `other` (one position per vertex slot: panics
    /// otherwise), for steps that compute every new position from the old ones into a second
    /// buffer.
    pub fn swap_positions(&mut self, other: &mut Vec<V3>) {
        assert_eq!(
            other.len(),
            self.positions.len(),
            "swap_positions: one position per vertex slot"
        );
        std::mem::swap(&mut self.positions, other);
    }
    pub fn positions(&self) -> &[V3] {
        &self.positions
    }
    #[inline]
    pub fn is_vertex_alive(&self, v: u32) -> bool {
        self.vertex_alive[v as usize] && self.out[v as usize] != NONE
    }
    #[inline]
    pub fn is_face_alive(&self, f: u32) -> bool {
        self.face_alive[f as usize]
    }
    #[inline]
    pub fn is_halfedge_alive(&self, h: u32) -> bool {
        self.face_alive[face_of(h) as usize]
    }
    /// Origin of `h`.
    #[inline]
    pub fn from(&self, h: u32) -> u32 {
        self.corner[h as usize]
    }
    /// Target of `h`.
    #[inline]
    pub fn to(&self, h: u32) -> u32 {
        self.corner[next(h) as usize]
    }
    /// Twin of `h`, `NONE` on the boundary.
    #[inline]
    pub fn opp(&self, h: u32) -> u32 {
        self.opp[h as usize]
    }
    /// Whether `h` is the canonical half-edge of its edge (boundary, or the smaller of a pair).
    #[inline]
    pub fn is_canonical(&self, h: u32) -> bool {
        let o = self.opp[h as usize];
        o == NONE || h < o
    }
    #[inline]
    pub fn is_boundary_edge(&self, h: u32) -> bool {
        self.opp[h as usize] == NONE
    }
    /// A vertex is on the boundary when its stored outgoing half-edge has no twin.
    #[inline]
    pub fn is_boundary_vertex(&self, v: u32) -> bool {
        let h = self.out[v as usize];
        h != NONE && self.opp[h as usize] == NONE
    }
    /// The three corners of face `f`.
    pub fn face_vertices(&self, f: u32) -> [u32; 3] {
        let b = 3 * f as usize;
        [self.corner[b], self.corner[b + 1], self.corner[b + 2]]
    }
    /// Tag of the edge of `h`.
    #[inline]
    pub fn tag(&self, h: u32) -> u32 {
        self.tag[h as usize]
    }
    /// Sets the tag of the edge of `h` (both half-edges).
    pub fn set_tag(&mut self, h: u32, t: u32) {
        self.tag[h as usize] = t;
        let o = self.opp[h as usize];
        if o != NONE {
            self.tag[o as usize] = t;
        }
    }
    /// Outgoing half-edges of `v`, counter-clockwise, starting from the boundary one.
    pub fn outgoing(&self, v: u32) -> Outgoing<'_> {
        let start = self.out[v as usize];
        Outgoing {
            mesh: self,
            start,
            cur: start,
        }
    }
    /// Neighbouring vertices of `v`, counter-clockwise (boundary vertices: both boundary
    /// neighbours included).
    pub fn neighbors(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> = Vec::with_capacity(8);
        let mut last = NONE;
        for h in self.outgoing(v) {
            out.push(self.to(h));
            last = h;
        }
        if last != NONE && self.opp[prev(last) as usize] == NONE {
            out.push(self.from(prev(last)));
        }
        out
    }
    /// Number of edges at `v`.
    #[inline]
    pub fn valence(&self, v: u32) -> usize {
        self.valence[v as usize] as usize
    }
    /// [`HalfEdgeMesh::valence`] counted around the fan.
    fn walk_valence(&self, v: u32) -> u32 {
        self.walk_fan(v).1
    }
    /// The number of faces of `v`'s fan (swept from its outgoing half-edge) and its valence:
    /// one edge more than faces where the fan ends on the boundary.
    fn walk_fan(&self, v: u32) -> (u32, u32) {
        let mut n = 0;
        let mut last = NONE;
        for h in self.outgoing(v) {
            n += 1;
            last = h;
        }
        let open = last != NONE && self.opp[prev(last) as usize] == NONE;
        (n, n + open as u32)
    }
    /// The half-edge from `a` to `b`, or the one from `b` to `a` when `a → b` is a boundary
    /// side only `b → a` exists for; `NONE` when a and b are not joined.
    pub fn find_edge(&self, a: u32, b: u32) -> u32 {
        if self.out[a as usize] == NONE {
            return NONE;
        }
        let mut last = NONE;
        for h in self.outgoing(a) {
            if self.to(h) == b {
                return h;
            }
            last = h;
        }
        if last != NONE {
            let p = prev(last);
            if self.opp[p as usize] == NONE && self.from(p) == b {
                return p;
            }
        }
        NONE
    }
    /// Unnormalised normal of face `f` (length = 2 × area).
    pub fn face_normal_raw(&self, f: u32) -> V3 {
        let [a, b, c] = self.face_vertices(f).map(|v| self.positions[v as usize]);
        vec3::cross(vec3::sub(b, a), vec3::sub(c, a))
    }

    /// Makes `out[v]` the boundary outgoing half-edge if there is one, starting from any
    /// outgoing half-edge `h` of `v` (clockwise sweep `next(opp(h))`).
    fn set_out(&mut self, v: u32, h: u32) {
        debug_assert_eq!(self.corner[h as usize], v);
        let mut cur = h;
        loop {
            let o = self.opp[cur as usize];
            if o == NONE {
                break;
            }
            cur = next(o);
            if cur == h {
                break;
            }
        }
        self.out[v as usize] = cur;
    }

    fn link(&mut self, h: u32, g: u32) {
        if h != NONE {
            self.opp[h as usize] = g;
        }
        if g != NONE {
            self.opp[g as usize] = h;
        }
    }

    fn new_face(&mut self, a: u32, b: u32, c: u32) -> u32 {
        let f = self.face_alive.len() as u32;
        self.corner.extend_from_slice(&[a, b, c]);
        self.opp.extend_from_slice(&[NONE; 3]);
        self.tag.extend_from_slice(&[NONE; 3]);
        self.face_alive.push(true);
        self.n_live_faces += 1;
        f
    }

    // ---------------------------------------------------------------- split

    /// Splits the edge of `h` at `p`; returns the new vertex. Interior edges become four
    /// triangles, boundary edges two. Both halves keep the edge's tag.
    pub fn split_edge(&mut self, h: u32, p: V3) -> u32 {
        let m = self.positions.len() as u32;
        self.positions.push(p);
        self.out.push(NONE);
        self.valence.push(0);
        self.vertex_alive.push(true);
        self.n_live_vertices += 1;
        let t = self.tag[h as usize];
        let g = self.opp[h as usize];
        // Face (a, b, c): h = a→b, h1 = b→c, h2 = c→a.
        let (h1, h2) = (next(h), prev(h));
        let (a, b, c) = (self.from(h), self.to(h), self.from(h2));
        let o_h1 = self.opp[h1 as usize];
        let tag_h1 = self.tag[h1 as usize];
        // (a, b, c) -> (a, m, c) + new (m, b, c).
        self.corner[h1 as usize] = m;
        let f2 = self.new_face(m, b, c);
        let (k0, k1, k2) = (3 * f2, 3 * f2 + 1, 3 * f2 + 2);
        self.link(k1, o_h1);
        self.tag[k1 as usize] = tag_h1;
        self.tag[h1 as usize] = NONE;
        self.link(k2, h1);
        self.tag[k0 as usize] = t;
        if g == NONE {
            self.opp[h as usize] = NONE;
            self.opp[k0 as usize] = NONE;
            self.set_out(m, k0);
        } else {
            // Face (b, a, d): g = b→a, g1 = a→d, g2 = d→b -> (b, m, d) + new (m, a, d).
            let (g1, g2) = (next(g), prev(g));
            let d = self.from(g2);
            self.valence[d as usize] += 1;
            let o_g1 = self.opp[g1 as usize];
            let tag_g1 = self.tag[g1 as usize];
            self.corner[g1 as usize] = m;
            let f3 = self.new_face(m, a, d);
            let (j0, j1, j2) = (3 * f3, 3 * f3 + 1, 3 * f3 + 2);
            self.link(j1, o_g1);
            self.tag[j1 as usize] = tag_g1;
            self.tag[g1 as usize] = NONE;
            self.link(j2, g1);
            // Across the split line: a→m with m→a, b→m with m→b.
            self.link(h, j0);
            self.link(g, k0);
            self.tag[j0 as usize] = t;
            self.tag[g as usize] = t;
            self.set_out(a, j1);
            self.set_out(d, g2);
            self.set_out(m, k0);
        }
        self.set_out(b, k1);
        self.set_out(c, h2);
        if g == NONE {
            self.set_out(a, h);
        }
        // a and b keep their counts (a–b becomes a–m and m–b); c and d gain an edge to m.
        self.valence[c as usize] += 1;
        self.valence[m as usize] = if g == NONE { 3 } else { 4 };
        m
    }

    // ---------------------------------------------------------------- flip

    /// Topological and geometric check of flipping the edge of `h`: interior, the new diagonal
    /// not already an edge, no end left with too few edges, and both new triangles keep a
    /// positive area and the orientation of the old pair.
    pub fn flip_ok(&self, h: u32) -> bool {
        let g = self.opp[h as usize];
        if g == NONE {
            return false;
        }
        let (a, b) = (self.from(h), self.to(h));
        let c = self.from(prev(h));
        let d = self.from(prev(g));
        if c == d || self.find_edge(c, d) != NONE {
            return false;
        }
        let min_val = |v: u32| if self.is_boundary_vertex(v) { 3 } else { 4 };
        if self.valence(a) < min_val(a) || self.valence(b) < min_val(b) {
            return false;
        }
        let p = |v: u32| self.positions[v as usize];
        let n_old = vec3::add(
            self.face_normal_raw(face_of(h)),
            self.face_normal_raw(face_of(g)),
        );
        let n1 = vec3::cross(vec3::sub(p(b), p(d)), vec3::sub(p(c), p(d)));
        let n2 = vec3::cross(vec3::sub(p(a), p(c)), vec3::sub(p(d), p(c)));
        let scale2 = vec3::dot(n_old, n_old);
        let tiny = 1e-12 * scale2;
        vec3::dot(n1, n_old) > 0.0
            && vec3::dot(n2, n_old) > 0.0
            && vec3::dot(n1, n1) > tiny
            && vec3::dot(n2, n2) > tiny
    }

    /// Flips the edge of `h` (interior; check [`HalfEdgeMesh::flip_ok`] first). The new edge
    /// is untagged; returns a half-edge of it.
    pub fn flip(&mut self, h: u32) -> u32 {
        let g = self.opp[h as usize];
        debug_assert!(g != NONE);
        let (h1, h2, g1, g2) = (next(h), prev(h), next(g), prev(g));
        let (a, b, c, d) = (self.from(h), self.to(h), self.from(h2), self.from(g2));
        let (o_bc, o_ca, o_ad, o_db) = (
            self.opp[h1 as usize],
            self.opp[h2 as usize],
            self.opp[g1 as usize],
            self.opp[g2 as usize],
        );
        let (t_bc, t_ca, t_ad, t_db) = (
            self.tag[h1 as usize],
            self.tag[h2 as usize],
            self.tag[g1 as usize],
            self.tag[g2 as usize],
        );
        // Face of h: (d, b, c) with h = d→b, h1 = b→c, h2 = c→d.
        self.corner[h as usize] = d;
        self.corner[h1 as usize] = b;
        self.corner[h2 as usize] = c;
        // Face of g: (c, a, d) with g = c→a, g1 = a→d, g2 = d→c.
        self.corner[g as usize] = c;
        self.corner[g1 as usize] = a;
        self.corner[g2 as usize] = d;
        self.link(h, o_db);
        self.tag[h as usize] = t_db;
        self.link(h1, o_bc);
        self.tag[h1 as usize] = t_bc;
        self.link(g, o_ca);
        self.tag[g as usize] = t_ca;
        self.link(g1, o_ad);
        self.tag[g1 as usize] = t_ad;
        self.link(h2, g2);
        self.tag[h2 as usize] = NONE;
        self.tag[g2 as usize] = NONE;
        self.set_out(a, g1);
        self.set_out(b, h1);
        self.set_out(c, h2);
        self.set_out(d, g2);
        self.valence[a as usize] -= 1;
        self.valence[b as usize] -= 1;
        self.valence[c as usize] += 1;
        self.valence[d as usize] += 1;
        h2
    }

    // ---------------------------------------------------------------- collapse

    /// Topological check of collapsing `h` (its origin merges into its target): the link
    /// condition, no pinch of two boundaries, and opposite vertices keep enough edges.
    pub fn collapse_topology_ok(&self, h: u32) -> Result<(), CollapseRejection> {
        let g = self.opp[h as usize];
        let (a, b) = (self.from(h), self.to(h));
        let c = self.from(prev(h));
        let d = if g == NONE { NONE } else { self.from(prev(g)) };
        if g != NONE && self.is_boundary_vertex(a) && self.is_boundary_vertex(b) {
            return Err(CollapseRejection::BoundaryPinch);
        }
        let na = self.neighbors(a);
        let nb = self.neighbors(b);
        for &x in &na {
            if x != b && x != c && x != d && nb.contains(&x) {
                return Err(CollapseRejection::LinkCondition);
            }
        }
        let min_val = |v: u32| if self.is_boundary_vertex(v) { 3 } else { 4 };
        if self.valence(c) < min_val(c) || (d != NONE && self.valence(d) < min_val(d)) {
            return Err(CollapseRejection::LowValence);
        }
        // A boundary edge whose ends both have only this triangle and one more would leave a
        // dangling configuration: the opposite checks above cover interior cases; for a
        // boundary edge with a 3-vertex component there is nothing left to keep.
        if self.n_live_faces <= 2 {
            return Err(CollapseRejection::LowValence);
        }
        Ok(())
    }

    /// [`HalfEdgeMesh::collapse_topology_ok`] plus geometry: with the origin moved to `p`, no
    /// surviving triangle around it flips (its normal turns by more than `max_normal_turn`
    /// radians) or loses its area (below `1e-12` of the original's, or zero).
    pub fn collapse_ok(
        &self,
        h: u32,
        p: V3,
        max_normal_turn: f64,
    ) -> Result<(), CollapseRejection> {
        self.collapse_topology_ok(h)?;
        let a = self.from(h);
        let b = self.to(h);
        let cos_max = max_normal_turn.cos();
        for k in self.outgoing(a) {
            let f = face_of(k);
            let [x, y, z] = self.face_vertices(f);
            if x == b || y == b || z == b {
                continue; // removed by the collapse
            }
            let q = |v: u32| {
                if v == a {
                    p
                } else {
                    self.positions[v as usize]
                }
            };
            let n_old = self.face_normal_raw(f);
            let n_new = vec3::cross(vec3::sub(q(y), q(x)), vec3::sub(q(z), q(x)));
            let (lo, ln) = (vec3::norm(n_old), vec3::norm(n_new));
            // Written so that NaN areas are rejected too.
            let has_area = ln > 1e-12 * lo.max(f64::MIN_POSITIVE) && ln > 0.0;
            if !has_area {
                return Err(CollapseRejection::Geometry);
            }
            if lo > 0.0 && vec3::dot(n_old, n_new) < cos_max * lo * ln {
                return Err(CollapseRejection::Geometry);
            }
        }
        Ok(())
    }

    /// Collapses `h`: its origin `a` is removed and its faces join the target `b` (whose
    /// position is kept; set it before or after). The one or two triangles of the edge are
    /// deleted; the two sides of each merge into one edge whose tag is the tagged side's (the
    /// removed side's if both are tagged). Check [`HalfEdgeMesh::collapse_ok`] first.
    pub fn collapse(&mut self, h: u32) {
        let g = self.opp[h as usize];
        let (a, b) = (self.from(h), self.to(h));
        let (h1, h2) = (next(h), prev(h));
        let c = self.from(h2);
        // Every corner at `a` becomes `b` (collect first: the sweep needs intact links).
        let corners_a: Vec<u32> = self.outgoing(a).collect();
        for &k in &corners_a {
            self.corner[k as usize] = b;
        }
        // Face (a, b, c): sides c→a (h2) and b→c (h1) fuse into one edge b–c.
        let (o_h1, o_h2) = (self.opp[h1 as usize], self.opp[h2 as usize]);
        let tag = merge_tags(self.tag[h2 as usize], self.tag[h1 as usize]);
        self.link(o_h1, o_h2);
        for x in [o_h1, o_h2] {
            if x != NONE {
                self.tag[x as usize] = tag;
            }
        }
        self.face_alive[face_of(h) as usize] = false;
        self.n_live_faces -= 1;
        let mut d = NONE;
        let (mut o_g1, mut o_g2) = (NONE, NONE);
        if g != NONE {
            // Face (b, a, d): sides a→d (g1) and d→b (g2) fuse into one edge d–b.
            let (g1, g2) = (next(g), prev(g));
            d = self.from(g2);
            o_g1 = self.opp[g1 as usize];
            o_g2 = self.opp[g2 as usize];
            let tag = merge_tags(self.tag[g1 as usize], self.tag[g2 as usize]);
            self.link(o_g1, o_g2);
            for x in [o_g1, o_g2] {
                if x != NONE {
                    self.tag[x as usize] = tag;
                }
            }
            self.face_alive[face_of(g) as usize] = false;
            self.n_live_faces -= 1;
        }
        for k in [h, h1, h2] {
            self.opp[k as usize] = NONE;
        }
        if g != NONE {
            for k in [g, next(g), prev(g)] {
                self.opp[k as usize] = NONE;
            }
        }
        self.vertex_alive[a as usize] = false;
        self.out[a as usize] = NONE;
        self.n_live_vertices -= 1;
        // New outgoing half-edges for b, c, d from surviving faces.
        let live = |m: &Self, k: u32| k != NONE && m.face_alive[face_of(k) as usize];
        let b_out = [o_h2, o_g2]
            .into_iter()
            .chain(corners_a.iter().copied())
            .find(|&k| live(self, k) && self.corner[k as usize] == b);
        match b_out {
            Some(k) => self.set_out(b, k),
            None => {
                // b keeps its own faces (if any) outside the deleted ones.
                let old = self.out[b as usize];
                if !live(self, old) {
                    self.out[b as usize] = NONE;
                }
            }
        }
        if live(self, self.out[b as usize]) {
            let k = self.out[b as usize];
            self.set_out(b, k);
        }
        for (v, cands) in [(c, [o_h1, next_if(o_h2)]), (d, [o_g1, next_if(o_g2)])] {
            if v == NONE {
                continue;
            }
            if let Some(k) = cands
                .into_iter()
                .find(|&k| live(self, k) && self.corner[k as usize] == v)
            {
                self.set_out(v, k);
            } else if !live(self, self.out[v as usize]) {
                self.out[v as usize] = NONE;
            } else {
                let k = self.out[v as usize];
                self.set_out(v, k);
            }
        }
        // The link condition (checked before) keeps every other vertex's count; b, c and d
        // are counted again.
        self.valence[a as usize] = 0;
        for v in [b, c, d] {
            if v != NONE {
                self.valence[v as usize] = self.walk_valence(v);
            }
        }
    }

    /// Collapses `h` the other way round: its target is removed and its faces join its origin,
    /// which keeps its index and position (a boundary edge has only this one half-edge, so
    /// [`HalfEdgeMesh::collapse`] can only remove its origin). Check
    /// [`HalfEdgeMesh::collapse_topology_ok`] first (the link condition is the same both ways).
    pub fn collapse_keeping_origin(&mut self, h: u32) {
        let (a, b) = (self.from(h), self.to(h));
        let pa = self.positions[a as usize];
        self.collapse(h);
        // b now holds the merged fan: a takes its place.
        let corners_b: Vec<u32> = self.outgoing(b).collect();
        for k in corners_b {
            self.corner[k as usize] = a;
        }
        self.out[a as usize] = self.out[b as usize];
        self.out[b as usize] = NONE;
        self.valence[a as usize] = self.valence[b as usize];
        self.valence[b as usize] = 0;
        self.vertex_alive[a as usize] = true;
        self.vertex_alive[b as usize] = false;
        self.positions[a as usize] = pa;
    }

    /// Checks every structural invariant; `Err` names the first broken one. For tests.
    pub fn check(&self) -> Result<(), String> {
        let nh = self.corner.len() as u32;
        let mut corners_at = vec![0usize; self.positions.len()];
        for h in 0..nh {
            if !self.is_halfedge_alive(h) {
                continue;
            }
            let (a, b) = (self.from(h), self.to(h));
            if a == b {
                return Err(format!("half-edge {h} is a loop at {a}"));
            }
            if !self.vertex_alive[a as usize] {
                return Err(format!("half-edge {h} starts at deleted vertex {a}"));
            }
            corners_at[a as usize] += 1;
            let o = self.opp[h as usize];
            if o != NONE {
                if !self.is_halfedge_alive(o) {
                    return Err(format!("twin {o} of {h} is deleted"));
                }
                if self.opp[o as usize] != h {
                    return Err(format!("twin of twin of {h} is not {h}"));
                }
                if self.from(o) != b || self.to(o) != a {
                    return Err(format!("twin {o} of {h} does not run {b}->{a}"));
                }
                if self.tag[o as usize] != self.tag[h as usize] {
                    return Err(format!("tags of {h} and its twin differ"));
                }
            }
        }
        let mut seen = std::collections::HashSet::new();
        for h in 0..nh {
            if self.is_halfedge_alive(h) && !seen.insert((self.from(h), self.to(h))) {
                return Err(format!(
                    "directed edge {}->{} appears twice",
                    self.from(h),
                    self.to(h)
                ));
            }
        }
        for v in 0..self.positions.len() as u32 {
            let o = self.out[v as usize];
            if !self.vertex_alive[v as usize] || o == NONE {
                if corners_at[v as usize] != 0 {
                    return Err(format!("vertex {v} has corners but no outgoing half-edge"));
                }
                continue;
            }
            if !self.is_halfedge_alive(o) || self.from(o) != v {
                return Err(format!("out[{v}] = {o} does not start at {v}"));
            }
            let boundary_start = (0..nh).any(|h| {
                self.is_halfedge_alive(h) && self.from(h) == v && self.opp[h as usize] == NONE
            });
            if boundary_start && self.opp[o as usize] != NONE {
                return Err(format!(
                    "boundary vertex {v}: out is not the boundary half-edge"
                ));
            }
            let fan = self.outgoing(v).count();
            if fan != corners_at[v as usize] {
                return Err(format!(
                    "vertex {v}: fan of {fan} faces but {} corners (non-manifold)",
                    corners_at[v as usize]
                ));
            }
            let (kept, counted) = (self.valence[v as usize], self.walk_valence(v));
            if kept != counted {
                return Err(format!(
                    "vertex {v}: valence kept as {kept}, counted {counted}"
                ));
            }
        }
        let live_f = self.face_alive.iter().filter(|&&x| x).count();
        if live_f != self.n_live_faces {
            return Err("live face count out of date".into());
        }
        Ok(())
    }

    /// V − E + F over live elements.
    pub fn euler_characteristic(&self) -> i64 {
        let v = (0..self.positions.len() as u32)
            .filter(|&v| self.is_vertex_alive(v))
            .count() as i64;
        let e = (0..self.corner.len() as u32)
            .filter(|&h| self.is_halfedge_alive(h) && self.is_canonical(h))
            .count() as i64;
        v - e + self.n_live_faces as i64
    }
}

fn merge_tags(removed: u32, kept: u32) -> u32 {
    if removed != NONE {
        removed
    } else {
        kept
    }
}

fn next_if(h: u32) -> u32 {
    if h == NONE {
        NONE
    } else {
        next(h)
    }
}

/// Counter-clockwise sweep over the outgoing half-edges of a vertex.
pub struct Outgoing<'m> {
    mesh: &'m HalfEdgeMesh,
    start: u32,
    cur: u32,
}

impl Iterator for Outgoing<'_> {
    type Item = u32;
    fn next(&mut self) -> Option<u32> {
        if self.cur == NONE {
            return None;
        }
        let h = self.cur;
        let o = self.mesh.opp[prev(h) as usize];
        self.cur = if o == NONE || o == self.start {
            NONE
        } else {
            o
        };
        Some(h)
    }
}

#[cfg(test)]
#[path = "halfedge_test.rs"]
mod tests;
