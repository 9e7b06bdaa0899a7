//! `crestflow watch GRAPH [--inputs DIR]...` (DESIGN §6): reruns a pipeline when its files
//! change.
//!
//! File events come from notify through a debouncer (a burst of writes is one change).
//! - Saving the graph re-validates it: problems are reported with their location and the last
//!   good graph (and its cached results) stays in force until the next valid save.
//! - Saving a file the pipeline reads reruns it; the content-addressed cache makes that rerun
//!   compute only the nodes that depend on the file (DESIGN §4).
//! - A mesh file (obj, off, ply, stl) created or changed in an `--inputs` folder runs the
//!   pipeline for that file, bound to the `mesh` param (or `--bind`), outputs in
//!   `<out>/<stem>` — the same convention as `run --each`.
//! - An atomic save (write a temporary file, rename it over the original) is an edit of the
//!   original. Editor swap and backup files, the cache folder and every file the pipeline
//!   writes are ignored, so a run never triggers itself.
//! - A change that arrives during a run marks the nodes it makes stale (changed signature,
//!   reads the changed file, or downstream of such a node). The run is cancelled as soon as
//!   every node still running is stale, so unaffected nodes finish and are cached, and then
//!   starts again; finished nodes come from the cache. (The engine has one cancel token per
//!   run, so a stale node that starts while unaffected ones still run keeps running until
//!   then.)
//!
//! The pipelines are those of Gehre's thesis "3D Shape Analysis based on Feature Curve
//! Networks" (§2.4–2.5 for the default one); this module only decides when to run them.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use crestflow_flow::graph::Graph;
use crestflow_flow::{
    load, resolve_path, CancelToken, Event, LoadError, Plan, Registry, RunOptions, Status,
};
use crossbeam_channel::{select, unbounded, Receiver};
use notify_debouncer_full::notify::{EventKind, RecursiveMode};
use notify_debouncer_full::{new_debouncer, DebounceEventResult};

use crate::app::{render_load_error, LogFormat, EXIT_INVALID};
use crate::batch::{
    create_out_dir, is_mesh_file, overrides_for_file, parse_sets, ron_text_as_string,
};

/// What to watch and how long.
#[derive(Clone, Debug)]
pub struct WatchOptions {
    pub graph: PathBuf,
    /// Folders whose new or changed mesh files each run the pipeline.
    pub inputs: Vec<PathBuf>,
    /// `--set` arguments as typed.
    pub sets: Vec<String>,
    /// The graph param a file from an `--inputs` folder is bound to.
    pub bind: String,
    pub cache: Option<PathBuf>,
    pub threads: usize,
    /// Quiet time that ends a burst of file events.
    pub debounce: Duration,
    /// How long an input file must go without events before its run starts: a scan still
    /// being written is not read half-way (each pause in its writing used to start a run that
    /// failed on a truncated file, or worse, read a shorter but valid OBJ).
    pub settle: Duration,
    /// Stop after this many finished runs (cancelled ones count).
    pub max_runs: Option<usize>,
    /// Stop this long after starting.
    pub exit_after: Option<Duration>,
    /// Stop when cancelled (Ctrl-C, or a test that is done).
    pub stop: CancelToken,
}

impl Default for WatchOptions {
    fn default() -> Self {
        WatchOptions {
            graph: PathBuf::new(),
            inputs: Vec::new(),
            sets: Vec::new(),
            bind: "mesh".into(),
            cache: None,
            threads: 0,
            debounce: Duration::from_millis(50),
            settle: Duration::from_millis(500),
            max_runs: None,
            exit_after: None,
            stop: CancelToken::new(),
        }
    }
}

/// What a pipeline run is for.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Target {
    /// The graph with its own params.
    Main,
    /// The graph bound to a file from an `--inputs` folder.
    File(PathBuf),
}

impl Target {
    pub fn label(&self) -> String {
        match self {
            Target::Main => "graph".into(),
            Target::File(p) => p.display().to_string(),
        }
    }
}

/// What the watcher tells its caller.
#[derive(Debug)]
pub enum WatchEvent {
    /// Watching started (folders watched).
    Watching { folders: Vec<PathBuf> },
    /// The graph file does not load; the last good graph stays in force.
    Invalid { error: Box<LoadError> },
    /// A run begins. `unix_ms`: when (for latency measurements).
    RunStarted {
        run: usize,
        target: Target,
        trigger: String,
        unix_ms: u128,
    },
    /// An engine event of run `run`.
    Engine { run: usize, event: Event },
    /// A run ended.
    RunFinished {
        run: usize,
        target: Target,
        ran: usize,
        cached: usize,
        failed: usize,
        skipped: usize,
        cancelled: bool,
        ms: f64,
    },
    /// A run was cancelled because a change made it stale.
    Restarting { run: usize, because: String },
    /// A problem that does not stop watching.
    Problem { message: String },
}

/// Why watching could not start.
#[derive(Debug, thiserror::Error)]
pub enum WatchError {
    #[error("cannot watch {path}: {message}")]
    Notify { path: PathBuf, message: String },
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{0}")]
    Usage(String),
}

fn unix_ms() -> u128 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_millis())
        .unwrap_or(0)
}

/// The absolute, normalised form of a path (canonical when it exists).
fn norm(p: &Path) -> PathBuf {
    crestflow_flow::file_identity(p)
}

/// Editor swap, backup and lock files, and other temporaries: never an edit by themselves.
pub fn is_editor_noise(p: &Path) -> bool {
    let Some(name) = p.file_name().and_then(|n| n.to_str()) else {
        return true;
    };
    name.ends_with('~')
        || name.starts_with(".#")
        || (name.starts_with('#') && name.ends_with('#'))
        || name == "4913"
        || name.starts_with('.')
        || [
            ".swp",
            ".swo",
            ".swx",
            ".tmp",
            ".part",
            ".crdownload",
            ".bak",
        ]
        .iter()
        .any(|s| name.ends_with(s))
}

/// Files and folders of the current graph, for classifying events.
#[derive(Default)]
struct Files {
    /// Files the main pipeline reads.
    inputs: BTreeSet<PathBuf>,
    /// Files any pipeline writes, and the `out` folder.
    outputs: BTreeSet<PathBuf>,
    out_dirs: BTreeSet<PathBuf>,
}

impl Files {
    fn add_plan(&mut self, plan: &Plan, main: bool) {
        for n in &plan.nodes {
            if main {
                for f in &n.params.input_files {
                    self.inputs.insert(norm(&resolve_path(&plan.base_dir, f)));
                }
            }
            for f in &n.params.output_files {
                self.outputs.insert(norm(&resolve_path(&plan.base_dir, f)));
            }
        }
    }
}

/// A classified file change.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Change {
    Graph,
    Input(PathBuf),
    NewFile(PathBuf),
}

/// What decides whether a node of a running plan is stale: per node (in topological order)
/// its signature (kind, version, canonical params, input edges), upstream nodes and files.
#[derive(Clone, Debug, Default)]
struct Shape {
    nodes: Vec<(String, String, Vec<String>, Vec<PathBuf>)>,
}

impl Shape {
    fn of(plan: &Plan) -> Shape {
        let nodes = plan
            .order
            .iter()
            .map(|&i| {
                let n = &plan.nodes[i];
                let mut edges: Vec<String> = n
                    .inputs
                    .iter()
                    .map(|e| format!("{}<-{}.{}", e.port, plan.nodes[e.from].name, e.from_port))
                    .collect();
                edges.sort();
                let sig = format!(
                    "{} v{} {} {}",
                    n.kind.kind(),
                    n.kind.version(),
                    n.params.canonical,
                    edges.join(",")
                );
                let ups = n
                    .inputs
                    .iter()
                    .map(|e| plan.nodes[e.from].name.clone())
                    .collect();
                let files = n
                    .params
                    .input_files
                    .iter()
                    .map(|f| norm(&resolve_path(&plan.base_dir, f)))
                    .collect();
                (n.name.clone(), sig, ups, files)
            })
            .collect();
        Shape { nodes }
    }

    /// Nodes of this plan whose results a change makes stale: those whose signature differs
    /// in `new` (or that `new` lacks), those reading `file`, and everything downstream.
    fn stale(&self, new: Option<&Shape>, file: Option<&Path>) -> BTreeSet<String> {
        let mut stale = BTreeSet::new();
        for (name, sig, ups, files) in &self.nodes {
            let changed =
                new.is_some_and(|n| !n.nodes.iter().any(|(m, s, _, _)| m == name && s == sig));
            let reads = file.is_some_and(|f| files.iter().any(|x| x == f));
            if changed || reads || ups.iter().any(|u| stale.contains(u)) {
                stale.insert(name.clone());
            }
        }
        stale
    }
}

struct Running {
    run: usize,
    target: Target,
    cancel: CancelToken,
    shape: Shape,
    /// Nodes running now.
    busy: BTreeSet<String>,
    /// Nodes made stale by changes since the run started, and why; the run is cancelled once
    /// every node still running is stale, so unaffected nodes finish and are cached.
    stale: BTreeSet<String>,
    because: Option<String>,
    cancelled: bool,
}

impl Running {
    fn mark_stale(
        &mut self,
        nodes: BTreeSet<String>,
        why: &str,
        emit: &(dyn Fn(WatchEvent) + Sync),
    ) {
        if nodes.is_empty() {
            return;
        }
        self.stale.extend(nodes);
        self.because.get_or_insert_with(|| why.to_string());
        self.maybe_cancel(emit);
    }

    fn maybe_cancel(&mut self, emit: &(dyn Fn(WatchEvent) + Sync)) {
        if self.cancelled || self.because.is_none() {
            return;
        }
        if self.busy.iter().all(|n| self.stale.contains(n)) {
            self.cancelled = true;
            self.cancel.cancel();
            emit(WatchEvent::Restarting {
                run: self.run,
                because: self.because.clone().unwrap_or_default(),
            });
        }
    }
}

struct State<'r> {
    registry: &'r Registry,
    graph_path: PathBuf,
    graph: Option<Graph>,
    sets: Vec<(String, String)>,
    bind: String,
    cache_dir: PathBuf,
    input_dirs: Vec<PathBuf>,
    files: Files,
    /// Files from input folders seen so far (rerun on a graph edit).
    seen: BTreeSet<PathBuf>,
    pending: VecDeque<(Target, String)>,
}

impl<'r> State<'r> {
    /// Loads the graph; on success replaces the last good one.
    fn reload(&mut self) -> Result<(), Box<LoadError>> {
        let g = Graph::from_file(&self.graph_path).map_err(Box::new)?;
        let plan = load(&g, self.registry, &self.sets).map_err(Box::new)?;
        let mut files = Files::default();
        files.add_plan(&plan, true);
        if let Some(out) = g.params.iter().find(|p| p.name == "out") {
            let v = self
                .sets
                .iter()
                .rev()
                .find(|(n, _)| n == "out")
                .map(|(_, v)| v.clone())
                .unwrap_or_else(|| out.value.clone());
            let dir = resolve_path(&g.base_dir, Path::new(&ron_text_as_string(&v)));
            files.out_dirs.insert(norm(&dir));
        }
        for f in &self.seen {
            if let Ok(ov) = overrides_for_file(&g, &self.sets, &self.bind, f) {
                if let Ok(p) = load(&g, self.registry, &ov) {
                    files.add_plan(&p, false);
                }
            }
        }
        self.files = files;
        self.graph = Some(g);
        Ok(())
    }

    fn plan_for(&self, target: &Target) -> Result<Plan<'r>, String> {
        let g = self
            .graph
            .as_ref()
            .ok_or("the graph has never loaded without errors")?;
        match target {
            Target::Main => load(g, self.registry, &self.sets).map_err(|e| e.to_string()),
            Target::File(f) => {
                let ov = overrides_for_file(g, &self.sets, &self.bind, f)?;
                let plan = load(g, self.registry, &ov).map_err(|e| e.to_string())?;
                create_out_dir(g, &ov)?;
                Ok(plan)
            }
        }
    }

    fn ignored(&self, p: &Path) -> bool {
        is_editor_noise(p)
            || p.starts_with(&self.cache_dir)
            || self.files.outputs.contains(p)
            || self.files.out_dirs.iter().any(|d| p.starts_with(d))
            || p.components().any(|c| c.as_os_str() == ".crestflow")
    }

    fn classify(&self, p: &Path) -> Option<Change> {
        if self.ignored(p) {
            return None;
        }
        if p == self.graph_path {
            return Some(Change::Graph);
        }
        if self.files.inputs.contains(p) {
            return Some(Change::Input(p.to_path_buf()));
        }
        let in_dir = p
            .parent()
            .is_some_and(|d| self.input_dirs.iter().any(|i| i == d));
        if in_dir && is_mesh_file(p) && p.is_file() {
            return Some(Change::NewFile(p.to_path_buf()));
        }
        None
    }

    fn queue(&mut self, t: Target, why: String) {
        if !self.pending.iter().any(|(x, _)| *x == t) {
            self.pending.push_back((t, why));
        }
    }

    /// Folders to watch: the graph's, the input folders, and those of the files it reads.
    fn folders(&self) -> BTreeSet<PathBuf> {
        let mut d = BTreeSet::new();
        if let Some(p) = self.graph_path.parent() {
            d.insert(p.to_path_buf());
        }
        d.extend(self.input_dirs.iter().cloned());
        for f in &self.files.inputs {
            if let Some(p) = f.parent() {
                if p.is_dir() {
                    d.insert(p.to_path_buf());
                }
            }
        }
        d
    }
}

/// Whether a notify event kind can mean new content (reads and metadata changes cannot).
fn is_content_change(k: &EventKind) -> bool {
    use notify_debouncer_full::notify::event::ModifyKind;
    match k {
        EventKind::Create(_) | EventKind::Any => true,
        EventKind::Modify(ModifyKind::Metadata(_)) => false,
        EventKind::Modify(_) => true,
        EventKind::Access(_) | EventKind::Remove(_) | EventKind::Other => false,
    }
}

/// Watches until a stop condition; returns the number of finished runs.
pub fn watch(
    registry: &Registry,
    opts: &WatchOptions,
    emit: &(dyn Fn(WatchEvent) + Sync),
) -> Result<usize, WatchError> {
    let t_start = Instant::now();
    let graph_path = std::fs::canonicalize(&opts.graph).map_err(|source| WatchError::Io {
        path: opts.graph.clone(),
        source,
    })?;
    // The graph as it is now tells which params are paths; an invalid graph is reported below.
    let sets = parse_sets(&opts.sets, Graph::from_file(&graph_path).ok().as_ref())
        .map_err(WatchError::Usage)?;
    let graph_dir = graph_path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("/"));
    let cache_dir = match &opts.cache {
        Some(c) => norm(c),
        None => graph_dir.join(".crestflow").join("cache"),
    };
    let mut input_dirs = Vec::new();
    for d in &opts.inputs {
        let c = std::fs::canonicalize(d).map_err(|source| WatchError::Io {
            path: d.clone(),
            source,
        })?;
        if !c.is_dir() {
            return Err(WatchError::Usage(format!(
                "--inputs {}: not a folder",
                d.display()
            )));
        }
        input_dirs.push(c);
    }
    let mut st = State {
        registry,
        graph_path: graph_path.clone(),
        graph: None,
        sets,
        bind: opts.bind.clone(),
        cache_dir,
        input_dirs,
        files: Files::default(),
        seen: BTreeSet::new(),
        pending: VecDeque::new(),
    };
    match st.reload() {
        Ok(()) => st.queue(Target::Main, "watch started".into()),
        Err(error) => emit(WatchEvent::Invalid { error }),
    }

    let (fs_tx, fs_rx) = unbounded::<DebounceEventResult>();
    let mut debouncer = new_debouncer(opts.debounce, None, move |r: DebounceEventResult| {
        let _ = fs_tx.send(r);
    })
    .map_err(|e| WatchError::Notify {
        path: graph_dir.clone(),
        message: e.to_string(),
    })?;
    let mut watched: BTreeSet<PathBuf> = BTreeSet::new();
    let mut sync_watches = |st: &State, watched: &mut BTreeSet<PathBuf>| -> Vec<String> {
        let mut problems = Vec::new();
        for d in st.folders() {
            if watched.contains(&d) {
                continue;
            }
            match debouncer.watch(&d, RecursiveMode::NonRecursive) {
                Ok(()) => {
                    watched.insert(d);
                }
                Err(e) => problems.push(format!("cannot watch {}: {e}", d.display())),
            }
        }
        problems
    };
    for p in sync_watches(&st, &mut watched) {
        emit(WatchEvent::Problem { message: p });
    }
    emit(WatchEvent::Watching {
        folders: watched.iter().cloned().collect(),
    });

    let (done_tx, done_rx) = unbounded::<usize>();
    // (run, node, started?) from the running pipeline, to know which nodes are busy.
    let (busy_tx, busy_rx) = unbounded::<(usize, String, bool)>();
    let mut finished = 0usize;
    let mut next_run = 0usize;
    let mut current: Option<Running> = None;
    let stop_now = |finished: usize| {
        opts.stop.is_cancelled()
            || opts.max_runs.is_some_and(|m| finished >= m)
            || opts.exit_after.is_some_and(|d| t_start.elapsed() >= d)
    };

    // Input changes wait here until their file has been quiet for `opts.settle`.
    let mut settling: BTreeMap<Change, Instant> = BTreeMap::new();
    std::thread::scope(|scope| {
        loop {
            if !settling.is_empty() {
                let now = Instant::now();
                let quiet: BTreeSet<Change> = settling
                    .iter()
                    .filter(|(_, t)| now.duration_since(**t) >= opts.settle)
                    .map(|(c, _)| c.clone())
                    .collect();
                if !quiet.is_empty() {
                    settling.retain(|c, _| !quiet.contains(c));
                    handle_changes(&mut st, quiet, &mut current, emit);
                }
            }
            if stop_now(finished) {
                if let Some(r) = &current {
                    r.cancel.cancel();
                }
                break;
            }
            // Start the next run when idle.
            if current.is_none() {
                if let Some((target, trigger)) = st.pending.pop_front() {
                    match st.plan_for(&target) {
                        Ok(plan) => {
                            next_run += 1;
                            let run = next_run;
                            let cancel = CancelToken::new();
                            emit(WatchEvent::RunStarted {
                                run,
                                target: target.clone(),
                                trigger,
                                unix_ms: unix_ms(),
                            });
                            let graph_id = match &target {
                                Target::Main => None,
                                Target::File(f) => Some(format!(
                                    "{}#each:{}",
                                    crestflow_flow::exec::graph_id_of_file(&st.graph_path),
                                    f.display()
                                )),
                            };
                            let ropts = RunOptions {
                                threads: opts.threads,
                                cache_dir: opts.cache.clone(),
                                use_cache: true,
                                cancel: cancel.clone(),
                                events: None,
                                graph_id,
                            };
                            let done_tx = done_tx.clone();
                            let busy_tx = busy_tx.clone();
                            let t = target.clone();
                            let shape = Shape::of(&plan);
                            scope.spawn(move || {
                                run_target(run, t, plan, ropts, &busy_tx, emit);
                                let _ = done_tx.send(run);
                            });
                            current = Some(Running {
                                run,
                                target,
                                cancel,
                                shape,
                                busy: BTreeSet::new(),
                                stale: BTreeSet::new(),
                                because: None,
                                cancelled: false,
                            });
                        }
                        Err(e) => emit(WatchEvent::Problem {
                            message: format!("cannot run {}: {e}", target.label()),
                        }),
                    }
                    continue;
                }
            }
            select! {
                recv(fs_rx) -> msg => {
                    let Ok(res) = msg else { break };
                    let events = match res {
                        Ok(ev) => ev,
                        Err(errs) => {
                            for e in errs {
                                emit(WatchEvent::Problem { message: format!("file watching: {e}") });
                            }
                            continue;
                        }
                    };
                    let mut changes: BTreeSet<Change> = BTreeSet::new();
                    for ev in &events {
                        if !is_content_change(&ev.event.kind) {
                            continue;
                        }
                        for p in &ev.event.paths {
                            if let Some(c) = st.classify(&norm(p)) {
                                changes.insert(c);
                            }
                        }
                    }
                    // The graph is saved at once (editors write it whole); files wait.
                    let now = Instant::now();
                    let (graph, files): (BTreeSet<Change>, BTreeSet<Change>) =
                        changes.into_iter().partition(|c| *c == Change::Graph);
                    for c in files {
                        settling.insert(c, now);
                    }
                    handle_changes(&mut st, graph, &mut current, emit);
                    for p in sync_watches(&st, &mut watched) {
                        emit(WatchEvent::Problem { message: p });
                    }
                }
                recv(busy_rx) -> msg => {
                    if let Ok((run, node, started)) = msg {
                        if let Some(r) = current.as_mut().filter(|r| r.run == run) {
                            if started {
                                r.busy.insert(node);
                            } else {
                                r.busy.remove(&node);
                            }
                            r.maybe_cancel(emit);
                        }
                    }
                }
                recv(done_rx) -> msg => {
                    if let Ok(run) = msg {
                        if current.as_ref().is_some_and(|r| r.run == run) {
                            current = None;
                        }
                        finished += 1;
                    }
                }
                default(Duration::from_millis(50)) => {}
            }
        }
    });
    Ok(finished)
}

fn handle_changes(
    st: &mut State,
    changes: BTreeSet<Change>,
    current: &mut Option<Running>,
    emit: &(dyn Fn(WatchEvent) + Sync),
) {
    let name = |p: &Path| {
        p.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| p.display().to_string())
    };
    for c in changes {
        match c {
            Change::Graph => match st.reload() {
                Ok(()) => {
                    let why = format!("{} changed", name(&st.graph_path));
                    if let Some(r) = current.as_mut() {
                        let new = st.plan_for(&r.target).ok().map(|p| Shape::of(&p));
                        // A plan that no longer loads for this target: all of it is stale.
                        let stale = match &new {
                            Some(n) => r.shape.stale(Some(n), None),
                            None => r.shape.stale(Some(&Shape::default()), None),
                        };
                        r.mark_stale(stale, &why, emit);
                        st.queue(r.target.clone(), why.clone());
                    }
                    st.queue(Target::Main, why.clone());
                    let seen: Vec<PathBuf> = st.seen.iter().cloned().collect();
                    for f in seen {
                        st.queue(Target::File(f), why.clone());
                    }
                }
                Err(error) => emit(WatchEvent::Invalid { error }),
            },
            Change::Input(p) => {
                let why = format!("input file {} changed", name(&p));
                if let Some(r) = current.as_mut() {
                    let stale = r.shape.stale(None, Some(&p));
                    r.mark_stale(stale, &why, emit);
                    st.queue(r.target.clone(), why.clone());
                }
                st.queue(Target::Main, why.clone());
                let seen: Vec<PathBuf> = st.seen.iter().cloned().collect();
                for f in seen {
                    st.queue(Target::File(f), why.clone());
                }
            }
            Change::NewFile(p) => {
                let why = if st.seen.insert(p.clone()) {
                    // Its outputs must not trigger runs either.
                    if let Some(g) = &st.graph {
                        if let Ok(ov) = overrides_for_file(g, &st.sets, &st.bind, &p) {
                            if let Ok(plan) = load(g, st.registry, &ov) {
                                st.files.add_plan(&plan, false);
                            }
                        }
                    }
                    format!("new file {}", name(&p))
                } else {
                    format!("{} changed", name(&p))
                };
                if let Some(r) = current
                    .as_mut()
                    .filter(|r| r.target == Target::File(p.clone()))
                {
                    let stale = r.shape.stale(None, Some(&p));
                    r.mark_stale(stale, &why, emit);
                }
                st.queue(Target::File(p), why);
            }
        }
    }
}

fn run_target(
    run: usize,
    target: Target,
    plan: Plan<'_>,
    mut ropts: RunOptions,
    busy: &crossbeam_channel::Sender<(usize, String, bool)>,
    emit: &(dyn Fn(WatchEvent) + Sync),
) {
    let t0 = Instant::now();
    let (tx, rx): (_, Receiver<Event>) = unbounded();
    ropts.events = Some(tx);
    let result = std::thread::scope(|s| {
        let h = s.spawn(|| crestflow_flow::run(&plan, &ropts));
        for e in rx.iter() {
            let done = matches!(e, Event::RunFinished { .. });
            match &e {
                Event::NodeStarted { node, .. } => {
                    let _ = busy.send((run, node.clone(), true));
                }
                Event::NodeFinished { node, .. } => {
                    let _ = busy.send((run, node.clone(), false));
                }
                _ => {}
            }
            emit(WatchEvent::Engine { run, event: e });
            if done {
                break;
            }
        }
        h.join()
    });
    match result {
        Ok(Ok(s)) => emit(WatchEvent::RunFinished {
            run,
            target,
            ran: s.count(Status::Ran),
            cached: s.count(Status::Cached),
            failed: s.count(Status::Failed),
            skipped: s.count(Status::Skipped),
            cancelled: s.cancelled,
            ms: t0.elapsed().as_secs_f64() * 1e3,
        }),
        Ok(Err(e)) => {
            emit(WatchEvent::Problem {
                message: format!("run {run} could not start: {e}"),
            });
            emit(WatchEvent::RunFinished {
                run,
                target,
                ran: 0,
                cached: 0,
                failed: 0,
                skipped: 0,
                cancelled: false,
                ms: t0.elapsed().as_secs_f64() * 1e3,
            });
        }
        Err(_) => emit(WatchEvent::Problem {
            message: format!("run {run}: the executor panicked"),
        }),
    }
}

/// The JSON form of a watch event (engine events keep their own shape plus `run`).
pub fn to_json(e: &WatchEvent) -> serde_json::Value {
    use serde_json::json;
    match e {
        WatchEvent::Watching { folders } => json!({
            "event": "watch_ready",
            "folders": folders.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        }),
        WatchEvent::Invalid { error } => json!({
            "event": "watch_invalid",
            "problems": error.diagnostics.len(),
            "message": error.to_string(),
        }),
        WatchEvent::RunStarted {
            run,
            target,
            trigger,
            unix_ms,
        } => json!({
            "event": "watch_run_started",
            "run": run,
            "target": target.label(),
            "trigger": trigger,
            "unix_ms": *unix_ms as u64,
        }),
        WatchEvent::Engine { run, event } => {
            let mut v = serde_json::to_value(event).unwrap_or(serde_json::Value::Null);
            if let Some(o) = v.as_object_mut() {
                o.insert("run".into(), json!(run));
            }
            v
        }
        WatchEvent::RunFinished {
            run,
            target,
            ran,
            cached,
            failed,
            skipped,
            cancelled,
            ms,
        } => json!({
            "event": "watch_run_finished",
            "run": run,
            "target": target.label(),
            "ran": ran, "cached": cached, "failed": failed, "skipped": skipped,
            "cancelled": cancelled,
            "ms": (ms * 1000.0).round() / 1000.0,
        }),
        WatchEvent::Restarting { run, because } => json!({
            "event": "watch_restart",
            "run": run,
            "because": because,
        }),
        WatchEvent::Problem { message } => json!({
            "event": "watch_problem",
            "message": message,
        }),
    }
}

/// Human-readable rendering on stderr: what ran and why.
pub fn render_human(e: &WatchEvent) {
    match e {
        WatchEvent::Watching { folders } => {
            eprintln!(
                "watching {} folder{} (Ctrl-C to stop)",
                folders.len(),
                if folders.len() == 1 { "" } else { "s" }
            );
        }
        WatchEvent::Invalid { error } => {
            render_load_error(error);
            eprintln!("keeping the last good graph; waiting for the next save");
        }
        WatchEvent::RunStarted {
            run,
            target,
            trigger,
            ..
        } => eprintln!("\n[run {run}] {trigger}: running {}", target.label()),
        WatchEvent::Engine { run, event } => match event {
            Event::NodeFinished {
                node,
                status,
                ms,
                reason,
                error,
                ..
            } if *status != Status::Cached => {
                let mut s = format!("[run {run}] {:>7} {node} ({ms:.1} ms): {reason}", status.as_str());
                if let Some(err) = error {
                    s.push_str(&format!("; error: {err}"));
                }
                eprintln!("{s}");
            }
            Event::Warning { node, message } => eprintln!(
                "[run {run}] warning{}: {message}",
                node.as_ref().map(|n| format!(" [{n}]")).unwrap_or_default()
            ),
            Event::Report { node, port, values } => {
                let items: Vec<String> = values
                    .as_object()
                    .map(|o| {
                        o.iter()
                            .map(|(k, v)| match v {
                                serde_json::Value::Number(n) => format!(
                                    "{k}={}",
                                    crate::experiment::fmt_sig(n.as_f64().unwrap_or(f64::NAN))
                                ),
                                serde_json::Value::String(s) => format!("{k}={s}"),
                                other => format!("{k}={other}"),
                            })
                            .collect()
                    })
                    .unwrap_or_default();
                eprintln!("[run {run}] report {node}.{port}: {}", items.join(" "))
            }
            _ => {}
        },
        WatchEvent::RunFinished {
            run,
            ran,
            cached,
            failed,
            skipped,
            cancelled,
            ms,
            ..
        } => eprintln!(
            "[run {run}] {ran} ran, {cached} cached, {failed} failed, {skipped} skipped in {ms:.1} ms{}",
            if *cancelled { " (cancelled)" } else { "" }
        ),
        WatchEvent::Restarting { run, because } => {
            eprintln!("[run {run}] {because}: cancelling the stale run to start again")
        }
        WatchEvent::Problem { message } => eprintln!("warning: {message}"),
    }
}

/// The `watch` command; returns the exit code.
pub fn watch_cmd(registry: &Registry, opts: WatchOptions, log: LogFormat) -> i32 {
    {
        let c = opts.stop.clone();
        let _ = ctrlc::set_handler(move || {
            if c.is_cancelled() {
                std::process::exit(130);
            }
            c.cancel();
        });
    }
    let lock = std::sync::Mutex::new(());
    let emit = |e: WatchEvent| {
        let _g = lock.lock();
        match log {
            LogFormat::Json => {
                if let WatchEvent::Invalid { error } = &e {
                    // Locations for people too.
                    render_load_error(error);
                    eprintln!("keeping the last good graph; waiting for the next save");
                }
                let mut out = std::io::stdout().lock();
                let _ = writeln!(out, "{}", to_json(&e));
                let _ = out.flush();
            }
            LogFormat::Human => render_human(&e),
        }
    };
    match watch(registry, &opts, &emit) {
        Ok(n) => {
            eprintln!("stopped after {n} run{}", if n == 1 { "" } else { "s" });
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_INVALID
        }
    }
}
