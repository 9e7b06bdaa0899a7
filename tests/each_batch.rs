//! `crestflow run GRAPH --each GLOB` through the binary on real meshes: one bad file among good
//! ones fails alone (exit 1, named in the summary), outputs are named after each input's stem,
//! the cache is shared, and a second batch is all cached.

mod common;

use std::path::Path;

use common::cli::{json_lines, mesh, run};
use common::{tempdir, write};
use serde_json::Value as Json;

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

const GRAPH: &str = r#"Graph(
    params: { "mesh": "none.off", "out": "out" },
    nodes: {
        "load": (kind: "io.load_mesh", params: (path: "$mesh")),
        "save": (kind: "io.save_report", params: (path: "$out/report.json"), inputs: { "report": "load.report" }),
        "ico": (kind: "shapes.analytic", params: (vertices: 42)),
    },
)"#;

fn finished_for<'a>(events: &'a [Json], input_suffix: &str, node: &str) -> Vec<&'a str> {
    events
        .iter()
        .filter(|e| {
            e["event"] == "node_finished"
                && e["node"] == node
                && e["input"]
                    .as_str()
                    .is_some_and(|i| i.ends_with(input_suffix))
        })
        .map(|e| e["status"].as_str().unwrap())
        .collect()
}

#[test]
fn one_bad_file_fails_alone() {
    let dir = tempdir();
    let d = dir.path();
    write(d, "graph.ron", GRAPH);
    std::fs::create_dir(d.join("in")).unwrap();
    let good = ["cad/cgal_fandisk.off", "organic/cgal_elephant.off"];
    for g in good {
        let src = mesh(g);
        std::fs::copy(&src, d.join("in").join(src.file_name().unwrap())).unwrap();
    }
    // Truncated: the header promises vertices that are not there.
    write(&d.join("in"), "broken.off", "OFF\n100 50 0\n0 0 0\n");

    let out = run(
        &[
            "run",
            "graph.ron",
            "--each",
            "in/*.off",
            "--jobs",
            "2",
            "--log",
            "json",
        ],
        d,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("1 of 3 files failed"), "{stderr}");
    let failed_line = stderr
        .lines()
        .find(|l| l.contains("broken.off") && l.contains("FAILED"))
        .unwrap_or_else(|| panic!("the summary table names the failure: {stderr}"));
    assert!(!failed_line.contains("cgal_"), "{failed_line}");
    assert!(stderr.contains("load [io.load_mesh]"), "{stderr}");

    let events = json_lines(&out);
    assert_eq!(finished_for(&events, "broken.off", "load"), ["failed"]);
    assert_eq!(finished_for(&events, "broken.off", "save"), ["skipped"]);
    for g in good {
        let name = Path::new(g).file_name().unwrap().to_str().unwrap();
        assert_eq!(finished_for(&events, name, "save"), ["ran"], "{name}");
        // Outputs named after the stem, with the right content.
        let stem = name.trim_end_matches(".off");
        let report: Json = serde_json::from_slice(
            &std::fs::read(d.join("out").join(stem).join("report.json")).unwrap(),
        )
        .unwrap();
        let text = report.to_string();
        let n = off_vertices(&mesh(g));
        assert!(
            text.contains(&format!(":{n}")) || text.contains(&format!(":{n}.0")),
            "{stem}: {text} lacks {n} vertices"
        );
    }
    let last = events.last().unwrap();
    assert_eq!(last["event"], "each_finished");
    assert_eq!(last["files"], 3);
    assert!(last["failed"][0].as_str().unwrap().ends_with("broken.off"));

    // Again, one at a time: the good files are all cached, the bad one fails again, and the
    // node that does not read the file (`ico`) comes from the shared cache everywhere.
    let out = run(
        &["run", "graph.ron", "--each", "in/*.off", "--log", "json"],
        d,
    );
    assert_eq!(out.status.code(), Some(1));
    let events = json_lines(&out);
    for name in ["cgal_fandisk.off", "cgal_elephant.off"] {
        for node in ["load", "save", "ico"] {
            assert_eq!(
                finished_for(&events, name, node),
                ["cached"],
                "{name} {node}"
            );
        }
    }
    assert_eq!(finished_for(&events, "broken.off", "load"), ["failed"]);
}

#[test]
fn shared_cache_runs_file_independent_nodes_once() {
    let dir = tempdir();
    let d = dir.path();
    write(d, "graph.ron", GRAPH);
    let poses = mesh("correspondence/sumner_cat_lion/cat-poses");
    let pattern = format!("{}/cat-0[1-3].obj", poses.display());
    let out = run(
        &[
            "run",
            "graph.ron",
            "--each",
            &pattern,
            "--jobs",
            "1",
            "--log",
            "json",
        ],
        d,
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let events = json_lines(&out);
    let ico: Vec<&str> = events
        .iter()
        .filter(|e| e["event"] == "node_finished" && e["node"] == "ico")
        .map(|e| e["status"].as_str().unwrap())
        .collect();
    assert_eq!(ico, ["ran", "cached", "cached"]);
    for k in 1..=3 {
        assert!(d.join(format!("out/cat-0{k}/report.json")).is_file());
    }

    // Three files at once, without the cache: the same outputs, byte for byte.
    let out = run(
        &[
            "run",
            "graph.ron",
            "--each",
            &pattern,
            "--jobs",
            "3",
            "--no-cache",
            "--set",
            "out=out3",
        ],
        d,
    );
    assert_eq!(out.status.code(), Some(0));
    for k in 1..=3 {
        let a = std::fs::read(d.join(format!("out/cat-0{k}/report.json"))).unwrap();
        let b = std::fs::read(d.join(format!("out3/cat-0{k}/report.json"))).unwrap();
        assert_eq!(a, b, "cat-0{k}");
    }
}

#[test]
fn no_match_and_unbindable_graph_are_usage_errors() {
    let dir = tempdir();
    let d = dir.path();
    write(d, "graph.ron", GRAPH);
    let out = run(&["run", "graph.ron", "--each", "nothing/*.off"], d);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no file matches"));

    std::fs::copy(mesh("organic/cgal_elephant.off"), d.join("e.off")).unwrap();
    let out = run(
        &["run", "graph.ron", "--each", "*.off", "--bind", "scan"],
        d,
    );
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no param `scan`") && err.contains("mesh, out"),
        "{err}"
    );
}
