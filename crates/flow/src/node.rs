//! The node contract (DESIGN §2).
//!
//! A node kind is a zero-sized type implementing [`NodeKind`]: a kind name, a version, typed
//! input and output ports, a serde parameter struct and a `run` function. Node-family crates keep
//! the algorithm in a pure function and make `run` a thin wrapper that unpacks [`Inputs`], calls
//! it and packs [`Outputs`].

use std::any::{Any, TypeId};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use serde::de::DeserializeOwned;
use serde::Serialize;

/// How a node may use threads. Passed in, never decided by the node: the executor owns the pool.
///
/// Whatever the value, results must be bit-for-bit identical (fixed-order reductions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Par {
    /// Run on the calling thread only.
    Seq,
    /// Use rayon's data parallelism on the current pool.
    #[default]
    Rayon,
}

impl Par {
    /// Runs `f` on a thread of the current rayon pool when `self` is `Rayon` and the caller is
    /// not one already (as when a node is called directly rather than by the executor), else
    /// on the calling thread. A caller outside the pool would otherwise hand every parallel
    /// loop of `f` to the pool and sleep until it ends: a wake-up per loop, and the pool's
    /// threads reading data that the caller's core wrote. Inside the pool, the thread that
    /// starts a loop also works on it.
    pub fn install<R, F>(self, f: F) -> R
    where
        R: Send,
        F: FnOnce() -> R + Send,
    {
        if self == Par::Rayon && rayon::current_thread_index().is_none() {
            rayon::scope(|_| f())
        } else {
            f()
        }
    }

    /// Runs `a` and `b`, potentially in parallel when `self` is `Rayon` (`a` first otherwise).
    pub fn join<A, B, RA, RB>(self, a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA + Send,
        B: FnOnce() -> RB + Send,
        RA: Send,
        RB: Send,
    {
        match self {
            Par::Seq => {
                let ra = a();
                (ra, b())
            }
            Par::Rayon => rayon::join(a, b),
        }
    }

    /// Maps `f` over `0..n` and collects in index order, in parallel when `self` is `Rayon`.
    pub fn map_collect<T, F>(self, n: usize, f: F) -> Vec<T>
    where
        T: Send,
        F: Fn(usize) -> T + Sync + Send,
    {
        use rayon::prelude::*;
        match self {
            Par::Seq => (0..n).map(f).collect(),
            Par::Rayon => (0..n).into_par_iter().map(f).collect(),
        }
    }

    /// [`Par::map_collect`] where `f` also gets a scratch value made by `init`: once under
    /// `Seq`, once per piece of work rayon hands a thread under `Rayon` (a few per thread, not
    /// one per index). `f` must not let its result depend on what the scratch held before.
    pub fn map_init_collect<S, T, I, F>(self, n: usize, init: I, f: F) -> Vec<T>
    where
        T: Send,
        I: Fn() -> S + Sync + Send,
        F: Fn(&mut S, usize) -> T + Sync + Send,
    {
        use rayon::prelude::*;
        match self {
            Par::Seq => {
                let mut s = init();
                (0..n).map(|i| f(&mut s, i)).collect()
            }
            Par::Rayon => (0..n).into_par_iter().map_init(init, f).collect(),
        }
    }

    /// The `Some` results of `f` over `0..n`, in index order, found in parallel over fixed
    /// chunks of `chunk` indices when `self` is `Rayon` (for scans that keep few indices, where
    /// a result per index would cost more than the scan). `chunk` is at least 1.
    pub fn filter_map_collect<T, F>(self, n: usize, chunk: usize, f: F) -> Vec<T>
    where
        T: Send,
        F: Fn(usize) -> Option<T> + Sync + Send,
    {
        let chunk = chunk.max(1);
        self.map_collect(n.div_ceil(chunk), |c| {
            (c * chunk..(c * chunk + chunk).min(n))
                .filter_map(&f)
                .collect::<Vec<_>>()
        })
        .into_iter()
        .flatten()
        .collect()
    }

    /// Runs `f(start, part_a, part_b)` on the consecutive parts of `a` and `b` of `chunk`
    /// elements (the same index range of each; `start` is its first index), in parallel when
    /// `self` is `Rayon`, and collects the results in order. `a` and `b` have the same length;
    /// `chunk` is at least 1.
    pub fn map_chunk_pairs_mut<A, B, T, F>(
        self,
        a: &mut [A],
        b: &mut [B],
        chunk: usize,
        f: F,
    ) -> Vec<T>
    where
        A: Send,
        B: Send,
        T: Send,
        F: Fn(usize, &mut [A], &mut [B]) -> T + Sync + Send,
    {
        use rayon::prelude::*;
        assert_eq!(
            a.len(),
            b.len(),
            "map_chunk_pairs_mut: slices of different lengths"
        );
        let chunk = chunk.max(1);
        match self {
            Par::Seq => a
                .chunks_mut(chunk)
                .zip(b.chunks_mut(chunk))
                .enumerate()
                .map(|(i, (pa, pb))| f(i * chunk, pa, pb))
                .collect(),
            Par::Rayon => a
                .par_chunks_mut(chunk)
                .zip(b.par_chunks_mut(chunk))
                .enumerate()
                .map(|(i, (pa, pb))| f(i * chunk, pa, pb))
                .collect(),
        }
    }

    /// Runs `f` on every index of `0..n`, in parallel when `self` is `Rayon` (for tasks that
    /// write disjoint parts of a shared output).
    pub fn for_each<F>(self, n: usize, f: F)
    where
        F: Fn(usize) + Sync + Send,
    {
        use rayon::prelude::*;
        match self {
            Par::Seq => (0..n).for_each(f),
            Par::Rayon => (0..n).into_par_iter().for_each(f),
        }
    }
}

/// One problem with a parameter value, found by [`Validate`]. `field` is the parameter's name
/// (a dotted path for nested values) so the loader can point at it in the pipeline file.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamIssue {
    pub field: String,
    pub message: String,
}

impl ParamIssue {
    pub fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            message: message.into(),
        }
    }
}

/// Range and consistency checks of a parameter struct, run when the graph is loaded.
pub trait Validate {
    /// Returns every problem, not only the first one.
    fn validate(&self) -> Vec<ParamIssue> {
        Vec::new()
    }
}

/// Pushes an issue when `value` is outside `[lo, hi]` (or not finite).
pub fn check_range<T>(issues: &mut Vec<ParamIssue>, field: &str, value: T, lo: T, hi: T)
where
    T: PartialOrd + fmt::Display + Copy,
{
    // `!(a <= b)` rather than `a > b` so that NaN is rejected too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(lo <= value && value <= hi) {
        issues.push(ParamIssue::new(
            field,
            format!("{value} is out of range [{lo}, {hi}]"),
        ));
    }
}

/// Encodes a value of a port's type for the cache (postcard).
pub type EncodeFn = fn(&Value) -> Result<Vec<u8>, String>;
/// Decodes a cached value of a port's type.
pub type DecodeFn = fn(&[u8]) -> Result<Value, String>;

/// The type a port carries: its name as shown to users, its Rust `TypeId`, and how the cache
/// stores it.
#[derive(Clone, Debug)]
pub struct PortType {
    /// `TriMesh`, `CurvatureField`, `Vec<f64>`: the Rust type name without module paths.
    pub name: String,
    pub id: TypeId,
    pub encode: EncodeFn,
    pub decode: DecodeFn,
}

impl PartialEq for PortType {
    fn eq(&self, other: &Self) -> bool {
        self.id == other.id
    }
}
impl Eq for PortType {}

/// A named, typed input or output of a node kind.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Port {
    pub name: &'static str,
    pub ty: PortType,
    /// Inputs only: whether the graph must connect it.
    pub required: bool,
    pub doc: &'static str,
}

impl Port {
    /// A required port carrying `T`.
    pub fn of<T: PortValue>(name: &'static str, doc: &'static str) -> Self {
        Port {
            name,
            ty: port_type::<T>(),
            required: true,
            doc,
        }
    }
    /// An optional input port.
    pub fn optional<T: PortValue>(name: &'static str, doc: &'static str) -> Self {
        Port {
            name,
            ty: port_type::<T>(),
            required: false,
            doc,
        }
    }
}

/// What can travel on an edge: serialisable (for the cache) and shareable across threads.
/// Every such type qualifies; there is nothing to implement.
pub trait PortValue: Serialize + DeserializeOwned + Send + Sync + 'static {}
impl<T: Serialize + DeserializeOwned + Send + Sync + 'static> PortValue for T {}

/// The [`PortType`] of `T`.
pub fn port_type<T: PortValue>() -> PortType {
    PortType {
        name: short_type_name(std::any::type_name::<T>()),
        id: TypeId::of::<T>(),
        encode: encode_value::<T>,
        decode: decode_value::<T>,
    }
}

/// The user-facing name of `T` (module paths dropped).
pub fn type_name_of<T: PortValue>() -> String {
    short_type_name(std::any::type_name::<T>())
}

fn encode_value<T: PortValue>(value: &Value) -> Result<Vec<u8>, String> {
    let v = value
        .downcast_ref::<T>()
        .ok_or_else(|| format!("value is not a {}", type_name_of::<T>()))?;
    postcard::to_allocvec(v).map_err(|e| e.to_string())
}

fn decode_value<T: PortValue>(bytes: &[u8]) -> Result<Value, String> {
    let v: T = postcard::from_bytes(bytes).map_err(|e| e.to_string())?;
    Ok(Arc::new(v))
}

/// `alloc::vec::Vec<crestflow_geom::mesh::TriMesh>` -> `Vec<TriMesh>`.
fn short_type_name(full: &str) -> String {
    let mut out = String::with_capacity(full.len());
    let mut segment = String::new();
    for c in full.chars() {
        if c.is_alphanumeric() || c == '_' || c == ':' {
            segment.push(c);
        } else {
            out.push_str(segment.rsplit("::").next().unwrap_or(""));
            segment.clear();
            out.push(c);
        }
    }
    out.push_str(segment.rsplit("::").next().unwrap_or(""));
    out
}

/// A value on an edge, shared between consumers without copying.
pub type Value = Arc<dyn Any + Send + Sync>;

/// The kinds of node failure (DESIGN §8).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum ErrorKind {
    /// The input data cannot be processed (bad file, empty mesh, …).
    InvalidInput,
    /// A numerical method failed (no convergence, singular system, …).
    NumericalFailure,
    /// A valid request this node does not support.
    Unsupported,
    /// A bug: an invariant of crestflow itself was broken.
    Internal,
    /// The run was cancelled while the node ran.
    Cancelled,
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            ErrorKind::InvalidInput => "invalid input",
            ErrorKind::NumericalFailure => "numerical failure",
            ErrorKind::Unsupported => "unsupported",
            ErrorKind::Internal => "internal error",
            ErrorKind::Cancelled => "cancelled",
        };
        f.write_str(s)
    }
}

/// The one error type a node returns. The executor adds the node name and graph location.
#[derive(Debug)]
pub struct NodeError {
    pub kind: ErrorKind,
    pub message: String,
    pub source: Option<Box<dyn std::error::Error + Send + Sync>>,
}

impl NodeError {
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        NodeError {
            kind,
            message: message.into(),
            source: None,
        }
    }
    pub fn invalid_input(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::InvalidInput, message)
    }
    pub fn numerical(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::NumericalFailure, message)
    }
    pub fn unsupported(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Unsupported, message)
    }
    pub fn internal(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Internal, message)
    }
    pub fn cancelled() -> Self {
        Self::new(ErrorKind::Cancelled, "cancelled")
    }
    /// Wraps a library error, keeping it as the source.
    pub fn from_source(
        kind: ErrorKind,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Self {
        NodeError {
            kind,
            message: source.to_string(),
            source: Some(Box::new(source)),
        }
    }
}

impl fmt::Display for NodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.kind, self.message)
    }
}

impl std::error::Error for NodeError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.source
            .as_ref()
            .map(|e| e.as_ref() as &(dyn std::error::Error + 'static))
    }
}

/// A shared flag that long loops poll (`ctx.check_cancelled()?`).
#[derive(Clone, Debug, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn cancel(&self) {
        self.0.store(true, Ordering::SeqCst);
    }
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// Where a node reports progress and warnings; implemented by the executor.
pub trait ProgressSink: Send + Sync {
    /// `fraction` in [0, 1].
    fn progress(&self, node: &str, fraction: f32);
    fn warn(&self, node: &str, message: &str);
}

/// What a running node may know about its surroundings.
pub struct Ctx<'a> {
    /// The node's name in the graph.
    pub node: &'a str,
    pub par: Par,
    /// The folder of the pipeline file; relative paths in params are resolved against it.
    pub base_dir: &'a Path,
    pub cancel: &'a CancelToken,
    pub sink: &'a dyn ProgressSink,
}

impl Ctx<'_> {
    /// Resolves a path written in a pipeline file (relative to the file's folder).
    pub fn resolve(&self, path: impl AsRef<Path>) -> PathBuf {
        resolve_path(self.base_dir, path.as_ref())
    }
    /// `Err(Cancelled)` once the run has been cancelled; call it inside long loops.
    pub fn check_cancelled(&self) -> Result<(), NodeError> {
        if self.cancel.is_cancelled() {
            Err(NodeError::cancelled())
        } else {
            Ok(())
        }
    }
    pub fn progress(&self, fraction: f32) {
        self.sink.progress(self.node, fraction.clamp(0.0, 1.0));
    }
    pub fn warn(&self, message: &str) {
        self.sink.warn(self.node, message);
    }
}

/// One name per file, for telling whether two paths are the same file: the canonical path
/// when the file exists; else the absolute path with `.` and `..` folded, inside its folder's
/// canonical path when the folder exists (an output may not exist yet). Relative paths are
/// taken from the current folder.
pub fn file_identity(path: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(path) {
        return c;
    }
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut folded = PathBuf::new();
    for c in abs.components() {
        match c {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                if !folded.pop() {
                    folded.push("..");
                }
            }
            other => folded.push(other),
        }
    }
    match (folded.parent(), folded.file_name()) {
        (Some(d), Some(name)) => std::fs::canonicalize(d)
            .map(|d| d.join(name))
            .unwrap_or(folded),
        _ => folded,
    }
}

/// `path` if absolute, else `base_dir/path`.
pub fn resolve_path(base_dir: &Path, path: &Path) -> PathBuf {
    if path.is_absolute() {
        path.to_path_buf()
    } else {
        base_dir.join(path)
    }
}

/// The values arriving at a node, by input port name.
#[derive(Default, Clone)]
pub struct Inputs {
    values: BTreeMap<String, Value>,
}

impl Inputs {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn insert(&mut self, port: impl Into<String>, value: Value) {
        self.values.insert(port.into(), value);
    }
    /// Builder form of [`Inputs::insert`] for a typed value.
    pub fn with<T: PortValue>(mut self, port: &str, value: T) -> Self {
        self.values.insert(port.to_string(), Arc::new(value));
        self
    }
    /// The value of a required input.
    pub fn get<T: PortValue>(&self, port: &str) -> Result<&T, NodeError> {
        self.opt::<T>(port)?
            .ok_or_else(|| NodeError::internal(format!("input `{port}` is not connected")))
    }
    /// The value of an optional input, `None` when not connected.
    pub fn opt<T: PortValue>(&self, port: &str) -> Result<Option<&T>, NodeError> {
        match self.values.get(port) {
            None => Ok(None),
            Some(v) => v.downcast_ref::<T>().map(Some).ok_or_else(|| {
                NodeError::internal(format!("input `{port}` is not a {}", type_name_of::<T>()))
            }),
        }
    }
    /// The shared handle of an input, for passing a value through without a copy.
    pub fn arc(&self, port: &str) -> Option<&Value> {
        self.values.get(port)
    }
}

/// The values a node produces, by output port name.
#[derive(Default, Clone)]
pub struct Outputs {
    values: BTreeMap<String, Value>,
}

impl Outputs {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn with<T: PortValue>(mut self, port: &str, value: T) -> Self {
        self.values.insert(port.to_string(), Arc::new(value));
        self
    }
    /// Passes a shared value through unchanged.
    pub fn with_arc(mut self, port: &str, value: Value) -> Self {
        self.values.insert(port.to_string(), value);
        self
    }
    pub fn get(&self, port: &str) -> Option<&Value> {
        self.values.get(port)
    }
    pub fn into_map(self) -> BTreeMap<String, Value> {
        self.values
    }
    pub fn iter(&self) -> impl Iterator<Item = (&String, &Value)> {
        self.values.iter()
    }
}

/// A node kind. Implement it on a unit struct and register it with
/// [`crate::Registry::add`].
pub trait NodeKind: Send + Sync + 'static {
    /// Parameters: `#[serde(default, deny_unknown_fields)]`, every field documented.
    type Params: Serialize + DeserializeOwned + Default + Validate + Send + Sync + 'static;

    /// Dotted kind name, `family.algorithm` (`"curvature.polynomial"`).
    const KIND: &'static str;
    /// Bump when the output for the same inputs and params changes: it is part of the cache key.
    const VERSION: u32;
    /// One paragraph for `crestflow nodes KIND`: what it does, the thesis section, the paper.
    const DOC: &'static str;

    fn inputs() -> Vec<Port>;
    fn outputs() -> Vec<Port>;

    /// Files the node reads (as written in params). Their content is part of the cache key.
    fn input_files(_params: &Self::Params) -> Vec<PathBuf> {
        Vec::new()
    }
    /// Files the node writes (as written in params). A cached node whose files are missing or
    /// changed on disk runs again.
    fn output_files(_params: &Self::Params) -> Vec<PathBuf> {
        Vec::new()
    }

    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError>;
}

#[cfg(test)]
#[path = "node_test.rs"]
mod tests;
