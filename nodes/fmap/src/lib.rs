//! crestflow node family `fmap`: functional maps between two shapes (thesis §2.6.3 and §5.2).
//!
//! - `fmap.landmarks` ([`landmarks`]): corresponding vertex pairs read from a text file.
//! - `curves.shortest_path` ([`shortest_path`]): corresponding curves between landmark pairs,
//!   traced by Dijkstra along mesh edges (thesis §5.2.2).
//! - `fmap.curve_constrained` ([`mod@curve_constrained`]): the curve-constrained functional map of
//!   eq. 5.5, solved by conjugate gradients on precomputed k×k terms (Algorithms 5.1, 5.2).
//! - `fmap.descriptor` ([`descriptor`]): the descriptor-preservation baseline (eq. 2.7 + 2.8)
//!   with heat or wave kernel signatures.
//! - `fmap.point_map` ([`mod@point_map`]): nearest neighbours in the spectral embedding, with an
//!   optional ZoomOut refinement; `fmap.save_point_map` writes it as text.
//! - `fmap.transfer` ([`mod@transfer`]) and `fmap.render_colors` ([`render_colors`]): a colour
//!   field carried from source to target and drawn as a PNG (thesis Fig. 5.6–5.9).
//! - `eval.correspondence` ([`eval_correspondence`]): geodesic error of a point map against a
//!   ground truth (Princeton protocol, Kim, Lipman, Funkhouser 2011).
//!
//! Conventions: the source shape is M₁, the target M₂. A functional map `C` (k₂ × k₁) takes the
//! spectral coefficients of a function on the source to those of its image on the target. A
//! point map sends every *target* vertex to a *source* vertex (the pull-back that induces `C`).

use crestflow_flow::Registry;

pub mod curve_constrained;
pub mod dense;
pub mod descriptor;
pub mod eval_correspondence;
pub mod landmarks;
pub mod point_map;
pub mod render_colors;
pub mod shortest_path;
pub mod transfer;
pub mod types;

pub use curve_constrained::{
    curve_constrained, CurveConstrainedNode, CurveConstrainedParams, CurveMapSolver,
};
pub use descriptor::{descriptor_map, DescriptorKind, DescriptorMapNode, DescriptorMapParams};
pub use eval_correspondence::{
    evaluate_correspondence, CorrespondenceError, EvalCorrespondenceNode, EvalCorrespondenceParams,
};
pub use landmarks::{
    farthest_point_landmarks, parse_landmarks, read_landmarks, LandmarksNode, LandmarksParams,
};
pub use point_map::{
    nearest_neighbors, point_map, write_point_map, zoomout, PointMapNode, PointMapParams,
    SavePointMapNode, SavePointMapParams,
};
pub use render_colors::{RenderColorsNode, RenderColorsParams};
pub use shortest_path::{shortest_paths, ShortestPathNode, ShortestPathParams, Side};
pub use transfer::{transfer, TransferNode, TransferParams};
pub use types::{FmapError, FunctionalMap, LandmarkPairs, PointMap, VertexColors};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<LandmarksNode>();
    registry.add::<ShortestPathNode>();
    registry.add::<CurveConstrainedNode>();
    registry.add::<DescriptorMapNode>();
    registry.add::<PointMapNode>();
    registry.add::<SavePointMapNode>();
    registry.add::<TransferNode>();
    registry.add::<RenderColorsNode>();
    registry.add::<EvalCorrespondenceNode>();
}
