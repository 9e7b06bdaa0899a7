//! Unit tests of `analytic.rs`.

use super::*;

#[test]
fn params_parse_from_ron_and_validate() {
    let p: AnalyticParams =
        ron::from_str("(shape: Torus(major: 1.0, minor: 0.35), vertices: 5000, jitter: 0.3)")
            .unwrap();
    assert_eq!(
        p.shape,
        AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35
        }
    );
    assert_eq!(p.seed, 0);
    assert!(p.validate().is_empty());
    let mesh = analytic_mesh(&p, Par::Seq).unwrap();
    // ~5000 vertices on a grid sized by the radii ratio.
    assert!(
        (4500..=5500).contains(&mesh.n_vertices()),
        "{}",
        mesh.n_vertices()
    );
    assert!(ron::from_str::<AnalyticParams>("(radius: 1.0)").is_err());

    let bad = AnalyticParams {
        shape: AnalyticShape::Torus {
            major: 0.2,
            minor: 0.35,
        },
        vertices: 3,
        jitter: 0.9,
        seed: 0,
    };
    let fields: Vec<String> = bad.validate().into_iter().map(|i| i.field).collect();
    assert_eq!(fields, ["shape", "vertices", "jitter"]);
}

#[test]
fn node_outputs_the_mesh() {
    struct Quiet;
    impl crestflow_flow::ProgressSink for Quiet {
        fn progress(&self, _: &str, _: f32) {}
        fn warn(&self, _: &str, _: &str) {}
    }
    let cancel = crestflow_flow::CancelToken::new();
    let ctx = Ctx {
        node: "shape",
        par: Par::Seq,
        base_dir: std::path::Path::new("."),
        cancel: &cancel,
        sink: &Quiet,
    };
    let p = AnalyticParams {
        shape: AnalyticShape::Sphere { radius: 2.0 },
        vertices: 642,
        ..Default::default()
    };
    let out = AnalyticNode::run(&p, &Inputs::new(), &ctx).unwrap();
    let mesh = out.get("mesh").unwrap().downcast_ref::<TriMesh>().unwrap();
    assert_eq!(mesh.n_vertices(), 642);
    assert!(mesh
        .positions
        .iter()
        .all(|p| (crestflow_geom::vec3::norm(*p) - 2.0).abs() < 1e-12));
}
