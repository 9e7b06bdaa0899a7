//! Every pipeline shipped in `graphs/` validates against the registry of the built binary:
//! kinds exist, params parse and lie in range, ports and types match. A renamed node, port or
//! param in a family breaks this test before it breaks a user.

mod common;

use std::path::{Path, PathBuf};

use common::cli::run;

/// The `.ron` files in `graphs/` that `keep` accepts, sorted.
fn shipped(keep: impl Fn(&Path) -> bool) -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut graphs: Vec<PathBuf> = std::fs::read_dir(root.join("graphs"))
        .expect("graphs/ exists")
        .map(|e| e.expect("readable entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron") && keep(p))
        .collect();
    graphs.sort();
    graphs
}

#[test]
fn every_shipped_graph_validates() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let graphs = shipped(|p| {
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
        !name.ends_with(".experiment.ron")
    });
    let names: Vec<String> = graphs
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    for expected in [
        "feature-curves.ron",
        "symmetry.ron",
        "co-completion.ron",
        "smooth.ron",
        "remesh.ron",
        "scale-remesh.ron",
        "scale-remesh-cad.ron",
        "curve-matching.ron",
        "fmap-cat-lion.ron",
    ] {
        assert!(names.iter().any(|n| n == expected), "missing {expected}");
    }
    for g in &graphs {
        let out = run(&["validate", g.to_str().unwrap()], root);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{}: {}{}",
            g.display(),
            stdout,
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(stdout.contains("ok ("), "{}: {stdout}", g.display());
    }
}

#[test]
fn every_shipped_mesh_graph_repairs_a_non_manifold_mesh_on_request() {
    // The error for a non-manifold mesh says `--set repair=true`: every shipped graph that
    // loads a mesh must take that param. A multi-part assembly with 242 non-manifold edges
    // (SOURCES.md names it a bad-input case) fails without it and runs with it.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let graphs = shipped(|p| {
        std::fs::read_to_string(p)
            .unwrap_or_default()
            .contains("io.load_mesh")
    });
    assert!(graphs.len() >= 9, "{graphs:?}");
    for g in &graphs {
        let out = run(
            &["validate", g.to_str().unwrap(), "--set", "repair=true"],
            root,
        );
        assert_eq!(
            out.status.code(),
            Some(0),
            "{}: {}",
            g.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let dir = common::tempdir();
    let mesh = common::cli::mesh("cad/trimesh_cycloidal.ply");
    let graph = root.join("graphs/feature-curves.ron");
    let args = |repair: &'static str| {
        vec![
            "run".to_string(),
            graph.to_string_lossy().into_owned(),
            "--no-cache".into(),
            "--set".into(),
            format!("mesh={}", mesh.display()),
            "--set".into(),
            format!("out={}", dir.path().display()),
            "--set".into(),
            format!("repair={repair}"),
        ]
    };
    let run_with = |repair| {
        let a = args(repair);
        run(&a.iter().map(String::as_str).collect::<Vec<_>>(), root)
    };
    let out = run_with("false");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("242 non-manifold edges") && err.contains("--set repair=true"),
        "{err}"
    );
    let out = run_with("true");
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join("curves.ply").is_file());
}
