//! `crestflow run GRAPH --each 'GLOB'` (DESIGN §6): the pipeline once per matching file.
//!
//! Each file is bound to a graph param (`mesh` unless `--bind` names another), and when the
//! graph has an `out` param its outputs go to `<out>/<stem>`, so runs never overwrite each
//! other. All runs share one cache: a node whose inputs do not depend on the file (an analytic
//! reference shape, a lookup table) runs once for the whole batch. `--jobs N` runs N files at
//! once; a file whose pipeline fails does not stop the others, and the summary names it.
//!
//! The pipelines themselves are those of the thesis (Gehre, "3D Shape Analysis based on
//! Feature Curve Networks", §2.4–2.5 for the default one); this module only schedules them.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use crestflow_flow::graph::Graph;
use crestflow_flow::spanned::{self, SKind, SValue};
use crestflow_flow::{
    exec, load, parse_set, parse_set_for, CancelToken, Event, Registry, RunOptions, Status,
};

use crate::app::{render_load_error, LogFormat, EXIT_FAILED, EXIT_INVALID};

/// File extensions that count as meshes (lower case).
pub const MESH_EXTENSIONS: [&str; 4] = ["obj", "off", "ply", "stl"];

/// Whether a path names a mesh file by its extension (any case).
pub fn is_mesh_file(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| MESH_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
}

/// The string a RON value text stands for: a string's content, else the text itself.
pub fn ron_text_as_string(text: &str) -> String {
    match spanned::parse(text) {
        Ok(SValue {
            kind: SKind::Str(s),
            ..
        }) => s,
        _ => text.trim().to_string(),
    }
}

/// The file stem used to name a file's outputs (`cat-01` for `poses/cat-01.obj`).
pub fn stem_of(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "input".into())
}

/// The `--set` overrides for one input file: `sets` without `bind`, then `bind` = the file
/// (absolute), then `out` = `<out>/<stem>` when the graph has an `out` param.
pub fn overrides_for_file(
    graph: &Graph,
    sets: &[(String, String)],
    bind: &str,
    file: &Path,
) -> Result<Vec<(String, String)>, String> {
    if !graph.params.iter().any(|p| p.name == bind) {
        let names: Vec<&str> = graph.params.iter().map(|p| p.name.as_str()).collect();
        return Err(format!(
            "the graph has no param `{bind}` to bind input files to (its params: {}); \
             name one with --bind",
            if names.is_empty() {
                "none".to_string()
            } else {
                names.join(", ")
            }
        ));
    }
    let abs = std::path::absolute(file).unwrap_or_else(|_| file.to_path_buf());
    let mut out: Vec<(String, String)> = sets.iter().filter(|(n, _)| n != bind).cloned().collect();
    out.push((bind.to_string(), spanned::quote(&abs.to_string_lossy())));
    if bind != "out" {
        let current = sets
            .iter()
            .rev()
            .find(|(n, _)| n == "out")
            .map(|(_, v)| v.clone())
            .or_else(|| {
                graph
                    .params
                    .iter()
                    .find(|p| p.name == "out")
                    .map(|p| p.value.clone())
            });
        if let Some(v) = current {
            let dir = PathBuf::from(ron_text_as_string(&v)).join(stem_of(file));
            out.retain(|(n, _)| n != "out");
            out.push(("out".into(), spanned::quote(&dir.to_string_lossy())));
        }
    }
    Ok(out)
}

/// Creates the folder a file's `out` override names (nodes may expect it to exist).
pub fn create_out_dir(graph: &Graph, overrides: &[(String, String)]) -> Result<(), String> {
    if let Some((_, v)) = overrides.iter().rev().find(|(n, _)| n == "out") {
        let dir = crestflow_flow::resolve_path(&graph.base_dir, Path::new(&ron_text_as_string(v)));
        std::fs::create_dir_all(&dir)
            .map_err(|e| format!("cannot create the output folder {}: {e}", dir.display()))?;
    }
    Ok(())
}

/// Parses `--set` arguments relative to the current folder; with the graph, its path params
/// are resolved there even before they exist (`parse_set_for`).
pub fn parse_sets(sets: &[String], graph: Option<&Graph>) -> Result<Vec<(String, String)>, String> {
    let cwd = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    sets.iter()
        .map(|s| match graph {
            Some(g) => parse_set_for(s, &cwd, g),
            None => parse_set(s, &cwd),
        })
        .collect()
}

/// The files a glob pattern matches, sorted; unreadable entries are errors.
pub fn expand_glob(pattern: &str) -> Result<Vec<PathBuf>, String> {
    let paths = glob::glob(pattern).map_err(|e| format!("bad pattern `{pattern}`: {e}"))?;
    let mut files = Vec::new();
    for p in paths {
        let p = p.map_err(|e| format!("while matching `{pattern}`: {e}"))?;
        if p.is_file() {
            files.push(p);
        }
    }
    files.sort();
    Ok(files)
}

/// What `--each` should do.
#[derive(Clone, Debug)]
pub struct EachOptions {
    /// `--set` arguments as typed.
    pub sets: Vec<String>,
    /// The graph param the file is bound to.
    pub bind: String,
    /// Files processed at once (at least 1).
    pub jobs: usize,
    /// Threads per run; 0 divides the cores among the jobs.
    pub threads: usize,
    pub cache: Option<PathBuf>,
    pub no_cache: bool,
    pub cancel: CancelToken,
}

impl Default for EachOptions {
    fn default() -> Self {
        EachOptions {
            sets: Vec::new(),
            bind: "mesh".into(),
            jobs: 1,
            threads: 0,
            cache: None,
            no_cache: false,
            cancel: CancelToken::new(),
        }
    }
}

/// The outcome of one file.
#[derive(Clone, Debug)]
pub struct FileOutcome {
    pub file: PathBuf,
    pub ok: bool,
    pub ran: usize,
    pub cached: usize,
    pub failed: usize,
    pub skipped: usize,
    pub ms: f64,
    /// The first failure: `node [kind]: message`, or why the run did not start.
    pub error: Option<String>,
}

/// Why `--each` could not start at all.
#[derive(Debug, thiserror::Error)]
pub enum EachError {
    #[error("{0}")]
    Usage(String),
    #[error("{0}")]
    Graph(#[from] Box<crestflow_flow::LoadError>),
    #[error("no file matches `{0}`")]
    NoMatch(String),
}

/// Runs `graph` once per file, `jobs` at a time; `on_event(file_index, event)` sees every
/// engine event. Outcomes are in file order.
pub fn run_each(
    registry: &Registry,
    graph_path: &Path,
    files: &[PathBuf],
    opts: &EachOptions,
    on_event: &(dyn Fn(usize, &Event) + Sync),
) -> Result<Vec<FileOutcome>, EachError> {
    let graph = Graph::from_file(graph_path).map_err(|e| EachError::Graph(Box::new(e)))?;
    let sets = parse_sets(&opts.sets, Some(&graph)).map_err(EachError::Usage)?;
    // Check the graph once, bound to the first file, so an invalid graph is one error.
    if let Some(first) = files.first() {
        let ov = overrides_for_file(&graph, &sets, &opts.bind, first).map_err(EachError::Usage)?;
        load(&graph, registry, &ov).map_err(|e| EachError::Graph(Box::new(e)))?;
    }
    let jobs = opts.jobs.max(1).min(files.len().max(1));
    let threads = if opts.threads > 0 {
        opts.threads
    } else {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        (cores / jobs).max(1)
    };
    let base_id = exec::graph_id_of_file(graph_path);
    let next = AtomicUsize::new(0);
    let results: Vec<Mutex<Option<FileOutcome>>> = files.iter().map(|_| Mutex::new(None)).collect();
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                // After Ctrl-C, files not yet started are left out (reported as not run).
                if i >= files.len() || opts.cancel.is_cancelled() {
                    break;
                }
                let o = run_one(
                    registry,
                    &graph,
                    &sets,
                    &base_id,
                    &files[i],
                    opts,
                    threads,
                    &|e| on_event(i, e),
                );
                if let Ok(mut slot) = results[i].lock() {
                    *slot = Some(o);
                }
            });
        }
    });
    Ok(results
        .into_iter()
        .zip(files)
        .map(|(m, f)| {
            m.into_inner()
                .ok()
                .flatten()
                .unwrap_or_else(|| FileOutcome {
                    file: f.clone(),
                    ok: false,
                    ran: 0,
                    cached: 0,
                    failed: 0,
                    skipped: 0,
                    ms: 0.0,
                    error: Some("not run (cancelled)".into()),
                })
        })
        .collect())
}

#[allow(clippy::too_many_arguments)]
fn run_one(
    registry: &Registry,
    graph: &Graph,
    sets: &[(String, String)],
    base_id: &str,
    file: &Path,
    opts: &EachOptions,
    threads: usize,
    on_event: &dyn Fn(&Event),
) -> FileOutcome {
    let t0 = Instant::now();
    let fail = |msg: String| FileOutcome {
        file: file.to_path_buf(),
        ok: false,
        ran: 0,
        cached: 0,
        failed: 0,
        skipped: 0,
        ms: t0.elapsed().as_secs_f64() * 1e3,
        error: Some(msg),
    };
    let ov = match overrides_for_file(graph, sets, &opts.bind, file) {
        Ok(o) => o,
        Err(e) => return fail(e),
    };
    let plan = match load(graph, registry, &ov) {
        Ok(p) => p,
        Err(e) => return fail(format!("the graph does not load for this file: {e}")),
    };
    if let Err(e) = create_out_dir(graph, &ov) {
        return fail(e);
    }
    let (tx, rx) = crossbeam_channel::unbounded::<Event>();
    let run_opts = RunOptions {
        threads,
        cache_dir: opts.cache.clone(),
        use_cache: !opts.no_cache,
        cancel: opts.cancel.clone(),
        events: Some(tx),
        // One run record per input, so `why` and early cutoff compare like with like.
        graph_id: Some(format!("{base_id}#each:{}", file.display())),
    };
    let result = std::thread::scope(|s| {
        let h = s.spawn(|| crestflow_flow::run(&plan, &run_opts));
        for e in rx.iter() {
            let done = matches!(e, Event::RunFinished { .. });
            on_event(&e);
            if done {
                break;
            }
        }
        h.join()
    });
    let summary = match result {
        Ok(Ok(s)) => s,
        Ok(Err(e)) => return fail(e.to_string()),
        Err(_) => return fail("the executor panicked".into()),
    };
    let error = summary
        .failures()
        .next()
        .map(|o| {
            let (k, m) = o
                .error
                .clone()
                .unwrap_or((crestflow_flow::ErrorKind::Internal, "unknown error".into()));
            format!("{} [{}]: {k}: {m}", o.name, o.kind)
        })
        .or_else(|| summary.cancelled.then(|| "cancelled".to_string()))
        .or_else(|| summary.cache_error.clone());
    FileOutcome {
        file: file.to_path_buf(),
        ok: summary.ok() && !summary.cancelled,
        ran: summary.count(Status::Ran),
        cached: summary.count(Status::Cached),
        failed: summary.count(Status::Failed),
        skipped: summary.count(Status::Skipped),
        ms: t0.elapsed().as_secs_f64() * 1e3,
        error,
    }
}

/// The summary table (one row per file) and the failures, as text.
pub fn summary_table(outcomes: &[FileOutcome], wall_ms: f64) -> String {
    let mut s = String::new();
    let w = outcomes
        .iter()
        .map(|o| o.file.display().to_string().chars().count())
        .max()
        .unwrap_or(4)
        .max(4);
    s.push_str(&format!(
        "{:<w$}  {:<6}  {:>4}  {:>6}  {:>6}  {:>7}  {:>10}\n",
        "file", "status", "ran", "cached", "failed", "skipped", "time"
    ));
    for o in outcomes {
        s.push_str(&format!(
            "{:<w$}  {:<6}  {:>4}  {:>6}  {:>6}  {:>7}  {:>10}\n",
            o.file.display().to_string(),
            if o.ok { "ok" } else { "FAILED" },
            o.ran,
            o.cached,
            o.failed,
            o.skipped,
            format!("{:.1} ms", o.ms)
        ));
    }
    let bad: Vec<&FileOutcome> = outcomes.iter().filter(|o| !o.ok).collect();
    if !bad.is_empty() {
        s.push_str(&format!(
            "\n{} of {} files failed:\n",
            bad.len(),
            outcomes.len()
        ));
        for o in &bad {
            s.push_str(&format!(
                "  {}: {}\n",
                o.file.display(),
                o.error.as_deref().unwrap_or("failed")
            ));
        }
    }
    let secs = wall_ms / 1e3;
    s.push_str(&format!(
        "\n{} files, {} ok, {} failed in {:.2} s ({:.2} files/s)\n",
        outcomes.len(),
        outcomes.len() - bad.len(),
        bad.len(),
        secs,
        if secs > 0.0 {
            outcomes.len() as f64 / secs
        } else {
            0.0
        }
    ));
    s
}

/// The `run --each` command: returns the exit code (0 all ok, 1 a file failed, 2 usage).
pub fn each_cmd(
    registry: &Registry,
    graph: &Path,
    pattern: &str,
    opts: &EachOptions,
    log: LogFormat,
) -> i32 {
    let files = match expand_glob(pattern) {
        Ok(f) if f.is_empty() => {
            eprintln!("error: {}", EachError::NoMatch(pattern.to_string()));
            return EXIT_INVALID;
        }
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: {e}");
            return EXIT_INVALID;
        }
    };
    {
        let c = opts.cancel.clone();
        let _ = ctrlc::set_handler(move || {
            if c.is_cancelled() {
                std::process::exit(130);
            }
            c.cancel();
        });
    }
    eprintln!(
        "running {} for {} file{} ({} at a time)",
        graph.display(),
        files.len(),
        if files.len() == 1 { "" } else { "s" },
        opts.jobs.max(1)
    );
    let t0 = Instant::now();
    let out_lock = Mutex::new(());
    let on_event = |i: usize, e: &Event| {
        let _g = out_lock.lock();
        match log {
            LogFormat::Json => {
                // The engine's event with the input file added.
                let mut v = serde_json::to_value(e).unwrap_or(serde_json::Value::Null);
                if let Some(obj) = v.as_object_mut() {
                    obj.insert(
                        "input".into(),
                        serde_json::Value::String(files[i].display().to_string()),
                    );
                }
                let mut out = std::io::stdout().lock();
                let _ = writeln!(out, "{v}");
                let _ = out.flush();
            }
            LogFormat::Human => {
                if let Event::RunFinished {
                    ran,
                    cached,
                    failed,
                    ms,
                    ..
                } = e
                {
                    eprintln!(
                        "{:>8} {} ({ran} ran, {cached} cached, {:.1} ms)",
                        if *failed > 0 { "failed" } else { "done" },
                        files[i].display(),
                        ms
                    );
                }
            }
        }
    };
    let outcomes = match run_each(registry, graph, &files, opts, &on_event) {
        Ok(o) => o,
        Err(EachError::Graph(e)) => {
            render_load_error(&e);
            return EXIT_INVALID;
        }
        Err(e) => {
            eprintln!("error: {e}");
            return EXIT_INVALID;
        }
    };
    let wall = t0.elapsed().as_secs_f64() * 1e3;
    eprint!("\n{}", summary_table(&outcomes, wall));
    if log == LogFormat::Json {
        let failed: Vec<String> = outcomes
            .iter()
            .filter(|o| !o.ok)
            .map(|o| o.file.display().to_string())
            .collect();
        println!(
            "{}",
            serde_json::json!({
                "event": "each_finished",
                "files": outcomes.len(),
                "failed": failed,
                "ms": (wall * 1000.0).round() / 1000.0,
            })
        );
    }
    if outcomes.iter().all(|o| o.ok) {
        0
    } else {
        EXIT_FAILED
    }
}
