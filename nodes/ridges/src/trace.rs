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
//!    by the cyclideness integral of eq. 2.1 (§2.1.2, YBS05) and by the length of the
//!    supporting curve (§4.1); arcs that become joined once a branch between them is removed
//!    are merged and measured again.
//!
//! Thresholds are scale-free: strength in multiples of the median max(|k_max|, |k_min|) of the
//! mesh's vertices, length in multiples of the mean edge length; the cyclideness integral
//! T = l ∫ sqrt(e_max² + e_min²) ds is dimensionless already.

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Report, Validate,
};
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{
    CurvatureField, CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, MeshDefect, TriMesh,
};
use serde::{Deserialize, Serialize};

use crate::crossing::{edge_crossings, Definition, Family};
use crate::network::{extract_arcs, join_gaps, segment_graph, Arc, SegmentGraph};

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
    /// Keep arcs whose supporting curve (the arc extended through junctions by its straightest
    /// continuation, §4.1) is at least this long, in multiples of the mean edge length.
    /// In [0, 1e6]. Default 3.
    pub min_length: f64,
    /// Join curve ends closer than this (in multiples of the mean edge length) when both
    /// curves head towards each other within 45° (YBS05's local reconnection of fragments).
    /// 0 turns it off. In [0, 100]. Default 2.
    pub join_gap: f64,
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
            join_gap: 2.0,
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
        check_range(&mut v, "join_gap", self.join_gap, 0.0, 100.0);
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
    /// Gaps between fragments closed by `join_gap`.
    pub joined: usize,
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
            .set("joined", self.joined)
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
        let mut graph = segment_graph(mesh, field, family, params.definition, &crossings, par);
        stats.trisectors += graph.trisectors;
        stats.joined += join_gaps(&mut graph, params.join_gap * stats.mean_edge_length);
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
    mesh.check_data().map_err(|d| match d {
        MeshDefect::NonFinitePosition { vertex, position } => {
            TraceError::NonFinitePosition { vertex, position }
        }
        MeshDefect::IndexOutOfRange {
            face,
            index,
            n_vertices,
        } => TraceError::FaceIndex {
            face,
            index,
            n_vertices,
        },
    })?;
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
/// the others merge) and repeats until every arc passes. Strength and cyclideness are measured
/// per arc; length is the supporting-curve length of §4.1 ([`supporting_lengths`]) among the
/// arcs that pass the other two filters.
fn filter_arcs(graph: &SegmentGraph, params: &TraceParams, stats: &mut TraceStats) -> Vec<Arc> {
    let min_strength = params.min_strength * stats.curvature_scale;
    let min_length = params.min_length * stats.mean_edge_length;
    let mut alive = vec![true; graph.edges.len()];
    loop {
        let arcs = extract_arcs(graph.nodes.len(), &graph.edges, &alive);
        let measures: Vec<ArcMeasure> = arcs.iter().map(|a| measure(graph, a)).collect();
        let mut keep = vec![true; arcs.len()];
        for (i, m) in measures.iter().enumerate() {
            if m.strength < min_strength {
                stats.removed_weak += 1;
                keep[i] = false;
            } else if m.cyclideness < params.min_cyclideness {
                stats.removed_cyclide += 1;
                keep[i] = false;
            }
        }
        let support = supporting_lengths(graph, &arcs, &measures, &keep);
        for i in 0..arcs.len() {
            if keep[i] && support[i] < min_length {
                stats.removed_short += 1;
                keep[i] = false;
            }
        }
        if keep.iter().all(|&k| k) {
            return arcs;
        }
        for (arc, _) in arcs.iter().zip(&keep).filter(|(_, &k)| !k) {
            for &e in &arc.edges {
                alive[e as usize] = false;
            }
        }
    }
}

/// The length of the feature curve each arc belongs to (thesis §4.1, "Length"): the arc, extended
/// at each end through junctions by the arc that continues it most straightly (turning by less
/// than 45°), then that arc's far end likewise, until no arc continues or one would repeat.
/// Only arcs with `keep` take part.
fn supporting_lengths(
    graph: &SegmentGraph,
    arcs: &[Arc],
    measures: &[ArcMeasure],
    keep: &[bool],
) -> Vec<f64> {
    // Arc ends at each junction node: (arc, end) with end 0 = first node, 1 = last node.
    let mut ends: std::collections::BTreeMap<u32, Vec<(usize, usize)>> = Default::default();
    for (i, arc) in arcs.iter().enumerate() {
        if arc.closed || !keep[i] {
            continue;
        }
        ends.entry(arc.nodes[0]).or_default().push((i, 0));
        ends.entry(arc.nodes[arc.nodes.len() - 1])
            .or_default()
            .push((i, 1));
    }
    // Unit direction leaving the node at `end` into the arc, over a few segments for stability.
    let leave = |i: usize, end: usize| {
        let n = &arcs[i].nodes;
        let k = 3.min(n.len() - 1);
        let (from, to) = if end == 0 {
            (n[0], n[k])
        } else {
            (n[n.len() - 1], n[n.len() - 1 - k])
        };
        vec3::normalize(vec3::sub(
            graph.nodes[to as usize].position,
            graph.nodes[from as usize].position,
        ))
    };
    let cos_max_turn = std::f64::consts::FRAC_1_SQRT_2;
    (0..arcs.len())
        .map(|i| {
            if !keep[i] || arcs[i].closed {
                return measures[i].length;
            }
            let mut total = measures[i].length;
            let mut used = vec![i];
            for start_end in [0, 1] {
                let (mut cur, mut end) = (i, start_end);
                loop {
                    let node = if end == 0 {
                        arcs[cur].nodes[0]
                    } else {
                        *arcs[cur].nodes.last().unwrap_or(&0)
                    };
                    let Some(cands) = ends.get(&node) else { break };
                    if cands.len() < 2 {
                        break;
                    }
                    // Continuing straight: leaving `cur` backwards ≈ leaving the next arc.
                    let incoming = vec3::scale(leave(cur, end), -1.0);
                    let best = cands
                        .iter()
                        .filter(|(j, _)| !used.contains(j))
                        .map(|&(j, e)| (vec3::dot(incoming, leave(j, e)), j, e))
                        .filter(|&(c, _, _)| c >= cos_max_turn)
                        .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
                    let Some((_, j, e)) = best else { break };
                    total += measures[j].length;
                    used.push(j);
                    cur = j;
                    end = 1 - e;
                }
            }
            total
        })
        .collect()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::GraphNode;
    use crestflow_geom::SurfacePoint;

    fn node(x: f64, y: f64) -> GraphNode {
        GraphNode {
            position: [x, y, 0.0],
            location: SurfacePoint::Free,
            strength: 1.0,
            cyclideness: 1.0,
        }
    }

    /// A straight line x = −5..5 (nodes 0..=10, unit steps) with a junction at x = 0 (node 5)
    /// and a spur of length `spur_len` leaving it at 90° (node 11).
    fn line_with_spur(spur_len: f64) -> SegmentGraph {
        let mut nodes: Vec<GraphNode> = (0..=10).map(|i| node(i as f64 - 5.0, 0.0)).collect();
        nodes.push(node(0.0, spur_len));
        let mut edges: Vec<[u32; 2]> = (0..10).map(|i| [i, i + 1]).collect();
        edges.push([5, 11]);
        SegmentGraph {
            nodes,
            edges,
            trisectors: 0,
            end_faces: 0,
        }
    }

    fn filter(graph: &SegmentGraph, min_length: f64) -> (Vec<Arc>, TraceStats) {
        let params = TraceParams {
            min_strength: 0.0,
            min_cyclideness: 0.0,
            min_length,
            ..Default::default()
        };
        let mut stats = TraceStats {
            curvature_scale: 1.0,
            mean_edge_length: 1.0,
            ..Default::default()
        };
        let arcs = filter_arcs(graph, &params, &mut stats);
        (arcs, stats)
    }

    #[test]
    fn halves_of_a_long_curve_count_its_whole_length() {
        // Each half is 5 long, the curve through the junction 10: a threshold of 7 keeps the
        // line (merged into one arc once the spur is gone) and drops the spur.
        let (arcs, stats) = filter(&line_with_spur(1.0), 7.0);
        assert_eq!(stats.removed_short, 1);
        assert_eq!(arcs.len(), 1);
        assert_eq!(arcs[0].nodes, (0..=10).collect::<Vec<u32>>());
        // Above the whole length nothing is left.
        let (arcs, stats) = filter(&line_with_spur(1.0), 10.5);
        assert!(arcs.is_empty());
        assert_eq!(stats.removed_short, 3);
    }

    #[test]
    fn a_turn_beyond_45_degrees_does_not_extend() {
        // The spur is 4 long and leaves at 90°: its supporting length is its own, 4 < 4.5, while
        // the halves support each other (10).
        let (arcs, _) = filter(&line_with_spur(4.0), 4.5);
        assert_eq!(arcs.len(), 1);
        assert_eq!(arcs[0].nodes.len(), 11);
        // At 3.5 all three stay: three arcs meeting at the junction.
        let (arcs, _) = filter(&line_with_spur(4.0), 3.5);
        assert_eq!(arcs.len(), 3);
    }
}
