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
use crestflow_geom::locality::morton_order;
use crestflow_geom::vec3::V3;
use crestflow_geom::{MeshDefect, TriMesh};

/// Re-exported: the BVH and the point-triangle distance live in `crestflow_geom::bvh`.
pub use crestflow_geom::bvh::{closest_point_on_triangle, ClosestPoint, TriangleBvh};

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
    mesh.check_data().map_err(|d| match d {
        MeshDefect::NonFinitePosition { vertex, position } => MeshDistanceError::NonFinite {
            mesh: name,
            vertex,
            position,
        },
        MeshDefect::IndexOutOfRange {
            face,
            index,
            n_vertices,
        } => MeshDistanceError::IndexOutOfRange {
            mesh: name,
            face,
            index,
            n_vertices,
        },
    })?;
    // Written so that a NaN area is rejected too.
    let area = mesh.total_area();
    if area.is_nan() || area <= 0.0 {
        return Err(MeshDistanceError::ZeroArea { mesh: name });
    }
    Ok(())
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

/// All vertices of `mesh` followed by `n` area-weighted random points on its faces. Sample i
/// depends only on the seed and i, so the points are the same at every thread count.
pub fn sample_surface(mesh: &TriMesh, n: usize, seed: u64, par: Par) -> Vec<V3> {
    let mut cum = Vec::with_capacity(mesh.n_faces());
    let mut total = 0.0;
    for f in 0..mesh.n_faces() {
        total += mesh.face_area(f);
        cum.push(total);
    }
    let mut out = mesh.positions.clone();
    if total <= 0.0 {
        return out;
    }
    let stream = mix(seed);
    out.extend(par.map_collect(n, |i| {
        let i = i as u64;
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
        [
            wa * a[0] + wb * b[0] + wc * c[0],
            wa * a[1] + wb * b[1] + wc * c[1],
            wa * a[2] + wb * b[2] + wc * c[2],
        ]
    }));
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

/// Queries per parallel task of [`distances`] (a fixed split: the result does not depend on
/// it).
const QUERY_CHUNK: usize = 2048;

/// The distance of every point of `points` to the surface of `bvh`, in point order: exactly
/// what [`TriangleBvh::closest`] gives each point. The queries run along a Morton curve
/// through the points, each seeded with the face found for the one before (the hint only
/// bounds the search; ties still go to the lowest face index), so that the first bound is
/// already tight (`eval.mesh_distance` of cgal_fandisk against its 1 % remesh, 100k samples
/// per side: 171–174 ms before, 144–153 ms after, sampling included).
pub fn distances(points: &[V3], bvh: &TriangleBvh, par: Par) -> Vec<f64> {
    let order = morton_order(points);
    let parts = par.map_collect(order.len().div_ceil(QUERY_CHUNK), |c| {
        let mut hint = u32::MAX;
        order[c * QUERY_CHUNK..((c + 1) * QUERY_CHUNK).min(order.len())]
            .iter()
            .map(|&i| {
                let hit = bvh.closest_with_hint(points[i as usize], hint);
                hint = hit.face;
                hit.distance
            })
            .collect::<Vec<f64>>()
    });
    let mut d = vec![0.0; points.len()];
    for (&i, x) in order.iter().zip(parts.into_iter().flatten()) {
        d[i as usize] = x;
    }
    d
}

/// Distances of `points` to the mesh of `bvh`, reduced in point order.
pub fn one_sided(points: &[V3], bvh: &TriangleBvh, par: Par) -> OneSided {
    let d = distances(points, bvh, par);
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
    let build = |m: &TriMesh| TriangleBvh::new_with(m, par == Par::Rayon);
    let (bvh_a, bvh_b) = par.join(|| build(a), || build(b));
    // Different streams for the two meshes: identical meshes must not get identical samples
    // by construction only.
    let pa = sample_surface(a, params.samples, params.seed, par);
    let pb = sample_surface(b, params.samples, params.seed ^ 0x5A5A_5A5A_5A5A_5A5A, par);
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
