//! `eval.mesh_distance`: Hausdorff, mean and RMS surface distance between two triangle meshes,
//! the figures of thesis Table 5.1 (§5.1.3, feature-preserving smoothing; the smoothing itself
//! follows Desbrun, Meyer, Schröder & Barr 1999 and Taubin 1995).
//!
//! Both surfaces are sampled: every vertex plus `samples` points drawn on the faces with
//! probability proportional to their area (seeded, so the same inputs give the same figures,
//! bit for bit, at any thread count). Each sample is measured to the other surface by the exact
//! point–triangle distance, found through a bounding volume hierarchy of the other mesh's
//! triangles ([`TriangleBvh`]), so the cost is O((n + s) log m), not O(n·m).
//!
//! Report (distances divided by the bounding-box diagonal of `a`):
//! - `hausdorff_rel`: the symmetric Hausdorff distance, max over both directions;
//! - `mean_rel`, `rms_rel`: mean and root mean square over the samples of both directions
//!   pooled (the sample-count weighted mean of the two directions, as MeshLab reports it);
//! - `a_to_b.*`, `b_to_a.*`: the same three figures for one direction (`a_to_b` samples `a`
//!   and measures to `b`);
//! - `hausdorff_abs`, `bbox_diagonal`, `samples_a`, `samples_b`.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Report, Validate,
};
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::TriMesh;

/// Parameters of `eval.mesh_distance`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MeshDistanceParams {
    /// Area-weighted random points drawn on the faces of each mesh, on top of all its vertices
    /// (default 100000, range 0..=50000000).
    pub samples: usize,
    /// Seed of the face sampling (default 0).
    pub seed: u64,
}

impl Default for MeshDistanceParams {
    fn default() -> Self {
        MeshDistanceParams {
            samples: 100_000,
            seed: 0,
        }
    }
}

impl Validate for MeshDistanceParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "samples", self.samples, 0, 50_000_000);
        issues
    }
}

/// Errors of [`mesh_distance`]. `mesh` is `"a"` or `"b"`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshDistanceError {
    #[error("mesh `{mesh}` has no faces ({vertices} vertices)")]
    NoFaces { mesh: &'static str, vertices: usize },
    #[error("mesh `{mesh}`: face {face} references vertex {index} but the mesh has {n_vertices} vertices")]
    IndexOutOfRange {
        mesh: &'static str,
        face: usize,
        index: u32,
        n_vertices: usize,
    },
    #[error("mesh `{mesh}`: vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFinite {
        mesh: &'static str,
        vertex: usize,
        position: V3,
    },
    #[error("mesh `{mesh}` has zero total area: there is no surface to measure to")]
    ZeroArea { mesh: &'static str },
    #[error("invalid parameters: {0}")]
    Params(String),
}

/// Checks indices and coordinates, and that the mesh has some area.
pub fn check_mesh(mesh: &TriMesh, name: &'static str) -> Result<(), MeshDistanceError> {
    let n = mesh.n_vertices();
    if mesh.n_faces() == 0 {
        return Err(MeshDistanceError::NoFaces {
            mesh: name,
            vertices: n,
        });
    }
    for (face, t) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= n) {
            return Err(MeshDistanceError::IndexOutOfRange {
                mesh: name,
                face,
                index,
                n_vertices: n,
            });
        }
    }
    for (vertex, p) in mesh.positions.iter().enumerate() {
        if !p.iter().all(|c| c.is_finite()) {
            return Err(MeshDistanceError::NonFinite {
                mesh: name,
                vertex,
                position: *p,
            });
        }
    }
    // Written so that a NaN area is rejected too.
    let area = mesh.total_area();
    if area.is_nan() || area <= 0.0 {
        return Err(MeshDistanceError::ZeroArea { mesh: name });
    }
    Ok(())
}

/// The closest point of triangle (a, b, c) to `p`: its squared distance and barycentric
/// coordinates. Exact case analysis over the Voronoi regions of the corners, sides and
/// interior (each region is tested with the signs of a few dot products).
pub fn closest_point_on_triangle(p: V3, a: V3, b: V3, c: V3) -> (f64, [f64; 3]) {
    let ab = vec3::sub(b, a);
    let ac = vec3::sub(c, a);
    let ap = vec3::sub(p, a);
    let d1 = vec3::dot(ab, ap);
    let d2 = vec3::dot(ac, ap);
    let bary = if d1 <= 0.0 && d2 <= 0.0 {
        [1.0, 0.0, 0.0]
    } else {
        let bp = vec3::sub(p, b);
        let d3 = vec3::dot(ab, bp);
        let d4 = vec3::dot(ac, bp);
        let cp = vec3::sub(p, c);
        let d5 = vec3::dot(ab, cp);
        let d6 = vec3::dot(ac, cp);
        let vc = d1 * d4 - d3 * d2;
        let vb = d5 * d2 - d1 * d6;
        let va = d3 * d6 - d5 * d4;
        if d3 >= 0.0 && d4 <= d3 {
            [0.0, 1.0, 0.0]
        } else if d6 >= 0.0 && d5 <= d6 {
            [0.0, 0.0, 1.0]
        } else if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            // Side ab.
            let v = d1 / (d1 - d3);
            [1.0 - v, v, 0.0]
        } else if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            // Side ac.
            let w = d2 / (d2 - d6);
            [1.0 - w, 0.0, w]
        } else if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            // Side bc.
            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            [0.0, 1.0 - w, w]
        } else {
            let s = va + vb + vc;
            if s > 0.0 && s.is_finite() {
                let v = vb / s;
                let w = vc / s;
                [1.0 - v - w, v, w]
            } else {
                // Degenerate (zero-area) triangle that slipped through: fall back to its
                // corners, which is where such a triangle's points are anyway.
                let da = vec3::dot(ap, ap);
                let db = vec3::dot(bp, bp);
                let dc = vec3::dot(cp, cp);
                if da <= db && da <= dc {
                    [1.0, 0.0, 0.0]
                } else if db <= dc {
                    [0.0, 1.0, 0.0]
                } else {
                    [0.0, 0.0, 1.0]
                }
            }
        }
    };
    let q = [
        bary[0] * a[0] + bary[1] * b[0] + bary[2] * c[0],
        bary[0] * a[1] + bary[1] * b[1] + bary[2] * c[1],
        bary[0] * a[2] + bary[1] * b[2] + bary[2] * c[2],
    ];
    let d = vec3::sub(p, q);
    (vec3::dot(d, d), bary)
}

/// An axis-aligned box.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: V3,
    hi: V3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
    };
    fn grow(&mut self, p: V3) {
        for (k, &c) in p.iter().enumerate() {
            self.lo[k] = self.lo[k].min(c);
            self.hi[k] = self.hi[k].max(c);
        }
    }
    fn merge(&mut self, o: &Aabb) {
        self.grow(o.lo);
        self.grow(o.hi);
    }
    /// Squared distance from `p` to the box (0 inside).
    fn dist2(&self, p: V3) -> f64 {
        let mut s = 0.0;
        for (k, &c) in p.iter().enumerate() {
            let d = (self.lo[k] - c).max(c - self.hi[k]).max(0.0);
            s += d * d;
        }
        s
    }
}

#[derive(Clone, Copy, Debug)]
struct BvhNode {
    bounds: Aabb,
    /// Leaf: first index into `order`; inner: index of the left child (right = left + 1).
    first: u32,
    /// Leaf: number of triangles (> 0); inner: 0.
    count: u32,
}

/// The closest point of a mesh to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    pub distance: f64,
    pub face: u32,
    pub bary: [f64; 3],
}

/// A bounding volume hierarchy over the triangles of a mesh, for exact closest-point queries.
/// Built by median splits on the longest axis of the triangle centroids (leaves of up to 4
/// triangles); a query descends the nearer child first and prunes boxes farther than the best
/// distance found, so it returns the exact minimum over all triangles.
pub struct TriangleBvh<'m> {
    mesh: &'m TriMesh,
    nodes: Vec<BvhNode>,
    order: Vec<u32>,
}

const LEAF_SIZE: usize = 4;

impl<'m> TriangleBvh<'m> {
    /// Builds the hierarchy. The mesh's indices must be valid (see [`check_mesh`]).
    pub fn new(mesh: &'m TriMesh) -> Self {
        let nf = mesh.n_faces();
        let boxes: Vec<Aabb> = (0..nf)
            .map(|f| {
                let mut b = Aabb::EMPTY;
                for p in mesh.face_points(f) {
                    b.grow(p);
                }
                b
            })
            .collect();
        let centroids: Vec<V3> = (0..nf)
            .map(|f| {
                let [a, b, c] = mesh.face_points(f);
                vec3::scale(vec3::add(vec3::add(a, b), c), 1.0 / 3.0)
            })
            .collect();
        let mut order: Vec<u32> = (0..nf as u32).collect();
        let mut nodes = Vec::with_capacity(2 * nf / LEAF_SIZE + 1);
        nodes.push(BvhNode {
            bounds: Aabb::EMPTY,
            first: 0,
            count: 0,
        });
        // Explicit stack of (node, start, end) so deep meshes cannot overflow the call stack.
        let mut stack = vec![(0usize, 0usize, nf)];
        while let Some((node, start, end)) = stack.pop() {
            let mut bounds = Aabb::EMPTY;
            let mut cbounds = Aabb::EMPTY;
            for &f in &order[start..end] {
                bounds.merge(&boxes[f as usize]);
                cbounds.grow(centroids[f as usize]);
            }
            nodes[node].bounds = bounds;
            if end - start <= LEAF_SIZE {
                nodes[node].first = start as u32;
                nodes[node].count = (end - start) as u32;
                continue;
            }
            let ext = vec3::sub(cbounds.hi, cbounds.lo);
            let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
                0
            } else if ext[1] >= ext[2] {
                1
            } else {
                2
            };
            let mid = (start + end) / 2;
            // Ties broken by face index: the tree (and so nothing downstream) depends on the
            // sort algorithm.
            order[start..end].select_nth_unstable_by(mid - start, |&x, &y| {
                centroids[x as usize][axis]
                    .total_cmp(&centroids[y as usize][axis])
                    .then(x.cmp(&y))
            });
            let left = nodes.len();
            for _ in 0..2 {
                nodes.push(BvhNode {
                    bounds: Aabb::EMPTY,
                    first: 0,
                    count: 0,
                });
            }
            nodes[node].first = left as u32;
            nodes[node].count = 0;
            stack.push((left + 1, mid, end));
            stack.push((left, start, mid));
        }
        TriangleBvh { mesh, nodes, order }
    }

    /// The closest point of the mesh to `p` (exact). Among equally close triangles the one
    /// with the smallest face index wins.
    pub fn closest(&self, p: V3) -> ClosestPoint {
        let mut best = (f64::INFINITY, u32::MAX, [0.0; 3]);
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            if node.bounds.dist2(p) > best.0 {
                continue;
            }
            if node.count > 0 {
                let s = node.first as usize;
                for &f in &self.order[s..s + node.count as usize] {
                    let [a, b, c] = self.mesh.face_points(f as usize);
                    let (d2, bary) = closest_point_on_triangle(p, a, b, c);
                    if d2 < best.0 || (d2 == best.0 && f < best.1) {
                        best = (d2, f, bary);
                    }
                }
            } else {
                let l = node.first;
                let (dl, dr) = (
                    self.nodes[l as usize].bounds.dist2(p),
                    self.nodes[l as usize + 1].bounds.dist2(p),
                );
                // Push the farther child first so the nearer one is searched first.
                if dl <= dr {
                    stack.push(l + 1);
                    stack.push(l);
                } else {
                    stack.push(l);
                    stack.push(l + 1);
                }
            }
        }
        ClosestPoint {
            distance: best.0.sqrt(),
            face: best.1,
            bary: best.2,
        }
    }
}

/// SplitMix64 finaliser: a counter-based generator, so sample i depends only on (seed, i).
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform in [0, 1) from 53 random bits.
fn unit(z: u64) -> f64 {
    (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// All vertices of `mesh` followed by `n` area-weighted random points on its faces.
pub fn sample_surface(mesh: &TriMesh, n: usize, seed: u64) -> Vec<V3> {
    let mut cum = Vec::with_capacity(mesh.n_faces());
    let mut total = 0.0;
    for f in 0..mesh.n_faces() {
        total += mesh.face_area(f);
        cum.push(total);
    }
    let mut out = mesh.positions.clone();
    out.reserve(n);
    if total <= 0.0 {
        return out;
    }
    let stream = mix(seed);
    for i in 0..n as u64 {
        let r0 = mix(stream ^ mix(3 * i));
        let r1 = mix(stream ^ mix(3 * i + 1));
        let r2 = mix(stream ^ mix(3 * i + 2));
        let target = unit(r0) * total;
        let f = cum.partition_point(|&c| c <= target).min(cum.len() - 1);
        // Uniform point in the triangle (square-root warp of the unit square).
        let s = unit(r1).sqrt();
        let t = unit(r2);
        let [a, b, c] = mesh.face_points(f);
        let (wa, wb, wc) = (1.0 - s, s * (1.0 - t), s * t);
        out.push([
            wa * a[0] + wb * b[0] + wc * c[0],
            wa * a[1] + wb * b[1] + wc * c[1],
            wa * a[2] + wb * b[2] + wc * c[2],
        ]);
    }
    out
}

/// One-sided figures: distances of `points` to the surface in `bvh`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OneSided {
    pub max: f64,
    pub mean: f64,
    pub rms: f64,
    pub n: usize,
    /// Sum of distances and of squared distances (for pooling).
    sum: f64,
    sum2: f64,
}

/// Distances of `points` to the mesh of `bvh`, reduced in point order.
pub fn one_sided(points: &[V3], bvh: &TriangleBvh, par: Par) -> OneSided {
    let d = par.map_collect(points.len(), |i| bvh.closest(points[i]).distance);
    let mut max = 0.0f64;
    let mut sum = 0.0;
    let mut sum2 = 0.0;
    for &x in &d {
        max = max.max(x);
        sum += x;
        sum2 += x * x;
    }
    let n = d.len().max(1) as f64;
    OneSided {
        max,
        mean: sum / n,
        rms: (sum2 / n).sqrt(),
        n: d.len(),
        sum,
        sum2,
    }
}

/// Measures the distance between the surfaces of `a` and `b` (see the module docs).
pub fn mesh_distance(
    a: &TriMesh,
    b: &TriMesh,
    params: &MeshDistanceParams,
    par: Par,
) -> Result<Report, MeshDistanceError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(MeshDistanceError::Params(text.join("; ")));
    }
    check_mesh(a, "a")?;
    check_mesh(b, "b")?;
    let bvh_a = TriangleBvh::new(a);
    let bvh_b = TriangleBvh::new(b);
    // Different streams for the two meshes: identical meshes must not get identical samples
    // by construction only.
    let pa = sample_surface(a, params.samples, params.seed);
    let pb = sample_surface(b, params.samples, params.seed ^ 0x5A5A_5A5A_5A5A_5A5A);
    let ab = one_sided(&pa, &bvh_b, par);
    let ba = one_sided(&pb, &bvh_a, par);

    let diag = a.bbox_diagonal();
    let rel = |x: f64| if diag > 0.0 { x / diag } else { x };
    let n = (ab.n + ba.n) as f64;
    let hausdorff = ab.max.max(ba.max);
    let mean = (ab.sum + ba.sum) / n;
    let rms = ((ab.sum2 + ba.sum2) / n).sqrt();

    let mut r = Report::new();
    r.set("hausdorff_rel", rel(hausdorff))
        .set("mean_rel", rel(mean))
        .set("rms_rel", rel(rms))
        .set("a_to_b.hausdorff_rel", rel(ab.max))
        .set("a_to_b.mean_rel", rel(ab.mean))
        .set("a_to_b.rms_rel", rel(ab.rms))
        .set("b_to_a.hausdorff_rel", rel(ba.max))
        .set("b_to_a.mean_rel", rel(ba.mean))
        .set("b_to_a.rms_rel", rel(ba.rms))
        .set("hausdorff_abs", hausdorff)
        .set("bbox_diagonal", diag)
        .set("samples_a", ab.n)
        .set("samples_b", ba.n);
    Ok(r)
}

/// The `eval.mesh_distance` node.
pub struct MeshDistanceNode;

impl NodeKind for MeshDistanceNode {
    type Params = MeshDistanceParams;
    const KIND: &'static str = "eval.mesh_distance";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Symmetric Hausdorff, mean and RMS distance between the surfaces \
        of two meshes, relative to the bounding-box diagonal of `a`: all vertices plus seeded \
        area-weighted face samples of each mesh, measured to the other by exact point-triangle \
        distance through a BVH. The figures of thesis Table 5.1 (§5.1.3, feature-preserving \
        smoothing; Desbrun et al. 1999). Output: a Report.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("a", "the reference mesh (its bbox diagonal is the unit)"),
            Port::of::<TriMesh>("b", "the mesh compared with it"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<Report>(
            "report",
            "hausdorff_rel, mean_rel, rms_rel and one-sided figures",
        )]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let a = inputs.get::<TriMesh>("a")?;
        let b = inputs.get::<TriMesh>("b")?;
        ctx.check_cancelled()?;
        let report = mesh_distance(a, b, params, ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new().with("report", report))
    }
}
