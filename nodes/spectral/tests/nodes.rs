//! The node wrappers: `spectral.laplacian` feeds `spectral.eigenbasis` through ports, and a
//! cancelled run stops with the Cancelled kind.

use std::path::Path;

use crestflow_flow::{CancelToken, Ctx, ErrorKind, Inputs, NodeKind, Par, ProgressSink};
use crestflow_geom::shapes::sphere;
use crestflow_geom::TriMesh;
use crestflow_nodes_spectral::{
    EigenBasis, EigenbasisNode, EigenbasisParams, LaplacianNode, LaplacianOperator, LaplacianParams,
};

struct Quiet;
impl ProgressSink for Quiet {
    fn progress(&self, _: &str, _: f32) {}
    fn warn(&self, _: &str, _: &str) {}
}

#[test]
fn laplacian_then_eigenbasis() {
    let cancel = CancelToken::new();
    let ctx = Ctx {
        node: "test",
        par: Par::Rayon,
        base_dir: Path::new("."),
        cancel: &cancel,
        sink: &Quiet,
    };
    let mesh: TriMesh = sphere(1.0, 3).unwrap();
    let out = LaplacianNode::run(
        &LaplacianParams::default(),
        &Inputs::new().with("mesh", mesh),
        &ctx,
    )
    .unwrap();
    let op = out
        .get("operator")
        .and_then(|v| v.downcast_ref::<LaplacianOperator>())
        .unwrap()
        .clone();
    assert_eq!(op.n(), 642);
    let params = EigenbasisParams {
        k: 4,
        ..Default::default()
    };
    let out =
        EigenbasisNode::run(&params, &Inputs::new().with("operator", op.clone()), &ctx).unwrap();
    let basis = out
        .get("basis")
        .and_then(|v| v.downcast_ref::<EigenBasis>())
        .unwrap();
    assert_eq!(basis.k(), 4);
    assert!((basis.values[1] - 2.0).abs() < 0.01, "{:?}", basis.values);

    cancel.cancel();
    let err = EigenbasisNode::run(&params, &Inputs::new().with("operator", op), &ctx)
        .err()
        .unwrap();
    assert_eq!(err.kind, ErrorKind::Cancelled);
}
