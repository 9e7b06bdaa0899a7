//! `render.png` through the engine's node contract.

use std::path::{Path, PathBuf};

use crestflow_flow::{CancelToken, Ctx, Inputs, NodeKind, Par, ProgressSink, Registry, Report};
use crestflow_geom::{shapes, TriMesh};
use crestflow_nodes_render::{register, RenderParams, RenderPngNode};

struct Quiet;
impl ProgressSink for Quiet {
    fn progress(&self, _: &str, _: f32) {}
    fn warn(&self, _: &str, _: &str) {}
}

#[test]
fn registered_and_declares_its_file() {
    let mut reg = Registry::new();
    register(&mut reg);
    let node = reg.get("render.png").expect("registered");
    let ins: Vec<(&str, bool)> = node.inputs().iter().map(|p| (p.name, p.required)).collect();
    assert_eq!(
        ins,
        vec![("mesh", true), ("curves", false), ("curvature", false)]
    );
    let prepared = node
        .prepare("(path: \"out/pic.png\", width: 64, height: 48)")
        .unwrap();
    assert_eq!(prepared.output_files, vec![PathBuf::from("out/pic.png")]);
    assert!(node.prepare("(widht: 10)").is_err());
    assert!(node.prepare("(width: 0)").is_err());
}

#[test]
fn run_writes_the_png_relative_to_the_graph_folder() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = shapes::sphere(1.0, 2).unwrap();
    let params = RenderParams {
        path: "pics/sphere.png".into(),
        width: 64,
        height: 48,
        ..RenderParams::default()
    };
    let inputs = Inputs::new().with::<TriMesh>("mesh", mesh);
    let cancel = CancelToken::new();
    let ctx = Ctx {
        node: "render",
        par: Par::Seq,
        base_dir: dir.path(),
        cancel: &cancel,
        sink: &Quiet,
    };
    let out = RenderPngNode::run(&params, &inputs, &ctx).unwrap();
    let file = dir.path().join("pics/sphere.png");
    let bytes = std::fs::read(&file).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    let report = out.get("report").unwrap().downcast_ref::<Report>().unwrap();
    assert_eq!(report.num("width"), Some(64.0));
    assert!(report.num("mesh_pixels").unwrap() > 0.0);
    assert!(Path::new(report.text("path").unwrap()).ends_with("pics/sphere.png"));
}
