//! Validation and cleaning shared by every reader: triangulation, degenerate and duplicate
//! faces, unreferenced vertices, non-manifold detection and repair, orientation repair,
//! statistics.
//!
//! Non-manifold repair works on corners (a face's use of a vertex). Two corners of the same
//! vertex are joined when their faces share a manifold edge (exactly two faces) at that vertex;
//! each resulting group is one fan. A vertex with several fans gets one copy per extra fan.
//! An edge with more than two faces is never a joining edge, and around a vertex each face has
//! two edges, so a fan is a path or a cycle through joining edges: at most its two end faces
//! can contain a given non-manifold edge. After the split every edge has at most two faces and
//! every vertex one fan.

use std::path::Path;

use super::{LoadOptions, LoadReport, LoadedMesh, MeshError, RawMesh};
use crate::mesh::{Topology, TriMesh, NO_FACE};
use crate::vec3;

/// Non-manifold edges and vertices of a triangle soup, and the vertex split that removes them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NonManifoldInfo {
    /// Edges with more than two faces.
    pub edges: usize,
    /// Vertices whose faces form more than one fan (edges with more than two faces do not
    /// connect fans).
    pub vertices: usize,
    /// For each corner `3 f + i`, the vertex it uses after the split: the first fan of a vertex
    /// (in face order) keeps the vertex, the others get new indices from `n_vertices` up.
    pub corner_vertex: Vec<u32>,
    /// For each new vertex `n_vertices + k`, the vertex it copies.
    pub split_from: Vec<u32>,
}

impl NonManifoldInfo {
    pub fn is_manifold(&self) -> bool {
        self.edges == 0 && self.vertices == 0
    }
}

/// Groups `items` by bucket (counting sort, O(n)) and sorts each bucket: the same order as a
/// full sort by (bucket, item), but buckets are small (a vertex's edges or faces).
fn bucket_sort<T: Ord + Copy + Default>(
    n_buckets: usize,
    items: impl Iterator<Item = (usize, T)> + Clone,
) -> (Vec<usize>, Vec<T>) {
    let mut offsets = vec![0usize; n_buckets + 1];
    for (b, _) in items.clone() {
        offsets[b + 1] += 1;
    }
    for i in 0..n_buckets {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut out = vec![T::default(); offsets[n_buckets]];
    for (b, x) in items {
        out[fill[b]] = x;
        fill[b] += 1;
    }
    for b in 0..n_buckets {
        out[offsets[b]..offsets[b + 1]].sort_unstable();
    }
    (offsets, out)
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    let mut root = x;
    while parent[root as usize] != root {
        root = parent[root as usize];
    }
    // Path compression keeps later finds short.
    while parent[x as usize] != root {
        let next = parent[x as usize];
        parent[x as usize] = root;
        x = next;
    }
    root
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    // The smaller root wins, so the result does not depend on the order of unions.
    if ra < rb {
        parent[rb as usize] = ra;
    } else if rb < ra {
        parent[ra as usize] = rb;
    }
}

/// Finds non-manifold edges and vertices of `triangles` (which must index `0..n_vertices` and
/// have no repeated index within a triangle).
pub fn find_nonmanifold(n_vertices: usize, triangles: &[[u32; 3]]) -> NonManifoldInfo {
    // Half-edges (larger end, face, side) grouped by their smaller end.
    let (offsets, half) = bucket_sort(
        n_vertices,
        triangles.iter().enumerate().flat_map(|(f, t)| {
            (0..3).map(move |i| {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                (a.min(b) as usize, (a.max(b), f as u32, i as u8))
            })
        }),
    );
    let mut parent: Vec<u32> = (0..triangles.len() as u32 * 3).collect();
    let corner_of = |f: u32, v: u32| -> u32 {
        let t = triangles[f as usize];
        let slot = if t[0] == v {
            0
        } else if t[1] == v {
            1
        } else {
            2
        };
        3 * f + slot
    };
    let mut edges = 0;
    for a in 0..n_vertices {
        let bucket = &half[offsets[a]..offsets[a + 1]];
        let mut i = 0;
        while i < bucket.len() {
            let b = bucket[i].0;
            let mut j = i + 1;
            while j < bucket.len() && bucket[j].0 == b {
                j += 1;
            }
            match j - i {
                2 => {
                    let (f, g) = (bucket[i].1, bucket[i + 1].1);
                    let a = a as u32;
                    union(&mut parent, corner_of(f, a), corner_of(g, a));
                    union(&mut parent, corner_of(f, b), corner_of(g, b));
                }
                n if n > 2 => edges += 1,
                _ => {}
            }
            i = j;
        }
    }

    let mut claimed = vec![false; n_vertices];
    let mut counted = vec![false; n_vertices];
    let mut root_vertex = vec![u32::MAX; parent.len()];
    let mut corner_vertex = vec![0u32; parent.len()];
    let mut split_from = Vec::new();
    let mut vertices = 0;
    for c in 0..parent.len() as u32 {
        let v = triangles[(c / 3) as usize][(c % 3) as usize];
        let r = find(&mut parent, c) as usize;
        if root_vertex[r] == u32::MAX {
            if !claimed[v as usize] {
                claimed[v as usize] = true;
                root_vertex[r] = v;
            } else {
                root_vertex[r] = (n_vertices + split_from.len()) as u32;
                split_from.push(v);
                if !counted[v as usize] {
                    counted[v as usize] = true;
                    vertices += 1;
                }
            }
        }
        corner_vertex[c as usize] = root_vertex[r];
    }
    NonManifoldInfo {
        edges,
        vertices,
        corner_vertex,
        split_from,
    }
}

/// Whether a triangle's area is negligible next to its longest edge (needles and points).
fn zero_area(p: [vec3::V3; 3]) -> bool {
    let n = vec3::norm(vec3::cross(vec3::sub(p[1], p[0]), vec3::sub(p[2], p[0])));
    let l = (0..3)
        .map(|i| vec3::dist(p[i], p[(i + 1) % 3]))
        .fold(0.0, f64::max);
    n <= 1e-12 * l * l
}

pub(crate) fn build(
    raw: RawMesh,
    path: &Path,
    options: &LoadOptions,
) -> Result<LoadedMesh, MeshError> {
    let n_faces_in = raw.n_polygons() + raw.strip_triangles.len();
    if raw.positions.is_empty() || n_faces_in == 0 {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
            vertices: raw.positions.len(),
            faces: raw.file_faces,
        });
    }
    for (v, p) in raw.positions.iter().enumerate() {
        if let Some(&value) = p.iter().find(|c| !c.is_finite()) {
            return Err(MeshError::NonFinite {
                path: path.to_path_buf(),
                vertex: v,
                value,
            });
        }
        // Finite but so large that the curvature fit, normals and areas overflow to NaN
        // downstream, where the error would name a curvature field instead of the file.
        if let Some(&value) = p.iter().find(|c| c.abs() > super::MAX_COORDINATE) {
            return Err(MeshError::CoordinateTooLarge {
                path: path.to_path_buf(),
                vertex: v,
                value,
            });
        }
    }
    let mut report = LoadReport {
        format: raw.format.to_string(),
        file_vertices: raw.positions.len(),
        file_faces: raw.file_faces,
        vertices_welded: raw.vertices_welded,
        ..Default::default()
    };

    // Triangulate; drop triangles with a repeated index.
    let mut tris: Vec<[u32; 3]> = Vec::with_capacity(n_faces_in);
    let degenerate = |t: &[u32; 3]| t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    for f in 0..raw.n_polygons() {
        let c = &raw.indices[raw.offsets[f]..raw.offsets[f + 1]];
        let reject = || MeshError::DegenerateFace {
            path: path.to_path_buf(),
            face: f,
            vertices: c.to_vec(),
        };
        if c.len() < 3 {
            if options.reject_degenerate {
                return Err(reject());
            }
            report.degenerate_faces_dropped += 1;
            continue;
        }
        if c.len() > 3 {
            report.polygons_triangulated += 1;
        }
        for k in 1..c.len() - 1 {
            let t = [c[0], c[k], c[k + 1]];
            if degenerate(&t) {
                if options.reject_degenerate {
                    return Err(reject());
                }
                report.degenerate_faces_dropped += 1;
            } else {
                tris.push(t);
            }
        }
    }
    for t in &raw.strip_triangles {
        if degenerate(t) {
            report.strip_degenerates_skipped += 1;
        } else {
            tris.push(*t);
        }
    }

    // Duplicates: the same vertex set again (either orientation); the first copy stays.
    let (offsets, keys) = bucket_sort(
        raw.positions.len(),
        tris.iter().enumerate().map(|(i, t)| {
            let mut k = *t;
            k.sort_unstable();
            (k[0] as usize, (k[1], k[2], i as u32))
        }),
    );
    let mut keep = vec![true; tris.len()];
    for b in 0..raw.positions.len() {
        for w in keys[offsets[b]..offsets[b + 1]].windows(2) {
            if (w[0].0, w[0].1) == (w[1].0, w[1].1) {
                keep[w[1].2 as usize] = false;
                report.duplicate_faces_dropped += 1;
            }
        }
    }
    drop(keys);
    let mut k = 0;
    tris.retain(|_| {
        k += 1;
        keep[k - 1]
    });

    // Unreferenced vertices go; the others keep their order.
    let mut positions = raw.positions;
    let mut new_index = vec![u32::MAX; positions.len()];
    for t in &tris {
        for &v in t {
            new_index[v as usize] = 0;
        }
    }
    let mut next = 0u32;
    let mut kept = Vec::with_capacity(positions.len());
    for (v, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = next;
            next += 1;
            kept.push(positions[v]);
        }
    }
    report.unreferenced_vertices_dropped = positions.len() - kept.len();
    positions = kept;
    for t in &mut tris {
        for v in t.iter_mut() {
            *v = new_index[*v as usize];
        }
    }
    if tris.is_empty() {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
            vertices: positions.len(),
            faces: 0,
        });
    }

    let nm = find_nonmanifold(positions.len(), &tris);
    report.nonmanifold_edges = nm.edges;
    report.nonmanifold_vertices = nm.vertices;
    if !nm.is_manifold() {
        if !options.repair {
            return Err(MeshError::NonManifold {
                path: path.to_path_buf(),
                edges: nm.edges,
                vertices: nm.vertices,
            });
        }
        for &v in &nm.split_from {
            positions.push(positions[v as usize]);
        }
        for (f, t) in tris.iter_mut().enumerate() {
            for (i, v) in t.iter_mut().enumerate() {
                *v = nm.corner_vertex[3 * f + i];
            }
        }
        report.vertices_split = nm.split_from.len();
    }

    let mut mesh = TriMesh::new(positions, tris);
    let topo = mesh.topology();
    report.boundary_edges = topo.boundary_edge_count();
    report.zero_area_faces = (0..mesh.n_faces())
        .filter(|&f| zero_area(mesh.face_points(f)))
        .count();

    // Components through shared edges; orientation agreement across interior edges.
    let mut parent: Vec<u32> = (0..mesh.n_faces() as u32).collect();
    for (e, faces) in topo.edge_faces.iter().enumerate() {
        if faces[1] == NO_FACE {
            continue;
        }
        union(&mut parent, faces[0], faces[1]);
        if forward(&mesh, topo, faces[0], e) == forward(&mesh, topo, faces[1], e) {
            report.inconsistent_edges += 1;
        }
    }
    report.components = (0..parent.len() as u32)
        .filter(|&f| find(&mut parent, f) == f)
        .count();
    if options.repair && report.inconsistent_edges > 0 {
        let o = orient_coherently(&mesh, topo);
        report.faces_flipped = o.flip.iter().filter(|&&f| f).count();
        report.nonorientable_components = o.nonorientable_components;
        let mut tris = mesh.triangles.clone();
        for (t, &flip) in tris.iter_mut().zip(&o.flip) {
            if flip {
                t.swap(1, 2);
            }
        }
        mesh = TriMesh::new(mesh.positions.clone(), tris);
    }
    report.vertices = mesh.n_vertices();
    report.faces = mesh.n_faces();
    Ok(LoadedMesh { mesh, report })
}

/// Whether face `f` runs along edge `e` from the edge's first vertex to its second.
pub(super) fn forward(mesh: &TriMesh, topo: &Topology, f: u32, e: usize) -> bool {
    let side = (0..3)
        .find(|&i| topo.face_edges[f as usize][i] == e as u32)
        .unwrap_or(0);
    mesh.triangles[f as usize][side] == topo.edges[e][0]
}

/// Which faces to flip so that every component runs coherently.
struct Orientation {
    flip: Vec<bool>,
    /// Components where no choice agrees across every edge (a Möbius strip).
    nonorientable_components: usize,
}

/// Orients the faces of each component that has inconsistent edges coherently (as MeshLab's
/// "re-orient all faces coherently" or libigl's `bfs_orient`): a breadth-first walk over its
/// interior edges from its first face sets each face against the one it was reached from.
/// Of the two coherent orientations the component then takes the outward one when it is
/// closed (positive signed volume, so normals and curvature signs point the usual way), else
/// the one that flips fewer faces. Components without an inconsistent edge are left as they
/// are (an inside-out closed surface stays inside-out).
fn orient_coherently(mesh: &TriMesh, topo: &Topology) -> Orientation {
    let nf = mesh.n_faces();
    let mut flip = vec![false; nf];
    let mut seen = vec![false; nf];
    // Each face's flip relative to the first face of its component.
    let mut rel = vec![false; nf];
    let mut nonorientable_components = 0;
    let mut queue: Vec<u32> = Vec::new();
    for seed in 0..nf as u32 {
        if seen[seed as usize] {
            continue;
        }
        // Walk the component: `rel[f]` is f's flip relative to the seed's orientation.
        seen[seed as usize] = true;
        queue.clear();
        queue.push(seed);
        let (mut inconsistent, mut conflicts, mut closed) = (false, false, true);
        let mut k = 0;
        while k < queue.len() {
            let f = queue[k];
            k += 1;
            let of = rel[f as usize];
            for &e in &topo.face_edges[f as usize] {
                let e = e as usize;
                let [a, b] = topo.edge_faces[e];
                if b == NO_FACE {
                    closed = false;
                    continue;
                }
                let g = if a == f { b } else { a };
                let (ff, fg) = (forward(mesh, topo, f, e), forward(mesh, topo, g, e));
                inconsistent |= ff == fg;
                // After flipping, f and g must run along e in opposite directions.
                let og = !(ff ^ of) ^ fg;
                if seen[g as usize] {
                    conflicts |= rel[g as usize] != og;
                } else {
                    seen[g as usize] = true;
                    rel[g as usize] = og;
                    queue.push(g);
                }
            }
        }
        if !inconsistent {
            continue;
        }
        nonorientable_components += conflicts as usize;
        let flipped = queue.iter().filter(|&&f| rel[f as usize]).count();
        let reverse = if closed && !conflicts {
            // Six times the signed volume with the first face's orientation.
            let volume: f64 = queue
                .iter()
                .map(|&f| {
                    let [p, q, r] = mesh.face_points(f as usize);
                    let v = vec3::dot(p, vec3::cross(q, r));
                    if rel[f as usize] {
                        -v
                    } else {
                        v
                    }
                })
                .sum();
            volume < 0.0
        } else {
            2 * flipped > queue.len()
        };
        for &f in &queue {
            flip[f as usize] = rel[f as usize] ^ reverse;
        }
    }
    Orientation {
        flip,
        nonorientable_components,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn book_of_three_pages_splits_into_three_triangles() {
        // Three triangles on edge (0, 1).
        let tris = [[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        let nm = find_nonmanifold(5, &tris);
        assert_eq!(nm.edges, 1);
        assert_eq!(nm.vertices, 2);
        // Vertices 0 and 1 get two copies each: 5, 6 for vertex 0 … in corner order.
        assert_eq!(nm.split_from, vec![1, 0, 0, 1]);
        let split: Vec<[u32; 3]> = (0..3)
            .map(|f| [0, 1, 2].map(|i| nm.corner_vertex[3 * f + i]))
            .collect();
        assert_eq!(split, vec![[0, 1, 2], [5, 6, 3], [7, 8, 4]]);
        assert!(find_nonmanifold(9, &split).is_manifold());
    }

    #[test]
    fn bowtie_vertex_is_split_once() {
        // Two triangles touching at vertex 0 only.
        let tris = [[0, 1, 2], [0, 3, 4]];
        let nm = find_nonmanifold(5, &tris);
        assert_eq!((nm.edges, nm.vertices), (0, 1));
        assert_eq!(nm.split_from, vec![0]);
        assert_eq!(nm.corner_vertex, vec![0, 1, 2, 5, 3, 4]);
    }

    #[test]
    fn closed_tetrahedron_is_manifold() {
        let tris = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let nm = find_nonmanifold(4, &tris);
        assert!(nm.is_manifold());
        assert_eq!(
            nm.corner_vertex,
            tris.iter().flatten().copied().collect::<Vec<_>>()
        );
    }
}
