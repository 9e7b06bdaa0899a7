//! Writing a custom node: a pure function, a params struct, and a thin `NodeKind` wrapper,
//! registered next to the built-in nodes and used in a pipeline.
//!
//! `cargo run --example custom_node`

use std::path::Path;

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, ParamIssue, Port, Report, Validate,
};
use crestflow_geom::mesh::TriMesh;
use serde::{Deserialize, Serialize};

/// Params: `#[serde(default, deny_unknown_fields)]`, documented defaults, validated ranges.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AreaStatsParams {
    /// Faces whose area is below `small_fraction` × the mean face area count as small.
    pub small_fraction: f64,
}

impl Default for AreaStatsParams {
    fn default() -> Self {
        AreaStatsParams {
            small_fraction: 0.1,
        }
    }
}

impl Validate for AreaStatsParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "small_fraction", self.small_fraction, 0.0, 1.0);
        issues
    }
}

/// The pure function: usable without the engine.
pub fn area_stats(mesh: &TriMesh, params: &AreaStatsParams) -> Result<Report, NodeError> {
    if mesh.n_faces() == 0 {
        return Err(NodeError::invalid_input("the mesh has no faces"));
    }
    let total = mesh.total_area();
    let mean = total / mesh.n_faces() as f64;
    let small = (0..mesh.n_faces())
        .filter(|&f| mesh.face_area(f) < params.small_fraction * mean)
        .count();
    let mut r = Report::new();
    r.set("total_area", total)
        .set("mean_face_area", mean)
        .set("small_faces", small);
    Ok(r)
}

/// The node wrapper: kind, version, ports, and a `run` that unpacks, calls and packs.
pub struct AreaStats;

impl NodeKind for AreaStats {
    type Params = AreaStatsParams;
    const KIND: &'static str = "example.area_stats";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Total and mean face area of a mesh, and how many faces are small.";

    fn inputs() -> Vec<Port> {
        vec![Port::of::<TriMesh>("mesh", "the mesh")]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<Report>("report", "area statistics")]
    }
    fn run(params: &AreaStatsParams, inputs: &Inputs, _ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        Ok(Outputs::new().with("report", area_stats(mesh, params)?))
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut registry = crestflow::registry();
    registry.add::<AreaStats>();

    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let graph = crestflow_flow::Graph::from_ron(
        r#"Graph(nodes: {
            "load": (kind: "io.load_mesh", params: (path: "../shared/data/meshes/cad/cgal_pinion.off")),
            "area": (kind: "example.area_stats", params: (small_fraction: 0.2), inputs: { "mesh": "load.mesh" }),
        })"#,
        None,
        root,
    )?;
    let plan = crestflow_flow::load(&graph, &registry, &[])?;
    let opts = crestflow_flow::RunOptions {
        cache_dir: Some(std::env::temp_dir().join("crestflow-example-custom-node")),
        ..Default::default()
    };
    let summary = crestflow_flow::run(&plan, &opts)?;
    let report = summary
        .node("area")
        .ok_or("no node area")?
        .get::<Report>("report")?;
    for (k, v) in &report.values {
        println!("{k} = {v:?}");
    }

    // A bad parameter is caught when the graph is loaded, before anything runs.
    let mut bad = graph.clone();
    bad.nodes[1].params = "(small_fraction: 3.0)".into();
    bad.nodes[1].params_span = None;
    match crestflow_flow::load(&bad, &registry, &[]) {
        Err(e) => println!("as expected: {e}"),
        Ok(_) => return Err("a bad parameter was accepted".into()),
    }
    Ok(())
}
