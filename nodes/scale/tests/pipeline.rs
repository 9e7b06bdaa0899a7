//! curvature → ridges → scale.conform → scale.check on a real CAD mesh.

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_ridges::{trace, TraceParams};
use crestflow_nodes_scale::{check, conform, CheckParams, ConformParams};

/// A mesh of ../shared/data/meshes and its ridges (min_strength 1, as in the graphs).
fn mesh_and_ridges(name: &str) -> (crestflow_geom::TriMesh, crestflow_geom::FeatureCurveNetwork) {
    let path = format!(
        "{}/../../../shared/data/meshes/{name}",
        env!("CARGO_MANIFEST_DIR")
    );
    let mesh = load_mesh(&path, &LoadOptions::default()).unwrap().mesh;
    let curv = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon).unwrap();
    let params = TraceParams {
        min_strength: 1.0,
        ..Default::default()
    };
    let ridges = trace(&mesh, &curv.field, &params, Par::Rayon).unwrap();
    (mesh, ridges.network)
}

#[test]
fn fandisk_ridges_become_scale_conforming() {
    let (mesh, ridges) = mesh_and_ridges("cad/cgal_fandisk.off");
    let mut kept = Vec::new();
    for scale in [0.01, 0.02] {
        let cp = CheckParams {
            scale,
            ..Default::default()
        };
        // The raw ridges are not scale conforming.
        assert!(check(&ridges, &mesh, &cp, Par::Rayon).unwrap().violations() > 0);
        let params = ConformParams {
            scale,
            ..Default::default()
        };
        let out = conform(&ridges, &mesh, &params, Par::Rayon).unwrap();
        let r = check(&out.network, &mesh, &cp, Par::Rayon).unwrap();
        assert_eq!(r.violations(), 0, "scale {scale}: {}", r.summary());
        let s = &out.stats;
        assert!(s.converged && s.repaired_edges == 0, "{s:?}");
        assert!(s.output_edges > 0 && s.output_edges < s.input_edges);
        assert!(s.first_objective >= s.greedy_objective - 1e-9 * s.first_objective);
        kept.push(s.output_edges);
    }
    // Twice the scale: fewer, longer edges.
    assert!(kept[1] < kept[0], "{kept:?}");
}

/// Both solvers on the bunny's ridges at 0.5 %, 1 % and 2 % (builds with the `highs`
/// feature): the same first objective, every component proven (ties may pick other edges). With
/// the greedy selection as a warm start HiGHS called one component of 70 binaries optimal
/// at 1.5 % below the optimum at 2 %, so this test fails if the warm start comes back.
#[cfg(feature = "highs")]
#[test]
fn highs_and_microlp_agree_on_the_bunny() {
    use crestflow_nodes_scale::Solver;
    let (mesh, ridges) = mesh_and_ridges("organic/cgal_bunny00.off");
    for scale in [0.005, 0.01, 0.02] {
        let params = ConformParams {
            scale,
            ..Default::default()
        };
        let highs = ConformParams {
            solver: Solver::Highs,
            ..params.clone()
        };
        let m = conform(&ridges, &mesh, &params, Par::Rayon).unwrap();
        let h = conform(&ridges, &mesh, &highs, Par::Rayon).unwrap();
        assert_eq!(m.stats.unproven_components, 0);
        assert_eq!(h.stats.unproven_components, 0);
        let (a, b) = (m.stats.first_objective, h.stats.first_objective);
        assert!(
            (a - b).abs() <= 1e-9 * a,
            "scale {scale}: microlp {a}, HiGHS {b}"
        );
    }
}
