//! crestflow node family `scale`: feature curve networks adapted to a prescribed scale (thesis
//! §4.3; Gehre, Lim & Kobbelt 2016, "Adapting feature curve networks to a prescribed scale").
//!
//! - `scale.conform` ([`mod@conform`]): resampling, conflict detection, exact selection of the best
//!   conflict-free subset by a binary linear program ([`ilp`], good_lp with the pure-Rust
//!   microlp solver, or HiGHS in builds with the `highs` feature), short-edge collapses,
//!   iterated until stable (Fig. 4.7).
//! - `scale.check` ([`mod@check`]): counts the violations of scale conformity of any network.
//!
//! The geometric predicates shared by both are in [`conflicts`]; arc resampling in
//! [`resample`]; the graph form of a network in [`network`].

use crestflow_flow::Registry;

pub mod check;
pub mod conflicts;
pub mod conform;
pub mod ilp;
pub mod network;
pub mod resample;

#[cfg(test)]
mod check_test;
#[cfg(test)]
mod conflicts_test;
#[cfg(test)]
mod conform_test;
#[cfg(test)]
mod ilp_test;

pub use check::{check, check_absolute, check_at, CheckNode, CheckParams, CheckResult};
pub use conflicts::Scale;
pub use conform::{
    conform, conform_with, ConformNode, ConformOutput, ConformParams, ConformStats, ScaleError,
    Solver,
};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<ConformNode>();
    registry.add::<CheckNode>();
}
