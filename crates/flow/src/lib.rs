//! crestflow-flow: the engine. Typed nodes ([`NodeKind`]), an explicit [`Registry`], RON
//! pipeline files loaded with locations, a planner on petgraph, a parallel executor on rayon
//! with a content-addressed on-disk cache, and events over crossbeam channels.
//!
//! It knows nothing about geometry: node families live in `nodes/*` and register into a
//! [`Registry`].

pub mod node;
pub mod registry;
pub mod report;

pub use node::{
    check_range, port_type, resolve_path, type_name_of, CancelToken, Ctx, ErrorKind, Inputs,
    NodeError, NodeKind, Outputs, Par, ParamIssue, Port, PortType, PortValue, ProgressSink,
    Validate, Value,
};
pub use registry::{DynNode, ParamError, PreparedParams, Registry};
pub use report::{Report, ReportValue};
