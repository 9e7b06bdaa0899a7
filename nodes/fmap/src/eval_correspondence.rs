//! `eval.correspondence`: the geodesic error of a point map against a ground-truth map, by
//! the Princeton protocol (Kim, Lipman, Funkhouser 2011; thesis §5.2.6.2).
//!
//! For each query target vertex y with ground-truth source vertex g(y) and predicted source
//! vertex T(y), the error is the geodesic distance on the source mesh between T(y) and g(y),
//! divided by √(source area). Reported: the mean, the median, the fraction mapped exactly, the
//! cumulative fraction of queries with error ≤ r at r = 0.025, 0.05, 0.1, 0.25, and the whole
//! cumulative curve at r = 0, 0.01, …, 0.25 (`curve`, comma-separated) with its mean (`auc`).
//!
//! Geodesics: one heat-method distance field (Crane et al. 2013, `nodes/geodesic`) per
//! distinct ground-truth vertex, solved in blocks of right-hand sides on one factorisation;
//! no n × n matrix is ever formed. `max_queries` evaluates an evenly strided subset. The
//! fields depend only on the ground truth, so a second map (`compare`, e.g. a baseline) is
//! measured on the same fields at the cost of a lookup.
//!
//! Ground truth: a text file whose line j (0-based, non-empty lines) is the source vertex of
//! target vertex j (`pyfm_lion2cat.txt` format), or the identity when no file is given.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Report, Validate,
};
use crestflow_geom::TriMesh;
use crestflow_nodes_geodesic::{HeatSolver, HeatSource};

use crate::transfer::check_point_map;
use crate::types::{FmapError, PointMap};

/// Sources per block of heat solves.
const HEAT_BLOCK: usize = 32;

/// Parameters of `eval.correspondence`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvalCorrespondenceParams {
    /// Ground-truth file (line j: source vertex of target vertex j), relative to the pipeline
    /// file; empty (default): the identity.
    pub ground_truth: PathBuf,
    /// Evaluate at most this many target vertices, evenly strided (default 0: all).
    pub max_queries: usize,
    /// Prefix of the report names (default empty).
    pub label: String,
    /// Prefix of the report names of the optional `compare` map (default "compare").
    pub compare_label: String,
    /// Heat method time factor m in t = m h² (default 1, range 1e-3..=1e3).
    pub time_factor: f64,
}

impl Default for EvalCorrespondenceParams {
    fn default() -> Self {
        EvalCorrespondenceParams {
            ground_truth: PathBuf::new(),
            max_queries: 0,
            label: String::new(),
            compare_label: "compare".into(),
            time_factor: 1.0,
        }
    }
}

impl Validate for EvalCorrespondenceParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "time_factor", self.time_factor, 1e-3, 1e3);
        issues
    }
}

/// Errors of [`evaluate_correspondence`] (an alias: all family errors are [`FmapError`]).
pub type CorrespondenceError = FmapError;

/// Parses a ground-truth map (one source vertex per non-empty line).
pub fn parse_ground_truth(
    text: &str,
    origin: &str,
    n_source: usize,
) -> Result<Vec<u32>, FmapError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let s = raw.trim();
        if s.is_empty() || s.starts_with('#') {
            continue;
        }
        let v: u32 = s.parse().map_err(|_| FmapError::Parse {
            origin: origin.to_string(),
            line: i + 1,
            message: format!("`{s}` is not a vertex index"),
        })?;
        if v as usize >= n_source {
            return Err(FmapError::GroundTruthOutOfRange {
                origin: origin.to_string(),
                line: i + 1,
                vertex: v,
                n_source,
            });
        }
        out.push(v);
    }
    Ok(out)
}

/// Reads a ground-truth file.
pub fn read_ground_truth(path: &Path, n_source: usize) -> Result<Vec<u32>, FmapError> {
    let text = crestflow_geom::io::read_text_file(path).map_err(|e| FmapError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    parse_ground_truth(&text, &name, n_source)
}

/// Thresholds of the cumulative curve.
pub fn curve_thresholds() -> Vec<f64> {
    (0..=25).map(|i| i as f64 * 0.01).collect()
}

/// Normalised geodesic errors per query of each point map (all of one target size), with
/// the query target vertices. The distance fields depend only on the ground truth, so every
/// map is measured on the same fields.
pub fn geodesic_errors(
    source_mesh: &TriMesh,
    maps: &[&PointMap],
    ground_truth: &[u32],
    max_queries: usize,
    time_factor: f64,
    par: Par,
    cancel: &dyn Fn() -> bool,
) -> Result<(Vec<usize>, Vec<Vec<f64>>), FmapError> {
    let n1 = source_mesh.n_vertices();
    let n2 = maps.first().map_or(0, |m| m.target_to_source.len());
    for points in maps {
        check_point_map(points, n1, n2)?;
    }
    if ground_truth.len() != n2 {
        return Err(FmapError::GroundTruthSize {
            have: ground_truth.len(),
            want: n2,
        });
    }
    let queries: Vec<usize> = if max_queries == 0 || max_queries >= n2 {
        (0..n2).collect()
    } else {
        (0..max_queries).map(|i| i * n2 / max_queries).collect()
    };
    let mut sources: Vec<u32> = queries.iter().map(|&y| ground_truth[y]).collect();
    sources.sort_unstable();
    sources.dedup();
    let solver = HeatSolver::new(source_mesh, time_factor, par)
        .map_err(|e| FmapError::Heat(e.to_string()))?;
    let scale = 1.0 / source_mesh.total_area().sqrt();
    // Queries by ground-truth vertex.
    let mut by_source: Vec<Vec<usize>> = vec![Vec::new(); sources.len()];
    for (qi, &y) in queries.iter().enumerate() {
        let s = sources.binary_search(&ground_truth[y]).unwrap_or(0);
        by_source[s].push(qi);
    }
    let mut errors = vec![vec![0.0; queries.len()]; maps.len()];
    for (block, chunk) in sources.chunks(HEAT_BLOCK).enumerate() {
        if cancel() {
            return Err(FmapError::Cancelled);
        }
        let srcs: Vec<HeatSource> = chunk.iter().map(|&v| HeatSource::vertices(&[v])).collect();
        let fields = solver
            .distances(&srcs, par)
            .map_err(|e| FmapError::Heat(e.to_string()))?;
        for (i, f) in fields.iter().enumerate() {
            let s = block * HEAT_BLOCK + i;
            for (points, errors) in maps.iter().zip(errors.iter_mut()) {
                for &qi in &by_source[s] {
                    let y = queries[qi];
                    let p = points.target_to_source[y] as usize;
                    let d = if p == sources[s] as usize {
                        0.0
                    } else {
                        f.values[p].max(0.0)
                    };
                    errors[qi] = d * scale;
                }
            }
        }
    }
    Ok((queries, errors))
}

/// Summary of normalised errors as a report (names prefixed by `label.` when not empty).
pub fn summarize(errors: &[f64], exact: usize, label: &str) -> Report {
    let name = |s: &str| {
        if label.is_empty() {
            s.to_string()
        } else {
            format!("{label}.{s}")
        }
    };
    let n = errors.len().max(1) as f64;
    let mut sorted = errors.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mean = errors.iter().sum::<f64>() / n;
    let median = if sorted.is_empty() {
        0.0
    } else {
        sorted[sorted.len() / 2]
    };
    let frac = |r: f64| errors.iter().filter(|&&e| e <= r + 1e-12).count() as f64 / n;
    let curve: Vec<f64> = curve_thresholds().iter().map(|&r| frac(r)).collect();
    let auc = curve.iter().sum::<f64>() / curve.len() as f64;
    let mut r = Report::new();
    r.set(name("mean"), mean)
        .set(name("median"), median)
        .set(name("exact"), exact as f64 / n)
        .set(name("queries"), errors.len())
        .set(name("cum_0.025"), frac(0.025))
        .set(name("cum_0.05"), frac(0.05))
        .set(name("cum_0.1"), frac(0.1))
        .set(name("cum_0.25"), frac(0.25))
        .set(name("auc"), auc)
        .set(
            name("curve"),
            curve
                .iter()
                .map(|v| format!("{v:.4}"))
                .collect::<Vec<_>>()
                .join(","),
        );
    r
}

/// Evaluates `points` against `ground_truth` (identity when `None`).
pub fn evaluate_correspondence(
    source_mesh: &TriMesh,
    points: &PointMap,
    ground_truth: Option<&[u32]>,
    params: &EvalCorrespondenceParams,
    par: Par,
    cancel: &dyn Fn() -> bool,
) -> Result<Report, FmapError> {
    evaluate_correspondences(
        source_mesh,
        &[(points, params.label.as_str())],
        ground_truth,
        params,
        par,
        cancel,
    )
}

/// Evaluates several point maps (each with its report label) against one ground truth
/// (identity when `None`), on one set of distance fields: the report holds the figures of
/// each map under its label, equal to those of separate evaluations.
pub fn evaluate_correspondences(
    source_mesh: &TriMesh,
    maps: &[(&PointMap, &str)],
    ground_truth: Option<&[u32]>,
    params: &EvalCorrespondenceParams,
    par: Par,
    cancel: &dyn Fn() -> bool,
) -> Result<Report, FmapError> {
    let n2 = maps.first().map_or(0, |(m, _)| m.target_to_source.len());
    let identity: Vec<u32>;
    let gt = match ground_truth {
        Some(g) => g,
        None => {
            if n2 > source_mesh.n_vertices() {
                return Err(FmapError::Param {
                    field: "ground_truth",
                    message: format!(
                        "the identity needs at least {n2} source vertices, the source has {}",
                        source_mesh.n_vertices()
                    ),
                });
            }
            identity = (0..n2 as u32).collect();
            &identity
        }
    };
    let points: Vec<&PointMap> = maps.iter().map(|(m, _)| *m).collect();
    let (queries, errors) = geodesic_errors(
        source_mesh,
        &points,
        gt,
        params.max_queries,
        params.time_factor,
        par,
        cancel,
    )?;
    let mut report = Report::new();
    for ((pm, label), errors) in maps.iter().zip(&errors) {
        let exact = queries
            .iter()
            .filter(|&&y| pm.target_to_source[y] == gt[y])
            .count();
        report.values.extend(summarize(errors, exact, label).values);
    }
    Ok(report)
}

/// Node wrapper of [`evaluate_correspondence`].
pub struct EvalCorrespondenceNode;

impl NodeKind for EvalCorrespondenceNode {
    type Params = EvalCorrespondenceParams;
    const KIND: &'static str = "eval.correspondence";
    const VERSION: u32 = 2;
    const DOC: &'static str = "Geodesic error of a point map against a ground-truth map \
        (Princeton protocol: distance on the source mesh by the heat method, normalised by \
        √area; mean, median, cumulative curve up to 0.25). Values are prefixed by `label.`; an \
        optional `compare` map (e.g. a baseline) is measured on the same distance fields, its \
        values prefixed by `compare_label.`; a `previous` report is extended.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("source_mesh", "the mesh errors are measured on"),
            Port::of::<PointMap>("points", "target vertex → source vertex"),
            Port::optional::<PointMap>(
                "compare",
                "a second point map, measured on the same distance fields",
            ),
            Port::optional::<Report>("previous", "a report to extend"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<Report>("report", "error statistics")]
    }
    fn input_files(params: &Self::Params) -> Vec<PathBuf> {
        if params.ground_truth.as_os_str().is_empty() {
            Vec::new()
        } else {
            vec![params.ground_truth.clone()]
        }
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("source_mesh")?;
        let pm = inputs.get::<PointMap>("points")?;
        let gt = if params.ground_truth.as_os_str().is_empty() {
            None
        } else {
            Some(
                read_ground_truth(&ctx.resolve(&params.ground_truth), mesh.n_vertices())
                    .map_err(FmapError::into_node)?,
            )
        };
        let cancel = || ctx.cancel.is_cancelled();
        let mut maps = vec![(pm, params.label.as_str())];
        if let Some(other) = inputs.opt::<PointMap>("compare")? {
            if params.compare_label == params.label {
                return Err(FmapError::Param {
                    field: "compare_label",
                    message: format!(
                        "must differ from `label` ({:?}) when a `compare` map is given: the two \
                         maps' figures would share names",
                        params.label
                    ),
                }
                .into_node());
            }
            maps.push((other, params.compare_label.as_str()));
        }
        let mut r = evaluate_correspondences(mesh, &maps, gt.as_deref(), params, ctx.par, &cancel)
            .map_err(FmapError::into_node)?;
        if let Some(prev) = inputs.opt::<Report>("previous")? {
            let mut merged = prev.clone();
            merged.values.extend(r.values);
            r = merged;
        }
        Ok(Outputs::new().with("report", r))
    }
}

#[cfg(test)]
#[path = "eval_correspondence_test.rs"]
mod tests;
