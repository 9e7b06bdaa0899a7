//! `scale.check`: verifies that a feature curve network is scale conforming (thesis §4.3.2) and
//! counts each kind of violation:
//!
//! - `short_edges`, `long_edges`: edge lengths outside S = [r_min, r_max]; with
//!   `special_long_edges: true`, an arc of one edge between r_max and 2 r_min (thesis
//!   §4.3.3.2: no resampling into S can hold it) is counted as `special_long_edges` instead,
//!   and is no violation;
//! - `angle_violations`: two edges at a vertex whose angle is outside the representable
//!   intervals ∪_k [k θ_min, k θ_max] (§4.3.2.1), including edges joined by a short edge;
//! - `proximity_violations`: non-adjacent edges closer than r_min for which no triangulation
//!   (c) or (d) of Fig. 4.9 has all edges at least r_min long;
//! - `vertex_conflicts`: extraordinary vertices (valence 1 or ≥ 3) closer than r_min.
//!
//! The predicates are those of [`crate::conflicts`], shared with `scale.conform`. The network
//! is checked as given: coincident vertices are not welded.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Report, Validate,
};
use crestflow_geom::vec3;
use crestflow_geom::{FeatureCurveNetwork, TriMesh};

use crate::conflicts::{find_conflicts, ConflictKind, Scale};
use crate::conform::{absolute_scale, special_long_edges, ScaleError};
use crate::network::Graph;

/// Parameters of `scale.check`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CheckParams {
    /// r_min, relative to the bounding-box diagonal when `relative` (default 0.01).
    pub scale: f64,
    /// Default true.
    pub relative: bool,
    /// r_max / r_min, in [1.05, 4] (default 1.5).
    pub aspect: f64,
    /// Fail the node when there is a violation (default false: only report).
    pub fail_on_violation: bool,
    /// Accept special long edges (as `scale.conform` with the same parameter; default false).
    pub special_long_edges: bool,
}

impl Default for CheckParams {
    fn default() -> Self {
        CheckParams {
            scale: 0.01,
            relative: true,
            aspect: 1.5,
            fail_on_violation: false,
            special_long_edges: false,
        }
    }
}

impl Validate for CheckParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "scale", self.scale, 1e-12, 1e12);
        check_range(&mut v, "aspect", self.aspect, 1.05, 4.0);
        v
    }
}

/// Violations found by [`check`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CheckResult {
    pub r_min: f64,
    pub r_max: f64,
    pub edges: usize,
    pub curves: usize,
    pub short_edges: usize,
    /// Edges longer than r_max, other than special long edges.
    pub long_edges: usize,
    /// Arcs of one edge between r_max and 2 r_min (thesis §4.3.3.2: no resampling into S
    /// exists); not violations.
    pub special_long_edges: usize,
    pub angle_violations: usize,
    pub proximity_violations: usize,
    pub vertex_conflicts: usize,
    /// Non-adjacent pairs closer than r_min that a configuration (c)/(d) resolves (no
    /// violation; for information).
    pub near_pairs_resolved: usize,
    /// Shortest and longest edge relative to r_min.
    pub min_length_rel: f64,
    pub max_length_rel: f64,
}

impl CheckResult {
    pub fn violations(&self) -> usize {
        self.short_edges
            + self.long_edges
            + self.angle_violations
            + self.proximity_violations
            + self.vertex_conflicts
    }
    pub fn summary(&self) -> String {
        format!(
            "{} violations: {} short edges, {} long edges, {} angle violations, {} proximity \
             violations, {} vertex conflicts (r_min {}, r_max {})",
            self.violations(),
            self.short_edges,
            self.long_edges,
            self.angle_violations,
            self.proximity_violations,
            self.vertex_conflicts,
            self.r_min,
            self.r_max
        )
    }
    pub fn to_report(&self) -> Report {
        let mut r = Report::new();
        r.set("violations", self.violations())
            .set("passed", (self.violations() == 0) as usize)
            .set("r_min", self.r_min)
            .set("r_max", self.r_max)
            .set("edges", self.edges)
            .set("curves", self.curves)
            .set("short_edges", self.short_edges)
            .set("long_edges", self.long_edges)
            .set("special_long_edges", self.special_long_edges)
            .set("angle_violations", self.angle_violations)
            .set("proximity_violations", self.proximity_violations)
            .set("vertex_conflicts", self.vertex_conflicts)
            .set("near_pairs_resolved", self.near_pairs_resolved)
            .set("min_length_rel", self.min_length_rel)
            .set("max_length_rel", self.max_length_rel);
        r
    }
}

/// Checks `net` at the absolute scale `r_min` with `aspect` = r_max / r_min.
pub fn check_absolute(
    net: &FeatureCurveNetwork,
    r_min: f64,
    aspect: f64,
    par: Par,
) -> Result<CheckResult, ScaleError> {
    check_at(net, &Scale::new(r_min, aspect), par)
}

/// Checks `net` at scale `s` (absolute; special long edges accepted when `s` allows them).
pub fn check_at(net: &FeatureCurveNetwork, s: &Scale, par: Par) -> Result<CheckResult, ScaleError> {
    let r_min = s.r_min;
    let g = Graph::from_network(net, false)?;
    let conf = find_conflicts(s, &g.pos, &g.edges, par);
    let mut r = CheckResult {
        r_min: s.r_min,
        r_max: s.r_max,
        edges: g.edges.len(),
        curves: net.curves.len(),
        min_length_rel: f64::INFINITY,
        max_length_rel: 0.0,
        ..Default::default()
    };
    let special = special_long_edges(&g, s);
    for (e, &[a, b]) in g.edges.iter().enumerate() {
        let l = vec3::dist(g.pos[a as usize], g.pos[b as usize]);
        r.short_edges += s.is_short(l) as usize;
        r.long_edges += (s.is_long(l) && !special[e]) as usize;
        r.special_long_edges += special[e] as usize;
        r.min_length_rel = r.min_length_rel.min(l / r_min);
        r.max_length_rel = r.max_length_rel.max(l / r_min);
    }
    if g.edges.is_empty() {
        r.min_length_rel = 0.0;
    }
    for &(_, _, k) in &conf.edge_pairs {
        match k {
            ConflictKind::Angle | ConflictKind::AngleAcrossShort => r.angle_violations += 1,
            ConflictKind::Proximity => r.proximity_violations += 1,
        }
    }
    r.vertex_conflicts = conf.vertex_pairs.len();
    r.near_pairs_resolved = conf.near_resolved;
    Ok(r)
}

/// Checks `net` on `mesh` at the scale of `params`.
pub fn check(
    net: &FeatureCurveNetwork,
    mesh: &TriMesh,
    params: &CheckParams,
    par: Par,
) -> Result<CheckResult, ScaleError> {
    if let Some(i) = params.validate().first() {
        return Err(ScaleError::Params(format!("{}: {}", i.field, i.message)));
    }
    let r_min = absolute_scale(mesh, params.scale, params.relative)?;
    let s = Scale::new(r_min, params.aspect).with_special_long(params.special_long_edges);
    let r = check_at(net, &s, par)?;
    if params.fail_on_violation && r.violations() > 0 {
        return Err(ScaleError::NotConforming(r.summary()));
    }
    Ok(r)
}

/// The `scale.check` node.
pub struct CheckNode;

impl NodeKind for CheckNode {
    type Params = CheckParams;
    const KIND: &'static str = "scale.check";
    const VERSION: u32 = 2;
    const DOC: &'static str = "Verifies that a feature curve network is scale conforming: edge \
        lengths in [r_min, r_max], representable angles between adjacent edges, no non-adjacent \
        edges closer than r_min without a valid triangulation, no extraordinary vertices closer \
        than r_min; reports each kind of violation and passes the network on. Thesis §4.3.2.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>("curves", "the network to check"),
            Port::of::<TriMesh>("mesh", "the mesh it lies on (sets the relative scale)"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>("network", "the input network, unchanged"),
            Port::of::<Report>(
                "report",
                "violation counts (violations = 0 when conforming)",
            ),
        ]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let net = inputs.get::<FeatureCurveNetwork>("curves")?;
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let r =
            check(net, mesh, params, ctx.par).map_err(|e| NodeError::from_source(e.kind(), e))?;
        Ok(Outputs::new()
            .with("network", net.clone())
            .with("report", r.to_report()))
    }
}
