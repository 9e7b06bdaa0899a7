//! `eval.mesh_quality`: triangle quality of a (remeshed) mesh, the figures by which thesis
//! §5.1.1 judges isotropic remeshing (Botsch & Kobbelt 2004; Fig. 5.1–5.3 give the Hausdorff
//! distance to the input, the vertex count and the triangle shapes).
//!
//! Report:
//! - `min_angle_deg`, `max_angle_deg`, `mean_min_angle_deg` (mean over triangles of their
//!   smallest angle), `frac_angles_lt_30` (share of all corner angles below 30°);
//! - `valence6_share`: share of interior vertices with exactly 6 edges; `valence_min`,
//!   `valence_max`;
//! - `edge_mean`, `edge_cv` (standard deviation / mean of the edge lengths);
//! - with a target length: `target_abs`, `edge_mean_over_target`, `frac_edges_in_range` (share
//!   of edges within [4/5, 4/3] of the target, the remesher's own bounds);
//! - `vertices`, `faces`, `edges`, `boundary_edges`, `interior_vertices`, `euler_characteristic`;
//! - with a reference mesh: `hausdorff_rel` (refined to within `tolerance`),
//!   `hausdorff_upper_rel` (a certified upper bound), `mean_rel`, `rms_rel` (relative to the
//!   reference's bounding-box diagonal) from [`crate::mesh_distance`], `vertices_reference`;
//!   `farthest_reference_x`, `_y`, `_z`: the point of the reference farthest from the mesh
//!   (what the mesh cuts off), and `farthest_mesh_*`: the point of the mesh farthest from the
//!   reference.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Report, Validate,
};
use crestflow_geom::mesh::{corner_angle, NO_FACE};
use crestflow_geom::vec3;
use crestflow_geom::TriMesh;

use crate::mesh_distance::{check_mesh, mesh_distance, MeshDistanceError, MeshDistanceParams};

/// Parameters of `eval.mesh_quality`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MeshQualityParams {
    /// Target edge length; 0 (default) means none. A fraction of the bounding-box diagonal of
    /// the reference mesh (or of the mesh itself when no reference is connected) when
    /// `relative`, else absolute. In [0, 1e12].
    pub target: f64,
    /// Whether `target` is relative to the bounding-box diagonal (default true).
    pub relative: bool,
    /// Face samples per mesh for the Hausdorff distance, on top of all vertices (default
    /// 100000, range 0..=50000000).
    pub samples: usize,
    /// Seed of the face sampling (default 0).
    pub seed: u64,
    /// How far below the true Hausdorff distance the reported one may lie, as a fraction of
    /// the reference's bounding-box diagonal (default 1e-4, range 0..=1; 0: samples only).
    /// See `eval.mesh_distance`.
    pub tolerance: f64,
}

impl Default for MeshQualityParams {
    fn default() -> Self {
        MeshQualityParams {
            target: 0.0,
            relative: true,
            samples: 100_000,
            seed: 0,
            tolerance: 1e-4,
        }
    }
}

impl Validate for MeshQualityParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "target", self.target, 0.0, 1e12);
        check_range(&mut v, "samples", self.samples, 0, 50_000_000);
        check_range(&mut v, "tolerance", self.tolerance, 0.0, 1.0);
        v
    }
}

/// Why the quality could not be measured.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshQualityError {
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error(transparent)]
    Mesh(#[from] MeshDistanceError),
}

/// Measures `mesh` (and its distance to `reference` when given); see the module docs.
pub fn mesh_quality(
    mesh: &TriMesh,
    reference: Option<&TriMesh>,
    params: &MeshQualityParams,
    par: Par,
) -> Result<Report, MeshQualityError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let t: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(MeshQualityError::Params(t.join("; ")));
    }
    check_mesh(mesh, "mesh")?;
    if let Some(r) = reference {
        check_mesh(r, "reference")?;
    }
    let mut r = Report::new();

    // Angles, per face in parallel, reduced in face order.
    let per_face: Vec<[f64; 3]> = par.map_collect(mesh.n_faces(), |f| {
        let p = mesh.face_points(f);
        let mut a = [0.0; 3];
        for (i, ai) in a.iter_mut().enumerate() {
            *ai = corner_angle(
                vec3::sub(p[(i + 1) % 3], p[i]),
                vec3::sub(p[(i + 2) % 3], p[i]),
            )
            .to_degrees();
        }
        a
    });
    let (mut lo, mut hi, mut below, mut sum_min) = (f64::INFINITY, 0.0f64, 0usize, 0.0);
    for a in &per_face {
        let m = a[0].min(a[1]).min(a[2]);
        lo = lo.min(m);
        hi = hi.max(a[0].max(a[1]).max(a[2]));
        below += a.iter().filter(|&&x| x < 30.0).count();
        sum_min += m;
    }
    let nf = mesh.n_faces();
    r.set("min_angle_deg", lo)
        .set("max_angle_deg", hi)
        .set("mean_min_angle_deg", sum_min / nf as f64)
        .set("frac_angles_lt_30", below as f64 / (3 * nf) as f64);

    // Valences and boundary.
    let topo = mesh.topology();
    let mut valence = vec![0usize; mesh.n_vertices()];
    for [a, b] in &topo.edges {
        valence[*a as usize] += 1;
        valence[*b as usize] += 1;
    }
    let boundary = topo.edge_faces.iter().filter(|f| f[1] == NO_FACE).count();
    let used: Vec<bool> = valence.iter().map(|&v| v > 0).collect();
    let interior: Vec<usize> = (0..mesh.n_vertices())
        .filter(|&v| used[v] && !topo.is_boundary_vertex[v])
        .collect();
    let six = interior.iter().filter(|&&v| valence[v] == 6).count();
    r.set(
        "valence6_share",
        if interior.is_empty() {
            0.0
        } else {
            six as f64 / interior.len() as f64
        },
    );
    let used_val = valence.iter().copied().filter(|&v| v > 0);
    r.set("valence_min", used_val.clone().min().unwrap_or(0))
        .set("valence_max", used_val.max().unwrap_or(0));
    let nv_used = used.iter().filter(|&&u| u).count();
    r.set("vertices", mesh.n_vertices())
        .set("faces", nf)
        .set("edges", topo.edges.len())
        .set("boundary_edges", boundary)
        .set("interior_vertices", interior.len())
        .set(
            "euler_characteristic",
            nv_used as f64 - topo.edges.len() as f64 + nf as f64,
        );

    // Edge lengths.
    let lens = mesh.edge_lengths();
    let n = lens.len().max(1) as f64;
    let mean = lens.iter().sum::<f64>() / n;
    let var = lens.iter().map(|l| (l - mean) * (l - mean)).sum::<f64>() / n;
    r.set("edge_mean", mean)
        .set("edge_cv", if mean > 0.0 { var.sqrt() / mean } else { 0.0 });
    if params.target > 0.0 {
        let unit = if params.relative {
            reference.unwrap_or(mesh).bbox_diagonal()
        } else {
            1.0
        };
        let l = params.target * unit;
        let in_range = lens
            .iter()
            .filter(|&&x| x >= 0.8 * l && x <= 4.0 / 3.0 * l)
            .count();
        r.set("target_abs", l)
            .set("edge_mean_over_target", mean / l)
            .set("frac_edges_in_range", in_range as f64 / n);
    }

    if let Some(reference) = reference {
        let d = mesh_distance(
            reference,
            mesh,
            &MeshDistanceParams {
                samples: params.samples,
                seed: params.seed,
                tolerance: params.tolerance,
            },
            par,
        )?;
        for k in [
            "hausdorff_rel",
            "hausdorff_upper_rel",
            "mean_rel",
            "rms_rel",
            "hausdorff_abs",
        ] {
            if let Some(x) = d.num(k) {
                r.set(k, x);
            }
        }
        // Where the distance is reached each way (`a` is the reference).
        for (from, to) in [
            ("a_to_b", "farthest_reference"),
            ("b_to_a", "farthest_mesh"),
        ] {
            for axis in ["x", "y", "z"] {
                if let Some(x) = d.num(&format!("{from}.farthest_{axis}")) {
                    r.set(format!("{to}_{axis}"), x);
                }
            }
        }
        r.set("vertices_reference", reference.n_vertices());
    }
    Ok(r)
}

/// The `eval.mesh_quality` node.
pub struct MeshQualityNode;

impl NodeKind for MeshQualityNode {
    type Params = MeshQualityParams;
    const KIND: &'static str = "eval.mesh_quality";
    const VERSION: u32 = 2;
    const DOC: &'static str = "Triangle quality of a mesh, the figures of isotropic remeshing \
        (thesis §5.1.1, Botsch & Kobbelt 2004): min/max angle, share of angles below 30°, \
        share of valence-6 interior vertices, edge-length mean and coefficient of variation \
        (and against a target length), counts; with a reference mesh, the Hausdorff (refined \
        to within `tolerance`, with a certified upper bound), mean and RMS distance to it \
        relative to its bbox diagonal (via eval.mesh_distance). Output: a Report.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the mesh to grade"),
            Port::optional::<TriMesh>(
                "reference",
                "the original surface, for the Hausdorff distance",
            ),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<Report>(
            "report",
            "min_angle_deg, frac_angles_lt_30, valence6_share, edge_cv, hausdorff_rel, …",
        )]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let reference = inputs.opt::<TriMesh>("reference")?;
        ctx.check_cancelled()?;
        let report = mesh_quality(mesh, reference, params, ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new().with("report", report))
    }
}

#[cfg(test)]
#[path = "mesh_quality_test.rs"]
mod tests;
