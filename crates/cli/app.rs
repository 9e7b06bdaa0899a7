//! The command line (DESIGN §5, §8): parses arguments with clap, loads graphs, runs them and
//! renders what the engine reports. This is the only place that renders: load diagnostics with
//! miette (file:line:column and a snippet), progress bars with indicatif, the end-of-run table
//! and the JSON event log.

use std::collections::{BTreeMap, BTreeSet};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand, ValueEnum};
use crestflow_flow::{
    exec, parse_set_for, CacheStore, CancelToken, Event, Graph, LoadError, Plan, Registry,
    RunOptions, Status,
};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Exit code: a node failed (or the run was cancelled).
pub const EXIT_FAILED: i32 = 1;
/// Exit code: the graph is invalid or the command line is wrong.
pub const EXIT_INVALID: i32 = 2;

#[derive(Parser, Debug)]
#[command(
    name = "crestflow",
    version,
    about = "Feature curve networks as typed, cached data-flow pipelines"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LogFormat {
    /// Progress bars and a summary table on stderr.
    Human,
    /// One JSON object per event and line on stdout; the human summary goes to stderr.
    Json,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum GraphFormat {
    Dot,
    Mermaid,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run a pipeline: only nodes whose inputs or params changed are computed.
    Run {
        graph: PathBuf,
        /// Override a graph param: `--set mesh=path/to.off` (RON value, or a string).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        #[arg(long, value_enum, default_value_t = LogFormat::Human)]
        log: LogFormat,
        /// Neither read nor write cached values.
        #[arg(long)]
        no_cache: bool,
        /// Worker threads (0 = one per core).
        #[arg(long, default_value_t = 0, value_parser = parse_threads)]
        threads: usize,
        /// Cache folder (default: `.crestflow/cache` next to the graph file).
        #[arg(long, value_name = "DIR")]
        cache: Option<PathBuf>,
        /// Run once per file matching this glob (sorted), e.g. `--each 'scans/*.ply'`.
        #[arg(long, value_name = "GLOB")]
        each: Option<String>,
        /// With --each: the graph param each file is bound to.
        #[arg(long, value_name = "PARAM", default_value = "mesh")]
        bind: String,
        /// With --each: files processed at once.
        #[arg(long, default_value_t = 1)]
        jobs: usize,
    },
    /// Rerun a pipeline when the graph or its input files change; with --inputs, run it for
    /// every mesh file that appears in those folders.
    Watch {
        graph: PathBuf,
        /// A folder whose new or changed mesh files (obj, off, ply, stl) each run the pipeline.
        #[arg(long = "inputs", value_name = "DIR")]
        inputs: Vec<PathBuf>,
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// The graph param a file from an --inputs folder is bound to.
        #[arg(long, value_name = "PARAM", default_value = "mesh")]
        bind: String,
        #[arg(long, value_enum, default_value_t = LogFormat::Human)]
        log: LogFormat,
        #[arg(long, default_value_t = 0, value_parser = parse_threads)]
        threads: usize,
        #[arg(long, value_name = "DIR")]
        cache: Option<PathBuf>,
        /// Quiet time in milliseconds that ends a burst of file events.
        #[arg(long, value_name = "MS", default_value_t = 50)]
        debounce_ms: u64,
        /// Quiet time in milliseconds an input file needs before its run starts (a file still
        /// being written is not read).
        #[arg(long, value_name = "MS", default_value_t = 500)]
        settle_ms: u64,
        /// Stop after N finished runs.
        #[arg(long, value_name = "N")]
        max_runs: Option<usize>,
        /// Stop after this many seconds.
        #[arg(long, value_name = "SECONDS")]
        exit_after: Option<f64>,
    },
    /// Run an experiment file: variants of a graph (swapped node kinds, params, grid and zip
    /// sweeps, input meshes) on one cache, then a comparison table and plots.
    Experiment {
        file: PathBuf,
        #[arg(long, value_enum, default_value_t = LogFormat::Human)]
        log: LogFormat,
        #[arg(long, default_value_t = 0, value_parser = parse_threads)]
        threads: usize,
        /// Cache folder (default: `.crestflow/cache` next to the experiment file).
        #[arg(long, value_name = "DIR")]
        cache: Option<PathBuf>,
        /// Where to write results.csv, results.md and the plots (default: the file's `out`).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
    },
    /// Check a pipeline without running it.
    Validate {
        graph: PathBuf,
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
    },
    /// List node kinds, or describe one.
    Nodes { kind: Option<String> },
    /// Print the plan: stages, params, edges, files.
    Explain {
        graph: PathBuf,
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
    },
    /// Print the graph as Graphviz dot or Mermaid.
    Graph {
        graph: PathBuf,
        #[arg(long, value_enum, default_value_t = GraphFormat::Dot)]
        format: GraphFormat,
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
    },
    /// Why a node ran or was cached in the last run of a graph.
    Why {
        graph: PathBuf,
        node: String,
        #[arg(long, value_name = "DIR")]
        cache: Option<PathBuf>,
    },
    /// Inspect or clean a cache folder.
    Cache {
        #[command(subcommand)]
        action: CacheAction,
    },
}

#[derive(Subcommand, Debug)]
pub enum CacheAction {
    /// Entries, blobs and bytes.
    Stats(CacheArgs),
    /// Drop entries and blobs that the last recorded run of no graph uses.
    Gc {
        #[command(flatten)]
        args: CacheArgs,
        /// Also keep anything written in the last N days.
        #[arg(long, value_name = "N")]
        keep_days: Option<u64>,
    },
    /// Delete everything in the cache folder.
    Clear(CacheArgs),
}

#[derive(clap::Args, Debug)]
pub struct CacheArgs {
    /// A graph file: its cache folder is `.crestflow/cache` next to it (a folder of graphs:
    /// the one inside it).
    pub graph: Option<PathBuf>,
    /// The cache folder (default: `.crestflow/cache` next to GRAPH, or in the current folder).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
}

/// Runs the command line with the given node kinds; returns the exit code.
/// `--threads`: 0 (one per core) up to [`crestflow_flow::exec::MAX_THREADS`]; a larger
/// count is refused before a pool would try to start that many threads.
fn parse_threads(s: &str) -> Result<usize, String> {
    let n: usize = s
        .parse()
        .map_err(|_| format!("`{s}` is not a thread count (0 = one per core)"))?;
    let max = crestflow_flow::exec::MAX_THREADS;
    if n > max {
        return Err(format!("at most {max} threads (0 = one per core)"));
    }
    Ok(n)
}

pub fn main_with(registry: Registry) -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { EXIT_INVALID } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    execute(cli, &registry)
}

/// Executes parsed arguments.
pub fn execute(cli: Cli, registry: &Registry) -> i32 {
    match cli.command {
        Command::Run {
            graph,
            set,
            log,
            no_cache,
            threads,
            cache,
            each: Some(pattern),
            bind,
            jobs,
        } => crate::batch::each_cmd(
            registry,
            &graph,
            &pattern,
            &crate::batch::EachOptions {
                sets: set,
                bind,
                jobs,
                threads,
                cache,
                no_cache,
                ..Default::default()
            },
            log,
        ),
        Command::Watch {
            graph,
            inputs,
            set,
            bind,
            log,
            threads,
            cache,
            debounce_ms,
            settle_ms,
            max_runs,
            exit_after,
        } => crate::watch::watch_cmd(
            registry,
            crate::watch::WatchOptions {
                graph,
                inputs,
                sets: set,
                bind,
                cache,
                threads,
                debounce: Duration::from_millis(debounce_ms),
                settle: Duration::from_millis(settle_ms),
                max_runs,
                exit_after: exit_after.and_then(|s| Duration::try_from_secs_f64(s.max(0.0)).ok()),
                ..Default::default()
            },
            log,
        ),
        Command::Experiment {
            file,
            log,
            threads,
            cache,
            out,
        } => crate::experiment::experiment_cmd(registry, &file, log, threads, cache, out),
        Command::Run {
            graph,
            set,
            log,
            no_cache,
            threads,
            cache,
            ..
        } => run_cmd(registry, &graph, &set, log, no_cache, threads, cache),
        Command::Validate { graph, set } => match load(registry, &graph, &set) {
            Ok(plan) => {
                println!("{}: ok ({} nodes)", graph.display(), plan.nodes.len());
                0
            }
            Err(code) => code,
        },
        Command::Nodes { kind } => nodes_cmd(registry, kind.as_deref()),
        Command::Explain { graph, set } => match load(registry, &graph, &set) {
            Ok(plan) => {
                print!("{}", plan.explain());
                0
            }
            Err(code) => code,
        },
        Command::Graph { graph, format, set } => match load(registry, &graph, &set) {
            Ok(plan) => {
                match format {
                    GraphFormat::Dot => print!("{}", plan.to_dot()),
                    GraphFormat::Mermaid => print!("{}", plan.to_mermaid()),
                }
                0
            }
            Err(code) => code,
        },
        Command::Why { graph, node, cache } => {
            if graph.is_dir() {
                eprintln!(
                    "error: {} is a folder: `why` needs a graph file",
                    graph.display()
                );
                return EXIT_INVALID;
            }
            let dir = match cache_dir(Some(&graph), cache.as_deref()) {
                Ok(d) => d,
                Err(e) => {
                    eprintln!("error: {e}");
                    return EXIT_INVALID;
                }
            };
            let store = match CacheStore::open(&dir) {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("error: cannot open the cache folder {}: {e}", dir.display());
                    return EXIT_FAILED;
                }
            };
            match exec::why(&store, &exec::graph_id_of_file(&graph), &node) {
                Ok(text) => {
                    print!("{text}");
                    0
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    EXIT_INVALID
                }
            }
        }
        Command::Cache { action } => cache_cmd(action),
    }
}

/// The cache folder a `cache` command works on. GRAPH may be a graph file or the folder of
/// graphs (`graphs/` used to mean the cache of the folder above it, which `cache clear` then
/// deleted); a cache folder itself must come with `--cache`, so that no command guesses what
/// to delete.
fn cache_dir(graph: Option<&Path>, cache: Option<&Path>) -> Result<PathBuf, String> {
    if let Some(c) = cache {
        return Ok(c.to_path_buf());
    }
    let base = match graph {
        Some(g) if g.is_dir() => {
            if g.join("entries").is_dir() || g.join("blobs").is_dir() {
                return Err(format!(
                    "{} is a cache folder, not a graph: pass it as --cache {}",
                    g.display(),
                    g.display()
                ));
            }
            g.to_path_buf()
        }
        Some(g) => match g.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        },
        None => PathBuf::from("."),
    };
    Ok(base.join(".crestflow").join("cache"))
}

fn cache_cmd(action: CacheAction) -> i32 {
    let (args, keep) = match &action {
        CacheAction::Stats(a) | CacheAction::Clear(a) => (a, None),
        CacheAction::Gc { args, keep_days } => (args, *keep_days),
    };
    let dir = match cache_dir(args.graph.as_deref(), args.cache.as_deref()) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("error: {e}");
            return EXIT_INVALID;
        }
    };
    if !dir.exists() {
        // Nothing to show or clean: not an error.
        eprintln!("no cache at {}", dir.display());
        return 0;
    }
    let store = match CacheStore::open(&dir) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: cannot open the cache folder {}: {e}", dir.display());
            return EXIT_FAILED;
        }
    };
    match action {
        CacheAction::Stats(_) => {
            let s = store.stats();
            println!("cache {}", dir.display());
            println!(
                "  entries  {:>8}  {}",
                s.entries,
                human_bytes(s.entry_bytes)
            );
            println!("  blobs    {:>8}  {}", s.blobs, human_bytes(s.blob_bytes));
            println!("  graphs   {:>8}  (with run records)", s.graphs);
        }
        CacheAction::Gc { .. } => {
            let g = store.gc(keep);
            println!(
                "removed {} entries and {} blobs ({}) not used by the last run of any graph{}",
                g.entries_removed,
                g.blobs_removed,
                human_bytes(g.bytes_freed),
                keep.map(|d| format!(" and older than {d} days"))
                    .unwrap_or_default()
            );
        }
        CacheAction::Clear(_) => {
            if let Err(e) = store.clear() {
                eprintln!("error: cannot clear {}: {e}", dir.display());
                return EXIT_FAILED;
            }
            println!("cleared {}", dir.display());
        }
    }
    0
}

/// Parses `--set` arguments and loads the graph, rendering every diagnostic on failure.
pub fn load<'r>(registry: &'r Registry, graph: &Path, sets: &[String]) -> Result<Plan<'r>, i32> {
    let cwd = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    let fail = |e: LoadError| {
        render_load_error(&e);
        EXIT_INVALID
    };
    let graph = Graph::from_file(graph).map_err(fail)?;
    let mut overrides = Vec::new();
    for s in sets {
        match parse_set_for(s, &cwd, &graph) {
            Ok(o) => overrides.push(o),
            Err(e) => {
                eprintln!("error: {e}");
                return Err(EXIT_INVALID);
            }
        }
    }
    crestflow_flow::load(&graph, registry, &overrides).map_err(fail)
}

/// Prints load diagnostics with miette: file:line:column, the snippet and a label.
pub fn render_load_error(e: &LoadError) {
    let file = e
        .file
        .as_ref()
        .map(|p| p.display().to_string())
        .unwrap_or_else(|| "<graph>".into());
    let n = e.diagnostics.len();
    for d in &e.diagnostics {
        let mut diag = miette::MietteDiagnostic::new(if d.line > 0 {
            format!("{file}:{}:{}: {}", d.line, d.column, d.message)
        } else {
            d.message.clone()
        })
        .with_code(format!("crestflow::{:?}", d.kind));
        if let Some(h) = &d.help {
            diag = diag.with_help(h.clone());
        }
        match (&d.span, &e.source_text) {
            (Some(span), Some(text)) => {
                // An empty span (a position) is widened to the character there.
                let mut end = span.end.min(text.len());
                if end <= span.start && span.start < text.len() {
                    end = span.start + text[span.start..].chars().next().map_or(1, char::len_utf8);
                }
                diag = diag.with_label(miette::LabeledSpan::at(span.start..end, d.label.clone()));
                let report = miette::Report::new(diag)
                    .with_source_code(miette::NamedSource::new(&file, text.clone()));
                eprintln!("{report:?}");
            }
            _ => eprintln!("{:?}", miette::Report::new(diag)),
        }
    }
    eprintln!(
        "{file}: {n} problem{} found; nothing was run",
        if n == 1 { "" } else { "s" }
    );
}

fn nodes_cmd(registry: &Registry, kind: Option<&str>) -> i32 {
    let Some(kind) = kind else {
        println!(
            "{} node kinds (`crestflow nodes KIND` for details)",
            registry.len()
        );
        for k in registry.kinds() {
            let Some(n) = registry.get(k) else { continue };
            let ins: Vec<String> = n
                .inputs()
                .iter()
                .map(|p| {
                    format!(
                        "{}: {}{}",
                        p.name,
                        p.ty.name,
                        if p.required { "" } else { "?" }
                    )
                })
                .collect();
            let outs: Vec<String> = n
                .outputs()
                .iter()
                .map(|p| format!("{}: {}", p.name, p.ty.name))
                .collect();
            println!(
                "{k} v{}\n    ({}) -> ({})\n    params {}",
                n.version(),
                ins.join(", "),
                outs.join(", "),
                one_line(&n.default_params())
            );
            println!("    {}", first_sentence(n.doc()));
        }
        return 0;
    };
    let Some(n) = registry.get(kind) else {
        eprintln!(
            "error: unknown node kind `{kind}`{}",
            crestflow_flow::diag::did_you_mean(kind, registry.kinds())
                .map(|h| format!(" ({h})"))
                .unwrap_or_default()
        );
        return EXIT_INVALID;
    };
    println!("{} (version {})\n", n.kind(), n.version());
    println!("{}\n", n.doc());
    println!("inputs:");
    if n.inputs().is_empty() {
        println!("  (none)");
    }
    for p in n.inputs() {
        println!(
            "  {:<16} {:<24} {}{}",
            p.name,
            p.ty.name,
            if p.required { "" } else { "(optional) " },
            p.doc
        );
    }
    println!("outputs:");
    for p in n.outputs() {
        println!("  {:<16} {:<24} {}", p.name, p.ty.name, p.doc);
    }
    println!("params (defaults):\n{}", n.default_params());
    0
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Up to the first `. ` that ends a sentence (not `e.g. ` or `Def. `).
fn first_sentence(s: &str) -> &str {
    let mut from = 0;
    while let Some(k) = s[from..].find(". ") {
        let i = from + k;
        let word = s[..i]
            .rsplit(|c: char| c.is_whitespace() || c == '(')
            .next()
            .unwrap_or("");
        if word.len() > 3 && !word.contains('.') {
            return &s[..=i];
        }
        from = i + 2;
    }
    s
}

/// `1.2 MB`.
pub fn human_bytes(b: u64) -> String {
    let b = b as f64;
    if b < 1e3 {
        format!("{b} B")
    } else if b < 1e6 {
        format!("{:.1} kB", b / 1e3)
    } else if b < 1e9 {
        format!("{:.1} MB", b / 1e6)
    } else {
        format!("{:.2} GB", b / 1e9)
    }
}

fn human_ms(ms: f64) -> String {
    if ms < 1.0 {
        format!("{:.0} µs", ms * 1e3)
    } else if ms < 1e4 {
        format!("{ms:.1} ms")
    } else {
        format!("{:.1} s", ms / 1e3)
    }
}

fn run_cmd(
    registry: &Registry,
    graph: &Path,
    sets: &[String],
    log: LogFormat,
    no_cache: bool,
    threads: usize,
    cache: Option<PathBuf>,
) -> i32 {
    let plan = match load(registry, graph, sets) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let cancel = CancelToken::new();
    {
        let c = cancel.clone();
        // A second Ctrl-C ends the process at once.
        let _ = ctrlc::set_handler(move || {
            if c.is_cancelled() {
                std::process::exit(130);
            }
            c.cancel();
        });
    }
    let (tx, rx) = crossbeam_channel::unbounded::<Event>();
    let opts = RunOptions {
        threads,
        cache_dir: cache,
        use_cache: !no_cache,
        cancel: cancel.clone(),
        events: Some(tx),
        graph_id: None,
    };
    let mut renderer = Renderer::new(log);
    let result = std::thread::scope(|s| {
        let h = s.spawn(|| crestflow_flow::run(&plan, &opts));
        loop {
            match rx.recv_timeout(Duration::from_millis(100)) {
                Ok(e) => {
                    let done = matches!(e, Event::RunFinished { .. });
                    renderer.event(&e);
                    if done {
                        break;
                    }
                }
                Err(crossbeam_channel::RecvTimeoutError::Timeout) => {
                    renderer.tick();
                    if h.is_finished() {
                        break;
                    }
                }
                Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break,
            }
        }
        h.join()
    });
    // Drain what arrived after RunFinished (nothing should).
    for e in rx.try_iter() {
        renderer.event(&e);
    }
    let summary = match result {
        Ok(Ok(s)) => s,
        Ok(Err(e)) => {
            eprintln!("error: {e}");
            return EXIT_FAILED;
        }
        Err(_) => {
            eprintln!("error: the executor panicked");
            return EXIT_FAILED;
        }
    };
    renderer.summary(&plan, &summary);
    if summary.ok() && !summary.cancelled {
        0
    } else {
        EXIT_FAILED
    }
}

struct Renderer {
    log: LogFormat,
    multi: MultiProgress,
    bars: BTreeMap<String, ProgressBar>,
    /// Nodes running now, since when.
    running: BTreeMap<String, Instant>,
    /// Nodes whose bar shows a fraction (the others show a spinner).
    with_progress: BTreeSet<String>,
    reports: Vec<(String, serde_json::Value)>,
    warnings: Vec<String>,
}

impl Renderer {
    fn new(log: LogFormat) -> Self {
        Renderer {
            log,
            multi: MultiProgress::with_draw_target(ProgressDrawTarget::stderr()),
            bars: BTreeMap::new(),
            running: BTreeMap::new(),
            with_progress: BTreeSet::new(),
            reports: Vec::new(),
            warnings: Vec::new(),
        }
    }

    /// The bar of a node, created as a spinner.
    fn bar(&mut self, node: &str) -> ProgressBar {
        self.bars
            .entry(node.to_string())
            .or_insert_with(|| {
                let b = self.multi.add(ProgressBar::new(1000));
                let style = ProgressStyle::with_template("{prefix:>16} {spinner} {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner());
                b.set_style(style);
                b.set_prefix(node.to_string());
                b.enable_steady_tick(Duration::from_millis(120));
                b
            })
            .clone()
    }

    /// Gives nodes that run for more than half a second a spinner, even without progress.
    fn tick(&mut self) {
        let long: Vec<String> = self
            .running
            .iter()
            .filter(|(n, t)| {
                t.elapsed() > Duration::from_millis(500) && !self.bars.contains_key(*n)
            })
            .map(|(n, _)| n.clone())
            .collect();
        for n in long {
            self.bar(&n);
        }
    }

    fn line(&self, s: &str) {
        // indicatif draws nothing when stderr is not a terminal: print plainly then.
        if std::io::stderr().is_terminal() {
            let _ = self.multi.println(s);
        } else {
            eprintln!("{s}");
        }
    }

    fn event(&mut self, e: &Event) {
        if self.log == LogFormat::Json {
            let mut out = std::io::stdout().lock();
            let _ = writeln!(out, "{}", e.to_json_line());
            let _ = out.flush();
        }
        match e {
            Event::RunStarted {
                graph,
                nodes,
                threads,
                cache,
            } => {
                self.line(&format!(
                    "running {graph}: {nodes} nodes on {threads} threads, {}",
                    cache
                        .as_ref()
                        .map(|c| format!("cache {c}"))
                        .unwrap_or_else(|| "no cache".into())
                ));
            }
            Event::NodeProgress { node, fraction } => {
                let bar = self.bar(node);
                if !self.with_progress.contains(node) {
                    let style = ProgressStyle::with_template(
                        "{prefix:>16} [{bar:30}] {percent:>3}% {elapsed}",
                    )
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> ");
                    bar.set_style(style);
                    self.with_progress.insert(node.clone());
                }
                bar.set_position((fraction * 1000.0) as u64);
            }
            Event::NodeFinished {
                node,
                status,
                ms,
                error,
                reason,
                ..
            } => {
                self.running.remove(node);
                if let Some(b) = self.bars.remove(node) {
                    b.finish_and_clear();
                }
                let mut s = format!("{:>8} {node} ({})", status.as_str(), human_ms(*ms));
                if let Some(err) = error {
                    s.push_str(&format!(": {err}"));
                } else if *status == Status::Skipped {
                    s.push_str(&format!(": {reason}"));
                }
                self.line(&s);
            }
            Event::Warning { node, message } => {
                let s = match node {
                    Some(n) => format!("warning [{n}]: {message}"),
                    None => format!("warning: {message}"),
                };
                self.line(&s);
                self.warnings.push(s);
            }
            Event::Report { node, port, values } => {
                self.reports
                    .push((format!("{node}.{port}"), values.clone()));
            }
            Event::NodeStarted { node, .. } => {
                self.running.insert(node.clone(), Instant::now());
            }
            Event::RunFinished { .. } => {}
        }
    }

    fn summary(&mut self, plan: &Plan, s: &crestflow_flow::RunSummary) {
        for (_, b) in std::mem::take(&mut self.bars) {
            b.finish_and_clear();
        }
        let mut err = std::io::stderr().lock();
        let w = plan
            .nodes
            .iter()
            .map(|n| n.name.len())
            .max()
            .unwrap_or(4)
            .max(4);
        let kw = plan
            .nodes
            .iter()
            .map(|n| n.kind.kind().len())
            .max()
            .unwrap_or(4)
            .max(4);
        let _ = writeln!(
            err,
            "\n{:<w$}  {:<kw$}  {:<7}  {:>10}  {:>9}",
            "node", "kind", "status", "time", "output"
        );
        for &i in &plan.order {
            let Some(o) = s.node(&plan.nodes[i].name) else {
                continue;
            };
            let _ = writeln!(
                err,
                "{:<w$}  {:<kw$}  {:<7}  {:>10}  {:>9}",
                o.name,
                o.kind,
                o.status.as_str(),
                human_ms(o.ms),
                if o.outputs.is_empty() {
                    "-".to_string()
                } else {
                    human_bytes(o.output_bytes())
                }
            );
        }
        for (name, values) in &self.reports {
            let _ = writeln!(err, "\nreport {name}");
            if let Some(obj) = values.as_object() {
                let kw = obj.keys().map(String::len).max().unwrap_or(0);
                for (k, v) in obj {
                    let v = match v {
                        serde_json::Value::String(s) => s.clone(),
                        serde_json::Value::Number(n) => match n.as_f64() {
                            Some(x) if x.fract() == 0.0 && x.abs() < 1e15 => {
                                format!("{}", x as i64)
                            }
                            Some(x) => format!("{x}"),
                            None => n.to_string(),
                        },
                        serde_json::Value::Null => "NaN".into(),
                        other => other.to_string(),
                    };
                    let _ = writeln!(err, "  {k:<kw$}  {v}");
                }
            }
        }
        let failed: Vec<_> = s.failures().collect();
        if !failed.is_empty() {
            let _ = writeln!(
                err,
                "\n{} node{} failed:",
                failed.len(),
                if failed.len() == 1 { "" } else { "s" }
            );
            for o in failed {
                let (k, m) = o
                    .error
                    .clone()
                    .unwrap_or((crestflow_flow::ErrorKind::Internal, "unknown error".into()));
                let at = plan.index_of(&o.name).and_then(|i| plan.nodes[i].location);
                let loc = match (&plan.file, at) {
                    (Some(f), Some((l, c))) => format!(" at {}:{l}:{c}", f.display()),
                    (Some(f), None) => format!(" in {}", f.display()),
                    _ => String::new(),
                };
                let _ = writeln!(err, "  {} [{}]{loc}: {k}: {m}", o.name, o.kind);
            }
            let skipped = s.count(Status::Skipped);
            if skipped > 0 {
                let _ = writeln!(
                    err,
                    "  {skipped} dependent node{} skipped",
                    if skipped == 1 { " was" } else { "s were" }
                );
            }
        }
        if let Some(e) = &s.cache_error {
            let _ = writeln!(err, "\nerror: the cache could not be written: {e}");
        }
        let _ = writeln!(
            err,
            "\n{} ran, {} cached, {} failed, {} skipped in {}{}",
            s.count(Status::Ran),
            s.count(Status::Cached),
            s.count(Status::Failed),
            s.count(Status::Skipped),
            human_ms(s.ms),
            if s.cancelled { " (cancelled)" } else { "" }
        );
    }
}
