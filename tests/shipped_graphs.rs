//! Every pipeline shipped in `graphs/` validates against the registry of the built binary:
//! kinds exist, params parse and lie in range, ports and types match. A renamed node, port or
//! param in a family breaks this test before it breaks a user.

mod common;

use std::path::Path;

use common::cli::run;

#[test]
fn every_shipped_graph_validates() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut graphs: Vec<_> = std::fs::read_dir(root.join("graphs"))
        .expect("graphs/ exists")
        .map(|e| e.expect("readable entry").path())
        .filter(|p| {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            name.ends_with(".ron") && !name.ends_with(".experiment.ron")
        })
        .collect();
    graphs.sort();
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
