//! crestflow-flow: the engine. Typed nodes ([`NodeKind`]), an explicit [`Registry`], RON
//! pipeline files loaded with locations ([`Graph`], [`load()`]), a planner on petgraph
//! ([`Plan`]), a parallel executor on rayon ([`run`]) with a content-addressed on-disk cache
//! ([`CacheStore`]), and events over crossbeam channels ([`Event`]).
//!
//! It knows nothing about geometry: node families live in `nodes/*` and register into a
//! [`Registry`]. The design is DESIGN §2–5 and §8 of the project; the algorithms the nodes
//! implement come from Gehre's thesis "3D Shape Analysis based on Feature Curve Networks".

pub mod cache;
pub mod diag;
pub mod exec;
pub mod graph;
pub mod load;
pub mod node;
pub mod registry;
pub mod report;
pub mod spanned;

pub use cache::{CacheStats, CacheStore, GcStats};
pub use diag::{DiagKind, Diagnostic, LoadError};
pub use exec::{run, why, Event, NodeOutcome, RunError, RunOptions, RunSummary, Status};
pub use graph::Graph;
pub use load::{load, load_file, parse_set, parse_set_for, path_params, Plan};
pub use node::{
    check_range, file_identity, port_type, resolve_path, type_name_of, CancelToken, Ctx, ErrorKind,
    Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, PortType, PortValue, ProgressSink,
    Validate, Value,
};
pub use registry::{DynNode, ParamError, PreparedParams, Registry};
pub use report::{Report, ReportValue};
