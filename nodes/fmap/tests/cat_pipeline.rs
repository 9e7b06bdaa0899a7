//! The node wrappers chained on real data: two poses of the Sumner cat (identity ground
//! truth) through landmarks → shortest paths → curve-constrained map → point map → error,
//! against the descriptor baseline on the same bases; plus the node-level error paths.

use std::path::{Path, PathBuf};

use crestflow_flow::{
    CancelToken, Ctx, ErrorKind, Inputs, NodeKind, Outputs, Par, ProgressSink, Report,
};
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_geom::{FeatureCurveNetwork, TriMesh};
use crestflow_nodes_fmap::eval_correspondence::EvalCorrespondenceNode;
use crestflow_nodes_fmap::*;
use crestflow_nodes_spectral::{
    EigenBasis, EigenbasisNode, EigenbasisParams, LaplacianNode, LaplacianOperator, LaplacianParams,
};

struct Quiet;
impl ProgressSink for Quiet {
    fn progress(&self, _: &str, _: f32) {}
    fn warn(&self, _: &str, _: &str) {}
}

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/meshes/correspondence/sumner_cat_lion")
}

fn run<N: NodeKind>(
    params: &N::Params,
    inputs: Inputs,
) -> Result<Outputs, crestflow_flow::NodeError> {
    let cancel = CancelToken::new();
    let dir = data();
    let ctx = Ctx {
        node: "test",
        par: Par::Rayon,
        base_dir: &dir,
        cancel: &cancel,
        sink: &Quiet,
    };
    N::run(params, &inputs, &ctx)
}

fn err(r: Result<Outputs, crestflow_flow::NodeError>) -> crestflow_flow::NodeError {
    match r {
        Ok(_) => panic!("expected an error"),
        Err(e) => e,
    }
}

fn get<T: Clone + 'static>(o: &Outputs, port: &str) -> T {
    o.get(port)
        .and_then(|v| v.downcast_ref::<T>())
        .unwrap()
        .clone()
}

fn basis(mesh: &TriMesh, k: usize) -> EigenBasis {
    let op: LaplacianOperator = get(
        &run::<LaplacianNode>(
            &LaplacianParams::default(),
            Inputs::new().with("mesh", mesh.clone()),
        )
        .unwrap(),
        "operator",
    );
    get(
        &run::<EigenbasisNode>(
            &EigenbasisParams {
                k,
                ..Default::default()
            },
            Inputs::new().with("operator", op),
        )
        .unwrap(),
        "basis",
    )
}

#[test]
fn cat_pose_to_pose_curves_beat_descriptors() {
    let load = |f: &str| {
        load_mesh(data().join(f), &LoadOptions::default())
            .unwrap()
            .mesh
    };
    let m1 = load("cat-poses/cat-reference.obj");
    let m2 = load("cat-poses/cat-05.obj");
    // The cat-lion landmark file, with the cat vertex on both sides (identity ground truth).
    let mut lm: LandmarkPairs = get(
        &run::<LandmarksNode>(
            &LandmarksParams {
                path: "pyfm_landmarks_cat_lion.txt".into(),
            },
            Inputs::new(),
        )
        .unwrap(),
        "landmarks",
    );
    lm.pairs.iter_mut().for_each(|p| p[1] = p[0]);
    let k = 60;
    let e1 = basis(&m1, k);
    let e2 = basis(&m2, k);
    let curves = |mesh: &TriMesh, side| -> FeatureCurveNetwork {
        get(
            &run::<ShortestPathNode>(
                &ShortestPathParams {
                    side,
                    curves: 20,
                    ..Default::default()
                },
                Inputs::new()
                    .with("mesh", mesh.clone())
                    .with("landmarks", lm.clone()),
            )
            .unwrap(),
            "network",
        )
    };
    let (c1, c2) = (curves(&m1, Side::Source), curves(&m2, Side::Target));
    assert_eq!(c1.curves.len(), 20);
    let fm: FunctionalMap = get(
        &run::<CurveConstrainedNode>(
            &CurveConstrainedParams {
                k,
                ..Default::default()
            },
            Inputs::new()
                .with("source_basis", e1.clone())
                .with("target_basis", e2.clone())
                .with("source_mesh", m1.clone())
                .with("target_mesh", m2.clone())
                .with("source_curves", c1)
                .with("target_curves", c2),
        )
        .unwrap(),
        "map",
    );
    let dm: FunctionalMap = get(
        &run::<DescriptorMapNode>(
            &DescriptorMapParams {
                k,
                ..Default::default()
            },
            Inputs::new()
                .with("source_basis", e1.clone())
                .with("target_basis", e2.clone()),
        )
        .unwrap(),
        "map",
    );
    let points = |m: &FunctionalMap| -> PointMap {
        get(
            &run::<PointMapNode>(
                &PointMapParams::default(),
                Inputs::new()
                    .with("source_basis", e1.clone())
                    .with("target_basis", e2.clone())
                    .with("map", m.clone()),
            )
            .unwrap(),
            "points",
        )
    };
    let score = |m: &FunctionalMap, label: &str| -> Report {
        let pm = points(m);
        get(
            &run::<EvalCorrespondenceNode>(
                &EvalCorrespondenceParams {
                    max_queries: 1500,
                    label: label.into(),
                    ..Default::default()
                },
                Inputs::new()
                    .with("source_mesh", m1.clone())
                    .with("points", pm),
            )
            .unwrap(),
            "report",
        )
    };
    let rc = score(&fm, "curves");
    let rd = score(&dm, "descriptor");
    let (mc, md) = (
        rc.num("curves.mean").unwrap(),
        rd.num("descriptor.mean").unwrap(),
    );
    eprintln!("cat pose→pose k={k}: curves mean {mc:.4}, descriptor mean {md:.4}");
    assert!(mc < md, "curves {mc} vs descriptor {md}");
    assert!(rc.num("curves.cum_0.25").unwrap() > rd.num("descriptor.cum_0.25").unwrap());
    // Both maps in one node, the baseline as `compare`: the same figures as the two
    // evaluations above, from one set of distance fields.
    let (pf, pd) = (points(&fm), points(&dm));
    let together = |label: &str, compare_label: &str| {
        run::<EvalCorrespondenceNode>(
            &EvalCorrespondenceParams {
                max_queries: 1500,
                label: label.into(),
                compare_label: compare_label.into(),
                ..Default::default()
            },
            Inputs::new()
                .with("source_mesh", m1.clone())
                .with("points", pf.clone())
                .with("compare", pd.clone()),
        )
    };
    let both: Report = get(&together("curves", "descriptor").unwrap(), "report");
    let mut separate = rc.clone();
    separate.values.extend(rd.values.clone());
    assert_eq!(both, separate);
    // The two maps under one label is an error naming the parameter.
    let e = err(together("x", "x"));
    assert_eq!(e.kind, ErrorKind::InvalidInput);
    assert!(e.message.contains("compare_label"), "{}", e.message);
}

#[test]
fn node_errors_have_the_invalid_input_kind() {
    let e = err(run::<LandmarksNode>(
        &LandmarksParams {
            path: "no-such-file.txt".into(),
        },
        Inputs::new(),
    ));
    assert_eq!(e.kind, ErrorKind::InvalidInput);
    assert!(e.message.contains("no-such-file.txt"), "{}", e.message);
    // A landmark index beyond the mesh, through the node.
    let mesh = crestflow_geom::shapes::sphere(1.0, 1).unwrap();
    let lm = parse_landmarks("0 0\n1 1\n# c\n99 2\n", "lm.txt").unwrap();
    let e = err(run::<ShortestPathNode>(
        &ShortestPathParams::default(),
        Inputs::new().with("mesh", mesh).with("landmarks", lm),
    ));
    assert_eq!(e.kind, ErrorKind::InvalidInput);
    assert_eq!(
        e.message,
        "lm.txt:4: source vertex 99 is out of range: the source mesh has 42 vertices"
    );
}
