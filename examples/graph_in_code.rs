//! Building a graph in code instead of a RON file, printing its plan, and running it twice to
//! see the cache at work.
//!
//! `cargo run --example graph_in_code`

use std::path::Path;

use crestflow_flow::{load, run, Graph, RunOptions, Status};
use crestflow_geom::mesh::TriMesh;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let registry = crestflow::registry();
    // Paths in params are relative to the graph's base folder: the repository root here.
    let mut graph = Graph::new(Path::new(env!("CARGO_MANIFEST_DIR")));
    graph.param("mesh", "\"../shared/data/meshes/cad/cgal_pinion.off\"");
    graph.node("load", "io.load_mesh", "(path: \"$mesh\")");
    graph
        .node("curv", "curvature.polynomial", "(rings: 2)")
        .input("mesh", "load.mesh");

    let plan = load(&graph, &registry, &[])?;
    print!("{}", plan.explain());

    // The cache is content-addressed: a later run of this example (or any graph computing the
    // same values into this folder) finds everything cached from the first run on.
    let cache = std::env::temp_dir().join("crestflow-example-graph-in-code");
    let opts = RunOptions {
        cache_dir: Some(cache),
        graph_id: Some("graph_in_code".into()),
        ..Default::default()
    };
    for attempt in 1..=2 {
        let summary = run(&plan, &opts)?;
        let statuses: Vec<String> = summary
            .nodes
            .iter()
            .map(|n| format!("{} {}", n.name, n.status.as_str()))
            .collect();
        println!(
            "run {attempt}: {} ({:.1} ms)",
            statuses.join(", "),
            summary.ms
        );
        if summary.count(Status::Failed) > 0 {
            return Err("a node failed".into());
        }
    }
    let summary = run(&plan, &opts)?;
    let mesh = summary
        .node("load")
        .ok_or("no node load")?
        .get::<TriMesh>("mesh")?;
    println!(
        "the cached mesh has {} vertices and {} faces",
        mesh.n_vertices(),
        mesh.n_faces()
    );
    Ok(())
}
