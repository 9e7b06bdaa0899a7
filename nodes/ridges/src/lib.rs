//! crestflow node family `ridges`: feature curve networks from ridges and ravines (thesis
//! §2.5.1.1, Def. 2.1, Def. 2.2, Thm 2.1; Ohtake, Belyaev & Seidel 2004; Yoshizawa, Belyaev &
//! Seidel 2005).
//!
//! - `ridges.trace` ([`trace::TraceNode`]): extremality zero crossings on edges, joined per
//!   triangle into arcs and loops, filtered by sharpness, cyclideness and length.
//!
//! The steps live in their own modules: [`crossing`] (feature points on edges, Thm 2.1) and
//! [`network`] (per-triangle joining and arcs, Def. 2.1).

use crestflow_flow::Registry;

pub mod crossing;
pub mod network;
pub mod trace;

pub use crossing::{Definition, Family};
pub use trace::{trace, Families, TraceError, TraceNode, TraceOutput, TraceParams, TraceStats};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<TraceNode>();
}
