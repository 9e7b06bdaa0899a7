//! Curve matching across the poses of the Sumner–Popović cat (same connectivity, so curve i
//! on the reference corresponds to curve i carried to another pose by vertex identity): the
//! experiment of thesis §3.1.4 / Table 3.1 on a data set shipped with crestflow's test data.

use std::path::PathBuf;

use crestflow_flow::Par;
use crestflow_geom::fcn::{FeatureCurve, FeatureCurveNetwork};
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_geom::mesh::TriMesh;
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_descriptors::curve_matching_eval::curve_matching_eval;
use crestflow_nodes_descriptors::{
    curve_gics, curve_hks, match_curves, CurveDescriptors, CurveGicsParams, CurveHksParams,
    MatchCurvesParams,
};
use crestflow_nodes_ridges::{trace, TraceParams};

fn cat(name: &str) -> TriMesh {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/meshes/correspondence/sumner_cat_lion/cat-poses")
        .join(format!("{name}.obj"));
    load_mesh(&path, &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .mesh
}

fn reference_curves(mesh: &TriMesh) -> FeatureCurveNetwork {
    let curv = polynomial_curvature(mesh, &PolynomialParams::default(), Par::Rayon).unwrap();
    trace(mesh, &curv.field, &TraceParams::default(), Par::Rayon)
        .unwrap()
        .network
}

/// Cuts up to a quarter of each curve's vertices off each end (closed curves are opened at a
/// random vertex first), with a seeded generator.
fn random_length(net: &FeatureCurveNetwork, seed: u64) -> FeatureCurveNetwork {
    let mut s = seed;
    let mut rnd = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let curves = net
        .curves
        .iter()
        .map(|c| {
            let mut v = c.vertices.clone();
            if c.closed && !v.is_empty() {
                let k = (rnd() * v.len() as f64) as usize % v.len();
                v.rotate_left(k);
            }
            let q = v.len() / 4;
            let a = (rnd() * (q + 1) as f64) as usize;
            let b = (rnd() * (q + 1) as f64) as usize;
            let kept = v[a.min(q)..v.len() - b.min(q)].to_vec();
            FeatureCurve {
                vertices: kept,
                closed: false,
                label: c.label,
            }
        })
        .collect();
    FeatureCurveNetwork {
        vertices: net.vertices.clone(),
        curves,
    }
}

fn accuracy(a: &CurveDescriptors, b: &CurveDescriptors) -> (f64, f64, f64) {
    let m = match_curves(a, b, &MatchCurvesParams::default(), Par::Rayon).unwrap();
    let e = curve_matching_eval(&m, &[]).unwrap();
    (e.accuracy_nearest, e.accuracy_hungarian, e.auc)
}

#[test]
fn gics_matches_curves_across_one_pose() {
    let reference = cat("cat-reference");
    let pose = cat("cat-01");
    assert_eq!(reference.n_vertices(), pose.n_vertices());
    let net = reference_curves(&reference);
    assert!(net.curves.len() >= 20, "{} curves", net.curves.len());
    let p = CurveGicsParams::default();
    let a = curve_gics(&reference, &net, &p, Par::Rayon).unwrap();
    let b = curve_gics(&pose, &net, &p, Par::Rayon).unwrap();
    let (near, hung, auc) = accuracy(&a, &b);
    eprintln!(
        "cat-reference -> cat-01, {} curves: GICS nearest {near:.3}, hungarian {hung:.3}, auc {auc:.4}",
        net.curves.len()
    );
    // Chance level is 1 / #curves; an isometric pose keeps most curves recognisable.
    assert!(hung > 0.5, "hungarian accuracy {hung}");
}

#[test]
fn gics_is_the_same_at_any_thread_count() {
    let reference = cat("cat-reference");
    let net = reference_curves(&reference);
    let small = FeatureCurveNetwork {
        vertices: net.vertices.clone(),
        curves: net.curves.iter().take(12).cloned().collect(),
    };
    let p = CurveGicsParams {
        batch: 5,
        ..Default::default()
    };
    let seq = curve_gics(&reference, &small, &p, Par::Seq).unwrap();
    let par = curve_gics(&reference, &small, &p, Par::Rayon).unwrap();
    assert_eq!(seq, par);
}

/// Table like thesis Table 3.1 over the nine cat poses.
#[test]
#[ignore]
fn table_gics_vs_hks_on_cat_poses() {
    let reference = cat("cat-reference");
    let net = reference_curves(&reference);
    let gp = CurveGicsParams::default();
    let hp = CurveHksParams::default();
    let g_ref = curve_gics(&reference, &net, &gp, Par::Rayon).unwrap();
    let h_ref = curve_hks(&reference, &net, None, &hp, Par::Rayon).unwrap();
    let mut rows = Vec::new();
    let mut sums = [0.0f64; 8];
    let poses: Vec<String> = (1..=9).map(|i| format!("cat-{i:02}")).collect();
    for (k, name) in poses.iter().enumerate() {
        let pose = cat(name);
        assert_eq!(pose.n_vertices(), reference.n_vertices());
        let cut = random_length(&net, 1000 + k as u64);
        let g_full = curve_gics(&pose, &net, &gp, Par::Rayon).unwrap();
        let g_cut = curve_gics(&pose, &cut, &gp, Par::Rayon).unwrap();
        let h_full = curve_hks(&pose, &net, None, &hp, Par::Rayon).unwrap();
        let h_cut = curve_hks(&pose, &cut, None, &hp, Par::Rayon).unwrap();
        let r = [
            accuracy(&g_ref, &g_full),
            accuracy(&g_ref, &g_cut),
            accuracy(&h_ref, &h_full),
            accuracy(&h_ref, &h_cut),
        ];
        for (i, x) in r.iter().enumerate() {
            sums[2 * i] += x.0;
            sums[2 * i + 1] += x.1;
        }
        rows.push((name.clone(), r));
    }
    println!("{} curves on cat-reference", net.curves.len());
    println!("| pose | GICS near | GICS hung | GICS rnd near | GICS rnd hung | HKS near | HKS hung | HKS rnd near | HKS rnd hung |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for (name, r) in &rows {
        println!(
            "| {name} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            r[0].0, r[0].1, r[1].0, r[1].1, r[2].0, r[2].1, r[3].0, r[3].1
        );
    }
    let n = poses.len() as f64;
    println!(
        "| mean | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
        sums[0] / n,
        sums[1] / n,
        sums[2] / n,
        sums[3] / n,
        sums[4] / n,
        sums[5] / n,
        sums[6] / n,
        sums[7] / n
    );
}
