//! `crestflow watch` driven through the library with the toy node family, in a temporary
//! folder, with bounded waits: a param edit reruns only its dependents, an invalid save keeps
//! watching, a new file in an input folder runs its pipeline, a rename-over save reruns, and a
//! change during a run cancels it and starts again.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use common::{tempdir, toy_registry, write};
use crestflow::watch::{watch, Target, WatchError, WatchEvent, WatchOptions};
use crestflow_flow::{CancelToken, Event, Status};
use crossbeam_channel::{unbounded, Receiver};

const WAIT: Duration = Duration::from_secs(30);

struct Watcher {
    rx: Receiver<WatchEvent>,
    stop: CancelToken,
    handle: Option<JoinHandle<Result<usize, WatchError>>>,
    /// Everything received so far.
    seen: Vec<WatchEvent>,
}

impl Watcher {
    fn start(graph: &Path, inputs: Vec<PathBuf>) -> Watcher {
        let (tx, rx) = unbounded();
        let stop = CancelToken::new();
        let opts = WatchOptions {
            graph: graph.to_path_buf(),
            inputs,
            threads: 2,
            debounce: Duration::from_millis(50),
            // A safety net: the watcher ends by itself even if a test forgets to stop it.
            exit_after: Some(Duration::from_secs(90)),
            stop: stop.clone(),
            ..Default::default()
        };
        let handle = std::thread::spawn(move || {
            let reg = toy_registry();
            watch(&reg, &opts, &|e| {
                let _ = tx.send(e);
            })
        });
        Watcher {
            rx,
            stop,
            handle: Some(handle),
            seen: Vec::new(),
        }
    }

    /// Receives events until `pred` holds for one; returns the events since the call.
    fn until(&mut self, what: &str, pred: impl Fn(&WatchEvent) -> bool) -> Vec<&WatchEvent> {
        let from = self.seen.len();
        let t0 = Instant::now();
        loop {
            if self.seen[from..].iter().any(&pred) {
                break;
            }
            let left = WAIT.saturating_sub(t0.elapsed());
            match self.rx.recv_timeout(left) {
                Ok(e) => self.seen.push(e),
                Err(_) => panic!(
                    "timed out waiting for {what}; events since: {:#?}",
                    &self.seen[from..]
                ),
            }
        }
        self.seen[from..].iter().collect()
    }

    /// Waits for run `run` to finish; returns node -> (status, reason) of that run.
    fn run_finished(&mut self, run: usize) -> BTreeMap<String, (Status, String)> {
        self.until(
            &format!("run {run} to finish"),
            |e| matches!(e, WatchEvent::RunFinished { run: r, .. } if *r == run),
        );
        nodes_of(&self.seen, run)
    }

    /// Nothing starts within `d`.
    fn quiet_for(&mut self, d: Duration) -> bool {
        let t0 = Instant::now();
        while t0.elapsed() < d {
            if let Ok(e) = self.rx.recv_timeout(Duration::from_millis(20)) {
                let started = matches!(e, WatchEvent::RunStarted { .. });
                self.seen.push(e);
                if started {
                    return false;
                }
            }
        }
        true
    }

    fn stop(mut self) -> usize {
        self.stop.cancel();
        let h = self.handle.take().expect("running");
        h.join().expect("no panic").expect("watch ends cleanly")
    }
}

impl Drop for Watcher {
    fn drop(&mut self) {
        self.stop.cancel();
    }
}

fn nodes_of(events: &[WatchEvent], run: usize) -> BTreeMap<String, (Status, String)> {
    events
        .iter()
        .filter_map(|e| match e {
            WatchEvent::Engine {
                run: r,
                event:
                    Event::NodeFinished {
                        node,
                        status,
                        reason,
                        ..
                    },
            } if *r == run => Some((node.clone(), (*status, reason.clone()))),
            _ => None,
        })
        .collect()
}

fn report_x(events: &[WatchEvent], run: usize, node: &str) -> Option<f64> {
    events.iter().rev().find_map(|e| match e {
        WatchEvent::Engine {
            run: r,
            event: Event::Report {
                node: n, values, ..
            },
        } if *r == run && n == node => values["x"].as_f64(),
        _ => None,
    })
}

fn started(events: &[WatchEvent], run: usize) -> Option<(Target, String)> {
    events.iter().find_map(|e| match e {
        WatchEvent::RunStarted {
            run: r,
            target,
            trigger,
            ..
        } if *r == run => Some((target.clone(), trigger.clone())),
        _ => None,
    })
}

fn with(nodes: &BTreeMap<String, (Status, String)>, s: Status) -> Vec<&str> {
    nodes
        .iter()
        .filter(|(_, (st, _))| *st == s)
        .map(|(n, _)| n.as_str())
        .collect()
}

fn sum_graph(offset: &str) -> String {
    format!(
        r#"Graph(
    params: {{}},
    nodes: {{
        "a": (kind: "toy.const", params: (value: 2.0)),
        "c": (kind: "toy.const", params: (value: 5.0)),
        "sum": (kind: "toy.add", params: (offset: {offset}), inputs: {{ "a": "a.value", "b": "c.value" }}),
        "rep": (kind: "toy.report", inputs: {{ "x": "sum.sum" }}),
        "other": (kind: "toy.add", params: (offset: 1.0), inputs: {{ "a": "c.value" }}),
    }},
)"#
    )
}

#[test]
fn param_edit_reruns_only_dependents() {
    let dir = tempdir();
    let g = write(dir.path(), "graph.ron", &sum_graph("0.0"));
    let mut w = Watcher::start(&g, vec![]);
    let first = w.run_finished(1);
    assert_eq!(with(&first, Status::Ran).len(), 5, "{first:?}");
    assert_eq!(report_x(&w.seen, 1, "rep"), Some(7.0));

    write(dir.path(), "graph.ron", &sum_graph("3.0"));
    let second = w.run_finished(2);
    assert_eq!(with(&second, Status::Ran), ["rep", "sum"], "{second:?}");
    assert_eq!(with(&second, Status::Cached), ["a", "c", "other"]);
    // Why it ran: the param that changed.
    let (_, why) = &second["sum"];
    assert!(why.contains("offset") && why.contains("3.0"), "{why}");
    assert_eq!(report_x(&w.seen, 2, "rep"), Some(10.0));
    let (target, trigger) = started(&w.seen, 2).expect("run 2 started");
    assert_eq!(target, Target::Main);
    assert!(trigger.contains("graph.ron changed"), "{trigger}");
    // Its own cache writes do not trigger anything.
    assert!(w.quiet_for(Duration::from_millis(600)));
    assert_eq!(w.stop(), 2);
}

#[test]
fn invalid_save_keeps_watching_and_next_valid_save_runs() {
    let dir = tempdir();
    let g = write(dir.path(), "graph.ron", &sum_graph("0.0"));
    let mut w = Watcher::start(&g, vec![]);
    w.run_finished(1);

    // A syntax error, then an unknown kind: each reported with its line, nothing runs.
    write(
        dir.path(),
        "graph.ron",
        "Graph(\n    nodes: {\n        \"a\": (kind: ,\n",
    );
    let ev = w.until("the invalid graph", |e| {
        matches!(e, WatchEvent::Invalid { .. })
    });
    let WatchEvent::Invalid { error } = ev.last().unwrap() else {
        unreachable!()
    };
    assert_eq!(error.diagnostics[0].line, 3, "{error}");
    let bad_kind = sum_graph("0.0").replace("toy.report", "toy.reprot");
    write(dir.path(), "graph.ron", &bad_kind);
    let ev = w.until("the second invalid graph", |e| {
        matches!(e, WatchEvent::Invalid { .. })
    });
    let WatchEvent::Invalid { error } = ev.last().unwrap() else {
        unreachable!()
    };
    let text = error.to_string();
    assert!(
        text.contains("graph.ron:7:") && text.contains("toy.reprot"),
        "{text}"
    );
    assert!(text.contains("toy.report"), "did-you-mean missing: {text}");
    assert!(
        started(&w.seen, 2).is_none(),
        "an invalid graph must not run"
    );

    write(dir.path(), "graph.ron", &sum_graph("1.5"));
    let nodes = w.run_finished(2);
    assert_eq!(with(&nodes, Status::Ran), ["rep", "sum"]);
    assert_eq!(report_x(&w.seen, 2, "rep"), Some(8.5));
    w.stop();
}

fn file_graph() -> String {
    r#"Graph(
    params: { "mesh": "seed.off", "out": "out" },
    nodes: {
        "read": (kind: "toy.read_file", params: (path: "$mesh")),
        "rep": (kind: "toy.report", inputs: { "x": "read.len" }),
        "save": (kind: "toy.write_text", params: (path: "$out/len.txt"), inputs: { "x": "read.len" }),
    },
)"#
    .to_string()
}

/// [`file_graph`] in `dir` watched with the input folder `dir/drop`, after its first run.
fn watch_a_drop_folder(dir: &Path) -> (PathBuf, Watcher) {
    write(dir, "seed.off", "seed");
    std::fs::create_dir(dir.join("out")).unwrap();
    let drop = dir.join("drop");
    std::fs::create_dir(&drop).unwrap();
    let g = write(dir, "graph.ron", &file_graph());
    let mut w = Watcher::start(&g, vec![drop.clone()]);
    w.run_finished(1);
    (drop, w)
}

#[test]
fn new_file_in_input_folder_runs_its_pipeline() {
    let dir = tempdir();
    let (drop, mut w) = watch_a_drop_folder(dir.path());
    assert_eq!(report_x(&w.seen, 1, "rep"), Some(4.0));

    // Editor noise and a file that is not a mesh: nothing runs.
    write(&drop, ".scan1.off.swp", "swap");
    write(&drop, "scan1.off~", "backup");
    write(&drop, "4913", "");
    write(&drop, "notes.txt", "not a mesh");
    assert!(w.quiet_for(Duration::from_millis(600)), "{:#?}", w.seen);

    write(&drop, "scan1.OFF", "1234567");
    let nodes = w.run_finished(2);
    let (target, trigger) = started(&w.seen, 2).unwrap();
    assert_eq!(
        target,
        Target::File(std::fs::canonicalize(drop.join("scan1.OFF")).unwrap())
    );
    assert!(trigger.contains("new file scan1.OFF"), "{trigger}");
    assert_eq!(with(&nodes, Status::Ran), ["read", "rep", "save"]);
    assert_eq!(report_x(&w.seen, 2, "rep"), Some(7.0));
    // Outputs named after the file's stem.
    let text = std::fs::read_to_string(dir.path().join("out/scan1/len.txt")).unwrap();
    assert_eq!(text.trim(), "7");
    // Writing out/scan1/len.txt did not trigger a run.
    assert!(w.quiet_for(Duration::from_millis(600)), "{:#?}", w.seen);

    // Changing that file reruns its pipeline only.
    write(&drop, "scan1.OFF", "123456789");
    w.run_finished(3);
    let (target, _) = started(&w.seen, 3).unwrap();
    assert!(matches!(target, Target::File(_)));
    assert_eq!(report_x(&w.seen, 3, "rep"), Some(9.0));
    w.stop();
}

#[test]
fn a_file_still_being_written_runs_once_when_it_is_quiet() {
    let dir = tempdir();
    let (drop, mut w) = watch_a_drop_folder(dir.path());
    // A scanner writing in six pieces, 150 ms apart (more than the debounce, less than the
    // settle time): each pause used to start a run on a truncated file.
    {
        use std::io::Write as _;
        let mut f = std::fs::File::create(drop.join("scan.off")).unwrap();
        for _ in 0..6 {
            f.write_all(b"0123456789").unwrap();
            f.flush().unwrap();
            std::thread::sleep(Duration::from_millis(150));
        }
    }
    w.run_finished(2);
    assert_eq!(report_x(&w.seen, 2, "rep"), Some(60.0));
    assert!(w.quiet_for(Duration::from_millis(800)), "{:#?}", w.seen);
    w.stop();
}

#[test]
fn rename_over_saves_rerun() {
    let dir = tempdir();
    write(dir.path(), "seed.off", "seed");
    std::fs::create_dir(dir.path().join("out")).unwrap();
    let g = write(dir.path(), "graph.ron", &file_graph());
    let mut w = Watcher::start(&g, vec![]);
    w.run_finished(1);

    // An editor's atomic save of the input: write a temporary file, rename it over.
    write(dir.path(), "seed.off.tmp", "seed file, longer");
    std::fs::rename(dir.path().join("seed.off.tmp"), dir.path().join("seed.off")).unwrap();
    let nodes = w.run_finished(2);
    assert_eq!(with(&nodes, Status::Ran), ["read", "rep", "save"]);
    let (_, trigger) = started(&w.seen, 2).unwrap();
    assert!(trigger.contains("input file seed.off changed"), "{trigger}");
    assert_eq!(report_x(&w.seen, 2, "rep"), Some(17.0));
    assert!(nodes["read"].1.contains("changed"), "{:?}", nodes["read"]);

    // The same for the graph: only the node whose params changed (and its dependents) rerun.
    let edited = file_graph().replace("$out/len.txt", "$out/length.txt");
    write(dir.path(), ".graph.ron.swp", &edited);
    std::fs::rename(dir.path().join(".graph.ron.swp"), &g).unwrap();
    let nodes = w.run_finished(3);
    assert_eq!(with(&nodes, Status::Ran), ["save"]);
    assert_eq!(with(&nodes, Status::Cached), ["read", "rep"]);
    assert!(dir.path().join("out/length.txt").is_file());
    w.stop();
}

#[test]
fn change_during_a_run_cancels_and_restarts() {
    let dir = tempdir();
    let graph = |v: &str| {
        format!(
            r#"Graph(
    params: {{}},
    nodes: {{
        "quick": (kind: "toy.const", params: (value: 1.0)),
        "a": (kind: "toy.const", params: (value: {v})),
        "slow": (kind: "toy.slow", params: (steps: 400, step_ms: 10), inputs: {{ "x": "a.value" }}),
        "rep": (kind: "toy.report", inputs: {{ "x": "slow.value" }}),
    }},
)"#
        )
    };
    let g = write(dir.path(), "graph.ron", &graph("2.0"));
    let mut w = Watcher::start(&g, vec![]);
    w.until("the slow node to start", |e| {
        matches!(e, WatchEvent::Engine { run: 1, event: Event::NodeStarted { node, .. } } if node == "slow")
    });
    let t_edit = Instant::now();
    write(dir.path(), "graph.ron", &graph("3.0"));
    w.until("run 1 to end", |e| {
        matches!(e, WatchEvent::RunFinished { run: 1, .. })
    });
    // Cancelled long before its 4 s were up.
    assert!(
        t_edit.elapsed() < Duration::from_secs(3),
        "{:?}",
        t_edit.elapsed()
    );
    let cancelled = w.seen.iter().any(|e| {
        matches!(
            e,
            WatchEvent::RunFinished {
                run: 1,
                cancelled: true,
                ..
            }
        )
    });
    assert!(cancelled, "{:#?}", w.seen);
    assert!(w
        .seen
        .iter()
        .any(|e| matches!(e, WatchEvent::Restarting { run: 1, .. })));
    let nodes = w.run_finished(2);
    // What had finished is in the cache; the changed branch runs to the end.
    assert_eq!(nodes["quick"].0, Status::Cached);
    assert_eq!(nodes["slow"].0, Status::Ran);
    assert_eq!(report_x(&w.seen, 2, "rep"), Some(3.0));
    w.stop();
}

#[test]
fn unaffected_running_nodes_finish_before_a_restart() {
    let dir = tempdir();
    let graph = |v: &str| {
        format!(
            r#"Graph(
    params: {{}},
    nodes: {{
        "a": (kind: "toy.const", params: (value: 1.0)),
        "b": (kind: "toy.const", params: (value: {v})),
        "slow_a": (kind: "toy.slow", params: (steps: 100, step_ms: 10), inputs: {{ "x": "a.value" }}),
        "slow_b": (kind: "toy.slow", params: (steps: 400, step_ms: 10), inputs: {{ "x": "b.value" }}),
        "rep": (kind: "toy.report", inputs: {{ "x": "slow_b.value" }}),
    }},
)"#
        )
    };
    let g = write(dir.path(), "graph.ron", &graph("2.0"));
    let mut w = Watcher::start(&g, vec![]);
    // Both branches running (two worker threads).
    let started = |w: &Watcher, n: &str| {
        w.seen.iter().any(|e| {
            matches!(e, WatchEvent::Engine { run: 1, event: Event::NodeStarted { node, .. } } if node == n)
        })
    };
    for n in ["slow_a", "slow_b"] {
        if !started(&w, n) {
            w.until(n, |e| {
                matches!(e, WatchEvent::Engine { run: 1, event: Event::NodeStarted { node, .. } } if node == n)
            });
        }
    }
    // The edit arrives while slow_a (1 s) is still running.
    assert!(!w.seen.iter().any(|e| matches!(e,
        WatchEvent::Engine { run: 1, event: Event::NodeFinished { node, .. } } if node == "slow_a")));
    write(dir.path(), "graph.ron", &graph("3.0"));
    w.run_finished(1);
    let first = nodes_of(&w.seen, 1);
    // slow_a does not depend on b: it finished instead of being cancelled.
    assert_eq!(first["slow_a"].0, Status::Ran, "{first:?}");
    // slow_b (4 s) was stale and cancelled once slow_a was done.
    assert_eq!(first["slow_b"].0, Status::Failed, "{first:?}");
    let second = w.run_finished(2);
    assert_eq!(second["slow_a"].0, Status::Cached);
    assert_eq!(second["slow_b"].0, Status::Ran);
    assert_eq!(report_x(&w.seen, 2, "rep"), Some(3.0));
    w.stop();
}
