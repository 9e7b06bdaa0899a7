//! crestflow node family `shapes`.

use crestflow_flow::Registry;

/// Adds this family's node kinds to `registry`.
pub fn register(_registry: &mut Registry) {}
