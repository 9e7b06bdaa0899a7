//! A toy node family for the engine's own tests and benchmarks (numbers and text, no
//! geometry), plus helpers to run a graph and collect its event log.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::time::Duration;

pub mod cli;

use crestflow_flow::{
    check_range, CancelToken, Ctx, Event, Inputs, NodeError, NodeKind, Outputs, ParamIssue, Port,
    Registry, Report, RunOptions, RunSummary, Status, Validate,
};
use serde::{Deserialize, Serialize};

/// `toy.const`: outputs `value`.
pub struct Const;
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConstParams {
    pub value: f64,
}
impl Default for ConstParams {
    fn default() -> Self {
        ConstParams { value: 1.0 }
    }
}
impl Validate for ConstParams {}
impl NodeKind for Const {
    type Params = ConstParams;
    const KIND: &'static str = "toy.const";
    const VERSION: u32 = 1;
    const DOC: &'static str = "A constant number.";
    fn inputs() -> Vec<Port> {
        vec![]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<f64>("value", "the number")]
    }
    fn run(p: &ConstParams, _: &Inputs, _: &Ctx) -> Result<Outputs, NodeError> {
        Ok(Outputs::new().with("value", p.value))
    }
}

/// `toy.add`: `a + b + offset` (`b` optional).
pub struct Add;
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AddParams {
    /// Added to the sum; in [-1000, 1000].
    pub offset: f64,
}
impl Validate for AddParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "offset", self.offset, -1000.0, 1000.0);
        v
    }
}
impl NodeKind for Add {
    type Params = AddParams;
    const KIND: &'static str = "toy.add";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Adds two numbers.";
    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<f64>("a", "first"),
            Port::optional::<f64>("b", "second"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<f64>("sum", "a + b + offset")]
    }
    fn run(p: &AddParams, i: &Inputs, _: &Ctx) -> Result<Outputs, NodeError> {
        let a = *i.get::<f64>("a")?;
        let b = i.opt::<f64>("b")?.copied().unwrap_or(0.0);
        Ok(Outputs::new().with("sum", a + b + p.offset))
    }
}

/// `toy.round`: rounds to an integer (so small upstream edits leave its output unchanged).
pub struct Round;
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoParams {}
impl Validate for NoParams {}
impl NodeKind for Round {
    type Params = NoParams;
    const KIND: &'static str = "toy.round";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Rounds a number.";
    fn inputs() -> Vec<Port> {
        vec![Port::of::<f64>("x", "input")]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<f64>("value", "rounded")]
    }
    fn run(_: &NoParams, i: &Inputs, _: &Ctx) -> Result<Outputs, NodeError> {
        Ok(Outputs::new().with("value", i.get::<f64>("x")?.round()))
    }
}

/// `toy.sum_vec`: a parallel sum of `n` terms with a fixed-order reduction.
pub struct SumVec;
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SumVecParams {
    pub n: usize,
}
impl Default for SumVecParams {
    fn default() -> Self {
        SumVecParams { n: 1000 }
    }
}
impl Validate for SumVecParams {}
impl NodeKind for SumVec {
    type Params = SumVecParams;
    const KIND: &'static str = "toy.sum_vec";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Per-element terms computed in parallel, summed in index order.";
    fn inputs() -> Vec<Port> {
        vec![Port::of::<f64>("x", "scale")]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<Vec<f64>>("terms", "the terms"),
            Port::of::<f64>("sum", "their sum"),
        ]
    }
    fn run(p: &SumVecParams, i: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let x = *i.get::<f64>("x")?;
        let terms = ctx
            .par
            .map_collect(p.n, |k| (x * (k as f64 + 0.5)).sin() / (k as f64 + 1.0));
        let sum: f64 = terms.iter().sum();
        Ok(Outputs::new().with("terms", terms).with("sum", sum))
    }
}

/// `toy.vec_sum`: `scale` × the sum of a vector, in index order.
pub struct VecSum;
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VecSumParams {
    pub scale: f64,
}
impl Default for VecSumParams {
    fn default() -> Self {
        VecSumParams { scale: 1.0 }
    }
}
impl Validate for VecSumParams {}
impl NodeKind for VecSum {
    type Params = VecSumParams;
    const KIND: &'static str = "toy.vec_sum";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Sums a vector.";
    fn inputs() -> Vec<Port> {
        vec![Port::of::<Vec<f64>>("v", "the vector")]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<f64>("sum", "scale × sum")]
    }
    fn run(p: &VecSumParams, i: &Inputs, _: &Ctx) -> Result<Outputs, NodeError> {
        let s: f64 = i.get::<Vec<f64>>("v")?.iter().sum();
        Ok(Outputs::new().with("sum", p.scale * s))
    }
}

/// `toy.read_file`: a text file's content.
pub struct ReadFile;
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PathParams {
    pub path: String,
}
impl Validate for PathParams {
    fn validate(&self) -> Vec<ParamIssue> {
        if self.path.is_empty() {
            vec![ParamIssue::new("path", "must not be empty")]
        } else {
            vec![]
        }
    }
}
impl NodeKind for ReadFile {
    type Params = PathParams;
    const KIND: &'static str = "toy.read_file";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Reads a file as bytes.";
    fn inputs() -> Vec<Port> {
        vec![]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<Vec<u8>>("bytes", "content"),
            Port::of::<f64>("len", "length in bytes"),
        ]
    }
    fn input_files(p: &PathParams) -> Vec<PathBuf> {
        vec![PathBuf::from(&p.path)]
    }
    fn run(p: &PathParams, _: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let path = ctx.resolve(&p.path);
        let bytes = std::fs::read(&path).map_err(|e| {
            NodeError::invalid_input(format!("cannot read {}: {e}", path.display()))
        })?;
        let len = bytes.len() as f64;
        Ok(Outputs::new().with("bytes", bytes).with("len", len))
    }
}

/// `toy.write_text`: writes a number as text to a file.
pub struct WriteText;
impl NodeKind for WriteText {
    type Params = PathParams;
    const KIND: &'static str = "toy.write_text";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Writes a number to a text file.";
    fn inputs() -> Vec<Port> {
        vec![Port::of::<f64>("x", "the number")]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<String>("text", "what was written")]
    }
    fn output_files(p: &PathParams) -> Vec<PathBuf> {
        vec![PathBuf::from(&p.path)]
    }
    fn run(p: &PathParams, i: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let text = format!("{}\n", i.get::<f64>("x")?);
        let path = ctx.resolve(&p.path);
        std::fs::write(&path, &text).map_err(|e| {
            NodeError::invalid_input(format!("cannot write {}: {e}", path.display()))
        })?;
        Ok(Outputs::new().with("text", text))
    }
}

/// `toy.fail`: always fails (or panics).
pub struct Fail;
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FailParams {
    pub panic: bool,
}
impl Validate for FailParams {}
impl NodeKind for Fail {
    type Params = FailParams;
    const KIND: &'static str = "toy.fail";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Fails on purpose.";
    fn inputs() -> Vec<Port> {
        vec![Port::of::<f64>("x", "ignored")]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<f64>("value", "never produced")]
    }
    fn run(p: &FailParams, _: &Inputs, _: &Ctx) -> Result<Outputs, NodeError> {
        if p.panic {
            panic!("toy.fail was asked to panic");
        }
        Err(NodeError::numerical("toy.fail failed on purpose"))
    }
}

/// `toy.slow`: sleeps `steps` × `step_ms`, polling cancellation and reporting progress.
pub struct Slow;
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SlowParams {
    pub steps: u32,
    pub step_ms: u64,
}
impl Default for SlowParams {
    fn default() -> Self {
        SlowParams {
            steps: 10,
            step_ms: 5,
        }
    }
}
impl Validate for SlowParams {}
impl NodeKind for Slow {
    type Params = SlowParams;
    const KIND: &'static str = "toy.slow";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Sleeps in steps, cancellable.";
    fn inputs() -> Vec<Port> {
        vec![Port::of::<f64>("x", "passed through")]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<f64>("value", "x")]
    }
    fn run(p: &SlowParams, i: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        for s in 0..p.steps {
            ctx.check_cancelled()?;
            ctx.progress(s as f32 / p.steps as f32);
            std::thread::sleep(Duration::from_millis(p.step_ms));
        }
        ctx.check_cancelled()?;
        Ok(Outputs::new().with("value", *i.get::<f64>("x")?))
    }
}

/// `toy.report`: a Report with the input value.
pub struct MakeReport;
impl NodeKind for MakeReport {
    type Params = NoParams;
    const KIND: &'static str = "toy.report";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Reports a number.";
    fn inputs() -> Vec<Port> {
        vec![Port::of::<f64>("x", "the number")]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<Report>("report", "x and its square")]
    }
    fn run(_: &NoParams, i: &Inputs, _: &Ctx) -> Result<Outputs, NodeError> {
        let x = *i.get::<f64>("x")?;
        let mut r = Report::new();
        r.set("x", x).set("x_squared", x * x).set("label", "toy");
        Ok(Outputs::new().with("report", r))
    }
}

/// `toy.big_report`: a Report of 40 values, too big to be kept inside its cache entry.
pub struct BigReport;
impl NodeKind for BigReport {
    type Params = NoParams;
    const KIND: &'static str = "toy.big_report";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Reports 40 multiples of a number.";
    fn inputs() -> Vec<Port> {
        vec![Port::of::<f64>("x", "the number")]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<Report>("report", "x times 0..40")]
    }
    fn run(_: &NoParams, i: &Inputs, _: &Ctx) -> Result<Outputs, NodeError> {
        let x = *i.get::<f64>("x")?;
        let mut r = Report::new();
        for k in 0..40 {
            r.set(format!("x_times_{k}"), x * k as f64);
        }
        Ok(Outputs::new().with("report", r))
    }
}

/// `toy.pool_threads`: how many threads the pool the node runs in has (nodes must use the
/// executor's pool, not one of their own).
pub struct PoolThreads;
impl NodeKind for PoolThreads {
    type Params = NoParams;
    const KIND: &'static str = "toy.pool_threads";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Reports the size of the current rayon pool.";
    fn inputs() -> Vec<Port> {
        vec![]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<f64>("threads", "rayon::current_num_threads()")]
    }
    fn run(_: &NoParams, _: &Inputs, _: &Ctx) -> Result<Outputs, NodeError> {
        Ok(Outputs::new().with("threads", rayon::current_num_threads() as f64))
    }
}

/// A registry with the toy family.
pub fn toy_registry() -> Registry {
    let mut r = Registry::new();
    r.add::<Const>()
        .add::<Add>()
        .add::<Round>()
        .add::<SumVec>()
        .add::<VecSum>()
        .add::<PoolThreads>()
        .add::<ReadFile>()
        .add::<WriteText>()
        .add::<Fail>()
        .add::<Slow>()
        .add::<MakeReport>()
        .add::<BigReport>();
    r
}

/// A fresh temporary folder.
pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temp dir")
}

/// Writes `text` to `dir/name` and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write test file");
    p
}

/// Runs a graph file and returns the summary and every event.
pub fn run_file(path: &Path, reg: &Registry, opts: RunOptions) -> (RunSummary, Vec<Event>) {
    run_file_with(path, reg, &[], opts)
}

pub fn run_file_with(
    path: &Path,
    reg: &Registry,
    sets: &[(String, String)],
    mut opts: RunOptions,
) -> (RunSummary, Vec<Event>) {
    let plan = crestflow_flow::load_file(path, reg, sets)
        .unwrap_or_else(|e| panic!("graph does not load:\n{e}"));
    let (tx, rx) = crossbeam_channel::unbounded();
    opts.events = Some(tx);
    let summary = crestflow_flow::run(&plan, &opts).expect("run starts");
    drop(opts);
    let events: Vec<Event> = rx.try_iter().collect();
    (summary, events)
}

/// Node name -> status from the NodeFinished events of a log.
pub fn statuses(events: &[Event]) -> std::collections::BTreeMap<String, Status> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::NodeFinished { node, status, .. } => Some((node.clone(), *status)),
            _ => None,
        })
        .collect()
}

/// The names of the nodes with a status, sorted.
pub fn with_status(events: &[Event], s: Status) -> Vec<String> {
    statuses(events)
        .into_iter()
        .filter(|(_, v)| *v == s)
        .map(|(k, _)| k)
        .collect()
}

/// The warnings of a log.
pub fn warnings(events: &[Event]) -> Vec<String> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Warning { message, .. } => Some(message.clone()),
            _ => None,
        })
        .collect()
}

pub fn cancel_token() -> CancelToken {
    CancelToken::new()
}
