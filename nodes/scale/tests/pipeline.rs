//! curvature → ridges → scale.conform → scale.check on a real CAD mesh.

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_ridges::{trace, TraceParams};
use crestflow_nodes_scale::{check, conform, CheckParams, ConformParams};

#[test]
fn fandisk_ridges_become_scale_conforming() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/meshes/cad/cgal_fandisk.off"
    );
    let mesh = load_mesh(path, &LoadOptions::default()).unwrap().mesh;
    let curv = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon).unwrap();
    let ridges = trace(
        &mesh,
        &curv.field,
        &TraceParams {
            min_strength: 1.0,
            ..Default::default()
        },
        Par::Rayon,
    )
    .unwrap();
    let mut kept = Vec::new();
    for scale in [0.01, 0.02] {
        let cp = CheckParams {
            scale,
            ..Default::default()
        };
        // The raw ridges are not scale conforming.
        assert!(
            check(&ridges.network, &mesh, &cp, Par::Rayon)
                .unwrap()
                .violations()
                > 0
        );
        let params = ConformParams {
            scale,
            ..Default::default()
        };
        let out = conform(&ridges.network, &mesh, &params, Par::Rayon).unwrap();
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
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/meshes/organic/cgal_bunny00.off"
    );
    let mesh = load_mesh(path, &LoadOptions::default()).unwrap().mesh;
    let curv = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon).unwrap();
    let ridges = trace(
        &mesh,
        &curv.field,
        &TraceParams {
            min_strength: 1.0,
            ..Default::default()
        },
        Par::Rayon,
    )
    .unwrap();
    for scale in [0.005, 0.01, 0.02] {
        let params = ConformParams {
            scale,
            ..Default::default()
        };
        let highs = ConformParams {
            solver: Solver::Highs,
            ..params.clone()
        };
        let m = conform(&ridges.network, &mesh, &params, Par::Rayon).unwrap();
        let h = conform(&ridges.network, &mesh, &highs, Par::Rayon).unwrap();
        assert_eq!(m.stats.unproven_components, 0);
        assert_eq!(h.stats.unproven_components, 0);
        let (a, b) = (m.stats.first_objective, h.stats.first_objective);
        assert!(
            (a - b).abs() <= 1e-9 * a,
            "scale {scale}: microlp {a}, HiGHS {b}"
        );
    }
}
