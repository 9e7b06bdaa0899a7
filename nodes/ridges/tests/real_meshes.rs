//! The default pipeline (polynomial curvature + default tracing) on real CAD meshes: the sharp
//! edges (dihedral angle above 60°) are found, convex ones as ridges and concave ones as
//! ravines.

mod common;

use common::*;
use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_geom::vec3;
use crestflow_geom::{CurveLabel, TriMesh};
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_ridges::{trace, TraceParams};

fn load(rel: &str) -> TriMesh {
    let path = format!(
        "{}/../../../shared/data/meshes/{rel}",
        env!("CARGO_MANIFEST_DIR")
    );
    load_mesh(&path, &LoadOptions::default())
        .expect("test mesh loads")
        .mesh
}

/// Sharp edges of `mesh` as (a, b, convex) with dihedral angle above `deg`.
fn sharp_edges(mesh: &TriMesh, deg: f64) -> Vec<([f64; 3], [f64; 3], bool)> {
    let topo = mesh.topology();
    let normals = mesh.face_normals();
    let cos = deg.to_radians().cos();
    let mut out = Vec::new();
    for (e, faces) in topo.edges.iter().zip(&topo.edge_faces) {
        if faces[1] == crestflow_geom::mesh::NO_FACE {
            continue;
        }
        let (n0, n1) = (normals[faces[0] as usize], normals[faces[1] as usize]);
        if vec3::dot(n0, n1) > cos {
            continue;
        }
        let (a, b) = (mesh.positions[e[0] as usize], mesh.positions[e[1] as usize]);
        // Convex when the second face's far corner lies behind the first face's plane.
        let t1 = mesh.triangles[faces[1] as usize];
        let far = t1
            .iter()
            .find(|&&v| v != e[0] && v != e[1])
            .map(|&v| mesh.positions[v as usize])
            .unwrap_or(a);
        let convex = vec3::dot(n0, vec3::sub(far, a)) < 0.0;
        out.push((a, b, convex));
    }
    out
}

/// Fraction of the length of `edges` whose midpoints lie within `tol` of `segs`.
fn covered(edges: &[([f64; 3], [f64; 3], bool)], segs: &[([f64; 3], [f64; 3])], tol: f64) -> f64 {
    let (mut hit, mut all) = (0.0, 0.0);
    for &(a, b, _) in edges {
        let l = vec3::dist(a, b);
        all += l;
        if dist_to_segments(vec3::lerp(a, b, 0.5), segs) <= tol {
            hit += l;
        }
    }
    hit / all
}

#[test]
fn fandisk_sharp_edges_are_traced_with_the_right_label() {
    let mesh = load("cad/cgal_fandisk.off");
    let field = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon)
        .unwrap()
        .field;
    let out = trace(&mesh, &field, &TraceParams::default(), Par::Rayon).unwrap();
    let sharp = sharp_edges(&mesh, 60.0);
    let convex: Vec<_> = sharp.iter().copied().filter(|e| e.2).collect();
    let concave: Vec<_> = sharp.iter().copied().filter(|e| !e.2).collect();
    let tol = 2.0 * mesh.mean_edge_length();
    let ridges = segments(&out.network, Some(CurveLabel::Ridge));
    let ravines = segments(&out.network, Some(CurveLabel::Ravine));
    let (cr, cv) = (
        covered(&convex, &ridges, tol),
        covered(&concave, &ravines, tol),
    );
    println!(
        "{} convex, {} concave sharp edges; covered {cr:.3} / {cv:.3}; {:?}",
        convex.len(),
        concave.len(),
        out.stats
    );
    assert!(convex.len() > 100 && !concave.is_empty());
    assert!(cr >= 0.8, "convex sharp edges covered by ridges: {cr}");
    assert!(cv >= 0.8, "concave sharp edges covered by ravines: {cv}");
    // And not the other way round.
    assert!(covered(&convex, &ravines, 0.5 * tol) < 0.2);
}

/// Two more CAD meshes with sharp edges; measured coverage (convex/concave) when written:
/// anchor_dense 1.000/0.942, fandisk_large 0.996/0.905.
#[test]
fn other_cad_meshes_sharp_edges_are_traced() {
    for m in ["cad/cgal_anchor_dense.off", "cad/cgal_fandisk_large.off"] {
        let mesh = load(m);
        let field = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon)
            .unwrap()
            .field;
        let out = trace(&mesh, &field, &TraceParams::default(), Par::Rayon).unwrap();
        let sharp = sharp_edges(&mesh, 60.0);
        let convex: Vec<_> = sharp.iter().copied().filter(|e| e.2).collect();
        let concave: Vec<_> = sharp.iter().copied().filter(|e| !e.2).collect();
        let tol = 2.0 * mesh.mean_edge_length();
        let cr = covered(
            &convex,
            &segments(&out.network, Some(CurveLabel::Ridge)),
            tol,
        );
        let cv = covered(
            &concave,
            &segments(&out.network, Some(CurveLabel::Ravine)),
            tol,
        );
        assert!(cr >= 0.85 && cv >= 0.85, "{m}: {cr} / {cv}");
    }
}
