//! `crestflow experiment` through the library with the toy node family: variants that share a
//! prefix compute it once (asserted from the event log), a second run is all cached, failed
//! runs rerun, and the table holds the right values.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::{tempdir, toy_registry, write};
use crestflow::experiment::{
    expand, run_experiment, set_param_field, Cell, Experiment, ExperimentError, ExperimentOptions,
    Table,
};
use crestflow_flow::graph::Graph;
use crestflow_flow::{Event, Status};

const BASE: &str = r#"Graph(
    params: { "unused": 0.0 },
    nodes: {
        "a": (kind: "toy.const", params: (value: 2.0)),
        "prefix": (kind: "toy.sum_vec", params: (n: 2000), inputs: { "x": "a.value" }),
        "tail": (kind: "toy.vec_sum", params: (scale: 1.0), inputs: { "v": "prefix.terms" }),
        "post": (kind: "toy.round", inputs: { "x": "tail.sum" }),
        "rep": (kind: "toy.report", inputs: { "x": "post.value" }),
    },
)"#;

const EXP: &str = r#"// three variants of the last steps, two scales
Experiment(
    graph: "base.ron",
    variants: [
        (name: "rounded"),
        (name: "exact", kinds: { "post": "toy.slow" }, params: { "post.steps": 1, "post.step_ms": 1 }),
        (name: "broken", kinds: { "post": "toy.fail" }),
    ],
    grid: { "tail.scale": [1.0, 2.5] },
    out: "results",
)"#;

/// The toy prefix's sum, computed here independently: sum over k of sin(x (k + 1/2)) / (k + 1).
fn prefix_sum(x: f64, n: usize) -> f64 {
    let mut s = 0.0;
    for k in 0..n {
        s += (x * (k as f64 + 0.5)).sin() / (k as f64 + 1.0);
    }
    s
}

type Log = Vec<(String, Event)>;

fn run(dir: &Path) -> (crestflow::experiment::ExperimentResult, Log) {
    let exp = Experiment::from_file(&dir.join("exp.ron")).expect("experiment parses");
    let reg = toy_registry();
    let mut log: Log = Vec::new();
    let opts = ExperimentOptions {
        threads: 2,
        ..Default::default()
    };
    let r = run_experiment(&reg, &exp, &opts, &mut |run, e| {
        log.push((run.to_string(), e.clone()))
    })
    .expect("experiment runs");
    (r, log)
}

/// How many times each node had status `s` over all runs.
fn count(log: &Log, s: Status) -> BTreeMap<String, usize> {
    let mut m = BTreeMap::new();
    for (_, e) in log {
        if let Event::NodeFinished { node, status, .. } = e {
            if *status == s {
                *m.entry(node.clone()).or_insert(0) += 1;
            }
        }
    }
    m
}

fn num(t: &Table, row: usize, col: &str) -> f64 {
    match t.get(row, col) {
        Some(Cell::Num(x)) => *x,
        other => panic!(
            "row {row} column {col}: {other:?} (columns {:?})",
            t.columns
        ),
    }
}

#[test]
fn variants_share_the_prefix_resume_from_cache_and_tabulate() {
    let dir = tempdir();
    write(dir.path(), "base.ron", BASE);
    write(dir.path(), "exp.ron", EXP);
    let (r, log) = run(dir.path());
    assert_eq!(r.runs.len(), 6);

    // The prefix (a, prefix) is common to all six runs: computed once.
    let ran = count(&log, Status::Ran);
    assert_eq!(ran.get("a"), Some(&1), "{ran:?}");
    assert_eq!(ran.get("prefix"), Some(&1), "{ran:?}");
    // tail depends on the scale only: once per scale.
    assert_eq!(ran.get("tail"), Some(&2), "{ran:?}");
    assert_eq!(count(&log, Status::Cached).get("prefix"), Some(&5));

    let table = Table::new(&r.runs);
    // Only the settings that differ: variant and tail.scale (no input column, no `unused`).
    assert_eq!(&table.columns[..3], ["run", "variant", "tail.scale"]);
    assert!(!table.columns.iter().any(|c| c == "input"));
    assert!(table.columns.iter().any(|c| c == "rep.x_squared"));
    assert!(table.columns.iter().any(|c| c == "post.ms"));
    let s = prefix_sum(2.0, 2000);
    // Runs in order: rounded ×2 scales, exact ×2, broken ×2.
    let expect = [
        ("rounded", 1.0, Some(s.round())),
        ("rounded", 2.5, Some((2.5 * s).round())),
        ("exact", 1.0, Some(s)),
        ("exact", 2.5, Some(2.5 * s)),
        ("broken", 1.0, None),
        ("broken", 2.5, None),
    ];
    for (i, (variant, scale, x)) in expect.iter().enumerate() {
        assert_eq!(
            table.get(i, "variant"),
            Some(&Cell::Text(variant.to_string()))
        );
        assert_eq!(num(&table, i, "tail.scale"), *scale);
        match x {
            Some(x) => {
                let got = num(&table, i, "rep.x");
                assert!(
                    (got - x).abs() <= 1e-12 * x.abs().max(1.0),
                    "row {i}: {got} vs {x}"
                );
                assert_eq!(table.get(i, "status"), Some(&Cell::Text("ok".into())));
            }
            None => {
                let Some(Cell::Text(st)) = table.get(i, "status") else {
                    panic!()
                };
                assert!(st.starts_with("failed: post"), "{st}");
                assert_eq!(table.get(i, "rep.x"), Some(&Cell::Text(String::new())));
            }
        }
    }
    assert_eq!(r.failed(), 2);

    // The files: CSV with a header and one row per run, Markdown, and a plot of rep.x.
    let csv = std::fs::read_to_string(dir.path().join("results/results.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 7);
    assert!(
        lines[0].starts_with("run,variant,tail.scale,"),
        "{}",
        lines[0]
    );
    assert!(lines[3].contains(&format!(",{s},")), "{}", lines[3]);
    let md = std::fs::read_to_string(dir.path().join("results/results.md")).unwrap();
    assert_eq!(md.lines().count(), 8);
    assert!(md.starts_with("| run | variant | tail.scale |"));
    assert_eq!(r.plots.len(), 1);
    let png = std::fs::read(&r.plots[0]).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");

    // Again: finished runs are all cache hits; the failed ones rerun (and fail again).
    let (r2, log2) = run(dir.path());
    let ran2 = count(&log2, Status::Ran);
    assert!(ran2.is_empty(), "{ran2:?}");
    assert_eq!(count(&log2, Status::Failed).get("post"), Some(&2));
    for run in r2.runs.iter().filter(|r| r.status == "ok") {
        assert_eq!(run.ran, 0, "{}", run.id);
    }
    let t2 = Table::new(&r2.runs);
    assert_eq!(num(&t2, 2, "rep.x"), num(&table, 2, "rep.x"));
    // Compute times of cached nodes are those measured when they ran.
    assert_eq!(num(&t2, 0, "post.ms"), num(&table, 0, "post.ms"));
}

#[test]
fn zip_sweeps_and_graph_params() {
    let dir = tempdir();
    write(dir.path(), "base.ron", BASE);
    let exp = r#"Experiment(
    graph: "base.ron",
    zip: { "a.value": [1.0, 3.0], "tail.scale": [2.0, 0.5] },
    set: { "unused": 4.0 },
)"#;
    let path = write(dir.path(), "exp.ron", exp);
    let e = Experiment::from_file(&path).unwrap();
    let base = Graph::from_file(&dir.path().join("base.ron")).unwrap();
    let runs = expand(&e, &base).unwrap();
    assert_eq!(runs.len(), 2);
    assert_eq!(
        runs[1].settings,
        [
            ("variant".to_string(), "base".to_string()),
            ("a.value".into(), "3.0".into()),
            ("tail.scale".into(), "0.5".into())
        ]
    );
    let a = runs[1].graph.find("a").unwrap();
    assert_eq!(a.params, "(value: 3.0)");
    assert!(runs[0]
        .overrides
        .contains(&("unused".to_string(), "4.0".to_string())));
    // Default out folder: out/<file stem> next to the file.
    assert!(e.out.ends_with("out/exp"));
}

#[test]
fn bad_experiment_files_are_located() {
    let dir = tempdir();
    write(dir.path(), "base.ron", BASE);
    let cases = [
        (
            "Experiment(\n  graph: \"base.ron\",\n  varients: [],\n)",
            3,
            "unknown experiment field `varients`",
        ),
        (
            "Experiment(\n  graph: \"base.ron\",\n  zip: { \"a.value\": [1.0], \"tail.scale\": [1.0, 2.0] },\n)",
            3,
            "equal lengths",
        ),
        (
            "Experiment(\n  graph: \"base.ron\",\n  inputs: [\"missing.off\"],\n)",
            3,
            "does not exist",
        ),
        ("Experiment(\n  graph: \"base.ron\"\n  grid: {},\n)", 3, "syntax"),
    ];
    for (text, line, msg) in cases {
        let p = write(dir.path(), "bad.ron", text);
        match Experiment::from_file(&p) {
            Err(ExperimentError::Invalid {
                line: l, message, ..
            }) => {
                assert_eq!(l, line, "{message}");
                assert!(message.contains(msg), "{message}");
            }
            other => panic!("{text}: {other:?}"),
        }
    }
    // A variant naming a node the graph lacks: an error before anything runs.
    let p = write(
        dir.path(),
        "bad.ron",
        "Experiment(graph: \"base.ron\", variants: [(name: \"x\", kinds: { \"nope\": \"toy.round\" })])",
    );
    let e = Experiment::from_file(&p).unwrap();
    let err = run_experiment(
        &toy_registry(),
        &e,
        &ExperimentOptions::default(),
        &mut |_, _| {},
    )
    .unwrap_err();
    assert!(err.to_string().contains("no node `nope`"), "{err}");
}

#[test]
fn param_fields_are_set_in_place_or_added() {
    assert_eq!(
        set_param_field("(rings: 2)", "rings", "3").unwrap(),
        "(rings: 3)"
    );
    assert_eq!(
        set_param_field("(rings: 2)", "degree", "4").unwrap(),
        "(rings: 2, degree: 4)"
    );
    assert_eq!(set_param_field("()", "x", "1.0").unwrap(), "(x: 1.0)");
    assert_eq!(set_param_field("", "x", "1.0").unwrap(), "(x: 1.0)");
    assert_eq!(
        set_param_field(
            "(shape: Torus(major: 1.0, minor: 0.3), n: 1)",
            "shape",
            "Sphere(radius: 2.0)"
        )
        .unwrap(),
        "(shape: Sphere(radius: 2.0), n: 1)"
    );
    assert!(set_param_field("[1, 2]", "x", "1").is_err());
}
