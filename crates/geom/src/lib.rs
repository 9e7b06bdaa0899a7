//! crestflow-geom: the geometry core. Triangle meshes with connectivity ([`TriMesh`]), typed
//! per-element data, curvature fields, feature curve networks (thesis Def. 2.1), mesh IO.
//!
//! It knows nothing about the engine: these are plain types with serde, used as port values.

pub mod bvh;
pub mod curvature;
pub mod fcn;
pub mod graph;
pub mod halfedge;
pub mod io;
pub mod locality;
pub mod mesh;
pub mod shapes;
pub mod vec3;

pub use curvature::CurvatureField;
pub use fcn::{CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint};
pub use mesh::{FaceId, MeshDefect, Topology, TriMesh, VertexId};
