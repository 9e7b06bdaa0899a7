//! The io nodes through the registry, as the engine runs them: params parsing and validation,
//! declared files, path resolution against the pipeline folder, warnings, outputs.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crestflow_flow::{
    CancelToken, Ctx, ErrorKind, Inputs, Outputs, Par, ParamError, ProgressSink, Registry, Report,
};
use crestflow_geom::io::{load_curves_ply, load_mesh, LoadOptions, MeshError};
use crestflow_geom::{
    CurvatureField, CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint, TriMesh,
};

#[derive(Default)]
struct Sink(Mutex<Vec<String>>);

impl ProgressSink for Sink {
    fn progress(&self, _node: &str, _fraction: f32) {}
    fn warn(&self, node: &str, message: &str) {
        self.0.lock().unwrap().push(format!("{node}: {message}"));
    }
}

fn registry() -> Registry {
    let mut r = Registry::new();
    crestflow_nodes_io::register(&mut r);
    r
}

/// Prepares `ron` params for `kind` and runs it with `base` as the pipeline folder.
fn run(
    kind: &str,
    ron: &str,
    inputs: &Inputs,
    base: &Path,
    sink: &Sink,
) -> Result<Outputs, crestflow_flow::NodeError> {
    let reg = registry();
    let node = reg.get(kind).unwrap();
    let params = node
        .prepare(ron)
        .unwrap_or_else(|e| panic!("{kind} {ron}: {e:?}"));
    let cancel = CancelToken::new();
    let ctx = Ctx {
        node: "n",
        par: Par::Seq,
        base_dir: base,
        cancel: &cancel,
        sink,
    };
    node.run(&params, inputs, &ctx)
}

const TWO_PARTS_OFF: &str = "OFF\n7 2 0\n0 0 0\n1 0 0\n0 1 0\n5 5 5\n3 0 0\n4 0 0\n3 1 0\n\
                             3 0 1 2\n3 4 5 6\n";

#[test]
fn the_family_registers_four_kinds() {
    let kinds: Vec<&str> = registry().kinds().collect();
    assert_eq!(
        kinds,
        [
            "io.load_mesh",
            "io.save_curves",
            "io.save_mesh",
            "io.save_report"
        ]
    );
}

#[test]
fn load_params_are_checked_when_the_graph_loads() {
    let reg = registry();
    let load = reg.get("io.load_mesh").unwrap();
    let p = load
        .prepare("(path: \"meshes/a.OFF\", repair: true)")
        .unwrap();
    assert_eq!(p.input_files, vec![PathBuf::from("meshes/a.OFF")]);
    assert!(p.output_files.is_empty());
    match load.prepare("()") {
        Err(ParamError::Invalid(issues)) => {
            assert_eq!(issues.len(), 1);
            assert_eq!(issues[0].field, "path");
        }
        other => panic!("{:?}", other.err()),
    }
    match load.prepare("(path: \"a.xyz\")") {
        Err(ParamError::Invalid(issues)) => assert!(issues[0].message.contains("`.xyz`")),
        other => panic!("{:?}", other.err()),
    }
    assert!(matches!(
        load.prepare("(path: \"a.off\", rapair: true)"),
        Err(ParamError::Parse { .. })
    ));
    for kind in ["io.save_mesh", "io.save_curves"] {
        let node = reg.get(kind).unwrap();
        assert_eq!(
            node.prepare("(path: \"out/x.ply\")").unwrap().output_files,
            vec![PathBuf::from("out/x.ply")]
        );
        match node.prepare("(path: \"out/x.stl\")") {
            Err(ParamError::Invalid(issues)) => {
                assert!(issues[0].message.contains("use .ply or .obj"))
            }
            other => panic!("{kind}: {:?}", other.err()),
        }
    }
    let report = reg.get("io.save_report").unwrap();
    assert!(matches!(
        report.prepare("(path: \"r.txt\")"),
        Err(ParamError::Invalid(_))
    ));
    assert_eq!(
        report.prepare("(path: \"r.json\")").unwrap().output_files,
        vec![PathBuf::from("r.json")]
    );
}

#[test]
fn load_node_resolves_the_path_warns_and_reports() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("m")).unwrap();
    std::fs::write(dir.path().join("m/two.off"), TWO_PARTS_OFF).unwrap();
    let sink = Sink::default();
    let out = run(
        "io.load_mesh",
        "(path: \"m/two.off\")",
        &Inputs::new(),
        dir.path(),
        &sink,
    )
    .unwrap();
    let mesh = out.get("mesh").unwrap().downcast_ref::<TriMesh>().unwrap();
    assert_eq!((mesh.n_vertices(), mesh.n_faces()), (6, 2));
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [3, 4, 5]]);
    let report = out.get("report").unwrap().downcast_ref::<Report>().unwrap();
    assert_eq!(report.num("components"), Some(2.0));
    assert_eq!(report.num("unreferenced_vertices_dropped"), Some(1.0));
    assert_eq!(report.num("boundary_edges"), Some(6.0));
    assert_eq!(report.text("format"), Some("off"));
    let warnings = sink.0.lock().unwrap().clone();
    assert_eq!(
        warnings,
        [
            "n: m/two.off: 1 unreferenced vertices dropped",
            "n: m/two.off: 2 connected components"
        ]
    );
}

#[test]
fn load_node_errors_keep_the_typed_source() {
    let dir = tempfile::tempdir().unwrap();
    // Three triangles on one edge.
    let off = "OFF\n5 3 0\n0 0 0\n1 0 0\n0 1 0\n0 -1 0\n0 0 1\n3 0 1 2\n3 1 0 3\n3 0 1 4\n";
    std::fs::write(dir.path().join("book.off"), off).unwrap();
    let sink = Sink::default();
    let Err(err) = run(
        "io.load_mesh",
        "(path: \"book.off\")",
        &Inputs::new(),
        dir.path(),
        &sink,
    ) else {
        panic!("a non-manifold mesh loaded without repair");
    };
    assert_eq!(err.kind, ErrorKind::InvalidInput);
    assert!(err.message.contains("repair: true"), "{}", err.message);
    let source = err
        .source
        .as_ref()
        .unwrap()
        .downcast_ref::<MeshError>()
        .unwrap();
    assert!(
        matches!(
            source,
            MeshError::NonManifold {
                edges: 1,
                vertices: 2,
                ..
            }
        ),
        "{source:?}"
    );
    // With repair: three separate triangles, and the split is reported.
    let out = run(
        "io.load_mesh",
        "(path: \"book.off\", repair: true)",
        &Inputs::new(),
        dir.path(),
        &sink,
    )
    .unwrap();
    let mesh = out.get("mesh").unwrap().downcast_ref::<TriMesh>().unwrap();
    assert_eq!(mesh.n_vertices(), 9);
    let report = out.get("report").unwrap().downcast_ref::<Report>().unwrap();
    assert_eq!(report.num("vertices_split"), Some(4.0));
    assert_eq!(report.num("components"), Some(3.0));
    // A missing file is an IO error naming it.
    let Err(err) = run(
        "io.load_mesh",
        "(path: \"nope.obj\")",
        &Inputs::new(),
        dir.path(),
        &sink,
    ) else {
        panic!("a missing file loaded");
    };
    assert!(err.message.contains("nope.obj"), "{}", err.message);
}

#[test]
fn load_node_repair_orients_the_faces() {
    // The tetrahedron of the other tests, outward, with face 1 turned over.
    let off = "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 3 1\n3 0 3 2\n3 1 2 3\n";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.off"), off).unwrap();
    let sink = Sink::default();
    let out = run(
        "io.load_mesh",
        "(path: \"t.off\")",
        &Inputs::new(),
        dir.path(),
        &sink,
    )
    .unwrap();
    let report = out.get("report").unwrap().downcast_ref::<Report>().unwrap();
    assert_eq!(report.num("inconsistent_edges"), Some(3.0));
    assert_eq!(report.num("faces_flipped"), Some(0.0));
    assert_eq!(
        sink.0.lock().unwrap().clone(),
        [
            "n: t.off: 3 edges with inconsistently oriented faces (load with `repair: true` to \
          orient them coherently; in the shipped graphs: `--set repair=true`)"
        ]
    );
    let out = run(
        "io.load_mesh",
        "(path: \"t.off\", repair: true)",
        &Inputs::new(),
        dir.path(),
        &sink,
    )
    .unwrap();
    let mesh = out.get("mesh").unwrap().downcast_ref::<TriMesh>().unwrap();
    assert_eq!(mesh.triangles, [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]);
    let report = out.get("report").unwrap().downcast_ref::<Report>().unwrap();
    assert_eq!(report.num("faces_flipped"), Some(1.0));
    assert_eq!(report.num("nonorientable_components"), Some(0.0));
}

fn tetra() -> TriMesh {
    TriMesh::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
    )
}

#[test]
fn save_mesh_node_writes_what_load_reads() {
    let dir = tempfile::tempdir().unwrap();
    let sink = Sink::default();
    let field = CurvatureField {
        k_max: vec![1.0, 2.0, 3.0, 4.0],
        k_min: vec![0.0, -1.0, -2.0, -3.0],
        ..Default::default()
    };
    for ext in ["ply", "obj"] {
        let inputs = Inputs::new()
            .with("mesh", tetra())
            .with("curvature", field.clone());
        let ron = format!("(path: \"out/deep/t.{ext}\")");
        let out = run("io.save_mesh", &ron, &inputs, dir.path(), &sink).unwrap();
        assert_eq!(out.iter().count(), 0);
        let back = load_mesh(
            dir.path().join(format!("out/deep/t.{ext}")),
            &LoadOptions::default(),
        )
        .unwrap();
        assert_eq!(back.mesh, tetra());
    }
    // The curvature is optional.
    let inputs = Inputs::new().with("mesh", tetra());
    run(
        "io.save_mesh",
        "(path: \"plain.ply\")",
        &inputs,
        dir.path(),
        &sink,
    )
    .unwrap();
    assert_eq!(
        load_mesh(dir.path().join("plain.ply"), &LoadOptions::default())
            .unwrap()
            .mesh,
        tetra()
    );
}

#[test]
fn save_curves_node_writes_ply_and_obj() {
    let dir = tempfile::tempdir().unwrap();
    let sink = Sink::default();
    let v = |x: f64| FcnVertex {
        position: [x, 0.0, 0.0],
        location: SurfacePoint::Free,
        strength: x,
    };
    let net = FeatureCurveNetwork {
        vertices: (0..4).map(|i| v(i as f64)).collect(),
        curves: vec![
            FeatureCurve {
                vertices: vec![0, 1, 2],
                closed: false,
                label: CurveLabel::Ridge,
            },
            FeatureCurve {
                vertices: vec![2, 3],
                closed: false,
                label: CurveLabel::Ravine,
            },
        ],
    };
    let inputs = Inputs::new().with("curves", net.clone());
    run(
        "io.save_curves",
        "(path: \"c/n.ply\")",
        &inputs,
        dir.path(),
        &sink,
    )
    .unwrap();
    assert_eq!(load_curves_ply(dir.path().join("c/n.ply")).unwrap(), net);
    run(
        "io.save_curves",
        "(path: \"c/n.obj\")",
        &inputs,
        dir.path(),
        &sink,
    )
    .unwrap();
    let text = std::fs::read_to_string(dir.path().join("c/n.obj")).unwrap();
    assert!(
        text.contains("g ridge_0\nl 1 2\nl 2 3\ng ravine_1\nl 3 4\n"),
        "{text}"
    );
}

#[test]
fn save_report_node_writes_pretty_json() {
    let dir = tempfile::tempdir().unwrap();
    let sink = Sink::default();
    let mut report = Report::new();
    report
        .set("mean_error", 0.0125)
        .set("method", "curvature.polynomial")
        .set("bad", f64::NAN);
    let inputs = Inputs::new().with("report", report.clone());
    run(
        "io.save_report",
        "(path: \"r/e.json\")",
        &inputs,
        dir.path(),
        &sink,
    )
    .unwrap();
    let text = std::fs::read_to_string(dir.path().join("r/e.json")).unwrap();
    assert!(
        text.contains("\n  \"mean_error\": 0.0125"),
        "pretty-printed: {text}"
    );
    let back: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(back, report.to_json());
    assert_eq!(back["bad"], serde_json::Value::Null);
    assert_eq!(back["method"], "curvature.polynomial");
}

/// The bundled default mesh (data/cgal_fandisk.off, see data/SOURCES.md) loads with the counts
/// its note gives, through the node as the default pipeline runs it (path relative to the
/// repository root), and survives a write-read round trip in both formats.
#[test]
fn bundled_fandisk_loads_and_round_trips() {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
    let sink = Sink::default();
    let out = run(
        "io.load_mesh",
        "(path: \"data/cgal_fandisk.off\")",
        &Inputs::new(),
        repo,
        &sink,
    )
    .unwrap();
    let mesh = out
        .get("mesh")
        .unwrap()
        .downcast_ref::<TriMesh>()
        .unwrap()
        .clone();
    let report = out.get("report").unwrap().downcast_ref::<Report>().unwrap();
    assert_eq!((mesh.n_vertices(), mesh.n_faces()), (6475, 12946));
    assert_eq!(report.num("components"), Some(1.0));
    assert_eq!(report.num("boundary_edges"), Some(0.0));
    assert!(
        sink.0.lock().unwrap().is_empty(),
        "a clean mesh gives no warnings"
    );

    let dir = tempfile::tempdir().unwrap();
    for ext in ["ply", "obj"] {
        let inputs = Inputs::new().with("mesh", mesh.clone());
        run(
            "io.save_mesh",
            &format!("(path: \"f.{ext}\")"),
            &inputs,
            dir.path(),
            &sink,
        )
        .unwrap();
        let back = load_mesh(dir.path().join(format!("f.{ext}")), &LoadOptions::default()).unwrap();
        assert!(back.mesh == mesh, "{ext} round trip changed the mesh");
    }
}
