//! `ridges.trace` through the engine's node contract: registry, params, ports, run.

mod common;

use std::path::Path;

use common::*;
use crestflow_flow::{CancelToken, Ctx, Inputs, NodeKind, Par, ProgressSink, Registry};
use crestflow_geom::{CurvatureField, FeatureCurveNetwork, TriMesh};
use crestflow_nodes_ridges::{register, trace, TraceNode, TraceParams};

struct Quiet;
impl ProgressSink for Quiet {
    fn progress(&self, _: &str, _: f32) {}
    fn warn(&self, _: &str, _: &str) {}
}

#[test]
fn registered_with_typed_ports_and_checked_params() {
    let mut reg = Registry::new();
    register(&mut reg);
    let node = reg.get("ridges.trace").expect("registered");
    let inputs: Vec<(&str, String)> = node
        .inputs()
        .iter()
        .map(|p| (p.name, p.ty.name.clone()))
        .collect();
    assert_eq!(
        inputs,
        vec![
            ("mesh", "TriMesh".to_string()),
            ("curvature", "CurvatureField".to_string())
        ]
    );
    let outputs: Vec<(&str, String)> = node
        .outputs()
        .iter()
        .map(|p| (p.name, p.ty.name.clone()))
        .collect();
    assert_eq!(
        outputs,
        vec![
            ("network", "FeatureCurveNetwork".to_string()),
            ("report", "Report".to_string())
        ]
    );
    assert!(node.prepare("()").is_ok());
    assert!(node.prepare("(min_length: 2.0, families: Ravines)").is_ok());
    assert!(node.prepare("(min_lenght: 2.0)").is_err());
    assert!(node.prepare("(min_strength: -1.0)").is_err());
}

#[test]
fn run_matches_the_pure_function() {
    let profile = crease(-1.0, 0.2);
    let mesh = profile.mesh(31, 0.3, 4);
    let field = profile.field(&mesh);
    let params = TraceParams::default();
    let expected = trace(&mesh, &field, &params, Par::Seq).unwrap();
    assert_eq!(expected.network.curves.len(), 1);

    let inputs = Inputs::new()
        .with::<TriMesh>("mesh", mesh.clone())
        .with::<CurvatureField>("curvature", field);
    let cancel = CancelToken::new();
    let ctx = Ctx {
        node: "ridges",
        par: Par::Rayon,
        base_dir: Path::new("."),
        cancel: &cancel,
        sink: &Quiet,
    };
    let out = TraceNode::run(&params, &inputs, &ctx).unwrap();
    let net = out
        .get("network")
        .unwrap()
        .downcast_ref::<FeatureCurveNetwork>()
        .unwrap();
    assert_eq!(net, &expected.network);
    let report = out
        .get("report")
        .unwrap()
        .downcast_ref::<crestflow_flow::Report>()
        .unwrap();
    assert_eq!(report.num("ridges"), Some(1.0));
    assert_eq!(report.num("ravines"), Some(0.0));
    assert_eq!(
        report.num("ridge_length"),
        Some(expected.stats.ridge_length)
    );

    // A field for another mesh is an input error, not a panic.
    let other = crease(-1.0, 0.2).mesh(11, 0.0, 1);
    let bad = Inputs::new()
        .with::<TriMesh>("mesh", mesh)
        .with::<CurvatureField>("curvature", profile.field(&other));
    let Err(err) = TraceNode::run(&params, &bad, &ctx) else {
        panic!("a mismatched field must fail")
    };
    assert_eq!(err.kind, crestflow_flow::ErrorKind::InvalidInput);
    assert!(
        err.message.contains("121 values but the mesh has 961"),
        "{}",
        err.message
    );

    // Cancellation is honoured.
    cancel.cancel();
    let inputs = Inputs::new()
        .with::<TriMesh>("mesh", other.clone())
        .with::<CurvatureField>("curvature", profile.field(&other));
    assert_eq!(
        TraceNode::run(&params, &inputs, &ctx).err().map(|e| e.kind),
        Some(crestflow_flow::ErrorKind::Cancelled)
    );
}
