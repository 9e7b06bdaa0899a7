//! The executor (DESIGN §5): runs a [`Plan`] on one rayon pool with the content-addressed cache
//! of DESIGN §4, sending [`Event`]s over a crossbeam channel.
//!
//! A scheduler on the calling thread spawns every node whose inputs are ready into the pool and
//! receives completions over a channel; nodes get `Par::Rayon` and their `par_iter`s run in the
//! same pool. A node's cache key is blake3(kind, version, canonical params, for each input port
//! its name and the upstream output digest, the content hash of each input file). Keying on
//! upstream output digests (not keys) gives early cutoff: a rerun node whose output did not
//! change leaves its dependents' keys unchanged. Cached values are decoded only when a node that
//! runs needs them, so a fully cached rerun reads no blob.

use std::any::{Any, TypeId};
use std::collections::{BTreeMap, VecDeque};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use crossbeam_channel::Sender;
use serde::Serialize;

use crate::cache::{CacheStore, Entry, InputRecord, NodeRecord, OutputMeta, RunRecord};
use crate::load::Plan;
use crate::node::{
    resolve_path, CancelToken, Ctx, ErrorKind, Inputs, NodeError, Par, PortType, ProgressSink,
    Value,
};
use crate::report::Report;
use crate::spanned::{self, SKind, SValue};

/// What happened to a node in a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Computed in this run.
    Ran,
    /// Taken from the cache.
    Cached,
    /// Returned an error (or panicked, or was cancelled while running).
    Failed,
    /// Not started: an upstream node failed, or the run was cancelled.
    Skipped,
}

impl Status {
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Ran => "ran",
            Status::Cached => "cached",
            Status::Failed => "failed",
            Status::Skipped => "skipped",
        }
    }
}

/// Everything the executor tells the outside world, in the order it happens.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    RunStarted {
        graph: String,
        nodes: usize,
        threads: usize,
        cache: Option<String>,
    },
    NodeStarted {
        node: String,
        kind: String,
    },
    NodeProgress {
        node: String,
        fraction: f32,
    },
    NodeFinished {
        node: String,
        kind: String,
        status: Status,
        ms: f64,
        reason: String,
        output_bytes: u64,
        #[serde(skip_serializing_if = "Option::is_none")]
        error: Option<String>,
    },
    Warning {
        #[serde(skip_serializing_if = "Option::is_none")]
        node: Option<String>,
        message: String,
    },
    Report {
        node: String,
        port: String,
        values: serde_json::Value,
    },
    RunFinished {
        ran: usize,
        cached: usize,
        failed: usize,
        skipped: usize,
        ms: f64,
        cancelled: bool,
        ok: bool,
    },
}

impl Event {
    /// One line of JSON.
    pub fn to_json_line(&self) -> String {
        serde_json::to_string(self)
            .unwrap_or_else(|e| format!("{{\"event\":\"error\",\"message\":\"{e}\"}}"))
    }
}

/// How to run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Worker threads; 0 means one per core; at most [`MAX_THREADS`].
    pub threads: usize,
    /// Cache folder; `None` means `<graph folder>/.crestflow/cache`.
    pub cache_dir: Option<PathBuf>,
    /// `false` (`--no-cache`): neither read nor write cached values (run records are still kept).
    pub use_cache: bool,
    pub cancel: CancelToken,
    pub events: Option<Sender<Event>>,
    /// Names the graph in run records; `None` means the absolute path of its file.
    pub graph_id: Option<String>,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            threads: 0,
            cache_dir: None,
            use_cache: true,
            cancel: CancelToken::new(),
            events: None,
            graph_id: None,
        }
    }
}

/// Failures of the run itself (not of a node).
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("cannot open the cache folder {dir}: {source}")]
    Cache {
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot start the thread pool: {0}")]
    Pool(String),
    #[error("{requested} worker threads requested; at most {MAX_THREADS} (0 = one per core)")]
    TooManyThreads { requested: usize },
}

/// The most worker threads a run accepts: a mistyped count (100000) would otherwise spend
/// minutes starting threads, or exhaust the process's limit, before anything runs.
pub const MAX_THREADS: usize = 1024;

/// An output value of a finished node; decoded from the cache on first use.
pub struct Slot {
    pub digest: String,
    pub size: u64,
    pub ty: PortType,
    value: Mutex<Option<Value>>,
    store: Option<Arc<CacheStore>>,
    /// The encoded value when the cache entry holds it inline.
    inline: Option<Vec<u8>>,
}

impl std::fmt::Debug for Slot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Slot")
            .field("digest", &self.digest)
            .field("size", &self.size)
            .field("ty", &self.ty.name)
            .finish()
    }
}

impl Slot {
    fn load(&self) -> Result<Value, String> {
        let mut v = self
            .value
            .lock()
            .map_err(|_| "a value slot is poisoned".to_string())?;
        if let Some(v) = v.as_ref() {
            return Ok(v.clone());
        }
        let bytes = match &self.inline {
            Some(b) => {
                if blake3::hash(b).to_hex().as_str() != self.digest {
                    return Err(format!(
                        "the inline cached value {} is corrupt",
                        self.digest
                    ));
                }
                b.clone()
            }
            None => self
                .store
                .as_ref()
                .ok_or("the value is not in memory and there is no cache")?
                .read_blob(&self.digest)?,
        };
        let value = (self.ty.decode)(&bytes).map_err(|e| {
            format!(
                "cache blob {} does not decode as {}: {e}",
                self.digest, self.ty.name
            )
        })?;
        *v = Some(value.clone());
        Ok(value)
    }
}

/// The outcome of one node.
#[derive(Debug)]
pub struct NodeOutcome {
    pub name: String,
    pub kind: String,
    pub status: Status,
    pub ms: f64,
    /// Why it ran, was cached or skipped (also in the run record for `crestflow why`).
    pub reason: String,
    pub error: Option<(ErrorKind, String)>,
    pub key: String,
    pub outputs: BTreeMap<String, Arc<Slot>>,
    /// The first failed node upstream, for skipped nodes.
    pub failed_upstream: Option<String>,
}

impl NodeOutcome {
    /// The value of an output (decoded from the cache if needed).
    pub fn value(&self, port: &str) -> Result<Value, String> {
        self.outputs
            .get(port)
            .ok_or_else(|| format!("node `{}` has no output `{port}` in this run", self.name))?
            .load()
    }
    /// A typed output value.
    pub fn get<T: Any + Send + Sync>(&self, port: &str) -> Result<Arc<T>, String> {
        self.value(port)?.downcast::<T>().map_err(|_| {
            format!(
                "output `{port}` of `{}` is not a {}",
                self.name,
                std::any::type_name::<T>()
            )
        })
    }
    pub fn output_bytes(&self) -> u64 {
        self.outputs.values().map(|s| s.size).sum()
    }
}

/// What a run did.
#[derive(Debug)]
pub struct RunSummary {
    /// In plan (file) order.
    pub nodes: Vec<NodeOutcome>,
    pub ms: f64,
    pub cancelled: bool,
    /// The first failed write to the cache, if any (the node that wrote failed too).
    pub cache_error: Option<String>,
}

impl RunSummary {
    pub fn node(&self, name: &str) -> Option<&NodeOutcome> {
        self.nodes.iter().find(|n| n.name == name)
    }
    pub fn count(&self, status: Status) -> usize {
        self.nodes.iter().filter(|n| n.status == status).count()
    }
    /// No node failed or was skipped.
    pub fn ok(&self) -> bool {
        self.nodes
            .iter()
            .all(|n| matches!(n.status, Status::Ran | Status::Cached))
    }
    pub fn failures(&self) -> impl Iterator<Item = &NodeOutcome> {
        self.nodes.iter().filter(|n| n.status == Status::Failed)
    }
    /// The digest of an output.
    pub fn digest(&self, node: &str, port: &str) -> Option<&str> {
        self.node(node)?
            .outputs
            .get(port)
            .map(|s| s.digest.as_str())
    }
}

/// Output port -> (value, digest, encoded bytes).
type Computed = BTreeMap<String, (Value, String, Vec<u8>)>;

struct Sink {
    events: Option<Sender<Event>>,
    last: AtomicU32,
}

impl ProgressSink for Sink {
    fn progress(&self, node: &str, fraction: f32) {
        // At most ~100 progress events per node.
        let step = (fraction * 100.0) as u32 + 1;
        if self.last.swap(step, Ordering::Relaxed) != step {
            if let Some(tx) = &self.events {
                let _ = tx.send(Event::NodeProgress {
                    node: node.to_string(),
                    fraction,
                });
            }
        }
    }
    fn warn(&self, node: &str, message: &str) {
        if let Some(tx) = &self.events {
            let _ = tx.send(Event::Warning {
                node: Some(node.to_string()),
                message: message.to_string(),
            });
        }
    }
}

struct Shared<'p, 'r> {
    plan: &'p Plan<'r>,
    store: Option<Arc<CacheStore>>,
    use_cache: bool,
    cancel: CancelToken,
    events: Option<Sender<Event>>,
    results: Vec<OnceLock<NodeOutcome>>,
    records: Vec<OnceLock<NodeRecord>>,
    prev: Option<RunRecord>,
    write_failed: Mutex<Option<String>>,
}

fn upd(h: &mut blake3::Hasher, s: &str) {
    h.update(&(s.len() as u64).to_le_bytes());
    h.update(s.as_bytes());
}

impl Shared<'_, '_> {
    fn emit(&self, e: Event) {
        if let Some(tx) = &self.events {
            let _ = tx.send(e);
        }
    }
    fn warn(&self, node: Option<&str>, message: String) {
        self.emit(Event::Warning {
            node: node.map(str::to_string),
            message,
        });
    }

    /// The value of output `port` of finished node `i`; recomputes the node when its cached
    /// blob is missing or corrupt.
    fn input_value(&self, i: usize, port: &str) -> Result<Value, NodeError> {
        let out = self.results[i]
            .get()
            .ok_or_else(|| NodeError::internal("an input was read before its node finished"))?;
        let slot = out.outputs.get(port).ok_or_else(|| {
            NodeError::internal(format!("node `{}` has no output `{port}`", out.name))
        })?;
        match slot.load() {
            Ok(v) => Ok(v),
            Err(why) => {
                self.warn(
                    Some(&out.name),
                    format!("{why}; recomputing `{}`", out.name),
                );
                self.reload(i, &out.name, &out.outputs, port)
            }
        }
    }

    /// Recomputes node `i` (named `name`) after a stored output failed to load: the fresh
    /// values go into its `outputs` slots (and repair the store); returns output `port`.
    fn reload(
        &self,
        i: usize,
        name: &str,
        outputs: &BTreeMap<String, Arc<Slot>>,
        port: &str,
    ) -> Result<Value, NodeError> {
        let values = self.recompute(i)?;
        let mut found = None;
        for (p, s) in outputs {
            if let Some((v, digest)) = values.get(p) {
                if *digest != s.digest {
                    self.warn(Some(name), format!("recomputed output `{p}` differs from the cached digest (is the node deterministic?)"));
                }
                if let Ok(mut g) = s.value.lock() {
                    *g = Some(v.clone());
                }
                if p == port {
                    found = Some(v.clone());
                }
            }
        }
        found.ok_or_else(|| {
            NodeError::internal(format!("recomputing `{name}` gave no output `{port}`"))
        })
    }

    fn gather(&self, i: usize) -> Result<Inputs, NodeError> {
        let mut inputs = Inputs::new();
        for e in &self.plan.nodes[i].inputs {
            inputs.insert(e.port.clone(), self.input_value(e.from, &e.from_port)?);
        }
        Ok(inputs)
    }

    fn call(&self, i: usize, inputs: &Inputs) -> Result<crate::node::Outputs, NodeError> {
        let n = &self.plan.nodes[i];
        let sink = Sink {
            events: self.events.clone(),
            last: AtomicU32::new(0),
        };
        let ctx = Ctx {
            node: &n.name,
            par: Par::Rayon,
            base_dir: &self.plan.base_dir,
            cancel: &self.cancel,
            sink: &sink,
        };
        match catch_unwind(AssertUnwindSafe(|| n.kind.run(&n.params, inputs, &ctx))) {
            Ok(r) => r,
            Err(panic) => {
                let msg = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "unknown panic".into());
                Err(NodeError::internal(format!("the node panicked: {msg}")))
            }
        }
    }

    /// Runs node `i` and encodes its outputs: port -> (value, digest, bytes).
    fn compute(&self, i: usize) -> Result<Computed, NodeError> {
        let n = &self.plan.nodes[i];
        let inputs = self.gather(i)?;
        let outputs = self.call(i, &inputs)?;
        let mut out = BTreeMap::new();
        for p in &n.outputs {
            let v = outputs.get(p.name).cloned().ok_or_else(|| {
                NodeError::internal(format!(
                    "{} did not produce its output `{}`",
                    n.kind.kind(),
                    p.name
                ))
            })?;
            if Any::type_id(&*v) != p.ty.id {
                return Err(NodeError::internal(format!(
                    "{} produced output `{}` of the wrong type (expected {})",
                    n.kind.kind(),
                    p.name,
                    p.ty.name
                )));
            }
            let bytes = (p.ty.encode)(&v).map_err(|e| {
                NodeError::internal(format!("output `{}` cannot be encoded: {e}", p.name))
            })?;
            let digest = blake3::hash(&bytes).to_hex().to_string();
            out.insert(p.name.to_string(), (v, digest, bytes));
        }
        Ok(out)
    }

    fn recompute(&self, i: usize) -> Result<BTreeMap<String, (Value, String)>, NodeError> {
        let out = self.compute(i)?;
        let mut res = BTreeMap::new();
        for (p, (v, d, bytes)) in out {
            if let (Some(store), true) = (&self.store, self.use_cache) {
                // Repair the store; failure here only costs a recomputation next time.
                let _ = store.repair_blob(&d, &bytes);
            }
            res.insert(p, (v, d));
        }
        Ok(res)
    }

    fn file_hash(&self, p: &Path) -> String {
        let r = match &self.store {
            Some(s) => s.file_hash(p),
            None => crate::cache::hash_file(p),
        };
        r.unwrap_or_else(|e| format!("missing ({e})"))
    }

    fn process(&self, i: usize) -> (NodeOutcome, NodeRecord) {
        let t0 = Instant::now();
        let n = &self.plan.nodes[i];
        self.emit(Event::NodeStarted {
            node: n.name.clone(),
            kind: n.kind.kind().to_string(),
        });

        // The key.
        let mut h = blake3::Hasher::new();
        upd(&mut h, "crestflow.key.v1");
        upd(&mut h, n.kind.kind());
        h.update(&n.kind.version().to_le_bytes());
        upd(&mut h, &n.params.canonical);
        let mut inputs_rec = BTreeMap::new();
        let mut edges: Vec<_> = n.inputs.iter().collect();
        edges.sort_by(|a, b| a.port.cmp(&b.port));
        for e in edges {
            let up = self.results[e.from].get();
            let digest = up
                .and_then(|o| o.outputs.get(&e.from_port))
                .map(|s| s.digest.clone())
                .unwrap_or_default();
            upd(&mut h, &e.port);
            upd(&mut h, &digest);
            inputs_rec.insert(
                e.port.clone(),
                InputRecord {
                    from: format!("{}.{}", self.plan.nodes[e.from].name, e.from_port),
                    digest,
                },
            );
        }
        let mut files = BTreeMap::new();
        for f in &n.params.input_files {
            let p = resolve_path(&self.plan.base_dir, f);
            let hash = self.file_hash(&p);
            upd(&mut h, &hash);
            files.insert(p.to_string_lossy().into_owned(), hash);
        }
        let key = h.finalize().to_hex().to_string();
        let mut record = NodeRecord {
            kind: n.kind.kind().to_string(),
            version: n.kind.version(),
            key: key.clone(),
            params: n.params.canonical.clone(),
            inputs: inputs_rec,
            files,
            outputs: BTreeMap::new(),
            status: String::new(),
            reason: String::new(),
            ms: 0.0,
        };
        let prev = self.prev.as_ref().and_then(|r| r.nodes.get(&n.name));

        // The cache.
        let mut miss_reason: Option<String> = None;
        if !self.use_cache {
            miss_reason = Some("--no-cache".into());
        } else if let Some(store) = &self.store {
            match store.read_entry(&key) {
                Ok(Some(entry)) => match self.check_entry(i, &entry) {
                    Ok(()) => {
                        let outputs = n
                            .outputs
                            .iter()
                            .filter_map(|p| {
                                entry.outputs.get(p.name).map(|m| {
                                    (
                                        p.name.to_string(),
                                        Arc::new(Slot {
                                            digest: m.digest.clone(),
                                            size: m.size,
                                            ty: p.ty.clone(),
                                            value: Mutex::new(None),
                                            store: Some(store.clone()),
                                            inline: m
                                                .inline
                                                .as_deref()
                                                .and_then(crate::cache::from_hex),
                                        }),
                                    )
                                })
                            })
                            .collect::<BTreeMap<_, _>>();
                        record.outputs = outputs
                            .iter()
                            .map(|(k, s)| (k.clone(), s.digest.clone()))
                            .collect();
                        let reason = self.cached_reason(i, &record, prev);
                        return self.finish(i, t0, record, Status::Cached, reason, None, outputs);
                    }
                    Err(why) => miss_reason = Some(why),
                },
                Ok(None) => {}
                Err(why) => {
                    self.warn(Some(&n.name), format!("{why}; treating it as a miss"));
                    miss_reason = Some(why);
                }
            }
        }
        let reason = miss_reason.unwrap_or_else(|| self.miss_reason(&record, prev));

        if self.cancel.is_cancelled() {
            return self.finish(
                i,
                t0,
                record,
                Status::Skipped,
                "the run was cancelled".into(),
                None,
                BTreeMap::new(),
            );
        }
        let computed = match self.compute(i) {
            Ok(c) => c,
            Err(e) => {
                let status = Status::Failed;
                return self.finish(
                    i,
                    t0,
                    record,
                    status,
                    reason,
                    Some((e.kind, e.message)),
                    BTreeMap::new(),
                );
            }
        };
        let mut outputs = BTreeMap::new();
        let mut entry = Entry {
            kind: record.kind.clone(),
            version: record.version,
            outputs: BTreeMap::new(),
            output_files: Vec::new(),
        };
        let mut write_err = None;
        for (port, (v, digest, bytes)) in computed {
            let size = bytes.len() as u64;
            let ty = n
                .outputs
                .iter()
                .find(|p| p.name == port)
                .map(|p| p.ty.clone());
            let Some(ty) = ty else { continue };
            let inline =
                (bytes.len() <= crate::cache::INLINE_MAX).then(|| crate::cache::to_hex(&bytes));
            if let (Some(store), true, None) = (&self.store, self.use_cache, &inline) {
                if let Err(e) = store.write_blob(&digest, &bytes) {
                    write_err = Some(format!(
                        "cannot write to the cache folder {}: {e}",
                        store.dir().display()
                    ));
                }
            }
            entry.outputs.insert(
                port.clone(),
                OutputMeta {
                    digest: digest.clone(),
                    size,
                    ty: ty.name.clone(),
                    inline,
                },
            );
            record.outputs.insert(port.clone(), digest.clone());
            outputs.insert(
                port,
                Arc::new(Slot {
                    digest,
                    size,
                    ty,
                    value: Mutex::new(Some(v)),
                    store: self.store.clone(),
                    inline: None,
                }),
            );
        }
        if let (Some(store), true) = (&self.store, self.use_cache) {
            for f in &n.params.output_files {
                let p = resolve_path(&self.plan.base_dir, f);
                entry
                    .output_files
                    .push((p.to_string_lossy().into_owned(), self.file_hash(&p)));
            }
            if write_err.is_none() {
                if let Err(e) = store.write_entry(&key, &entry) {
                    write_err = Some(format!(
                        "cannot write to the cache folder {}: {e}",
                        store.dir().display()
                    ));
                }
            }
        }
        if let Some(msg) = write_err {
            if let Ok(mut w) = self.write_failed.lock() {
                w.get_or_insert(msg.clone());
            }
            return self.finish(
                i,
                t0,
                record,
                Status::Failed,
                reason,
                Some((ErrorKind::Internal, msg)),
                outputs,
            );
        }
        self.finish(i, t0, record, Status::Ran, reason, None, outputs)
    }

    /// Whether a cache entry can be used as is.
    fn check_entry(&self, i: usize, entry: &Entry) -> Result<(), String> {
        let n = &self.plan.nodes[i];
        let store = self.store.as_ref().ok_or("no cache")?;
        if entry.kind != n.kind.kind() || entry.version != n.kind.version() {
            return Err("the cache entry belongs to another kind or version".into());
        }
        for p in &n.outputs {
            let Some(m) = entry.outputs.get(p.name) else {
                return Err(format!("the cache entry lacks output `{}`", p.name));
            };
            if m.ty != p.ty.name {
                return Err(format!(
                    "the cached output `{}` is a {}, not a {}",
                    p.name, m.ty, p.ty.name
                ));
            }
            if m.inline.is_none() && !store.has_blob(&m.digest) {
                return Err(format!(
                    "the cached value of output `{}` is missing from the cache",
                    p.name
                ));
            }
        }
        for (path, hash) in &entry.output_files {
            let p = Path::new(path);
            if !p.exists() {
                return Err(format!("output file {path} is missing"));
            }
            if self.file_hash(p) != *hash {
                return Err(format!(
                    "output file {path} was changed since it was written"
                ));
            }
        }
        Ok(())
    }

    fn miss_reason(&self, rec: &NodeRecord, prev: Option<&NodeRecord>) -> String {
        let Some(prev) = prev else {
            return "no cache entry (first run of this node)".into();
        };
        if prev.key.is_empty() {
            return format!(
                "it did not run in the last run ({}: {})",
                prev.status, prev.reason
            );
        }
        let mut why = diff_records(prev, rec, self);
        if why.is_empty() {
            if matches!(prev.status.as_str(), "failed" | "skipped") {
                why.push(format!(
                    "it did not finish in the last run ({})",
                    prev.status
                ));
            } else {
                why.push("the cache entry is missing (cache cleared or collected?)".into());
            }
        }
        why.join("; ")
    }

    fn cached_reason(&self, i: usize, rec: &NodeRecord, prev: Option<&NodeRecord>) -> String {
        let n = &self.plan.nodes[i];
        let mut cutoff = Vec::new();
        for e in &n.inputs {
            if let Some(up) = self.results[e.from].get() {
                if up.status == Status::Ran {
                    cutoff.push(format!(
                        "`{}` ran but its output `{}` is unchanged",
                        up.name, e.from_port
                    ));
                }
            }
        }
        cutoff.sort();
        cutoff.dedup();
        let base = match prev {
            Some(p) if p.key == rec.key => "key unchanged since the last run".to_string(),
            Some(p) => format!(
                "an earlier run had the same key ({})",
                diff_records(p, rec, self).join("; ")
            ),
            None => "the key is in the cache".to_string(),
        };
        if cutoff.is_empty() {
            base
        } else {
            format!("{base}; early cutoff: {}", cutoff.join(", "))
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn finish(
        &self,
        i: usize,
        t0: Instant,
        mut record: NodeRecord,
        status: Status,
        reason: String,
        error: Option<(ErrorKind, String)>,
        outputs: BTreeMap<String, Arc<Slot>>,
    ) -> (NodeOutcome, NodeRecord) {
        let n = &self.plan.nodes[i];
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        record.status = status.as_str().into();
        record.reason = match &error {
            Some((k, m)) => format!("{reason}; it failed: {k}: {m}"),
            None => reason.clone(),
        };
        record.ms = ms;
        let out = NodeOutcome {
            name: n.name.clone(),
            kind: n.kind.kind().to_string(),
            status,
            ms,
            reason,
            error,
            key: record.key.clone(),
            outputs,
            failed_upstream: None,
        };
        // Reports: every output of type Report, ran or cached.
        if matches!(status, Status::Ran | Status::Cached) {
            for p in &n.outputs {
                if p.ty.id == TypeId::of::<Report>() {
                    if let Some(slot) = out.outputs.get(p.name) {
                        // A stored report that fails to load (a corrupt blob) is recomputed,
                        // which also repairs the store: else it stayed unreadable in every
                        // later run, since nothing downstream reads a report.
                        let value = slot.load().or_else(|e| {
                            self.warn(
                                Some(&n.name),
                                format!("report `{}`: {e}; recomputing `{}`", p.name, n.name),
                            );
                            self.reload(i, &n.name, &out.outputs, p.name)
                                .map_err(|e| e.to_string())
                        });
                        match value {
                            Ok(v) => {
                                if let Some(r) = v.downcast_ref::<Report>() {
                                    self.emit(Event::Report {
                                        node: n.name.clone(),
                                        port: p.name.to_string(),
                                        values: r.to_json(),
                                    });
                                }
                            }
                            Err(e) => self.warn(
                                Some(&n.name),
                                format!("report `{}` cannot be shown: {e}", p.name),
                            ),
                        }
                    }
                }
            }
        }
        (out, record)
    }
}

/// Field-level differences between two runs of a node, in words.
fn diff_records(prev: &NodeRecord, cur: &NodeRecord, sh: &Shared) -> Vec<String> {
    let mut why = Vec::new();
    if prev.kind != cur.kind {
        why.push(format!("kind changed: {} -> {}", prev.kind, cur.kind));
    }
    if prev.version != cur.version {
        why.push(format!(
            "version changed: {} -> {}",
            prev.version, cur.version
        ));
    }
    if prev.params != cur.params {
        let d = diff_params(&prev.params, &cur.params);
        if d.is_empty() {
            why.push(format!("params changed: {} -> {}", prev.params, cur.params));
        } else {
            why.push(format!("param {}", d.join(", param ")));
        }
    }
    for (port, inp) in &cur.inputs {
        match prev.inputs.get(port) {
            None => why.push(format!(
                "input `{port}` is newly connected (from {})",
                inp.from
            )),
            Some(p) if p.from != inp.from => why.push(format!(
                "input `{port}` now reads {} instead of {}",
                inp.from, p.from
            )),
            Some(p) if p.digest != inp.digest => {
                let up = inp
                    .from
                    .rsplit_once('.')
                    .map(|(n, _)| n)
                    .unwrap_or(&inp.from);
                let up_reason = sh
                    .plan
                    .index_of(up)
                    .and_then(|k| sh.results[k].get())
                    .map(|o| format!(" (`{up}` {}: {})", o.status.as_str(), o.reason))
                    .unwrap_or_default();
                why.push(format!(
                    "input `{port}` changed: {} has a new value{up_reason}",
                    inp.from
                ));
            }
            _ => {}
        }
    }
    for port in prev.inputs.keys() {
        if !cur.inputs.contains_key(port) {
            why.push(format!("input `{port}` is no longer connected"));
        }
    }
    for (path, hash) in &cur.files {
        match prev.files.get(path) {
            None => why.push(format!("reads a new input file {path}")),
            Some(h) if h != hash => why.push(format!("input file {path} changed")),
            _ => {}
        }
    }
    why
}

/// `rings: 2 -> 3` for every field that differs between two canonical params texts.
pub fn diff_params(a: &str, b: &str) -> Vec<String> {
    let (Ok(ta), Ok(tb)) = (spanned::parse(a), spanned::parse(b)) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    diff_value("", &ta, a, &tb, b, &mut out);
    out
}

fn diff_value(path: &str, x: &SValue, xs: &str, y: &SValue, ys: &str, out: &mut Vec<String>) {
    let tx = &xs[x.span.clone()];
    let ty = &ys[y.span.clone()];
    if tx == ty {
        return;
    }
    if let (SKind::Struct { fields: fa, .. }, SKind::Struct { fields: fb, .. }) = (&x.kind, &y.kind)
    {
        for f in fa {
            let p = if path.is_empty() {
                f.name.clone()
            } else {
                format!("{path}.{}", f.name)
            };
            match fb.iter().find(|g| g.name == f.name) {
                Some(g) => diff_value(&p, &f.value, xs, &g.value, ys, out),
                None => out.push(format!("`{p}` removed")),
            }
        }
        for g in fb {
            if !fa.iter().any(|f| f.name == g.name) {
                let p = if path.is_empty() {
                    g.name.clone()
                } else {
                    format!("{path}.{}", g.name)
                };
                out.push(format!("`{p}` added: {}", &ys[g.value.span.clone()]));
            }
        }
        return;
    }
    let name = if path.is_empty() {
        "params".to_string()
    } else {
        path.to_string()
    };
    out.push(format!("`{name}` changed: {tx} -> {ty}"));
}

/// Runs a plan. Node failures are in the summary; `Err` only when the run could not start.
pub fn run(plan: &Plan, opts: &RunOptions) -> Result<RunSummary, RunError> {
    let t0 = Instant::now();
    let cache_dir = opts
        .cache_dir
        .clone()
        .unwrap_or_else(|| plan.base_dir.join(".crestflow").join("cache"));
    let store = match CacheStore::open(&cache_dir) {
        Ok(s) => Some(Arc::new(s)),
        Err(source) if opts.use_cache => {
            return Err(RunError::Cache {
                dir: cache_dir,
                source,
            })
        }
        Err(_) => None,
    };
    let graph_id = opts.graph_id.clone().unwrap_or_else(|| graph_id(plan));
    let prev = store
        .as_ref()
        .and_then(|s| s.history(&graph_id).runs.last().cloned());
    if opts.threads > MAX_THREADS {
        return Err(RunError::TooManyThreads {
            requested: opts.threads,
        });
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .thread_name(|i| format!("crestflow-{i}"))
        .build()
        .map_err(|e| RunError::Pool(e.to_string()))?;
    let n = plan.nodes.len();
    let shared = Shared {
        plan,
        store: store.clone(),
        use_cache: opts.use_cache,
        cancel: opts.cancel.clone(),
        events: opts.events.clone(),
        results: (0..n).map(|_| OnceLock::new()).collect(),
        records: (0..n).map(|_| OnceLock::new()).collect(),
        prev,
        write_failed: Mutex::new(None),
    };
    shared.emit(Event::RunStarted {
        graph: graph_id.clone(),
        nodes: n,
        threads: pool.current_num_threads(),
        cache: opts.use_cache.then(|| cache_dir.display().to_string()),
    });

    // Distinct upstream nodes of each node.
    let mut waiting: Vec<usize> = plan
        .nodes
        .iter()
        .map(|nd| {
            let mut f: Vec<usize> = nd.inputs.iter().map(|e| e.from).collect();
            f.sort_unstable();
            f.dedup();
            f.len()
        })
        .collect();

    let (tx, rx) = crossbeam_channel::unbounded::<(usize, NodeOutcome, NodeRecord)>();
    let shared_ref = &shared;
    pool.in_place_scope(|scope| {
        let spawn = |i: usize| {
            let tx = tx.clone();
            scope.spawn(move |_| {
                let (o, r) = match catch_unwind(AssertUnwindSafe(|| shared_ref.process(i))) {
                    Ok(x) => x,
                    Err(_) => {
                        let nd = &shared_ref.plan.nodes[i];
                        let rec = empty_record(
                            nd.kind.kind(),
                            nd.kind.version(),
                            "failed",
                            "engine error",
                        );
                        let out = NodeOutcome {
                            name: nd.name.clone(),
                            kind: nd.kind.kind().into(),
                            status: Status::Failed,
                            ms: 0.0,
                            reason: "engine error".into(),
                            error: Some((
                                ErrorKind::Internal,
                                "the engine panicked while running this node".into(),
                            )),
                            key: String::new(),
                            outputs: BTreeMap::new(),
                            failed_upstream: None,
                        };
                        (out, rec)
                    }
                };
                // Emitted here, on the worker, so that the log orders it before anything
                // this thread does next.
                shared_ref.emit(finished_event(&o));
                let _ = tx.send((i, o, r));
            });
        };
        let mut running = 0usize;
        for &i in &plan.order {
            if waiting[i] == 0 {
                running += 1;
                spawn(i);
            }
        }
        let mut decided: VecDeque<usize> = VecDeque::new();
        while running > 0 {
            let Ok((i, out, rec)) = rx.recv() else { break };
            running -= 1;
            let _ = shared.results[i].set(out);
            let _ = shared.records[i].set(rec);
            decided.push_back(i);
            while let Some(d) = decided.pop_front() {
                for &k in &plan.nodes[d].dependents {
                    waiting[k] -= 1;
                    if waiting[k] > 0 {
                        continue;
                    }
                    // All inputs decided: run, or skip when an upstream failed or on cancel.
                    let mut ups: Vec<usize> = plan.nodes[k].inputs.iter().map(|e| e.from).collect();
                    ups.sort_unstable();
                    ups.dedup();
                    let failed = ups.iter().find_map(|&u| {
                        shared.results[u].get().and_then(|o| match o.status {
                            Status::Failed => Some(o.name.clone()),
                            Status::Skipped => {
                                o.failed_upstream.clone().or_else(|| Some(o.name.clone()))
                            }
                            _ => None,
                        })
                    });
                    if failed.is_some() || shared.cancel.is_cancelled() {
                        let nd = &plan.nodes[k];
                        // After a cancel, upstream failures are usually the cancel itself.
                        let reason = match &failed {
                            _ if shared.cancel.is_cancelled() => "the run was cancelled".into(),
                            Some(f) => format!("upstream node `{f}` failed"),
                            None => "the run was cancelled".into(),
                        };
                        let out = NodeOutcome {
                            name: nd.name.clone(),
                            kind: nd.kind.kind().into(),
                            status: Status::Skipped,
                            ms: 0.0,
                            reason: reason.clone(),
                            error: None,
                            key: String::new(),
                            outputs: BTreeMap::new(),
                            failed_upstream: failed,
                        };
                        shared.emit(finished_event(&out));
                        let _ = shared.results[k].set(out);
                        let _ = shared.records[k].set(empty_record(
                            nd.kind.kind(),
                            nd.kind.version(),
                            "skipped",
                            &reason,
                        ));
                        decided.push_back(k);
                    } else {
                        running += 1;
                        spawn(k);
                    }
                }
            }
        }
    });
    drop(tx);

    let Shared {
        results,
        records,
        write_failed,
        ..
    } = shared;
    let mut nodes: Vec<NodeOutcome> = Vec::with_capacity(n);
    let mut run_rec = RunRecord {
        unix_time: crate::cache::unix_now(),
        nodes: BTreeMap::new(),
    };
    for (i, (o, r)) in results.into_iter().zip(records).enumerate() {
        let nd = &plan.nodes[i];
        let o = o.into_inner().unwrap_or_else(|| NodeOutcome {
            name: nd.name.clone(),
            kind: nd.kind.kind().into(),
            status: Status::Skipped,
            ms: 0.0,
            reason: "not reached".into(),
            error: None,
            key: String::new(),
            outputs: BTreeMap::new(),
            failed_upstream: None,
        });
        if let Some(r) = r.into_inner() {
            run_rec.nodes.insert(nd.name.clone(), r);
        }
        nodes.push(o);
    }
    let cancelled = opts.cancel.is_cancelled();
    if let Some(store) = &store {
        let mut problems = Vec::new();
        if let Err(e) = store.push_run(&graph_id, run_rec) {
            problems.push(format!("cannot save the run record: {e}"));
        }
        if let Err(e) = store.save_memo() {
            problems.push(format!("cannot save the file hash memo: {e}"));
        }
        for p in problems {
            if let Some(tx) = &opts.events {
                let _ = tx.send(Event::Warning {
                    node: None,
                    message: p,
                });
            }
        }
    }
    let cache_error = write_failed.into_inner().ok().flatten();
    let summary = RunSummary {
        nodes,
        ms: t0.elapsed().as_secs_f64() * 1e3,
        cancelled,
        cache_error,
    };
    if let Some(tx) = &opts.events {
        let _ = tx.send(Event::RunFinished {
            ran: summary.count(Status::Ran),
            cached: summary.count(Status::Cached),
            failed: summary.count(Status::Failed),
            skipped: summary.count(Status::Skipped),
            ms: (summary.ms * 1000.0).round() / 1000.0,
            cancelled,
            ok: summary.ok(),
        });
    }
    Ok(summary)
}

fn empty_record(kind: &str, version: u32, status: &str, reason: &str) -> NodeRecord {
    NodeRecord {
        kind: kind.into(),
        version,
        key: String::new(),
        params: String::new(),
        inputs: BTreeMap::new(),
        files: BTreeMap::new(),
        outputs: BTreeMap::new(),
        status: status.into(),
        reason: reason.into(),
        ms: 0.0,
    }
}

fn finished_event(o: &NodeOutcome) -> Event {
    Event::NodeFinished {
        node: o.name.clone(),
        kind: o.kind.clone(),
        status: o.status,
        ms: (o.ms * 1000.0).round() / 1000.0,
        reason: o.reason.clone(),
        output_bytes: o.output_bytes(),
        error: o.error.as_ref().map(|(k, m)| format!("{k}: {m}")),
    }
}

/// How run records name a graph: the absolute path of its file (or `<graph built in code>`).
pub fn graph_id(plan: &Plan) -> String {
    match &plan.file {
        Some(f) => graph_id_of_file(f),
        None => "<graph built in code>".into(),
    }
}

/// The run-record name of the graph in file `f` (its absolute path).
pub fn graph_id_of_file(f: &Path) -> String {
    std::fs::canonicalize(f)
        .unwrap_or_else(|_| f.to_path_buf())
        .to_string_lossy()
        .into_owned()
}

/// `crestflow why`: the last recorded decision about `node` and what differed from the run
/// before, in words.
pub fn why(store: &CacheStore, graph_id: &str, node: &str) -> Result<String, String> {
    let h = store.history(graph_id);
    let last = h.runs.last().ok_or_else(|| {
        format!(
            "no run of {graph_id} is recorded in {}",
            store.dir().display()
        )
    })?;
    let rec = last.nodes.get(node).ok_or_else(|| {
        let names: Vec<&str> = last.nodes.keys().map(String::as_str).collect();
        let hint = crate::diag::did_you_mean(node, names.iter().copied()).unwrap_or_default();
        format!("node `{node}` is not in the last run {hint}")
    })?;
    let mut s = format!(
        "{node} [{} v{}]: {} in the last run ({:.1} ms)\n  why: {}\n",
        rec.kind, rec.version, rec.status, rec.ms, rec.reason
    );
    if !rec.key.is_empty() {
        s.push_str(&format!("  key: {}\n", rec.key));
        s.push_str(&format!("  params: {}\n", rec.params));
        for (port, i) in &rec.inputs {
            s.push_str(&format!(
                "  input {port} <- {} ({})\n",
                i.from,
                short(&i.digest)
            ));
        }
        for (path, hash) in &rec.files {
            s.push_str(&format!("  file {path} ({})\n", short(hash)));
        }
        for (port, d) in &rec.outputs {
            s.push_str(&format!("  output {port} = {}\n", short(d)));
        }
    }
    Ok(s)
}

fn short(h: &str) -> &str {
    h.get(..12).unwrap_or(h)
}
