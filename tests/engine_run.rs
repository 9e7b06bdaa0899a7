//! Execution and cache behaviour, asserted from the executor's event log.

mod common;

use std::path::Path;

use common::*;
use crestflow_flow::{exec, CacheStore, ErrorKind, Event, RunOptions, Status};

const CHAIN: &str = r#"Graph(
    params: { "v": 1.2 },
    nodes: {
        "c":   (kind: "toy.const", params: (value: "$v")),
        "r":   (kind: "toy.round", inputs: { "x": "c.value" }),
        "s":   (kind: "toy.add", params: (offset: 0.0), inputs: { "a": "r.value" }),
        "k":   (kind: "toy.const", params: (value: 5.0)),
        "t":   (kind: "toy.add", inputs: { "a": "k.value", "b": "s.sum" }),
        "rep": (kind: "toy.report", inputs: { "x": "t.sum" }),
    },
)"#;

fn opts() -> RunOptions {
    RunOptions {
        threads: 2,
        ..Default::default()
    }
}

fn names(v: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = v.iter().map(|s| s.to_string()).collect();
    v.sort();
    v
}

fn value(summary: &crestflow_flow::RunSummary, node: &str, port: &str) -> f64 {
    *summary.node(node).unwrap().get::<f64>(port).unwrap()
}

#[test]
fn first_run_runs_all_second_is_cached_edits_rerun_dependents_only() {
    let reg = toy_registry();
    let dir = tempdir();
    let g = write(dir.path(), "g.ron", CHAIN);

    let (s1, ev1) = run_file(&g, &reg, opts());
    assert!(s1.ok());
    assert_eq!(
        with_status(&ev1, Status::Ran),
        names(&["c", "r", "s", "k", "t", "rep"])
    );
    assert_eq!(value(&s1, "t", "sum"), 6.0);
    assert!(dir.path().join(".crestflow/cache/entries").is_dir());

    let (s2, ev2) = run_file(&g, &reg, opts());
    assert_eq!(
        with_status(&ev2, Status::Cached),
        names(&["c", "r", "s", "k", "t", "rep"])
    );
    assert_eq!(
        s2.node("s").unwrap().reason,
        "key unchanged since the last run"
    );
    // Values come back from the cache on demand.
    assert_eq!(value(&s2, "t", "sum"), 6.0);

    // One param edit: that node and its dependents run, nothing else.
    write(
        dir.path(),
        "g.ron",
        &CHAIN.replace("offset: 0.0", "offset: 1.0"),
    );
    let (s3, ev3) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev3, Status::Ran), names(&["s", "t", "rep"]));
    assert_eq!(with_status(&ev3, Status::Cached), names(&["c", "r", "k"]));
    assert_eq!(value(&s3, "t", "sum"), 7.0);
    assert_eq!(
        s3.node("s").unwrap().reason,
        "param `offset` changed: 0.0 -> 1.0"
    );
    assert!(s3
        .node("t")
        .unwrap()
        .reason
        .starts_with("input `b` changed: s.sum has a new value"));

    // `why` reads the run record.
    let plan = crestflow_flow::load_file(&g, &reg, &[]).unwrap();
    let store = CacheStore::open(&dir.path().join(".crestflow/cache")).unwrap();
    let why = exec::why(&store, &exec::graph_id(&plan), "s").unwrap();
    assert!(why.contains("s [toy.add v1]: ran in the last run"), "{why}");
    assert!(why.contains("param `offset` changed: 0.0 -> 1.0"), "{why}");
    let why_k = exec::why(&store, &exec::graph_id(&plan), "k").unwrap();
    assert!(
        why_k.contains("cached in the last run") && why_k.contains("key unchanged"),
        "{why_k}"
    );
    assert!(exec::why(&store, &exec::graph_id(&plan), "nosuch").is_err());
}

#[test]
fn an_edit_that_leaves_an_output_unchanged_keeps_dependents_cached() {
    let reg = toy_registry();
    let dir = tempdir();
    let g = write(dir.path(), "g.ron", CHAIN);
    run_file(&g, &reg, opts());
    // 1.2 -> 1.3: `c` changes, `r` reruns and still gives 1.0: early cutoff.
    let (s, ev) = run_file_with(&g, &reg, &[("v".into(), "1.3".into())], opts());
    assert_eq!(with_status(&ev, Status::Ran), names(&["c", "r"]));
    assert_eq!(
        with_status(&ev, Status::Cached),
        names(&["s", "k", "t", "rep"])
    );
    assert!(s
        .node("r")
        .unwrap()
        .reason
        .contains("input `x` changed: c.value has a new value"));
    assert!(s
        .node("s")
        .unwrap()
        .reason
        .contains("early cutoff: `r` ran but its output `value` is unchanged"));
    // 1.3 -> 1.6 changes the rounded value: everything downstream runs.
    let (s, ev) = run_file_with(&g, &reg, &[("v".into(), "1.6".into())], opts());
    assert_eq!(
        with_status(&ev, Status::Ran),
        names(&["c", "r", "s", "t", "rep"])
    );
    assert_eq!(value(&s, "t", "sum"), 7.0);
}

#[test]
fn reports_appear_in_the_event_log_ran_or_cached() {
    let reg = toy_registry();
    let dir = tempdir();
    let g = write(dir.path(), "g.ron", CHAIN);
    for _ in 0..2 {
        let (_, ev) = run_file(&g, &reg, opts());
        let reports: Vec<_> = ev
            .iter()
            .filter_map(|e| match e {
                Event::Report { node, values, .. } => Some((node.clone(), values.clone())),
                _ => None,
            })
            .collect();
        assert_eq!(reports.len(), 1);
        assert_eq!(reports[0].0, "rep");
        assert_eq!(reports[0].1["x"], 6.0);
        assert_eq!(reports[0].1["x_squared"], 36.0);
        let json = ev
            .iter()
            .find(|e| matches!(e, Event::Report { .. }))
            .unwrap()
            .to_json_line();
        assert!(
            json.starts_with(r#"{"event":"report","node":"rep""#),
            "{json}"
        );
        let last = ev.last().unwrap().to_json_line();
        assert!(last.starts_with(r#"{"event":"run_finished""#), "{last}");
    }
}

fn entry_path(cache: &Path, key: &str) -> std::path::PathBuf {
    cache.join("entries").join(format!("{key}.json"))
}
fn blob_path(cache: &Path, digest: &str) -> std::path::PathBuf {
    cache.join("blobs").join(&digest[..2]).join(digest)
}

#[test]
fn a_corrupt_cache_entry_is_a_warned_miss() {
    let reg = toy_registry();
    let dir = tempdir();
    let cache = dir.path().join(".crestflow/cache");
    let g = write(dir.path(), "g.ron", CHAIN);
    let (s1, _) = run_file(&g, &reg, opts());
    std::fs::write(
        entry_path(&cache, &s1.node("k").unwrap().key),
        b"{\"kind\": garbage",
    )
    .unwrap();
    let (s2, ev) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev, Status::Ran), names(&["k"]));
    let w = warnings(&ev);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("is corrupt"), "{w:?}");
    assert_eq!(value(&s2, "k", "value"), 5.0);
    // The entry was rewritten: the next run is fully cached again.
    let (_, ev) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev, Status::Ran), Vec::<String>::new());
}

const VECTORS: &str = r#"Graph(nodes: {
    "c":  (kind: "toy.const", params: (value: 0.25)),
    "a":  (kind: "toy.sum_vec", params: (n: 100), inputs: { "x": "c.value" }),
    "vs": (kind: "toy.vec_sum", params: (scale: 1.0), inputs: { "v": "a.terms" }),
})"#;

#[test]
fn a_corrupt_blob_is_recomputed_when_needed() {
    let reg = toy_registry();
    let dir = tempdir();
    let cache = dir.path().join(".crestflow/cache");
    let g = write(dir.path(), "g.ron", VECTORS);
    let (s1, _) = run_file(&g, &reg, opts());
    let sum1 = value(&s1, "vs", "sum");
    // 100 f64 terms: too big to be kept inside the entry, so they are a blob file.
    let d = s1.digest("a", "terms").unwrap().to_string();
    let mut bytes = std::fs::read(blob_path(&cache, &d)).unwrap();
    assert_eq!(bytes.len(), 801);
    // Same length, different bytes: decodes fine, but no longer matches its digest.
    bytes[100] ^= 0x55;
    std::fs::write(blob_path(&cache, &d), bytes).unwrap();
    // A fully cached rerun never reads the blob (values load lazily): no warning.
    let (_, ev) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev, Status::Cached).len(), 3);
    assert_eq!(warnings(&ev), Vec::<String>::new());
    // Editing `vs` makes it run, so it needs `a`'s cached value.
    write(
        dir.path(),
        "g.ron",
        &VECTORS.replace("scale: 1.0", "scale: 2.0"),
    );
    let (s2, ev) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev, Status::Ran), names(&["vs"]));
    let w = warnings(&ev);
    assert!(
        w.iter()
            .any(|m| m.contains("is corrupt") && m.contains("recomputing `a`")),
        "{w:?}"
    );
    assert_eq!(value(&s2, "vs", "sum"), 2.0 * sum1);
    // The blob was repaired.
    assert_eq!(
        blake3::hash(&std::fs::read(blob_path(&cache, &d)).unwrap())
            .to_hex()
            .as_str(),
        d
    );
}

#[test]
fn a_corrupt_report_blob_is_recomputed_and_shown() {
    // Nothing downstream reads a report, so a corrupt stored report used to stay corrupt:
    // every later run warned that it "cannot be shown" and showed nothing.
    let reg = toy_registry();
    let dir = tempdir();
    let cache = dir.path().join(".crestflow/cache");
    let g = write(
        dir.path(),
        "g.ron",
        r#"Graph(nodes: {
    "c":   (kind: "toy.const", params: (value: 1.5)),
    "rep": (kind: "toy.big_report", inputs: { "x": "c.value" }),
})"#,
    );
    let shown = |ev: &[Event]| -> Vec<f64> {
        ev.iter()
            .filter_map(|e| match e {
                Event::Report { node, values, .. } if node == "rep" => values["x_times_7"].as_f64(),
                _ => None,
            })
            .collect()
    };
    let (s1, ev) = run_file(&g, &reg, opts());
    assert_eq!(shown(&ev), [10.5]);
    let d = s1.digest("rep", "report").unwrap().to_string();
    let mut bytes = std::fs::read(blob_path(&cache, &d)).unwrap();
    bytes[20] ^= 0x55;
    std::fs::write(blob_path(&cache, &d), bytes).unwrap();
    let (_, ev) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev, Status::Cached), names(&["c", "rep"]));
    assert_eq!(shown(&ev), [10.5]);
    let w = warnings(&ev);
    assert!(
        w.iter()
            .any(|m| m.contains("is corrupt") && m.contains("recomputing `rep`")),
        "{w:?}"
    );
    // Repaired: the next run shows it without a warning.
    let (_, ev) = run_file(&g, &reg, opts());
    assert_eq!(shown(&ev), [10.5]);
    assert_eq!(warnings(&ev), Vec::<String>::new());
}

#[test]
fn a_failing_branch_does_not_stop_the_independent_one() {
    let reg = toy_registry();
    let dir = tempdir();
    let g = write(
        dir.path(),
        "g.ron",
        r#"Graph(nodes: {
    "c": (kind: "toy.const"),
    "bad": (kind: "toy.fail", inputs: { "x": "c.value" }),
    "after": (kind: "toy.add", inputs: { "a": "bad.value" }),
    "after2": (kind: "toy.round", inputs: { "x": "after.sum" }),
    "boom": (kind: "toy.fail", params: (panic: true), inputs: { "x": "c.value" }),
    "good": (kind: "toy.slow", params: (steps: 5, step_ms: 2), inputs: { "x": "c.value" }),
    "good2": (kind: "toy.add", inputs: { "a": "good.value", "b": "c.value" }),
})"#,
    );
    let (s, ev) = run_file(&g, &reg, opts());
    assert!(!s.ok());
    assert_eq!(
        with_status(&ev, Status::Ran),
        names(&["c", "good", "good2"])
    );
    assert_eq!(with_status(&ev, Status::Failed), names(&["bad", "boom"]));
    assert_eq!(
        with_status(&ev, Status::Skipped),
        names(&["after", "after2"])
    );
    assert_eq!(
        s.node("after2").unwrap().reason,
        "upstream node `bad` failed"
    );
    let bad = s.node("bad").unwrap().error.clone().unwrap();
    assert_eq!(
        bad,
        (
            ErrorKind::NumericalFailure,
            "toy.fail failed on purpose".to_string()
        )
    );
    let boom = s.node("boom").unwrap().error.clone().unwrap();
    assert_eq!(boom.0, ErrorKind::Internal);
    assert!(
        boom.1.contains("panicked: toy.fail was asked to panic"),
        "{}",
        boom.1
    );
    assert_eq!(value(&s, "good2", "sum"), 2.0);
    assert_eq!(s.failures().count(), 2);
    // Failed nodes are not cached: they run (and fail) again.
    let (_, ev) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev, Status::Failed), names(&["bad", "boom"]));
    assert_eq!(
        with_status(&ev, Status::Cached),
        names(&["c", "good", "good2"])
    );
}

#[test]
fn cancel_leaves_a_valid_cache() {
    let reg = toy_registry();
    let dir = tempdir();
    let g = write(
        dir.path(),
        "g.ron",
        r#"Graph(nodes: {
    "c": (kind: "toy.const", params: (value: 3.0)),
    "fast": (kind: "toy.add", inputs: { "a": "c.value" }),
    "slow": (kind: "toy.slow", params: (steps: 2000, step_ms: 5), inputs: { "x": "fast.sum" }),
    "after": (kind: "toy.round", inputs: { "x": "slow.value" }),
})"#,
    );
    let plan = crestflow_flow::load_file(&g, &reg, &[]).unwrap();
    let (tx, rx) = crossbeam_channel::unbounded();
    let cancel = cancel_token();
    let o = RunOptions {
        threads: 2,
        cancel: cancel.clone(),
        events: Some(tx),
        ..Default::default()
    };
    let mut events = Vec::new();
    let summary = std::thread::scope(|sc| {
        let h = sc.spawn(|| crestflow_flow::run(&plan, &o).unwrap());
        // Cancel as soon as `slow` reports progress: it is then running.
        for e in rx.iter() {
            if matches!(&e, Event::NodeProgress { node, .. } if node == "slow") {
                cancel.cancel();
            }
            let done = matches!(e, Event::RunFinished { .. });
            events.push(e);
            if done {
                break;
            }
        }
        h.join().unwrap()
    });
    assert!(summary.cancelled);
    assert_eq!(with_status(&events, Status::Ran), names(&["c", "fast"]));
    assert_eq!(with_status(&events, Status::Failed), names(&["slow"]));
    assert_eq!(
        summary.node("slow").unwrap().error.as_ref().unwrap().0,
        ErrorKind::Cancelled
    );
    assert_eq!(with_status(&events, Status::Skipped), names(&["after"]));
    // The next run reuses what finished.
    let fast = write(
        dir.path(),
        "g.ron",
        &std::fs::read_to_string(&g)
            .unwrap()
            .replace("steps: 2000", "steps: 3"),
    );
    let (s, ev) = run_file(&fast, &reg, opts());
    assert_eq!(with_status(&ev, Status::Cached), names(&["c", "fast"]));
    assert_eq!(with_status(&ev, Status::Ran), names(&["slow", "after"]));
    assert_eq!(
        s.node("after").unwrap().reason,
        "it did not run in the last run (skipped: the run was cancelled)"
    );
    assert_eq!(value(&s, "after", "value"), 3.0);
}

/// A mistyped thread count is refused at once, before a pool tries to start that many threads.
#[test]
fn a_thread_count_above_the_limit_is_refused_before_the_pool_starts() {
    let reg = toy_registry();
    let dir = tempdir();
    let g = write(
        dir.path(),
        "g.ron",
        r#"Graph(nodes: { "c": (kind: "toy.const", params: (value: 1.0)) })"#,
    );
    let plan = crestflow_flow::load_file(&g, &reg, &[]).unwrap();
    let opts = |threads| RunOptions {
        threads,
        use_cache: false,
        ..Default::default()
    };
    let err = crestflow_flow::run(&plan, &opts(100_000)).unwrap_err();
    assert!(
        matches!(
            err,
            crestflow_flow::RunError::TooManyThreads { requested: 100_000 }
        ),
        "{err:?}"
    );
    assert_eq!(
        err.to_string(),
        "100000 worker threads requested; at most 1024 (0 = one per core)"
    );
    assert!(crestflow_flow::run(&plan, &opts(exec::MAX_THREADS.min(4))).is_ok());
}

#[test]
fn same_digests_at_one_and_two_threads() {
    let reg = toy_registry();
    let dir = tempdir();
    let g = write(
        dir.path(),
        "g.ron",
        r#"Graph(nodes: {
    "c": (kind: "toy.const", params: (value: 0.37)),
    "a": (kind: "toy.sum_vec", params: (n: 200000), inputs: { "x": "c.value" }),
    "b": (kind: "toy.sum_vec", params: (n: 12345), inputs: { "x": "a.sum" }),
    "d": (kind: "toy.add", inputs: { "a": "a.sum", "b": "b.sum" }),
})"#,
    );
    let run_at = |threads: usize| {
        let o = RunOptions {
            threads,
            use_cache: false,
            ..Default::default()
        };
        let (s, ev) = run_file(&g, &reg, o);
        assert_eq!(with_status(&ev, Status::Ran).len(), 4);
        s.nodes
            .iter()
            .flat_map(|n| {
                n.outputs
                    .iter()
                    .map(move |(p, sl)| (format!("{}.{p}", n.name), sl.digest.clone()))
            })
            .collect::<Vec<_>>()
    };
    let one = run_at(1);
    let two = run_at(2);
    assert_eq!(one.len(), 6);
    assert_eq!(one, two);
}

#[test]
fn input_and_output_files_take_part_in_caching() {
    let reg = toy_registry();
    let dir = tempdir();
    write(dir.path(), "in.txt", "hello");
    let g = write(
        dir.path(),
        "g.ron",
        r#"Graph(nodes: {
    "read": (kind: "toy.read_file", params: (path: "in.txt")),
    "save": (kind: "toy.write_text", params: (path: "out.txt"), inputs: { "x": "read.len" }),
})"#,
    );
    let (_, ev) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev, Status::Ran).len(), 2);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("out.txt")).unwrap(),
        "5\n"
    );
    // The output file was deleted: only its writer runs again.
    std::fs::remove_file(dir.path().join("out.txt")).unwrap();
    let (s, ev) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev, Status::Ran), names(&["save"]));
    assert!(
        s.node("save")
            .unwrap()
            .reason
            .contains("out.txt is missing"),
        "{}",
        s.node("save").unwrap().reason
    );
    // The output file was edited by hand: rewritten.
    std::fs::write(dir.path().join("out.txt"), "tampered").unwrap();
    let (_, ev) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev, Status::Ran), names(&["save"]));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("out.txt")).unwrap(),
        "5\n"
    );
    // The input file changed (same length, so `save` gets an unchanged input: early cutoff).
    write(dir.path(), "in.txt", "HELLO");
    let (s, ev) = run_file(&g, &reg, opts());
    assert_eq!(with_status(&ev, Status::Ran), names(&["read"]));
    assert!(s.node("read").unwrap().reason.contains("in.txt changed"));
    assert_eq!(with_status(&ev, Status::Cached), names(&["save"]));
}

#[test]
fn no_cache_runs_everything_and_says_so() {
    let reg = toy_registry();
    let dir = tempdir();
    let g = write(dir.path(), "g.ron", CHAIN);
    run_file(&g, &reg, opts());
    let (s, ev) = run_file(
        &g,
        &reg,
        RunOptions {
            use_cache: false,
            ..opts()
        },
    );
    assert_eq!(with_status(&ev, Status::Ran).len(), 6);
    assert_eq!(s.node("c").unwrap().reason, "--no-cache");
}

#[test]
fn cache_gc_keeps_what_the_last_run_uses() {
    let reg = toy_registry();
    let dir = tempdir();
    let g = write(dir.path(), "g.ron", CHAIN);
    run_file(&g, &reg, opts());
    let (_, ev) = run_file_with(&g, &reg, &[("v".into(), "3.0".into())], opts());
    assert_eq!(with_status(&ev, Status::Ran).len(), 5);
    let store = CacheStore::open(&dir.path().join(".crestflow/cache")).unwrap();
    let before = store.stats();
    assert_eq!(before.entries, 11);
    assert_eq!(before.graphs, 1);
    let gc = store.gc(None);
    // The five entries of the first run that the last one did not use are dropped.
    assert_eq!(gc.entries_removed, 5);
    assert_eq!(store.stats().entries, 6);
    let (_, ev) = run_file_with(&g, &reg, &[("v".into(), "3.0".into())], opts());
    assert_eq!(with_status(&ev, Status::Cached).len(), 6);
    store.clear().unwrap();
    assert_eq!(store.stats().entries, 0);
}

#[test]
fn a_failed_cache_write_fails_the_node_loudly() {
    let reg = toy_registry();
    let dir = tempdir();
    write(dir.path(), "in.txt", &"x".repeat(1000));
    let g = write(
        dir.path(),
        "g.ron",
        r#"Graph(nodes: {
    "read": (kind: "toy.read_file", params: (path: "in.txt")),
    "r": (kind: "toy.round", inputs: { "x": "read.len" }),
})"#,
    );
    // The blob of the 1000 bytes (postcard: varint length 0xE8 0x07, then the bytes) would go
    // to blobs/<2 hex digits>/: a file in the way of that folder makes the write fail.
    let mut encoded = vec![0xE8, 0x07];
    encoded.extend(std::iter::repeat_n(b'x', 1000));
    let digest = blake3::hash(&encoded).to_hex().to_string();
    let blobs = dir.path().join(".crestflow/cache/blobs");
    std::fs::create_dir_all(&blobs).unwrap();
    std::fs::write(blobs.join(&digest[..2]), b"in the way").unwrap();
    let (s, ev) = run_file(&g, &reg, opts());
    assert!(!s.ok());
    assert_eq!(with_status(&ev, Status::Failed), names(&["read"]));
    assert_eq!(with_status(&ev, Status::Skipped), names(&["r"]));
    let (kind, msg) = s.node("read").unwrap().error.clone().unwrap();
    assert_eq!(kind, ErrorKind::Internal);
    assert!(msg.starts_with("cannot write to the cache folder"), "{msg}");
    assert_eq!(s.cache_error.as_deref(), Some(msg.as_str()));
    // Once the obstacle is gone the same graph runs and caches.
    std::fs::remove_file(blobs.join(&digest[..2])).unwrap();
    let (s, _) = run_file(&g, &reg, opts());
    assert!(s.ok());
    assert_eq!(s.digest("read", "bytes"), Some(digest.as_str()));
}

/// `toy.const` at version 2 (same output), to show that a version bump reruns the node.
struct ConstV2;
impl crestflow_flow::NodeKind for ConstV2 {
    type Params = ConstParams;
    const KIND: &'static str = "toy.const";
    const VERSION: u32 = 2;
    const DOC: &'static str = "A constant number, version 2.";
    fn inputs() -> Vec<crestflow_flow::Port> {
        Const::inputs()
    }
    fn outputs() -> Vec<crestflow_flow::Port> {
        Const::outputs()
    }
    fn run(
        p: &ConstParams,
        i: &crestflow_flow::Inputs,
        c: &crestflow_flow::Ctx,
    ) -> Result<crestflow_flow::Outputs, crestflow_flow::NodeError> {
        Const::run(p, i, c)
    }
}

#[test]
fn a_version_bump_reruns_the_node_and_says_so() {
    let dir = tempdir();
    let g = write(dir.path(), "g.ron", CHAIN);
    run_file(&g, &toy_registry(), opts());
    let mut reg = toy_registry();
    reg.add::<ConstV2>();
    let (s, ev) = run_file(&g, &reg, opts());
    // Both constants rerun; their values are unchanged, so everything downstream stays cached.
    assert_eq!(with_status(&ev, Status::Ran), names(&["c", "k"]));
    assert_eq!(s.node("c").unwrap().reason, "version changed: 1 -> 2");
    assert_eq!(with_status(&ev, Status::Cached).len(), 4);
}

/// The order of NodeStarted / NodeFinished events of the named nodes.
fn starts_and_ends(events: &[Event], of: &[&str]) -> Vec<String> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::NodeStarted { node, .. } if of.contains(&node.as_str()) => {
                Some(format!("start {node}"))
            }
            Event::NodeFinished { node, .. } if of.contains(&node.as_str()) => {
                Some(format!("end {node}"))
            }
            _ => None,
        })
        .collect()
}

#[test]
fn independent_nodes_run_in_parallel_on_one_pool() {
    let reg = toy_registry();
    let dir = tempdir();
    let g = write(
        dir.path(),
        "g.ron",
        r#"Graph(nodes: {
    "c": (kind: "toy.const"),
    "x": (kind: "toy.slow", params: (steps: 20, step_ms: 10), inputs: { "x": "c.value" }),
    "y": (kind: "toy.slow", params: (steps: 20, step_ms: 10), inputs: { "x": "c.value" }),
    "pool": (kind: "toy.pool_threads"),
})"#,
    );
    // Two threads: both slow nodes start before either ends.
    let o = RunOptions {
        threads: 2,
        use_cache: false,
        ..Default::default()
    };
    let (s, ev) = run_file(&g, &reg, o);
    let order = starts_and_ends(&ev, &["x", "y"]);
    assert!(
        order[0].starts_with("start") && order[1].starts_with("start"),
        "{order:?}"
    );
    assert_eq!(value(&s, "pool", "threads"), 2.0);
    // One thread: one after the other.
    let o = RunOptions {
        threads: 1,
        use_cache: false,
        ..Default::default()
    };
    let (s, ev) = run_file(&g, &reg, o);
    let order = starts_and_ends(&ev, &["x", "y"]);
    assert_eq!(order, ["start x", "end x", "start y", "end y"]);
    assert_eq!(value(&s, "pool", "threads"), 1.0);
    // Three threads: nodes see the executor's pool.
    let o = RunOptions {
        threads: 3,
        use_cache: false,
        ..Default::default()
    };
    let (s, _) = run_file(&g, &reg, o);
    assert_eq!(value(&s, "pool", "threads"), 3.0);
}
