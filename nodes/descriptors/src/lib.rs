//! crestflow node family `descriptors`: feature-curve descriptors and curve correspondences
//! (thesis §3.1, Gehre et al. 2016).
//!
//! - `descriptors.curve_hks` ([`mod@curve_hks`]): heat kernel signature of a curve (§3.1.1).
//! - `descriptors.curve_gics` ([`mod@curve_gics`]): geodesic iso-curve signature (§3.1.2).
//! - `match.curves` ([`mod@match_curves`]): nearest and Hungarian matching of two networks'
//!   curves by descriptor distance (§3.1.4).
//! - `eval.curve_matching` ([`mod@curve_matching_eval`]): accuracy against ground truth and the
//!   ROC curve of thesis Fig. 3.6.
//!
//! [`descriptor`] holds the shared descriptor type and the distances of §3.1.1.1 and
//! §3.1.2.3.

use crestflow_flow::Registry;

pub mod curve_gics;
pub mod curve_hks;
pub mod curve_matching_eval;
pub mod descriptor;
pub mod match_curves;

pub use curve_gics::{curve_gics, CurveGicsNode, CurveGicsParams, GicsError, Sampling};
pub use curve_hks::{curve_hks, CurveHksNode, CurveHksParams, HksError};
pub use curve_matching_eval::{
    curve_matching_eval, CurveMatchingEvalNode, CurveMatchingEvalParams, EvalError,
};
pub use descriptor::{descriptor_distance, CurveDescriptor, CurveDescriptors, DescriptorKind};
pub use match_curves::{match_curves, CurveMatching, MatchCurvesNode, MatchCurvesParams};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<CurveHksNode>();
    registry.add::<CurveGicsNode>();
    registry.add::<MatchCurvesNode>();
    registry.add::<CurveMatchingEvalNode>();
}
