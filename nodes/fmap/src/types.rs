//! Port types of the `fmap` family and its error type.

use serde::{Deserialize, Serialize};

/// Corresponding vertex pairs (source vertex, target vertex), as read from a file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LandmarkPairs {
    /// `(source vertex, target vertex)`, 0-based.
    pub pairs: Vec<[u32; 2]>,
    /// The 1-based line of the file each pair came from (for error messages).
    pub lines: Vec<usize>,
    /// Where the pairs came from (file name), for error messages.
    pub origin: String,
}

/// A functional map `C` (k₂ × k₁) between the unit-area-normalised Laplace–Beltrami bases of
/// the source (k₁ functions) and the target (k₂ functions): the coefficients `a` of a function
/// on the source map to `C a` on the target.
///
/// Normalisation: each basis is taken on the mesh scaled to unit area (`φ' = √A φ`,
/// `λ' = A λ`, `M' = M / A`), so that maps between shapes of different sizes are comparable.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FunctionalMap {
    /// Number of source basis functions (columns).
    pub k_source: usize,
    /// Number of target basis functions (rows).
    pub k_target: usize,
    /// The matrix, column-major (`matrix[j·k_target + i] = C[i][j]`).
    pub matrix: Vec<f64>,
    /// Value of the objective at the solution.
    pub energy: f64,
    /// Solver iterations (0 for direct solves).
    pub iterations: usize,
}

impl FunctionalMap {
    /// Entry `C[i][j]`.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.matrix[j * self.k_target + i]
    }
}

/// A point-to-point map: every target vertex is sent to a source vertex.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PointMap {
    /// `target_to_source[y]` is the source vertex matched to target vertex `y`.
    pub target_to_source: Vec<u32>,
    /// Number of source vertices.
    pub n_source: usize,
}

/// Per-vertex RGB colours in [0, 1] on the source and, transferred, on the target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VertexColors {
    pub source: Vec<[f64; 3]>,
    pub target: Vec<[f64; 3]>,
}

/// Errors of the `fmap` family. Every variant names the element at fault.
#[derive(Debug, thiserror::Error)]
pub enum FmapError {
    #[error("cannot read {path}: {message}")]
    Io { path: String, message: String },
    #[error("{origin}:{line}: {message}")]
    Parse {
        origin: String,
        line: usize,
        message: String,
    },
    #[error("{origin} holds no landmark pairs")]
    NoLandmarks { origin: String },
    #[error(
        "{origin}:{line}: {side} vertex {vertex} is out of range: the {side} mesh has \
         {n_vertices} vertices"
    )]
    LandmarkOutOfRange {
        origin: String,
        line: usize,
        side: &'static str,
        vertex: u32,
        n_vertices: usize,
    },
    #[error("curve pair {pair} names landmark {index} but there are only {count} landmarks")]
    PairOutOfRange {
        pair: usize,
        index: u32,
        count: usize,
    },
    #[error("{what} asks for {asked} curves but only {available} are available")]
    TooManyCurves {
        what: &'static str,
        asked: usize,
        available: usize,
    },
    #[error("no path joins vertex {from} and vertex {to}: they lie on different components")]
    Disconnected { from: u32, to: u32 },
    #[error("the source network has {source_count} curves but the target network has {target}")]
    CurveCountMismatch { source_count: usize, target: usize },
    #[error("curve {curve} of the {side} network is empty or has no length")]
    DegenerateCurve { side: &'static str, curve: usize },
    #[error(
        "curve {curve} of the {side} network references mesh vertex {vertex}, but the mesh has \
         {n_vertices} vertices"
    )]
    CurveVertexOutOfRange {
        side: &'static str,
        curve: usize,
        vertex: u32,
        n_vertices: usize,
    },
    #[error("curve {curve} of the {side} network has a point that is not on the mesh")]
    CurveNotOnMesh { side: &'static str, curve: usize },
    #[error("the {side} eigenbasis has {have} functions but k = {asked} is asked")]
    BasisTooSmall {
        side: &'static str,
        have: usize,
        asked: usize,
    },
    #[error("the {side} eigenbasis has {basis} rows but the {side} mesh has {mesh} vertices")]
    BasisMeshMismatch {
        side: &'static str,
        basis: usize,
        mesh: usize,
    },
    #[error("the {side} eigenbasis has zero total mass")]
    ZeroArea { side: &'static str },
    #[error(
        "the functional map is {rows}×{cols} but the bases give {k_target} target and \
         {k_source} source functions"
    )]
    MapSizeMismatch {
        rows: usize,
        cols: usize,
        k_target: usize,
        k_source: usize,
    },
    #[error("the point map covers {have} target vertices but the target mesh has {want}")]
    PointMapSize { have: usize, want: usize },
    #[error("the point map sends target vertex {target} to source vertex {source_vertex}, but the source has {n_source} vertices")]
    PointMapOutOfRange {
        target: usize,
        source_vertex: u32,
        n_source: usize,
    },
    #[error("the ground truth covers {have} target vertices but the point map covers {want}")]
    GroundTruthSize { have: usize, want: usize },
    #[error("{origin}:{line}: ground-truth source vertex {vertex} is out of range (the source has {n_source} vertices)")]
    GroundTruthOutOfRange {
        origin: String,
        line: usize,
        vertex: u32,
        n_source: usize,
    },
    #[error("the dense system for column {column} is not positive definite")]
    NotPositiveDefinite { column: usize },
    #[error("invalid parameter {field}: {message}")]
    Param {
        field: &'static str,
        message: String,
    },
    #[error("geodesic distances failed: {0}")]
    Heat(String),
    #[error("render failed: {0}")]
    Render(String),
    #[error("cancelled")]
    Cancelled,
}

impl FmapError {
    /// The engine's error kind for this error.
    pub fn kind(&self) -> crestflow_flow::ErrorKind {
        use crestflow_flow::ErrorKind;
        match self {
            FmapError::NotPositiveDefinite { .. } | FmapError::Heat(_) => {
                ErrorKind::NumericalFailure
            }
            FmapError::Cancelled => ErrorKind::Cancelled,
            _ => ErrorKind::InvalidInput,
        }
    }
    /// As a node error.
    pub fn into_node(self) -> crestflow_flow::NodeError {
        crestflow_flow::NodeError::from_source(self.kind(), self)
    }
}
