//! `crestflow watch` through the binary with the real io nodes, in a temporary folder with
//! bounded waits: an invalid save prints its location and the process stays alive; the next
//! valid save runs; `--max-runs` ends the process by itself.

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{tempdir, write};
use crossbeam_channel::{unbounded, Receiver};
use serde_json::Value as Json;

const WAIT: Duration = Duration::from_secs(60);

fn graph(out_name: &str, bad: bool) -> String {
    format!(
        r#"Graph(
    params: {{ "mesh": "mesh.off", "out": "out" }},
    nodes: {{
        "load": (kind: "io.load_mesh", params: (path: "$mesh"{})),
        "ico": (kind: "shapes.analytic", params: (vertices: 42)),
        "save": (kind: "io.save_report", params: (path: "$out/{out_name}"), inputs: {{ "report": "load.report" }}),
    }},
)"#,
        if bad { ", repiar: true" } else { "" }
    )
}

struct Proc {
    child: Child,
    stdout: Receiver<Json>,
    stderr: Arc<Mutex<String>>,
}

impl Drop for Proc {
    fn drop(&mut self) {
        // Never leave a watcher behind, whatever the test did.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn spawn(dir: &Path) -> Proc {
    let mut child = Command::new(env!("CARGO_BIN_EXE_crestflow"))
        .args([
            "watch",
            "graph.ron",
            "--log",
            "json",
            "--max-runs",
            "2",
            "--exit-after",
            "120",
        ])
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary starts");
    let (tx, rx) = unbounded();
    let out = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            let v: Json =
                serde_json::from_str(&line).unwrap_or_else(|e| panic!("not JSON: {line}: {e}"));
            if tx.send(v).is_err() {
                break;
            }
        }
    });
    let stderr = Arc::new(Mutex::new(String::new()));
    let err = child.stderr.take().unwrap();
    let sink = stderr.clone();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            let mut s = sink.lock().unwrap();
            s.push_str(&line);
            s.push('\n');
        }
    });
    Proc {
        child,
        stdout: rx,
        stderr,
    }
}

impl Proc {
    fn until(&self, what: &str, pred: impl Fn(&Json) -> bool) -> Vec<Json> {
        let t0 = Instant::now();
        let mut seen = Vec::new();
        loop {
            let left = WAIT.saturating_sub(t0.elapsed());
            match self.stdout.recv_timeout(left) {
                Ok(v) => {
                    let hit = pred(&v);
                    seen.push(v);
                    if hit {
                        return seen;
                    }
                }
                Err(_) => panic!(
                    "timed out waiting for {what}; seen {seen:#?}; stderr:\n{}",
                    self.stderr.lock().unwrap()
                ),
            }
        }
    }
}

#[test]
fn invalid_save_is_reported_and_the_process_stays_alive() {
    let dir = tempdir();
    let d = dir.path();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/data/meshes/organic/cgal_elephant.off"),
        d.join("mesh.off"),
    )
    .unwrap();
    write(d, "graph.ron", &graph("a.json", false));
    let mut p = spawn(d);
    let first = p.until("run 1", |e| e["event"] == "watch_run_finished");
    let fin = first.last().unwrap();
    assert_eq!(fin["ran"], 3, "{first:#?}");
    assert!(d.join("out/a.json").is_file());

    // A misspelled param: reported with file:line:column, nothing runs, still alive.
    write(d, "graph.ron", &graph("a.json", true));
    let ev = p.until("the invalid graph", |e| e["event"] == "watch_invalid");
    let msg = ev.last().unwrap()["message"].as_str().unwrap().to_string();
    assert!(
        msg.contains("graph.ron:4:") && msg.contains("repiar"),
        "{msg}"
    );
    let t0 = Instant::now();
    loop {
        if p.stderr
            .lock()
            .unwrap()
            .contains("keeping the last good graph")
            || t0.elapsed() > WAIT
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let stderr = p.stderr.lock().unwrap().clone();
    assert!(stderr.contains("graph.ron:4:"), "{stderr}");
    assert!(p.child.try_wait().unwrap().is_none(), "the watcher exited");

    // The next valid save runs; only `save` had new params.
    write(d, "graph.ron", &graph("b.json", false));
    let ev = p.until("run 2", |e| e["event"] == "watch_run_finished");
    let fin = ev.last().unwrap();
    assert_eq!(
        (fin["ran"].as_u64(), fin["cached"].as_u64()),
        (Some(1), Some(2))
    );
    let saved: Vec<&Json> = ev
        .iter()
        .filter(|e| e["event"] == "node_finished" && e["node"] == "save")
        .collect();
    assert_eq!(saved.len(), 1);
    assert!(
        saved[0]["reason"].as_str().unwrap().contains("b.json"),
        "{saved:?}"
    );
    assert!(d.join("out/b.json").is_file());

    // --max-runs 2: the process ends by itself.
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = p.child.try_wait().unwrap() {
            break s;
        }
        assert!(t0.elapsed() < WAIT, "the watcher did not stop after 2 runs");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(status.code(), Some(0));
}
