//! `crestflow experiment EXP.ron` (DESIGN §6): variants of one graph on one cache, compared in
//! a table and plots.
//!
//! An experiment file names a base graph and what to vary:
//!
//! ```ron
//! Experiment(
//!     graph: "feature-curves.ron",                       // relative to this file
//!     inputs: (param: "mesh", files: ["a.off", "b.obj"]), // optional: one run per file
//!     set: { "out": "../out/tmp" },                      // optional: graph params for all runs
//!     variants: [                                        // optional: swap kinds, set params
//!         (name: "poly", kinds: { "curvature": "curvature.polynomial" }),
//!         (name: "shop", kinds: { "curvature": "curvature.shape_operator" }),
//!     ],
//!     grid: { "ridges.min_length": [2.0, 5.0] },          // every combination
//!     zip: { "a.x": [1, 2], "b.y": [3, 4] },              // taken together, index by index
//!     plot: ["ridges.curves"],                           // optional: metrics to plot
//!     out: "../out/exp",                                 // results.csv, results.md, plots
//! )
//! ```
//!
//! A key `node.field` sets a field of a node's params; a key without a dot sets a graph param.
//! Swapping a node's kind resets its params to the new kind's defaults (the old kind's fields
//! would not fit), then the variant's `params` apply. Runs = inputs × variants × grid × zip.
//!
//! Every run uses the same cache, so whatever part of the graph two runs share is computed
//! once; running the experiment again finds finished runs in the cache and reruns failed
//! ones. When the graph has an `out` param each run writes to `<out>/runs/<run>` so runs never
//! overwrite each other's files (which would also invalidate their cache entries).
//!
//! The table has one row per run: the settings that differ between runs, every value of every
//! `Report` the run produced (`node.metric`), compute times and the status. Plots (PNG) show
//! each metric against each numeric swept param, one line per combination of the other
//! settings. The experiments compare the estimators and extractors of Gehre's thesis "3D
//! Shape Analysis based on Feature Curve Networks" (§2.4 curvature, §2.5 feature curves).

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crestflow_flow::graph::Graph;
use crestflow_flow::spanned::{self, SKind, SValue};
use crestflow_flow::{
    exec, load, resolve_path, CancelToken, Event, LoadError, Registry, RunOptions, Status,
};

use crate::app::{render_load_error, LogFormat, EXIT_FAILED, EXIT_INVALID};
use crate::batch::{ron_text_as_string, stem_of};

/// A problem with an experiment file, located.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}:{line}:{column}: {message}")]
    Invalid {
        file: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{file}: {message}")]
    Setup { file: PathBuf, message: String },
    #[error("run `{run}`: {error}")]
    Graph { run: String, error: Box<LoadError> },
    #[error("cannot write {path}: {message}")]
    Output { path: PathBuf, message: String },
}

/// One variant: a name, kind swaps and param settings.
#[derive(Clone, Debug, Default)]
pub struct Variant {
    pub name: String,
    /// node -> kind.
    pub kinds: Vec<(String, String)>,
    /// `node.field` or graph param -> RON text.
    pub params: Vec<(String, String)>,
}

/// A parsed experiment file.
#[derive(Clone, Debug)]
pub struct Experiment {
    pub file: PathBuf,
    pub graph: PathBuf,
    pub input_param: String,
    pub inputs: Vec<PathBuf>,
    pub set: Vec<(String, String)>,
    pub variants: Vec<Variant>,
    /// key -> values (RON text), in file order.
    pub grid: Vec<(String, Vec<String>)>,
    pub zip: Vec<(String, Vec<String>)>,
    pub plot: Vec<String>,
    pub out: PathBuf,
}

struct Src<'a> {
    file: &'a Path,
    text: &'a str,
}

impl Src<'_> {
    fn err(&self, offset: usize, message: impl Into<String>) -> ExperimentError {
        let (line, column) = spanned::line_col(self.text, offset);
        ExperimentError::Invalid {
            file: self.file.to_path_buf(),
            line,
            column,
            message: message.into(),
        }
    }
    fn string(&self, v: &SValue, what: &str) -> Result<String, ExperimentError> {
        v.as_str()
            .map(str::to_string)
            .ok_or_else(|| self.err(v.span.start, format!("{what} must be a string")))
    }
    fn raw(&self, v: &SValue) -> String {
        self.text[v.span.clone()].to_string()
    }
    /// `{ "key": value }` -> (key, value node).
    fn map<'v>(
        &self,
        v: &'v SValue,
        what: &str,
    ) -> Result<Vec<(String, &'v SValue)>, ExperimentError> {
        let SKind::Map(es) = &v.kind else {
            return Err(self.err(
                v.span.start,
                format!("{what} must be a map {{ \"name\": … }}"),
            ));
        };
        let mut out: Vec<(String, &SValue)> = Vec::new();
        for (k, val) in es {
            let key = self.string(k, &format!("a key of {what}"))?;
            if out.iter().any(|(n, _)| *n == key) {
                return Err(self.err(k.span.start, format!("{what}: `{key}` is given twice")));
            }
            out.push((key, val));
        }
        Ok(out)
    }
    fn list<'v>(&self, v: &'v SValue, what: &str) -> Result<&'v [SValue], ExperimentError> {
        match &v.kind {
            SKind::List(items) => Ok(items),
            _ => Err(self.err(v.span.start, format!("{what} must be a list [ … ]"))),
        }
    }
}

impl Experiment {
    /// Reads and checks an experiment file (paths in it are relative to its folder).
    pub fn from_file(path: &Path) -> Result<Experiment, ExperimentError> {
        let text =
            crestflow_geom::io::read_text_file(path).map_err(|source| ExperimentError::Io {
                path: path.to_path_buf(),
                source,
            })?;
        Self::parse(&text, path)
    }

    pub fn parse(text: &str, path: &Path) -> Result<Experiment, ExperimentError> {
        let src = Src { file: path, text };
        let base = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        // Absolute, so that bound input paths do not depend on the graph's folder.
        let base = std::fs::canonicalize(&base).unwrap_or(base);
        let root = spanned::parse(text)
            .map_err(|e| src.err(e.offset, format!("RON syntax error: {}", e.message)))?;
        let SKind::Struct { name, fields } = &root.kind else {
            return Err(src.err(
                root.span.start,
                "an experiment file is `Experiment(graph: \"…\", variants: [ … ], …)`",
            ));
        };
        if name.as_deref().is_some_and(|n| n != "Experiment") {
            return Err(src.err(root.span.start, "expected `Experiment(…)`"));
        }
        let stem = stem_of(path);
        let stem = stem.trim_end_matches(".experiment").to_string();
        let mut exp = Experiment {
            file: path.to_path_buf(),
            graph: PathBuf::new(),
            input_param: "mesh".into(),
            inputs: Vec::new(),
            set: Vec::new(),
            variants: Vec::new(),
            grid: Vec::new(),
            zip: Vec::new(),
            plot: Vec::new(),
            out: base.join("out").join(&stem),
        };
        let mut has_graph = false;
        for f in fields {
            let v = &f.value;
            match f.name.as_str() {
                "graph" => {
                    exp.graph = resolve_path(&base, Path::new(&src.string(v, "`graph`")?));
                    has_graph = true;
                }
                "out" => exp.out = resolve_path(&base, Path::new(&src.string(v, "`out`")?)),
                "inputs" => {
                    let files = match &v.kind {
                        SKind::List(_) => v,
                        SKind::Struct { fields, .. } => {
                            let mut files = None;
                            for g in fields {
                                match g.name.as_str() {
                                    "param" => {
                                        exp.input_param = src.string(&g.value, "`inputs.param`")?
                                    }
                                    "files" => files = Some(&g.value),
                                    other => {
                                        return Err(src.err(
                                            g.name_span.start,
                                            format!("unknown field `{other}` of `inputs` (expected param, files)"),
                                        ))
                                    }
                                }
                            }
                            files.ok_or_else(|| {
                                src.err(v.span.start, "`inputs` needs `files: [ … ]`")
                            })?
                        }
                        _ => {
                            return Err(src.err(
                                v.span.start,
                                "`inputs` is `(param: \"mesh\", files: [ … ])` or a list of files",
                            ))
                        }
                    };
                    for item in src.list(files, "`inputs.files`")? {
                        let p = resolve_path(&base, Path::new(&src.string(item, "an input")?));
                        if !p.is_file() {
                            return Err(src.err(
                                item.span.start,
                                format!("input file {} does not exist", p.display()),
                            ));
                        }
                        exp.inputs.push(p);
                    }
                }
                "set" => {
                    for (k, val) in src.map(v, "`set`")? {
                        exp.set.push((k, src.raw(val)));
                    }
                }
                "variants" => {
                    for item in src.list(v, "`variants`")? {
                        let SKind::Struct { fields, .. } = &item.kind else {
                            return Err(src.err(
                                item.span.start,
                                "a variant is `(name: \"…\", kinds: { … }, params: { … })`",
                            ));
                        };
                        let mut var = Variant::default();
                        for g in fields {
                            match g.name.as_str() {
                                "name" => var.name = src.string(&g.value, "a variant's name")?,
                                "kinds" => {
                                    for (node, kind) in src.map(&g.value, "`kinds`")? {
                                        var.kinds.push((node, src.string(kind, "a kind")?));
                                    }
                                }
                                "params" => {
                                    for (k, val) in src.map(&g.value, "`params`")? {
                                        var.params.push((k, src.raw(val)));
                                    }
                                }
                                other => {
                                    return Err(src.err(
                                        g.name_span.start,
                                        format!("unknown variant field `{other}` (expected name, kinds, params)"),
                                    ))
                                }
                            }
                        }
                        if var.name.is_empty() {
                            return Err(src.err(item.span.start, "a variant needs a `name`"));
                        }
                        if exp.variants.iter().any(|x| x.name == var.name) {
                            return Err(src.err(
                                item.span.start,
                                format!("two variants are named `{}`", var.name),
                            ));
                        }
                        exp.variants.push(var);
                    }
                }
                "grid" | "zip" => {
                    let mut axes = Vec::new();
                    for (k, val) in src.map(v, &format!("`{}`", f.name))? {
                        let items = src.list(val, &format!("`{}.{k}`", f.name))?;
                        if items.is_empty() {
                            return Err(src.err(val.span.start, format!("`{k}` has no values")));
                        }
                        axes.push((k, items.iter().map(|i| src.raw(i)).collect::<Vec<_>>()));
                    }
                    if f.name == "zip" {
                        if let Some((k0, v0)) = axes.first() {
                            if let Some((k, vs)) = axes.iter().find(|(_, vs)| vs.len() != v0.len())
                            {
                                return Err(src.err(
                                    v.span.start,
                                    format!(
                                        "zip lists must have equal lengths: `{k0}` has {}, `{k}` has {}",
                                        v0.len(),
                                        vs.len()
                                    ),
                                ));
                            }
                        }
                        exp.zip = axes;
                    } else {
                        exp.grid = axes;
                    }
                }
                "plot" => {
                    for item in src.list(v, "`plot`")? {
                        exp.plot.push(src.string(item, "a metric name")?);
                    }
                }
                other => {
                    return Err(src.err(
                        f.name_span.start,
                        format!(
                            "unknown experiment field `{other}` (expected graph, inputs, set, \
                             variants, grid, zip, plot, out)"
                        ),
                    ))
                }
            }
        }
        if !has_graph {
            return Err(src.err(root.span.start, "the experiment names no `graph`"));
        }
        Ok(exp)
    }
}

/// One run of an experiment, ready to load.
#[derive(Clone, Debug)]
pub struct RunSpec {
    /// A file-name-safe id, unique in the experiment.
    pub id: String,
    /// Setting -> value as shown: `input`, `variant`, and each grid/zip key.
    pub settings: Vec<(String, String)>,
    pub graph: Graph,
    pub overrides: Vec<(String, String)>,
    /// Nodes whose kind or params this run changes.
    pub touched: BTreeSet<String>,
}

fn safe(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Sets `field` to `value` (RON text) in a params text such as `(rings: 2)`.
pub fn set_param_field(params: &str, field: &str, value: &str) -> Result<String, String> {
    let text = if params.trim().is_empty() {
        "()"
    } else {
        params
    };
    let tree = spanned::parse(text).map_err(|e| format!("params `{text}`: {}", e.message))?;
    match &tree.kind {
        SKind::Struct { fields, .. } => {
            if let Some(f) = fields.iter().find(|f| f.name == field) {
                let s = &f.value.span;
                return Ok(format!("{}{value}{}", &text[..s.start], &text[s.end..]));
            }
            let end = fields.last().map(|f| f.value.span.end).unwrap_or(0);
            Ok(format!(
                "{}, {field}: {value}{}",
                &text[..end],
                &text[end..]
            ))
        }
        SKind::Tuple { items, .. } if items.is_empty() => {
            let close = text.rfind(')').ok_or("params are not `( … )`")?;
            Ok(format!(
                "{}{field}: {value}{}",
                &text[..close],
                &text[close..]
            ))
        }
        _ => Err(format!("params `{text}` are not `(field: value, …)`")),
    }
}

/// The runs of an experiment: inputs × variants × grid × zip, each with its graph.
pub fn expand(exp: &Experiment, base: &Graph) -> Result<Vec<RunSpec>, String> {
    let inputs: Vec<Option<&PathBuf>> = if exp.inputs.is_empty() {
        vec![None]
    } else {
        exp.inputs.iter().map(Some).collect()
    };
    let variants: Vec<Variant> = if exp.variants.is_empty() {
        vec![Variant {
            name: "base".into(),
            ..Default::default()
        }]
    } else {
        exp.variants.clone()
    };
    // Grid combinations in order (the last key varies fastest).
    let mut combos: Vec<Vec<(String, String)>> = vec![Vec::new()];
    for (k, vals) in &exp.grid {
        let mut next = Vec::new();
        for c in &combos {
            for v in vals {
                let mut c = c.clone();
                c.push((k.clone(), v.clone()));
                next.push(c);
            }
        }
        combos = next;
    }
    let zip_len = exp.zip.first().map_or(1, |(_, v)| v.len());
    let has_param = |name: &str| base.params.iter().any(|p| p.name == name);
    if !exp.inputs.is_empty() && !has_param(&exp.input_param) {
        return Err(format!(
            "the graph has no param `{}` to bind the inputs to",
            exp.input_param
        ));
    }
    let mut runs = Vec::new();
    let mut ids = BTreeSet::new();
    for input in &inputs {
        for var in &variants {
            for combo in &combos {
                for z in 0..zip_len {
                    let mut settings: Vec<(String, String)> = Vec::new();
                    let mut g = base.clone();
                    let mut overrides: Vec<(String, String)> = exp.set.clone();
                    let mut touched = BTreeSet::new();
                    if let Some(f) = input {
                        settings.push(("input".into(), stem_of(f)));
                        overrides.retain(|(n, _)| *n != exp.input_param);
                        overrides.push((
                            exp.input_param.clone(),
                            spanned::quote(&f.to_string_lossy()),
                        ));
                    }
                    settings.push(("variant".into(), var.name.clone()));
                    for (node, kind) in &var.kinds {
                        let n = g
                            .nodes
                            .iter_mut()
                            .find(|n| n.name == *node)
                            .ok_or_else(|| {
                                format!("variant `{}`: the graph has no node `{node}`", var.name)
                            })?;
                        if n.kind != *kind {
                            n.kind = kind.clone();
                            n.params = "()".into();
                            n.params_span = None;
                            n.kind_span = None;
                        }
                        touched.insert(node.clone());
                    }
                    let mut sets: Vec<(String, String)> = var.params.clone();
                    for (k, v) in combo {
                        settings.push((k.clone(), v.clone()));
                        sets.push((k.clone(), v.clone()));
                    }
                    for (k, vs) in &exp.zip {
                        settings.push((k.clone(), vs[z].clone()));
                        sets.push((k.clone(), vs[z].clone()));
                    }
                    for (k, v) in sets {
                        match k.split_once('.') {
                            Some((node, field)) => {
                                let n = g.nodes.iter_mut().find(|n| n.name == node).ok_or_else(
                                    || format!("`{k}`: the graph has no node `{node}`"),
                                )?;
                                n.params = set_param_field(&n.params, field, &v)
                                    .map_err(|e| format!("`{k}`: {e}"))?;
                                n.params_span = None;
                                touched.insert(node.to_string());
                            }
                            None => {
                                if !has_param(&k) {
                                    return Err(format!("`{k}`: the graph has no param `{k}`"));
                                }
                                overrides.retain(|(n, _)| *n != k);
                                overrides.push((k, v));
                            }
                        }
                    }
                    let mut id = settings
                        .iter()
                        .map(|(k, v)| {
                            if k == "input" || k == "variant" {
                                safe(v)
                            } else {
                                safe(&format!("{k}={}", ron_text_as_string(v)))
                            }
                        })
                        .collect::<Vec<_>>()
                        .join("__");
                    if !ids.insert(id.clone()) {
                        let mut k = 2;
                        while !ids.insert(format!("{id}__{k}")) {
                            k += 1;
                        }
                        id = format!("{id}__{k}");
                    }
                    if has_param("out") {
                        let dir = exp.out.join("runs").join(&id);
                        overrides.retain(|(n, _)| n != "out");
                        overrides.push(("out".into(), spanned::quote(&dir.to_string_lossy())));
                    }
                    runs.push(RunSpec {
                        id,
                        settings,
                        graph: g,
                        overrides,
                        touched,
                    });
                }
            }
        }
    }
    Ok(runs)
}

/// A cell of the results table.
#[derive(Clone, Debug, PartialEq)]
pub enum Cell {
    Num(f64),
    Text(String),
}

impl Cell {
    fn csv(&self) -> String {
        match self {
            Cell::Num(x) if x.is_finite() => format!("{x}"),
            Cell::Num(_) => "NaN".into(),
            Cell::Text(s) => csv_escape(s),
        }
    }
    fn md(&self) -> String {
        match self {
            Cell::Num(x) => fmt_sig(*x),
            Cell::Text(s) => s.replace('|', "\\|").replace('\n', " "),
        }
    }
    fn num(&self) -> Option<f64> {
        match self {
            Cell::Num(x) if x.is_finite() => Some(*x),
            _ => None,
        }
    }
}

fn csv_escape(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Four significant digits, without exponent for everyday magnitudes.
pub fn fmt_sig(x: f64) -> String {
    if !x.is_finite() {
        return "NaN".into();
    }
    if x == x.trunc() && x.abs() < 1e9 {
        return format!("{}", x as i64);
    }
    let a = x.abs();
    if (1e-3..1e6).contains(&a) {
        let digits = (3 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{x:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{x:.3e}")
    }
}

/// What one run gave.
#[derive(Clone, Debug)]
pub struct RunResult {
    pub id: String,
    pub settings: Vec<(String, String)>,
    pub status: String,
    pub ran: usize,
    pub cached: usize,
    /// `node.metric` -> value, from every Report output.
    pub metrics: BTreeMap<String, Cell>,
    /// node -> compute time in ms (for cached nodes: the time of the run that computed it).
    pub node_ms: BTreeMap<String, f64>,
    pub touched: BTreeSet<String>,
}

/// The whole experiment's outcome.
#[derive(Clone, Debug)]
pub struct ExperimentResult {
    pub runs: Vec<RunResult>,
    pub out: PathBuf,
    pub plots: Vec<PathBuf>,
}

impl ExperimentResult {
    pub fn failed(&self) -> usize {
        self.runs.iter().filter(|r| r.status != "ok").count()
    }
}

/// How to run an experiment.
#[derive(Clone, Debug, Default)]
pub struct ExperimentOptions {
    pub threads: usize,
    /// Default: `.crestflow/cache` next to the experiment file.
    pub cache: Option<PathBuf>,
    /// Default: the file's `out`.
    pub out: Option<PathBuf>,
    pub cancel: CancelToken,
}

/// Loads every run (all problems before anything runs), runs them in order on one cache and
/// writes `results.csv`, `results.md` and the plots.
pub fn run_experiment(
    registry: &Registry,
    exp: &Experiment,
    opts: &ExperimentOptions,
    on_event: &mut dyn FnMut(&str, &Event),
) -> Result<ExperimentResult, ExperimentError> {
    let base = Graph::from_file(&exp.graph).map_err(|e| ExperimentError::Graph {
        run: "base graph".into(),
        error: Box::new(e),
    })?;
    let specs = expand(exp, &base).map_err(|message| ExperimentError::Setup {
        file: exp.file.clone(),
        message,
    })?;
    let mut plans = Vec::new();
    for s in &specs {
        let plan = load(&s.graph, registry, &s.overrides).map_err(|e| ExperimentError::Graph {
            run: s.id.clone(),
            error: Box::new(e),
        })?;
        plans.push(plan);
    }
    let out = opts.out.clone().unwrap_or_else(|| exp.out.clone());
    std::fs::create_dir_all(&out).map_err(|e| ExperimentError::Output {
        path: out.clone(),
        message: e.to_string(),
    })?;
    let cache_dir = opts.cache.clone().unwrap_or_else(|| {
        exp.file
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .join(".crestflow")
            .join("cache")
    });
    let timings_path = out.join("timings.json");
    // Compute times by cache key, so rows whose nodes came from the cache (a resumed
    // experiment, or a prefix another run computed) still show what those nodes cost.
    let mut timings: BTreeMap<String, f64> = std::fs::read(&timings_path)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_default();
    let exp_id = exec::graph_id_of_file(&exp.file);
    let mut results = Vec::new();
    for (spec, plan) in specs.iter().zip(&plans) {
        let (tx, rx) = crossbeam_channel::unbounded::<Event>();
        let ropts = RunOptions {
            threads: opts.threads,
            cache_dir: Some(cache_dir.clone()),
            use_cache: true,
            cancel: opts.cancel.clone(),
            events: Some(tx),
            graph_id: Some(format!("{exp_id}#{}", spec.id)),
        };
        let mut metrics = BTreeMap::new();
        let mut node_ms = BTreeMap::new();
        let res = std::thread::scope(|s| {
            let h = s.spawn(|| crestflow_flow::run(plan, &ropts));
            for e in rx.iter() {
                on_event(&spec.id, &e);
                if let Event::Report { node, values, .. } = &e {
                    for (k, v) in values.as_object().into_iter().flatten() {
                        let c = match v {
                            serde_json::Value::Number(n) => {
                                Cell::Num(n.as_f64().unwrap_or(f64::NAN))
                            }
                            serde_json::Value::Null => Cell::Num(f64::NAN),
                            serde_json::Value::String(s) => Cell::Text(s.clone()),
                            other => Cell::Text(other.to_string()),
                        };
                        metrics.insert(format!("{node}.{k}"), c);
                    }
                }
                if matches!(e, Event::RunFinished { .. }) {
                    break;
                }
            }
            h.join()
        });
        let (status, ran, cached) = match res {
            Ok(Ok(s)) => {
                for o in &s.nodes {
                    match o.status {
                        Status::Ran => {
                            timings.insert(o.key.clone(), o.ms);
                            node_ms.insert(o.name.clone(), o.ms);
                        }
                        Status::Cached => {
                            if let Some(t) = timings.get(&o.key) {
                                node_ms.insert(o.name.clone(), *t);
                            }
                        }
                        _ => {}
                    }
                }
                let status = if s.cancelled {
                    "cancelled".to_string()
                } else if let Some(f) = s.failures().next() {
                    format!(
                        "failed: {} ({})",
                        f.name,
                        f.error.as_ref().map(|(_, m)| m.as_str()).unwrap_or("error")
                    )
                } else if let Some(e) = &s.cache_error {
                    format!("failed: {e}")
                } else if !s.ok() {
                    "failed".into()
                } else {
                    "ok".into()
                };
                (status, s.count(Status::Ran), s.count(Status::Cached))
            }
            Ok(Err(e)) => (format!("failed: {e}"), 0, 0),
            Err(_) => ("failed: the executor panicked".into(), 0, 0),
        };
        results.push(RunResult {
            id: spec.id.clone(),
            settings: spec.settings.clone(),
            status,
            ran,
            cached,
            metrics,
            node_ms,
            touched: spec.touched.clone(),
        });
        if opts.cancel.is_cancelled() {
            break;
        }
    }
    let write = |path: PathBuf, bytes: &[u8]| -> Result<(), ExperimentError> {
        std::fs::write(&path, bytes).map_err(|e| ExperimentError::Output {
            path,
            message: e.to_string(),
        })
    };
    if let Ok(j) = serde_json::to_vec_pretty(&timings) {
        write(timings_path, &j)?;
    }
    let table = Table::new(&results);
    write(out.join("results.csv"), table.csv().as_bytes())?;
    write(out.join("results.md"), table.markdown().as_bytes())?;
    let plots = crate::experiment::plots::write_plots(exp, &results, &out)
        .map_err(|(path, message)| ExperimentError::Output { path, message })?;
    Ok(ExperimentResult {
        runs: results,
        out,
        plots,
    })
}

/// The comparison table: settings that differ, metrics, times, status.
pub struct Table {
    pub columns: Vec<String>,
    pub rows: Vec<Vec<Cell>>,
}

impl Table {
    pub fn new(results: &[RunResult]) -> Table {
        // Settings that differ between runs, in first-seen order.
        let mut setting_names: Vec<String> = Vec::new();
        for r in results {
            for (k, _) in &r.settings {
                if !setting_names.contains(k) {
                    setting_names.push(k.clone());
                }
            }
        }
        let value = |r: &RunResult, k: &str| {
            r.settings
                .iter()
                .find(|(n, _)| n == k)
                .map(|(_, v)| v.clone())
        };
        let differing: Vec<String> = setting_names
            .into_iter()
            .filter(|k| {
                let vals: BTreeSet<Option<String>> = results.iter().map(|r| value(r, k)).collect();
                vals.len() > 1
            })
            .collect();
        let metrics: BTreeSet<&String> = results.iter().flat_map(|r| r.metrics.keys()).collect();
        // Times of the nodes that the variants change, and the total.
        let touched: BTreeSet<&String> = results.iter().flat_map(|r| r.touched.iter()).collect();
        let mut columns: Vec<String> = vec!["run".into()];
        columns.extend(differing.iter().cloned());
        columns.extend(metrics.iter().map(|m| m.to_string()));
        columns.extend(touched.iter().map(|n| format!("{n}.ms")));
        columns.extend(["total_ms", "ran", "cached", "status"].map(String::from));
        let mut rows = Vec::new();
        for r in results {
            let mut row = vec![Cell::Text(r.id.clone())];
            for k in &differing {
                let v = value(r, k).unwrap_or_default();
                row.push(match v.parse::<f64>() {
                    Ok(x) => Cell::Num(x),
                    Err(_) => Cell::Text(ron_text_as_string(&v)),
                });
            }
            for m in &metrics {
                row.push(
                    r.metrics
                        .get(*m)
                        .cloned()
                        .unwrap_or(Cell::Text(String::new())),
                );
            }
            for n in &touched {
                row.push(
                    r.node_ms
                        .get(*n)
                        .map(|x| Cell::Num((x * 1000.0).round() / 1000.0))
                        .unwrap_or(Cell::Text(String::new())),
                );
            }
            let total: f64 = r.node_ms.values().sum();
            row.push(Cell::Num((total * 1000.0).round() / 1000.0));
            row.push(Cell::Num(r.ran as f64));
            row.push(Cell::Num(r.cached as f64));
            row.push(Cell::Text(r.status.clone()));
            rows.push(row);
        }
        Table { columns, rows }
    }

    pub fn csv(&self) -> String {
        let mut s = self
            .columns
            .iter()
            .map(|c| csv_escape(c))
            .collect::<Vec<_>>()
            .join(",");
        s.push('\n');
        for r in &self.rows {
            s.push_str(&r.iter().map(Cell::csv).collect::<Vec<_>>().join(","));
            s.push('\n');
        }
        s
    }

    pub fn markdown(&self) -> String {
        let mut s = format!("| {} |\n", self.columns.join(" | "));
        s.push_str(&format!(
            "|{}\n",
            self.columns.iter().map(|_| "---|").collect::<String>()
        ));
        for r in &self.rows {
            s.push_str(&format!(
                "| {} |\n",
                r.iter().map(Cell::md).collect::<Vec<_>>().join(" | ")
            ));
        }
        s
    }

    /// The value of `column` in row `row`.
    pub fn get(&self, row: usize, column: &str) -> Option<&Cell> {
        let c = self.columns.iter().position(|x| x == column)?;
        self.rows.get(row)?.get(c)
    }
}

pub mod plots;

/// The `experiment` command; returns the exit code.
pub fn experiment_cmd(
    registry: &Registry,
    file: &Path,
    log: LogFormat,
    threads: usize,
    cache: Option<PathBuf>,
    out: Option<PathBuf>,
) -> i32 {
    let exp = match Experiment::from_file(file) {
        Ok(e) => e,
        Err(e) => {
            eprintln!("error: {e}");
            return EXIT_INVALID;
        }
    };
    let cancel = CancelToken::new();
    {
        let c = cancel.clone();
        let _ = ctrlc::set_handler(move || {
            if c.is_cancelled() {
                std::process::exit(130);
            }
            c.cancel();
        });
    }
    let opts = ExperimentOptions {
        threads,
        cache,
        out,
        cancel,
    };
    let t0 = Instant::now();
    let mut on_event = |run: &str, e: &Event| match log {
        LogFormat::Json => {
            let mut v = serde_json::to_value(e).unwrap_or(serde_json::Value::Null);
            if let Some(o) = v.as_object_mut() {
                o.insert("run".into(), serde_json::Value::String(run.to_string()));
            }
            let mut out = std::io::stdout().lock();
            let _ = writeln!(out, "{v}");
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
                    "{:>8} {run}: {ran} ran, {cached} cached, {failed} failed ({ms:.1} ms)",
                    if *failed > 0 { "failed" } else { "done" }
                );
            }
        }
    };
    match run_experiment(registry, &exp, &opts, &mut on_event) {
        Ok(r) => {
            eprintln!(
                "\n{} runs ({} failed) in {:.2} s",
                r.runs.len(),
                r.failed(),
                t0.elapsed().as_secs_f64()
            );
            eprintln!("wrote {}", r.out.join("results.csv").display());
            eprintln!("wrote {}", r.out.join("results.md").display());
            for p in &r.plots {
                eprintln!("wrote {}", p.display());
            }
            if r.failed() > 0 {
                EXIT_FAILED
            } else {
                0
            }
        }
        Err(ExperimentError::Graph { run, error }) => {
            eprintln!("error: run `{run}` does not load:");
            render_load_error(&error);
            EXIT_INVALID
        }
        Err(e @ ExperimentError::Output { .. }) => {
            eprintln!("error: {e}");
            EXIT_FAILED
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_INVALID
        }
    }
}
