//! From feature points on edges to curves: the per-triangle cases of step 4 of the tracing
//! scheme (thesis §2.5.1.1: regular, trisector, start/end) and the split of the resulting graph
//! into arcs between extraordinary vertices or closed loops (Def. 2.1).

use crestflow_flow::Par;
use crestflow_geom::vec3;
use crestflow_geom::{CurvatureField, SurfacePoint, TriMesh};

use crate::crossing::{Crossing, Definition, Family};

/// A point of the segment graph.
#[derive(Clone, Debug, PartialEq)]
pub struct GraphNode {
    pub position: vec3::V3,
    pub location: SurfacePoint,
    pub strength: f64,
    /// Integrand of the cyclideness at this point.
    pub cyclideness: f64,
}

/// Feature points joined by segments, before arcs are formed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SegmentGraph {
    pub nodes: Vec<GraphNode>,
    /// Segments between nodes.
    pub edges: Vec<[u32; 2]>,
    /// Faces with three feature points (joined at their centroid).
    pub trisectors: usize,
    /// Faces with a single feature point (a curve starts or ends there).
    pub end_faces: usize,
}

#[derive(Clone, Copy)]
enum FaceCase {
    Empty,
    End,
    Regular(u32, u32),
    Trisector([u32; 3]),
}

/// Joins the feature points (candidates from [`crate::crossing::edge_crossings`], one per edge
/// at most, in `Topology::edges` order) inside each triangle.
///
/// For [`Definition::Thesis`] the maximum (ridge) or minimum (ravine) condition of Thm 2.1 is
/// checked here, with the gradient of the linear interpolant of the aligned extremality
/// coefficient over the triangle against the mean principal direction: on a crease that runs
/// along mesh edges, e is near zero with random sign at the crease vertices and an edge along the
/// crease has no reliable slope, while the triangle's gradient is dominated by its third vertex.
/// Where the directions cannot be aligned consistently around the triangle (a singularity of
/// the line field inside it, e.g. a trisector), each point keeps its own edge's slope.
///
/// Nodes are the candidate points in edge order, then one node per trisector face in face
/// order, so the graph is the same at any thread count.
pub fn segment_graph(
    mesh: &TriMesh,
    field: &CurvatureField,
    family: Family,
    definition: Definition,
    crossings: &[Option<Crossing>],
    par: Par,
) -> SegmentGraph {
    let topo = mesh.topology();
    let mut node_of_edge = vec![u32::MAX; crossings.len()];
    let mut nodes = Vec::new();
    for (e, c) in crossings.iter().enumerate() {
        if let Some(c) = c {
            node_of_edge[e] = nodes.len() as u32;
            let [a, b] = topo.edges[e];
            nodes.push(GraphNode {
                position: c.position,
                location: SurfacePoint::Edge { a, b, t: c.t },
                strength: c.strength,
                cyclideness: c.cyclideness,
            });
        }
    }
    let want_max = family == Family::Ridge;
    let cases = par.map_collect(mesh.n_faces(), |f| {
        let fe = topo.face_edges[f];
        let cand = fe.map(|e| node_of_edge[e as usize]);
        let n_cand = cand.iter().filter(|&&n| n != u32::MAX).count();
        if n_cand < 2 {
            return if n_cand == 1 {
                FaceCase::End
            } else {
                FaceCase::Empty
            };
        }
        let accept: [bool; 3] = match definition {
            Definition::Extrema => cand.map(|n| n != u32::MAX),
            Definition::Thesis => match triangle_slope(mesh, field, family, f) {
                Some(slope) => {
                    let ok = (slope < 0.0) == want_max;
                    cand.map(|n| n != u32::MAX && ok)
                }
                None => {
                    let mut acc = [false; 3];
                    for i in 0..3 {
                        if let Some(c) = crossings[fe[i] as usize] {
                            acc[i] = c.edge_slope != 0.0 && (c.edge_slope < 0.0) == want_max;
                        }
                    }
                    acc
                }
            },
        };
        let hits: Vec<u32> = (0..3).filter(|&i| accept[i]).map(|i| cand[i]).collect();
        match hits.len() {
            0 => FaceCase::Empty,
            1 => FaceCase::End,
            2 => FaceCase::Regular(hits[0], hits[1]),
            _ => FaceCase::Trisector([hits[0], hits[1], hits[2]]),
        }
    });
    let mut g = SegmentGraph {
        nodes,
        ..Default::default()
    };
    for (f, case) in cases.into_iter().enumerate() {
        match case {
            FaceCase::Empty => {}
            FaceCase::End => g.end_faces += 1,
            FaceCase::Regular(p, q) => g.edges.push([p, q]),
            FaceCase::Trisector(three) => {
                g.trisectors += 1;
                let centre = trisector_node(mesh, f, &three.map(|n| &g.nodes[n as usize]));
                let id = g.nodes.len() as u32;
                g.nodes.push(centre);
                for n in three {
                    g.edges.push([id, n]);
                }
            }
        }
    }
    g
}

/// ∇e · t over face `f` for the traced family, with directions aligned to the first corner's;
/// negative means a maximum along t. `None` when aligning to the first corner disagrees with
/// aligning along some edge (the direction field turns by about 180° around the face), when the
/// face is degenerate, or when the slope is zero.
fn triangle_slope(mesh: &TriMesh, field: &CurvatureField, family: Family, f: usize) -> Option<f64> {
    let (t, e) = match family {
        Family::Ridge => (&field.t_max, &field.e_max),
        Family::Ravine => (&field.t_min, &field.e_min),
    };
    let tri = mesh.triangles[f].map(|v| v as usize);
    let t0 = t[tri[0]];
    let sign = |a: vec3::V3, b: vec3::V3| if vec3::dot(a, b) < 0.0 { -1.0 } else { 1.0 };
    let flip = [1.0, sign(t[tri[1]], t0), sign(t[tri[2]], t0)];
    for (i, j) in [(0, 1), (1, 2), (2, 0)] {
        if flip[i] * flip[j] != sign(t[tri[i]], t[tri[j]]) {
            return None;
        }
    }
    let ev = [0, 1, 2].map(|i| flip[i] * e[tri[i]]);
    let tsum = (0..3).fold([0.0; 3], |acc, i| {
        vec3::add(acc, vec3::scale(t[tri[i]], flip[i]))
    });
    let [p0, p1, p2] = mesh.face_points(f);
    let (u, v) = (vec3::sub(p1, p0), vec3::sub(p2, p0));
    let n = vec3::cross(u, v);
    if vec3::dot(n, n) == 0.0 {
        return None;
    }
    // ∇e ∝ (e1 − e0) n × (−v) + (e2 − e0) n × u (the positive factor 1/|n|² does not change
    // the sign).
    let grad = vec3::add(
        vec3::scale(vec3::cross(n, vec3::scale(v, -1.0)), ev[1] - ev[0]),
        vec3::scale(vec3::cross(n, u), ev[2] - ev[0]),
    );
    let slope = vec3::dot(grad, tsum);
    (slope != 0.0 && slope.is_finite()).then_some(slope)
}

/// The centroid of a face's three feature points, with its barycentric coordinates in the face.
fn trisector_node(mesh: &TriMesh, f: usize, pts: &[&GraphNode; 3]) -> GraphNode {
    let tri = mesh.triangles[f];
    let mut bary = [0.0; 3];
    let mut pos = [0.0; 3];
    for p in pts {
        pos = vec3::add(pos, vec3::scale(p.position, 1.0 / 3.0));
        if let SurfacePoint::Edge { a, b, t } = p.location {
            for (i, &v) in tri.iter().enumerate() {
                if v == a {
                    bary[i] += (1.0 - t) / 3.0;
                } else if v == b {
                    bary[i] += t / 3.0;
                }
            }
        }
    }
    GraphNode {
        position: pos,
        location: SurfacePoint::Face { f: f as u32, bary },
        strength: pts.iter().map(|p| p.strength).sum::<f64>() / 3.0,
        cyclideness: pts.iter().map(|p| p.cyclideness).sum::<f64>() / 3.0,
    }
}

/// Reconnects fragments (the "local connectivity" post-processing of YBS05, thesis §2.5.1.1
/// step 5): two curve ends (valence-1 nodes) closer than `max_gap` are joined by a segment when
/// each curve, continued straight on, heads towards the other end (within 45°). Closest pairs
/// are joined first and every end at most once. Returns the number of segments added.
pub fn join_gaps(graph: &mut SegmentGraph, max_gap: f64) -> usize {
    if max_gap.is_nan() || max_gap <= 0.0 || graph.nodes.is_empty() {
        return 0;
    }
    let n = graph.nodes.len();
    let mut valence = vec![0u32; n];
    let mut neighbour = vec![u32::MAX; n];
    for &[p, q] in &graph.edges {
        valence[p as usize] += 1;
        valence[q as usize] += 1;
        neighbour[p as usize] = q;
        neighbour[q as usize] = p;
    }
    let ends: Vec<u32> = (0..n as u32)
        .filter(|&v| valence[v as usize] == 1)
        .collect();
    // Heading of the curve at each end: from its neighbour out through the end.
    let heading = |v: u32| {
        let p = graph.nodes[v as usize].position;
        let q = graph.nodes[neighbour[v as usize] as usize].position;
        vec3::normalize(vec3::sub(p, q))
    };
    // Uniform grid of cell `max_gap`: candidates are in the 27 cells around an end.
    let cell = |p: vec3::V3| p.map(|c| (c / max_gap).floor() as i64);
    let mut grid: std::collections::HashMap<[i64; 3], Vec<u32>> = Default::default();
    for &v in &ends {
        grid.entry(cell(graph.nodes[v as usize].position))
            .or_default()
            .push(v);
    }
    let cos45 = std::f64::consts::FRAC_1_SQRT_2;
    let mut pairs: Vec<(f64, u32, u32)> = Vec::new();
    for &a in &ends {
        let pa = graph.nodes[a as usize].position;
        let c = cell(pa);
        let ha = heading(a);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                        continue;
                    };
                    for &b in list {
                        if b <= a || neighbour[a as usize] == b {
                            continue;
                        }
                        let pb = graph.nodes[b as usize].position;
                        let d = vec3::dist(pa, pb);
                        if d > max_gap || d == 0.0 {
                            continue;
                        }
                        let g = vec3::scale(vec3::sub(pb, pa), 1.0 / d);
                        if vec3::dot(ha, g) >= cos45 && vec3::dot(heading(b), g) <= -cos45 {
                            pairs.push((d, a, b));
                        }
                    }
                }
            }
        }
    }
    // Closest first; ties by node index, so the result does not depend on hash order.
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut taken = vec![false; n];
    let mut added = 0;
    for (_, a, b) in pairs {
        if !taken[a as usize] && !taken[b as usize] {
            taken[a as usize] = true;
            taken[b as usize] = true;
            graph.edges.push([a, b]);
            added += 1;
        }
    }
    added
}

pub use crestflow_geom::graph::{extract_arcs, Arc};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arcs_of_a_y_and_a_loop() {
        // A "Y": centre 0 with branches 0-1-2, 0-3, 0-4-5-6; and a triangle loop 7-8-9.
        let edges = [
            [0, 1],
            [1, 2],
            [0, 3],
            [4, 0],
            [4, 5],
            [5, 6],
            [7, 8],
            [8, 9],
            [9, 7],
        ];
        let arcs = extract_arcs(10, &edges, &[true; 9]);
        assert_eq!(arcs.len(), 4);
        assert_eq!(arcs[0].nodes, vec![0, 1, 2]);
        assert_eq!(arcs[1].nodes, vec![0, 3]);
        assert_eq!(arcs[2].nodes, vec![0, 4, 5, 6]);
        assert!(!arcs[2].closed);
        assert_eq!(arcs[3].nodes, vec![7, 8, 9]);
        assert!(arcs[3].closed);
        assert_eq!(arcs[3].edges.len(), 3);
        // Every edge in exactly one arc.
        let mut all: Vec<u32> = arcs.iter().flat_map(|a| a.edges.clone()).collect();
        all.sort();
        assert_eq!(all, (0..9).collect::<Vec<u32>>());
    }

    #[test]
    fn removing_a_branch_merges_the_others() {
        let edges = [[0, 1], [1, 2], [0, 3], [4, 0], [4, 5], [5, 6]];
        let alive = [true, true, false, true, true, true];
        let arcs = extract_arcs(7, &edges, &alive);
        // Node 0 is now regular: one arc 2-1-0-4-5-6.
        assert_eq!(arcs.len(), 1);
        assert_eq!(arcs[0].nodes, vec![2, 1, 0, 4, 5, 6]);
    }

    fn chain(points: &[[f64; 3]], first: u32) -> (Vec<GraphNode>, Vec<[u32; 2]>) {
        let nodes = points
            .iter()
            .map(|&p| GraphNode {
                position: p,
                location: SurfacePoint::Free,
                strength: 1.0,
                cyclideness: 1.0,
            })
            .collect();
        let edges = (0..points.len() as u32 - 1)
            .map(|i| [first + i, first + i + 1])
            .collect();
        (nodes, edges)
    }

    #[test]
    fn gaps_between_aligned_fragments_are_joined() {
        // Two collinear fragments along x with a gap of 0.5, and a third fragment beside the
        // gap but perpendicular to it (heading along y): only the collinear pair is joined.
        let (mut nodes, mut edges) = chain(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], 0);
        let (n2, e2) = chain(&[[2.5, 0.0, 0.0], [3.5, 0.0, 0.0]], 3);
        let (n3, e3) = chain(&[[2.25, 1.5, 0.0], [2.25, 0.4, 0.0]], 5);
        nodes.extend(n2.into_iter().chain(n3));
        edges.extend(e2.into_iter().chain(e3));
        let mut g = SegmentGraph {
            nodes,
            edges,
            trisectors: 0,
            end_faces: 0,
        };
        assert_eq!(join_gaps(&mut g, 0.6), 1);
        assert_eq!(g.edges.last(), Some(&[2, 3]));
        let arcs = extract_arcs(g.nodes.len(), &g.edges, &vec![true; g.edges.len()]);
        assert_eq!(arcs.len(), 2);
        assert_eq!(arcs[0].nodes, vec![0, 1, 2, 3, 4]);
        // A gap wider than allowed stays open.
        let mut g2 = SegmentGraph {
            edges: g.edges[..g.edges.len() - 1].to_vec(),
            ..g
        };
        assert_eq!(join_gaps(&mut g2, 0.4), 0);
    }

    #[test]
    fn loop_through_a_junction_is_an_arc_from_it_to_itself() {
        // Node 0 has valence 3: a loop 0-1-2-0 plus a tail 0-3.
        let edges = [[0, 1], [1, 2], [2, 0], [0, 3]];
        let arcs = extract_arcs(4, &edges, &[true; 4]);
        assert_eq!(arcs.len(), 2);
        assert_eq!(arcs[0].nodes, vec![0, 1, 2, 0]);
        assert_eq!(arcs[1].nodes, vec![0, 3]);
    }
}
