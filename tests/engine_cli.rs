//! The `crestflow` binary: exit codes (0 ok, 1 a node failed, 2 invalid graph or usage), the
//! JSON event log, and the inspection commands.

mod common;

use std::path::{Path, PathBuf};

use common::cli::{json_lines, mesh, run};
use common::{tempdir, write};
use serde_json::Value as Json;

fn finished(events: &[Json]) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = events
        .iter()
        .filter(|e| e["event"] == "node_finished")
        .map(|e| {
            (
                e["node"].as_str().unwrap().to_string(),
                e["status"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    v.sort();
    v
}

/// The vertex count in an OFF file's header.
fn off_vertices(p: &Path) -> f64 {
    let text = std::fs::read_to_string(p).unwrap();
    let mut lines = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'));
    let first = lines.next().unwrap();
    let counts = if first == "OFF" {
        lines.next().unwrap()
    } else {
        first.trim_start_matches("OFF")
    };
    counts.split_whitespace().next().unwrap().parse().unwrap()
}

fn good_graph(dir: &Path) -> PathBuf {
    let m = mesh("cad/cgal_pinion.off");
    write(
        dir,
        "good.ron",
        &format!(
            r#"Graph(
    params: {{ "mesh": {m:?} }},
    nodes: {{
        "load": (kind: "io.load_mesh", params: (path: "$mesh")),
        "save": (kind: "io.save_report", params: (path: "report.json"), inputs: {{ "report": "load.report" }}),
    }},
)"#
        ),
    )
}

#[test]
fn run_exits_0_and_logs_json_events() {
    let dir = tempdir();
    let g = good_graph(dir.path());
    let gs = g.to_str().unwrap();
    let out = run(&["run", gs, "--log", "json", "--threads", "2"], dir.path());
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ev = json_lines(&out);
    assert_eq!(ev[0]["event"], "run_started");
    assert_eq!(
        finished(&ev),
        vec![("load".into(), "ran".into()), ("save".into(), "ran".into())]
    );
    let nf = ev.iter().find(|e| e["event"] == "node_finished").unwrap();
    assert!(nf["ms"].is_number());
    let report = ev.iter().find(|e| e["event"] == "report").unwrap();
    assert_eq!(report["node"], "load");
    assert_eq!(
        report["values"]["file_vertices"].as_f64(),
        Some(off_vertices(&mesh("cad/cgal_pinion.off")))
    );
    let last = ev.last().unwrap();
    assert_eq!(last["event"], "run_finished");
    assert_eq!(last["ok"], true);
    assert_eq!(last["ran"], 2);
    // io.save_report wrote next to the graph, and the human summary went to stderr.
    assert!(dir.path().join("report.json").is_file());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("2 ran, 0 cached"), "{err}");

    // Second run: everything cached; `why` explains it.
    let out = run(&["run", gs, "--log", "json"], dir.path());
    assert_eq!(out.status.code(), Some(0));
    assert_eq!(
        finished(&json_lines(&out)),
        vec![
            ("load".into(), "cached".into()),
            ("save".into(), "cached".into())
        ]
    );
    let why = run(&["why", gs, "load"], dir.path());
    assert_eq!(why.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&why.stdout).contains("cached in the last run"));

    // --set with a path relative to the shell's folder; changing the mesh reruns both nodes.
    let other = dir.path().join("other.off");
    std::fs::copy(mesh("cad/cgal_couplingdown.off"), &other).unwrap();
    let out = run(
        &["run", gs, "--log", "json", "--set", "mesh=other.off"],
        dir.path(),
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        finished(&json_lines(&out)),
        vec![("load".into(), "ran".into()), ("save".into(), "ran".into())]
    );
    let why = run(&["why", gs, "load"], dir.path());
    let why = String::from_utf8_lossy(&why.stdout).to_string();
    assert!(why.contains("param `path` changed"), "{why}");

    // cache stats / gc / clear.
    let stats = run(&["cache", "stats", gs], dir.path());
    assert_eq!(stats.status.code(), Some(0));
    assert!(
        String::from_utf8_lossy(&stats.stdout).contains("entries         4"),
        "{}",
        String::from_utf8_lossy(&stats.stdout)
    );
    let gc = run(&["cache", "gc", gs], dir.path());
    assert!(
        String::from_utf8_lossy(&gc.stdout).starts_with("removed 2 entries"),
        "{}",
        String::from_utf8_lossy(&gc.stdout)
    );
    let clear = run(&["cache", "clear", gs], dir.path());
    assert_eq!(clear.status.code(), Some(0));
    let stats = run(&["cache", "stats", gs], dir.path());
    assert!(String::from_utf8_lossy(&stats.stdout).contains("entries         0"));
}

#[test]
fn an_output_folder_set_on_the_command_line_is_relative_to_the_shell() {
    // `--set out=results` for a folder that does not exist yet: it used to land beside the
    // graph file on the first run and in the shell's folder once it existed, so the second
    // run saw new keys and ran again.
    let dir = tempdir();
    let graphs = dir.path().join("graphs");
    std::fs::create_dir(&graphs).unwrap();
    let m = mesh("cad/cgal_pinion.off");
    let g = write(
        &graphs,
        "g.ron",
        &format!(
            r#"Graph(
    params: {{ "mesh": {m:?}, "out": "../out/g" }},
    nodes: {{
        "load": (kind: "io.load_mesh", params: (path: "$mesh")),
        "save": (kind: "io.save_report", params: (path: "$out/report.json"), inputs: {{ "report": "load.report" }}),
    }},
)"#
        ),
    );
    let gs = g.to_str().unwrap();
    let args = ["run", gs, "--log", "json", "--set", "out=results"];
    let out = run(&args, dir.path());
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join("results/report.json").is_file());
    assert!(!graphs.join("results").exists());
    let out = run(&args, dir.path());
    assert_eq!(
        finished(&json_lines(&out)),
        vec![
            ("load".into(), "cached".into()),
            ("save".into(), "cached".into())
        ]
    );
}

#[test]
fn cache_commands_take_a_folder_of_graphs_and_refuse_a_cache_folder() {
    let dir = tempdir();
    let graphs = dir.path().join("graphs");
    std::fs::create_dir(&graphs).unwrap();
    let g = good_graph(&graphs);
    assert_eq!(
        run(&["run", g.to_str().unwrap()], dir.path()).status.code(),
        Some(0)
    );
    // A folder of graphs means the cache inside it (it used to mean the one of the folder
    // above, so that `cache clear graphs` cleared another cache).
    let stats = run(&["cache", "stats", "graphs"], dir.path());
    let text = String::from_utf8_lossy(&stats.stdout).to_string();
    assert!(text.contains("entries         2"), "{text}");
    // A cache folder as GRAPH is refused, and nothing is deleted.
    let cache = graphs.join(".crestflow/cache");
    let clear = run(&["cache", "clear", cache.to_str().unwrap()], dir.path());
    assert_eq!(clear.status.code(), Some(2));
    let err = String::from_utf8_lossy(&clear.stderr).to_string();
    assert!(
        err.contains("is a cache folder") && err.contains("--cache"),
        "{err}"
    );
    assert!(cache.join("entries").read_dir().unwrap().next().is_some());
    let why = run(&["why", "graphs", "load"], dir.path());
    assert_eq!(why.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&why.stderr).contains("needs a graph file"));
}

#[test]
fn a_failing_node_exits_1_and_is_listed() {
    let dir = tempdir();
    let m = mesh("cad/cgal_pinion.off");
    let g = write(
        dir.path(),
        "fail.ron",
        &format!(
            r#"Graph(nodes: {{
    "missing": (kind: "io.load_mesh", params: (path: "no/such/mesh.off")),
    "fine": (kind: "io.load_mesh", params: (path: {m:?})),
}})"#
        ),
    );
    let out = run(&["run", g.to_str().unwrap(), "--log", "json"], dir.path());
    assert_eq!(out.status.code(), Some(1));
    let ev = json_lines(&out);
    assert_eq!(
        finished(&ev),
        vec![
            ("fine".into(), "ran".into()),
            ("missing".into(), "failed".into())
        ]
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("1 node failed:"), "{err}");
    assert!(err.contains("missing [io.load_mesh]"), "{err}");
}

#[test]
fn an_invalid_graph_exits_2_with_located_diagnostics() {
    let dir = tempdir();
    let g = write(
        dir.path(),
        "bad.ron",
        "Graph(nodes: {\n  \"load\": (kind: \"io.load_mseh\"),\n  \"s\": (kind: \"io.save_report\", params: (path: \"r.json\"), inputs: { \"report\": \"load.report\" }),\n})",
    );
    for cmd in ["run", "validate", "explain"] {
        let out = run(&[cmd, g.to_str().unwrap()], dir.path());
        assert_eq!(out.status.code(), Some(2), "{cmd}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("bad.ron:2:18"), "{err}");
        assert!(err.contains("did you mean `io.load_mesh`?"), "{err}");
        assert!(err.contains("1 problem found; nothing was run"), "{err}");
    }
    // Usage errors are 2 as well.
    assert_eq!(run(&["run"], dir.path()).status.code(), Some(2));
    assert_eq!(run(&["frobnicate"], dir.path()).status.code(), Some(2));
    assert_eq!(
        run(&["nodes", "io.load_mseh"], dir.path()).status.code(),
        Some(2)
    );
}

#[test]
fn inspection_commands() {
    let dir = tempdir();
    let g = good_graph(dir.path());
    let gs = g.to_str().unwrap();
    let out = run(&["validate", gs], dir.path());
    assert_eq!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stdout).ends_with("ok (2 nodes)\n"));
    let out = run(&["explain", gs], dir.path());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("stage 1 (1 node can run in parallel)"),
        "{text}"
    );
    assert!(
        text.contains("in      report <- load.report (Report)"),
        "{text}"
    );
    let out = run(&["graph", gs, "--format", "mermaid"], dir.path());
    assert!(String::from_utf8_lossy(&out.stdout).contains("n0 -->|\"report → report: Report\"| n1"));
    let out = run(&["graph", gs, "--format", "dot"], dir.path());
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"load\" -> \"save\""));
    let out = run(&["nodes", "io.load_mesh"], dir.path());
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("mesh") && text.contains("TriMesh") && text.contains("path"),
        "{text}"
    );
    let out = run(&["nodes"], dir.path());
    assert!(String::from_utf8_lossy(&out.stdout).contains("io.load_mesh v"));
}

/// A reader that closes the pipe before the output is written (`crestflow nodes | head -1`)
/// ends the binary quietly: no panic, no backtrace, killed by SIGPIPE like other Unix tools.
#[cfg(unix)]
#[test]
fn a_closed_stdout_pipe_ends_the_binary_without_a_panic() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::Stdio;
    let dir = tempdir();
    for args in [&["nodes"][..], &["nodes", "io.load_mesh"]] {
        let mut child = common::cli::bin()
            .args(args)
            .current_dir(dir.path())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .env("RUST_BACKTRACE", "1")
            .spawn()
            .expect("the binary runs");
        // Closing the read end at once: the binary's first write finds no reader.
        drop(child.stdout.take());
        let out = child.wait_with_output().expect("the binary ends");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(
            out.status.success() || out.status.signal() == Some(13),
            "{args:?}: {:?} {err}",
            out.status
        );
    }
}

/// `--threads` above the limit, or not a number, is a usage error naming the option.
#[test]
fn an_impossible_thread_count_is_a_usage_error() {
    let dir = tempdir();
    let g = good_graph(dir.path());
    let gs = g.to_str().unwrap();
    for (count, says) in [
        ("100000", "at most 1024 threads"),
        ("many", "is not a thread count"),
    ] {
        let out = run(&["run", gs, "--threads", count], dir.path());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains("--threads") && err.contains(says), "{err}");
    }
}

/// A mesh path that names a pipe (or a device) fails its load node with the path and the
/// reason, and the run ends: neither hashing the input for the cache key nor loading it waits
/// on the pipe.
#[cfg(unix)]
#[test]
fn a_mesh_path_that_is_a_pipe_fails_its_node_and_the_run_ends() {
    let dir = tempdir();
    let g = good_graph(dir.path());
    let fifo = dir.path().join("scan.off");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let set = format!("mesh={}", fifo.display());
    for cache in [&[][..], &["--no-cache"]] {
        let mut args = vec!["run", g.to_str().unwrap(), "--set", &set, "--log", "json"];
        args.extend(cache);
        let out = run(&args, dir.path());
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let events = json_lines(&out);
        assert_eq!(
            finished(&events),
            [
                ("load".to_string(), "failed".to_string()),
                ("save".to_string(), "skipped".to_string())
            ]
        );
        let failed = events
            .iter()
            .find(|e| e["event"] == "node_finished" && e["node"] == "load")
            .unwrap();
        let text = failed.to_string();
        assert!(
            text.contains("scan.off") && text.contains("not a regular file"),
            "{text}"
        );
    }
}
