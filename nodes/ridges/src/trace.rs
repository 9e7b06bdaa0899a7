//! `ridges.trace`: ridges and ravines of a mesh as a feature curve network.
//!
//! Thesis §2.5.1.1 ("FCNs based on ridges and ravines"), following the five-step scheme of
//! Ohtake, Belyaev & Seidel 2004 and Yoshizawa, Belyaev & Seidel 2005 (YBS05):
//!
//! 1. principal curvatures, directions and extremality coefficients come in as a
//!    [`CurvatureField`] (any `curvature.*` node);
//! 2. principal directions are aligned per mesh edge (flipped at one end when obtuse), so the
//!    field's global orientation does not matter;
//! 3. on each edge, a zero crossing of the extremality coefficient where k_max > |k_min|
//!    (ridges) resp. k_min < −|k_max| (ravines) gives a candidate point by linear interpolation
//!    ([`crate::crossing`]); the maximum (ridge) or minimum (ravine) condition of Thm 2.1 is
//!    checked per triangle from the gradient of e, which stays reliable on creases that run
//!    along mesh edges ([`crate::network`]);
//! 4. inside each triangle two points make a segment, three meet at their centroid
//!    (trisector), one is a curve end; the segments form a network whose arcs run between
//!    extraordinary vertices or close into loops (Def. 2.1, [`crate::network`]);
//! 5. arcs are filtered by sharpness w_κ (§4.1: length-weighted mean of |κ| along the arc),
//!    by the cyclideness integral of eq. 2.1 (§2.1.2, YBS05) and by length; arcs that become
//!    joined once a branch between them is removed are merged and measured again.
//!
//! Thresholds are scale-free: strength in multiples of the median max(|k_max|, |k_min|) of the
//! mesh's vertices, length in multiples of the mean edge length; the cyclideness integral
//! T = l ∫ sqrt(e_max² + e_min²) ds is dimensionless already.

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Report, Validate,
};
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{
    CurvatureField, CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, TriMesh,
};
use serde::{Deserialize, Serialize};

use crate::crossing::{edge_crossings, Definition, Family};
use crate::network::{extract_arcs, segment_graph, Arc, SegmentGraph};

/// Which curve families to trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Families {
    Ridges,
    Ravines,
    #[default]
    Both,
}

/// Parameters of `ridges.trace`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TraceParams {
    /// `Ridges`, `Ravines` or `Both` (default).
    pub families: Families,
    /// `Thesis` (default: Def. 2.2 / Thm 2.1) or `Extrema` (every extremum of k_max and of
    /// k_min, whatever its sign and kind).
    pub definition: Definition,
    /// Keep arcs whose sharpness w_κ (length-weighted mean |principal curvature| of the traced
    /// family) is at least this multiple of the mesh's median max(|k_max|, |k_min|).
    /// In [0, 1e6]. Default 1.5.
    pub min_strength: f64,
    /// Keep arcs whose cyclideness integral T = l ∫ sqrt(e_max² + e_min²) ds (eq. 2.1,
    /// dimensionless) is at least this: it removes the noise lines that curvature estimates
    /// leave on surfaces close to Dupin cyclides (cylinders, spheres, tori), where the
    /// curvature hardly changes along the curvature lines. In [0, 1e12]. Default 8.
    pub min_cyclideness: f64,
    /// Keep arcs at least this long, in multiples of the mean edge length. In [0, 1e6].
    /// Default 3.
    pub min_length: f64,
    /// Skip edges with a (nearly) umbilic end, where |k_max − k_min| ≤ this × max(|k_max|,
    /// |k_min|): principal directions are undefined there. In [0, 1]. Default 0.01.
    pub umbilic_tolerance: f64,
}

impl Default for TraceParams {
    fn default() -> Self {
        TraceParams {
            families: Families::Both,
            definition: Definition::Thesis,
            min_strength: 1.5,
            min_cyclideness: 8.0,
            min_length: 3.0,
            umbilic_tolerance: 0.01,
        }
    }
}

impl Validate for TraceParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "min_strength", self.min_strength, 0.0, 1e6);
        check_range(&mut v, "min_cyclideness", self.min_cyclideness, 0.0, 1e12);
        check_range(&mut v, "min_length", self.min_length, 0.0, 1e6);
        check_range(
            &mut v,
            "umbilic_tolerance",
            self.umbilic_tolerance,
            0.0,
            1.0,
        );
        v
    }
}

/// Why tracing could not run.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TraceError {
    #[error(
        "the curvature field's `{quantity}` has {field} values but the mesh has {mesh} vertices"
    )]
    FieldSize {
        quantity: &'static str,
        field: usize,
        mesh: usize,
    },
    #[error("the curvature field's `{quantity}` is not finite at vertex {vertex} ({value})")]
    NonFiniteField {
        quantity: &'static str,
        vertex: usize,
        value: f64,
    },
    #[error("mesh vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFinitePosition { vertex: usize, position: V3 },
    #[error("face {face} references vertex {index} but the mesh has {n_vertices} vertices")]
    FaceIndex {
        face: usize,
        index: u32,
        n_vertices: usize,
    },
    #[error("invalid parameters: {0}")]
    Params(String),
}

/// Counts and measures of one tracing run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TraceStats {
    pub ridges: usize,
    pub ravines: usize,
    pub ridge_length: f64,
    pub ravine_length: f64,
    /// Edges with a ridge (ravine) point, before filtering.
    pub ridge_points: usize,
    pub ravine_points: usize,
    /// Trisector faces, before filtering.
    pub trisectors: usize,
    /// Arcs removed by each filter (an arc failing several counts under the first).
    pub removed_weak: usize,
    pub removed_cyclide: usize,
    pub removed_short: usize,
    /// The strength unit: median over vertices of max(|k_max|, |k_min|).
    pub curvature_scale: f64,
    /// The length unit: mean edge length.
    pub mean_edge_length: f64,
}

impl TraceStats {
    /// The stats as a [`Report`].
    pub fn to_report(&self) -> Report {
        let mut r = Report::new();
        r.set("ridges", self.ridges)
            .set("ravines", self.ravines)
            .set("curves", self.ridges + self.ravines)
            .set("ridge_length", self.ridge_length)
            .set("ravine_length", self.ravine_length)
            .set("total_length", self.ridge_length + self.ravine_length)
            .set("ridge_points", self.ridge_points)
            .set("ravine_points", self.ravine_points)
            .set("trisectors", self.trisectors)
            .set("removed_weak", self.removed_weak)
            .set("removed_cyclide", self.removed_cyclide)
            .set("removed_short", self.removed_short)
            .set("curvature_scale", self.curvature_scale)
            .set("mean_edge_length", self.mean_edge_length);
        r
    }
}

/// The traced network and its stats.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceOutput {
    pub network: FeatureCurveNetwork,
    pub stats: TraceStats,
}

/// Traces ridges and/or ravines of `mesh` from `field` into a feature curve network.
pub fn trace(
    mesh: &TriMesh,
    field: &CurvatureField,
    params: &TraceParams,
    par: Par,
) -> Result<TraceOutput, TraceError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(TraceError::Params(text.join("; ")));
    }
    check_inputs(mesh, field)?;
    let mut stats = TraceStats {
        curvature_scale: median_abs_curvature(field),
        mean_edge_length: mesh.mean_edge_length(),
        ..Default::default()
    };
    let mut network = FeatureCurveNetwork::default();
    let families: &[Family] = match params.families {
        Families::Ridges => &[Family::Ridge],
        Families::Ravines => &[Family::Ravine],
        Families::Both => &[Family::Ridge, Family::Ravine],
    };
    for &family in families {
        let crossings = edge_crossings(
            mesh,
            field,
            family,
            params.definition,
            params.umbilic_tolerance,
            par,
        );
        let n_points = crossings.iter().filter(|c| c.is_some()).count();
        let graph = segment_graph(mesh, field, family, params.definition, &crossings, par);
        stats.trisectors += graph.trisectors;
        let arcs = filter_arcs(&graph, params, &mut stats);
        let label = match family {
            Family::Ridge => {
                stats.ridge_points = n_points;
                CurveLabel::Ridge
            }
            Family::Ravine => {
                stats.ravine_points = n_points;
                CurveLabel::Ravine
            }
        };
        append_arcs(&mut network, &graph, &arcs, label);
    }
    for c in 0..network.curves.len() {
        let len = network.curve_length(c);
        match network.curves[c].label {
            CurveLabel::Ridge => {
                stats.ridges += 1;
                stats.ridge_length += len;
            }
            _ => {
                stats.ravines += 1;
                stats.ravine_length += len;
            }
        }
    }
    Ok(TraceOutput { network, stats })
}

fn check_inputs(mesh: &TriMesh, field: &CurvatureField) -> Result<(), TraceError> {
    let n = mesh.n_vertices();
    for (vertex, p) in mesh.positions.iter().enumerate() {
        if !p.iter().all(|c| c.is_finite()) {
            return Err(TraceError::NonFinitePosition {
                vertex,
                position: *p,
            });
        }
    }
    for (face, t) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= n) {
            return Err(TraceError::FaceIndex {
                face,
                index,
                n_vertices: n,
            });
        }
    }
    let scalars: [(&'static str, &[f64]); 4] = [
        ("k_max", &field.k_max),
        ("k_min", &field.k_min),
        ("e_max", &field.e_max),
        ("e_min", &field.e_min),
    ];
    let vectors: [(&'static str, &[V3]); 2] = [("t_max", &field.t_max), ("t_min", &field.t_min)];
    for (quantity, xs) in scalars {
        if xs.len() != n {
            return Err(TraceError::FieldSize {
                quantity,
                field: xs.len(),
                mesh: n,
            });
        }
    }
    for (quantity, xs) in vectors {
        if xs.len() != n {
            return Err(TraceError::FieldSize {
                quantity,
                field: xs.len(),
                mesh: n,
            });
        }
    }
    for (quantity, xs) in scalars {
        if let Some((vertex, &value)) = xs.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(TraceError::NonFiniteField {
                quantity,
                vertex,
                value,
            });
        }
    }
    for (quantity, xs) in vectors {
        if let Some((vertex, t)) = xs
            .iter()
            .enumerate()
            .find(|(_, t)| !t.iter().all(|c| c.is_finite()))
        {
            let value = t
                .iter()
                .copied()
                .find(|c| !c.is_finite())
                .unwrap_or(f64::NAN);
            return Err(TraceError::NonFiniteField {
                quantity,
                vertex,
                value,
            });
        }
    }
    Ok(())
}

/// Median over vertices of max(|k_max|, |k_min|): a curvature unit that sharp edges (few,
/// huge values) and flat regions (many zeros) both leave meaningful on typical meshes.
fn median_abs_curvature(field: &CurvatureField) -> f64 {
    let mut k: Vec<f64> = field
        .k_max
        .iter()
        .zip(&field.k_min)
        .map(|(a, b)| a.abs().max(b.abs()))
        .collect();
    if k.is_empty() {
        return 0.0;
    }
    let mid = k.len() / 2;
    let (_, m, _) = k.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// Measures of one arc.
#[derive(Clone, Copy, Debug)]
struct ArcMeasure {
    length: f64,
    /// w_κ: length-weighted mean strength.
    strength: f64,
    /// T = l ∫ sqrt(e_max² + e_min²) ds.
    cyclideness: f64,
}

fn measure(graph: &SegmentGraph, arc: &Arc) -> ArcMeasure {
    let mut length = 0.0;
    let mut strength = 0.0;
    let mut cyc = 0.0;
    for &e in &arc.edges {
        let [p, q] = graph.edges[e as usize];
        let (a, b) = (&graph.nodes[p as usize], &graph.nodes[q as usize]);
        let l = vec3::dist(a.position, b.position);
        length += l;
        strength += l * 0.5 * (a.strength + b.strength);
        cyc += l * 0.5 * (a.cyclideness + b.cyclideness);
    }
    let strength = if length > 0.0 { strength / length } else { 0.0 };
    ArcMeasure {
        length,
        strength,
        cyclideness: length * cyc,
    }
}

/// Step 5: drops arcs failing a threshold, re-forms arcs (branches removed at a junction let
/// the others merge) and repeats until every arc passes.
fn filter_arcs(graph: &SegmentGraph, params: &TraceParams, stats: &mut TraceStats) -> Vec<Arc> {
    let min_strength = params.min_strength * stats.curvature_scale;
    let min_length = params.min_length * stats.mean_edge_length;
    let mut alive = vec![true; graph.edges.len()];
    loop {
        let arcs = extract_arcs(graph.nodes.len(), &graph.edges, &alive);
        let mut removed = false;
        for arc in &arcs {
            let m = measure(graph, arc);
            let reason = if m.strength < min_strength {
                &mut stats.removed_weak
            } else if m.cyclideness < params.min_cyclideness {
                &mut stats.removed_cyclide
            } else if m.length < min_length {
                &mut stats.removed_short
            } else {
                continue;
            };
            *reason += 1;
            removed = true;
            for &e in &arc.edges {
                alive[e as usize] = false;
            }
        }
        if !removed {
            return arcs;
        }
    }
}

/// Adds `arcs` to `net` as curves with `label`; graph nodes become network vertices in order of
/// first use.
fn append_arcs(
    net: &mut FeatureCurveNetwork,
    graph: &SegmentGraph,
    arcs: &[Arc],
    label: CurveLabel,
) {
    let mut index = vec![u32::MAX; graph.nodes.len()];
    for arc in arcs {
        let mut vertices = Vec::with_capacity(arc.nodes.len());
        for &n in &arc.nodes {
            if index[n as usize] == u32::MAX {
                index[n as usize] = net.vertices.len() as u32;
                let g = &graph.nodes[n as usize];
                net.vertices.push(FcnVertex {
                    position: g.position,
                    location: g.location,
                    strength: g.strength,
                });
            }
            vertices.push(index[n as usize]);
        }
        net.curves.push(FeatureCurve {
            vertices,
            closed: arc.closed,
            label,
        });
    }
}

/// The `ridges.trace` node.
pub struct TraceNode;

impl NodeKind for TraceNode {
    type Params = TraceParams;
    const KIND: &'static str = "ridges.trace";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Traces ridges (positive maxima of k_max) and ravines (negative minima \
        of k_min) as zero crossings of the extremality coefficients on mesh edges (thesis Def. 2.2, \
        Thm 2.1), joins them per triangle (regular, trisector, end cases) into a feature curve \
        network of arcs and loops (Def. 2.1), and filters arcs by sharpness w_κ (§4.1), the \
        cyclideness integral (eq. 2.1) and length. Thesis §2.5.1.1; Ohtake, Belyaev & Seidel 2004, \
        Yoshizawa, Belyaev & Seidel 2005.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the surface"),
            Port::of::<CurvatureField>(
                "curvature",
                "principal curvatures, directions, extremality",
            ),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>(
                "network",
                "ridges and ravines (labelled), arcs and loops",
            ),
            Port::of::<Report>("report", "curve counts, lengths, filtered counts"),
        ]
    }
    fn run(params: &TraceParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let field = inputs.get::<CurvatureField>("curvature")?;
        ctx.check_cancelled()?;
        let out = trace(mesh, field, params, ctx.par)
            .map_err(|e| NodeError::from_source(crestflow_flow::ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new()
            .with("network", out.network)
            .with("report", out.stats.to_report()))
    }
}
