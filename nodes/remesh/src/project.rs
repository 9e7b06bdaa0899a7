//! Projection of a relaxed vertex back onto the input surface (Botsch & Kobbelt 2004, thesis
//! §5.1.1) by a walk over the input triangles from the face the vertex was last projected
//! onto, with the [`Bvh`] as the fallback.
//!
//! A vertex moves a fraction of the target length per round, within its tangent plane, so its
//! closest point is almost always on the face it was projected onto before or a few faces
//! away. The walk finds the closest point `q` of the current face and moves, when one is
//! strictly closer, to: the closest of the three faces across its sides when `q` is inside the
//! face (the surface may be concave there); the face across the side `q` lies on; the closest
//! face around the corner `q` is (ties to the smallest face index). Every move lowers the
//! distance, so the walk ends at a local minimum of the distance over the faces it looked at:
//! on a convex piece of surface, seen from outside, that is the exact closest point; inside a
//! concave one it is a foot point on the surface that may be a little farther than the
//! nearest. It gives up after [`MAX_STEPS`] moves, and when the distance found exceeds the
//! caller's `far` bound (a point that left the surface, where a local minimum may lie on the
//! wrong sheet); then the exact BVH query answers, starting from the walk's face as its bound.
//!
//! The answer depends only on the point and the start face, so it is the same at any thread
//! count.

use crestflow_flow::Par;
use crestflow_geom::bvh::closest_point_on_triangle;
use crestflow_geom::mesh::NO_FACE;
use crestflow_geom::vec3::V3;
use crestflow_geom::TriMesh;
use std::sync::OnceLock;

use crate::bvh::{Bvh, Hit};

/// Moves of one walk before it gives up for the BVH.
pub const MAX_STEPS: usize = 24;

/// The input surface, for walks: its triangles, the face across each side and the faces around
/// each corner, plus the BVH (built when first needed).
pub struct Projector<'a> {
    mesh: &'a TriMesh,
    /// Built on first use: most runs never need it.
    bvh: OnceLock<Bvh>,
    /// Whether that build may use the rayon pool.
    par: Par,
    /// Face across side i = `(tri[i], tri[i+1])` of each face (`NO_FACE` on the boundary or at a
    /// non-manifold edge).
    across: Vec<[u32; 3]>,
}

/// How a projection was answered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    pub hit: Hit,
    /// Whether the BVH answered (the walk gave up).
    pub fallback: bool,
}

impl<'a> Projector<'a> {
    /// A projector whose hierarchy, when needed, is built on the calling thread.
    pub fn new(mesh: &'a TriMesh) -> Self {
        Self::new_with(mesh, Par::Seq)
    }

    /// A projector whose hierarchy is built on the rayon pool under `Par::Rayon` (the same
    /// hierarchy either way).
    pub fn new_with(mesh: &'a TriMesh, par: Par) -> Self {
        let topo = mesh.topology();
        let mut nonmanifold = vec![false; topo.edges.len()];
        for &e in &topo.nonmanifold_edges {
            nonmanifold[e as usize] = true;
        }
        let across = topo
            .face_edges
            .iter()
            .enumerate()
            .map(|(f, es)| {
                es.map(|e| {
                    let [f0, f1] = topo.edge_faces[e as usize];
                    if nonmanifold[e as usize] {
                        NO_FACE
                    } else if f0 == f as u32 {
                        f1
                    } else {
                        f0
                    }
                })
            })
            .collect();
        Projector {
            mesh,
            bvh: OnceLock::new(),
            par,
            across,
        }
    }

    /// The exact closest-point hierarchy over the input (built on the first call).
    pub fn bvh(&self) -> &Bvh {
        self.bvh
            .get_or_init(|| Bvh::new_with(self.mesh, self.par == Par::Rayon))
    }

    /// The squared distance from `p` to input face `f` (`None` when `f` is not a face): an
    /// upper bound of the distance to the input, and of what a walk from `f` finds.
    pub fn dist2_to_face(&self, f: u32, p: V3) -> Option<f64> {
        ((f as usize) < self.mesh.n_faces()).then(|| self.test(f, p).0)
    }

    fn test(&self, f: u32, p: V3) -> (f64, [f64; 3]) {
        let [a, b, c] = self.mesh.face_points(f as usize);
        closest_point_on_triangle(p, a, b, c)
    }

    /// The closest point of the input surface to `p` found by a walk from face `start` (see
    /// the module docs); the exact BVH answer when `start` is not a face, when the walk takes
    /// more than [`MAX_STEPS`] moves, or when it ends farther than `far` from `p`.
    pub fn project(&self, p: V3, start: u32, far: f64) -> Projection {
        if start >= self.mesh.n_faces() as u32 {
            return Projection {
                hit: self.bvh().closest(p),
                fallback: true,
            };
        }
        match self.walk(p, start, far) {
            Ok(hit) => Projection {
                hit,
                fallback: false,
            },
            Err(cur) => Projection {
                hit: self.bvh().closest_with_hint(p, cur),
                fallback: true,
            },
        }
    }

    /// The walk of [`Self::project`] alone: `None` where `project` would ask the BVH. For
    /// tests that can do without an answer, so that a rare failed walk does not build the
    /// BVH (on a 200k-face input that costs as much as a few rounds of remeshing).
    pub fn project_walk(&self, p: V3, start: u32, far: f64) -> Option<Hit> {
        if start >= self.mesh.n_faces() as u32 {
            return None;
        }
        self.walk(p, start, far).ok()
    }

    /// The walk from face `start` (a face of the input): the hit, or the face it ended on when
    /// it gave up.
    fn walk(&self, p: V3, start: u32, far: f64) -> Result<Hit, u32> {
        let topo = self.mesh.topology();
        let mut cur = start;
        let (mut d2, mut bary) = self.test(cur, p);
        let mut settled = false;
        for _ in 0..MAX_STEPS {
            let zeros = bary.iter().filter(|&&b| b == 0.0).count();
            let next = match zeros {
                // Orthogonally into the face: a face across one of its sides may still be
                // closer where the surface is concave.
                0 => {
                    let mut best: Option<(u32, f64, [f64; 3])> = None;
                    for g in self.across[cur as usize] {
                        if g == NO_FACE {
                            continue;
                        }
                        let (e2, eb) = self.test(g, p);
                        if e2 < d2 && best.is_none_or(|b| e2 < b.1 || (e2 == b.1 && g < b.0)) {
                            best = Some((g, e2, eb));
                        }
                    }
                    best
                }
                // On the side between the two corners with nonzero weight.
                1 => {
                    let k = bary.iter().position(|&b| b == 0.0).unwrap_or(0);
                    let g = self.across[cur as usize][(k + 1) % 3];
                    if g == NO_FACE {
                        None
                    } else {
                        let (e2, eb) = self.test(g, p);
                        (e2 < d2).then_some((g, e2, eb))
                    }
                }
                // At a corner: the closest face around it.
                _ => {
                    let k = bary.iter().position(|&b| b != 0.0).unwrap_or(0);
                    let v = self.mesh.triangles[cur as usize][k];
                    let mut best: Option<(u32, f64, [f64; 3])> = None;
                    for &g in topo.vertex_faces(v) {
                        if g == cur {
                            continue;
                        }
                        let (e2, eb) = self.test(g, p);
                        if e2 < d2 && best.is_none_or(|b| e2 < b.1 || (e2 == b.1 && g < b.0)) {
                            best = Some((g, e2, eb));
                        }
                    }
                    best
                }
            };
            match next {
                Some((g, e2, eb)) => {
                    cur = g;
                    d2 = e2;
                    bary = eb;
                }
                None => {
                    settled = true;
                    break;
                }
            }
        }
        if !settled || !(d2 <= far * far) {
            return Err(cur);
        }
        let [a, b, c] = self.mesh.face_points(cur as usize);
        let point = [
            bary[0] * a[0] + bary[1] * b[0] + bary[2] * c[0],
            bary[0] * a[1] + bary[1] * b[1] + bary[2] * c[1],
            bary[0] * a[2] + bary[1] * b[2] + bary[2] * c[2],
        ];
        Ok(Hit {
            distance: d2.sqrt(),
            dist2: d2,
            face: cur,
            bary,
            point,
        })
    }
}

#[cfg(test)]
#[path = "project_test.rs"]
mod tests;
