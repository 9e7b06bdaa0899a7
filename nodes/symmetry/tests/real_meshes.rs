//! What the symmetry chain finds on real CAD meshes (rotation orders of gears and nuts,
//! repeated holes). Run with `cargo test -p crestflow-nodes-symmetry --test real_meshes --
//! --ignored --nocapture` to print the table.

use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_remesh::{isotropic, sharp_edges, IsotropicParams, SharpEdgesParams};
use crestflow_nodes_ridges::{trace, TraceParams};
use crestflow_nodes_symmetry::{
    blast, cluster, orbits, BlastParams, ClusterParams, Generator, OrbitParams,
};

const MESHES: &[&str] = &[
    "cad/cgal_pinion.off",
    "cad/cgal_turbine.off",
    "cad/trimesh_idler_riser.STL",
    "cad/pyvista_nut.ply",
    "cad/cgal_couplingdown.off",
    "cad/cgal_cheese.off",
];

/// The chain of `graphs/symmetry-cad.ron`: isotropic remeshing at 0.5 % of the diagonal
/// (creases kept), the sharp-edge chains as curves, then the thesis defaults. Returns the
/// strongest orbit's generator and its instance count.
fn cad_chain(name: &str) -> (Generator, usize) {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/meshes/");
    let mesh = load_mesh(format!("{root}{name}"), &LoadOptions::default())
        .expect("mesh")
        .mesh;
    let remeshed = isotropic(
        &mesh,
        None,
        &IsotropicParams {
            target: 0.005,
            ..Default::default()
        },
        Par::Rayon,
    )
    .expect("remesh")
    .mesh;
    // As graphs/symmetry-cad.ron: chains joined through corners below 60°.
    let sharp = SharpEdgesParams {
        join_angle_deg: 60.0,
        ..Default::default()
    };
    let net = sharp_edges(&remeshed, &sharp).expect("sharp edges").network;
    let m = blast(&net, &remeshed, &BlastParams::default(), Par::Rayon).expect("blast");
    let c = cluster(&m, &ClusterParams::default(), Par::Rayon).expect("cluster");
    let o = orbits(&c, &OrbitParams::default(), Par::Rayon).expect("orbits");
    let best = o.orbits.first().expect("an orbit");
    (best.generator.clone(), best.instances)
}

/// The pinion has 10 teeth, the turbine's flange 10 bolt holes, the nut is an octagon
/// (counted on the meshes by rotating surface samples about the symmetry axis).
#[test]
fn cad_chain_finds_the_rotation_orders_of_pinion_turbine_and_nut() {
    for (name, n) in [
        ("cad/cgal_pinion.off", 10),
        ("cad/cgal_turbine.off", 10),
        ("cad/pyvista_nut.ply", 8),
    ] {
        let (generator, instances) = cad_chain(name);
        let Generator::Rotation {
            angle_deg, order, ..
        } = generator
        else {
            panic!("{name}: strongest orbit {generator:?}");
        };
        assert!(
            (angle_deg - 360.0 / n as f64).abs() < 1.0,
            "{name}: {angle_deg}°"
        );
        assert_eq!((order as usize, instances), (n, n), "{name}");
    }
}

/// Thesis defaults, and a short-match setting for coarse CAD meshes whose mean edge length is
/// dominated by the long edges of flat faces (a gear tooth is then only a few edge lengths long).
#[test]
#[ignore]
fn real_mesh_table() {
    let short = BlastParams {
        l0: 8.0,
        signature_length: 4.0,
        delta_l: 2.0,
        ..Default::default()
    };
    for (label, bp) in [
        ("defaults (l0 = 25 h)", BlastParams::default()),
        ("l0 = 8 h", short),
    ] {
        println!("\n{label}\n");
        table(&bp);
    }
}

fn table(bp: &BlastParams) {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/meshes/");
    println!("| mesh | vertices | curves | strong | matches | clusters | orbits found | chain s |");
    println!("|---|---|---|---|---|---|---|---|");
    for name in MESHES {
        if let Ok(f) = std::env::var("SYM_MESH") {
            if !name.contains(&f) {
                continue;
            }
        }
        let mesh = match load_mesh(
            format!("{root}{name}"),
            &LoadOptions {
                repair: true,
                ..Default::default()
            },
        ) {
            Ok(m) => m.mesh,
            Err(e) => {
                println!("| {name} | load failed: {e} |");
                continue;
            }
        };
        let field = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon)
            .expect("curvature")
            .field;
        let net = trace(&mesh, &field, &TraceParams::default(), Par::Rayon)
            .expect("ridges")
            .network;
        let t0 = Instant::now();
        let m = blast(&net, &mesh, bp, Par::Rayon).expect("blast");
        let c = cluster(&m, &ClusterParams::default(), Par::Rayon).expect("cluster");
        let o = orbits(&c, &OrbitParams::default(), Par::Rayon).expect("orbits");
        let secs = t0.elapsed().as_secs_f64();
        let h = mesh.mean_edge_length();
        let found: Vec<String> =
            o.orbits
                .iter()
                .map(|x| match &x.generator {
                    Generator::Rotation {
                        angle_deg, order, ..
                    } => format!(
                        "rotation {angle_deg:.2}° (n = {order}, support {:.0} h)",
                        x.support / h
                    ),
                    Generator::Translation { steps } => format!(
                        "translation {}-D step {:.3} ×{} (support {:.0} h)",
                        steps.len(),
                        crestflow_geom::vec3::norm(steps[0]),
                        x.instances,
                        x.support / h
                    ),
                    Generator::Reflection { normal, offset } => {
                        format!(
                    "reflection n = ({:.2}, {:.2}, {:.2}) d = {offset:.3} (support {:.0} h)",
                    normal[0], normal[1], normal[2], x.support / h
                )
                    }
                })
                .collect();
        println!(
            "| {name} | {} | {} | {} | {} | {} | {} | {secs:.2} |",
            mesh.n_vertices(),
            net.curves.len(),
            m.strong_curves.len(),
            m.matches.len(),
            c.clusters.len(),
            if found.is_empty() {
                "none".to_string()
            } else {
                found.join("; ")
            }
        );
    }
}
