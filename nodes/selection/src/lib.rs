//! crestflow node family `selection`: meaningful feature curve networks from reoccurrence
//! (thesis §4.2, after Gehre, Lim & Kobbelt 2018).
//!
//! - `selection.model` ([`model`]): FCN + transformation clusters (+ orbits) →
//!   [`SelectedModel`]: Bayesian model selection of the transformations that explain the
//!   curves (§4.2.2, eq. 4.1, heuristic §4.2.2.1), each curve's assignment, log-likelihoods
//!   and Bayes ratios, and a Report.
//! - `selection.complete` ([`mod@complete`]): FCN + [`SelectedModel`] → completed FCN, templates,
//!   components and a Report (§4.2.3: noise removal, connected components, consolidation by
//!   longest shortest paths, grid origins, gaps, template copies).
//!
//! Lengths in parameters are multiples of the mesh's mean edge length, as in the thesis.

use crestflow_flow::Registry;

pub mod complete;
pub mod consolidate;
pub mod curves;
pub mod model;

#[cfg(test)]
mod complete_test;
#[cfg(test)]
mod model_test;

pub use complete::{
    complete, completion_report, CompleteError, CompleteNode, CompleteParams, Completion, Template,
};
pub use curves::Iso;
pub use model::{
    model_report, select_model, Candidate, ModelError, ModelNode, ModelParams, Partner,
    RemovalStep, SelectedModel,
};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<ModelNode>();
    registry.add::<CompleteNode>();
}
