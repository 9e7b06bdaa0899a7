//! crestflow node family `symmetry`: reoccurring feature curves under rigid transformations,
//! thesis §3.2 (Feature BLAST partial matching and local voting §3.2.2 with Algorithm 3.1,
//! global clustering §3.2.3, orbit detection §3.2.4 after Pauly et al. 2008; background §2.6.2,
//! Mitra, Guibas & Pauly 2006). Evidence from reoccurrence is what makes a curve meaningful
//! (thesis Ch. 3–4).
//!
//! - `symmetry.blast` ([`mod@blast`]): FCN + mesh → [`CurveMatches`] (per curve pair: best
//!   transformations from binned 7-D voting, affinities, point correspondences).
//! - `symmetry.cluster` ([`mod@cluster`]): [`CurveMatches`] → [`TransformClusters`].
//! - `symmetry.orbits` ([`mod@orbits`]): [`TransformClusters`] → [`Orbits`] (translation grids,
//!   rotations by 360°/n, reflections) and a `Report`.
//! - `symmetry.draw` ([`draw`]): curves coloured by orbit and by cluster (PLY, PNG).
//!
//! Lengths in parameters are multiples of the mesh's mean edge length, as in the thesis.

use crestflow_flow::Registry;

pub mod blast;
pub mod cluster;
pub mod draw;
pub mod orbits;
pub mod transform;

pub use blast::{
    blast, blast_with_unit, BlastError, BlastNode, BlastParams, CurveMatch, CurveMatches,
};
pub use cluster::{
    cluster, ClusterError, ClusterMember, ClusterNode, ClusterParams, TransformCluster,
    TransformClusters,
};
pub use draw::{ColorBy, DrawError, DrawNode, DrawParams};
pub use orbits::{
    orbits, to_report, Generator, Orbit, OrbitError, OrbitParams, Orbits, OrbitsNode,
};
pub use transform::RigidTransform;

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<BlastNode>();
    registry.add::<ClusterNode>();
    registry.add::<OrbitsNode>();
    registry.add::<DrawNode>();
}
