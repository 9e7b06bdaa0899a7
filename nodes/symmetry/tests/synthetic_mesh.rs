//! Ground truth on meshes built here: plates carrying identical chiral bumps placed by known
//! transformations (1-D and 2-D translation grids, a ring of n bumps, a mirrored pair), run
//! through curvature.polynomial → ridges.trace → symmetry.{blast, cluster, orbits}.
//! The bumps have no symmetry of their own (two arms of different lengths at 60°), so the only
//! symmetries of each plate are the placements.

use crestflow_flow::Par;
use std::collections::BTreeMap;

use crestflow_geom::vec3::{add, cross, dist, dot, norm, scale, sub, V3};
use crestflow_geom::TriMesh;
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_ridges::{trace, TraceParams};
use crestflow_nodes_symmetry::{
    blast, cluster, orbits, BlastParams, ClusterParams, Generator, OrbitParams, Orbits,
};

/// Grid spacing of the plates.
const A: f64 = 0.1;

/// Height of one chiral bump at local coordinates (x, y), after rotating by `rot` radians and
/// mirroring x when `mirror`.
fn bump(x: f64, y: f64, rot: f64, mirror: bool) -> f64 {
    let (s, c) = rot.sin_cos();
    let (mut u, v) = (c * x + s * y, -s * x + c * y);
    if mirror {
        u = -u;
    }
    let arm1 = (-(u * u / (1.5 * 1.5) + v * v / (0.35 * 0.35))).exp();
    let (a2s, a2c) = (60f64.to_radians()).sin_cos();
    let (du, dv) = (u - 0.9, v - 0.8);
    let (p, q) = (a2c * du + a2s * dv, -a2s * du + a2c * dv);
    let arm2 = (-(p * p / (0.9 * 0.9) + q * q / (0.3 * 0.3))).exp();
    0.5 * (arm1 + 0.8 * arm2)
}

/// A height-field plate over [x0, x1] × [y0, y1] with spacing A, height `f`.
fn plate(x0: f64, x1: f64, y0: f64, y1: f64, f: impl Fn(f64, f64) -> f64) -> TriMesh {
    let nx = ((x1 - x0) / A).round() as usize + 1;
    let ny = ((y1 - y0) / A).round() as usize + 1;
    let mut pos = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let (x, y) = (x0 + i as f64 * A, y0 + j as f64 * A);
            pos.push([x, y, f(x, y)]);
        }
    }
    let mut tris = Vec::new();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let v = (j * nx + i) as u32;
            let n = nx as u32;
            tris.push([v, v + 1, v + n + 1]);
            tris.push([v, v + n + 1, v + n]);
        }
    }
    TriMesh::new(pos, tris)
}

/// Seeded Gaussian vertex noise of standard deviation `sigma` (xorshift + Box–Muller).
fn add_noise(mesh: &TriMesh, sigma: f64, seed: u64) -> TriMesh {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut uniform = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let pos = mesh
        .positions
        .iter()
        .map(|p| {
            let mut q = *p;
            for x in q.iter_mut() {
                let (u1, u2) = (uniform(), uniform());
                *x += sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            }
            q
        })
        .collect();
    mesh.with_positions(pos)
}

fn pipeline(mesh: &TriMesh, par: Par) -> Orbits {
    pipeline_with(
        mesh,
        par,
        &BlastParams::default(),
        &ClusterParams::default(),
    )
}

fn pipeline_with(mesh: &TriMesh, par: Par, bp: &BlastParams, cp: &ClusterParams) -> Orbits {
    pipeline_full(
        mesh,
        par,
        &PolynomialParams::default(),
        &TraceParams::default(),
        bp,
        cp,
    )
}

fn pipeline_full(
    mesh: &TriMesh,
    par: Par,
    pp: &PolynomialParams,
    tp: &TraceParams,
    bp: &BlastParams,
    cp: &ClusterParams,
) -> Orbits {
    let field = polynomial_curvature(mesh, pp, par).unwrap().field;
    let net = trace(mesh, &field, tp, par).unwrap().network;
    let m = blast(&net, mesh, bp, par).unwrap();
    let c = cluster(&m, cp, par).unwrap();
    let o = orbits(&c, &OrbitParams::default(), par).unwrap();
    eprintln!(
        "curves {} strong {} matches {} clusters {} orbits {}",
        net.curves.len(),
        m.strong_curves.len(),
        m.matches.len(),
        c.clusters.len(),
        o.orbits.len()
    );
    for orb in &o.orbits {
        eprintln!(
            "  {} instances {} support {:.2} {:?}",
            orb.generator.kind(),
            orb.instances,
            orb.support,
            orb.generator
        );
    }
    o
}

fn grid_1d() -> (TriMesh, V3) {
    let step = 60.0 * A;
    let mesh = plate(-3.0, 3.0 * step + 3.0, -2.5, 2.5, |x, y| {
        (0..4)
            .map(|k| bump(x - k as f64 * step, y, 0.0, false))
            .sum()
    });
    (mesh, [step, 0.0, 0.0])
}

fn grid_2d() -> (TriMesh, V3, V3) {
    let (sx, sy) = (60.0 * A, 50.0 * A);
    let mesh = plate(-3.0, 2.0 * sx + 3.0, -2.5, sy + 2.5, |x, y| {
        let mut z = 0.0;
        for i in 0..3 {
            for j in 0..2 {
                z += bump(x - i as f64 * sx, y - j as f64 * sy, 0.0, false);
            }
        }
        z
    });
    (mesh, [sx, 0.0, 0.0], [0.0, sy, 0.0])
}

fn ring(n: usize) -> TriMesh {
    let r = 4.5;
    plate(-7.0, 7.0, -7.0, 7.0, |x, y| {
        (0..n)
            .map(|k| {
                let phi = std::f64::consts::TAU * k as f64 / n as f64;
                // bump centre on the circle; the bump turns with it
                let (s, c) = phi.sin_cos();
                let (cx, cy) = (r * c, r * s);
                let (dx, dy) = (x - cx, y - cy);
                bump(dx, dy, phi, false)
            })
            .sum()
    })
}

fn mirrored_pair() -> TriMesh {
    plate(-5.0, 5.0, -3.0, 3.0, |x, y| {
        bump(x - 2.5, y, 0.0, false) + bump(x + 2.5, y, 0.0, true)
    })
}

fn translation_steps(o: &Orbits) -> Vec<Vec<V3>> {
    o.orbits
        .iter()
        .filter_map(|x| match &x.generator {
            Generator::Translation { steps } => Some(steps.clone()),
            _ => None,
        })
        .collect()
}

fn close_up_to_sign(a: V3, b: V3) -> f64 {
    dist(a, b).min(dist(a, [-b[0], -b[1], -b[2]]))
}

#[test]
fn plate_with_four_bumps_on_a_line() {
    let (mesh, g) = grid_1d();
    let h = mesh.mean_edge_length();
    let o = pipeline(&mesh, Par::Rayon);
    assert_eq!(o.orbits.len(), 1);
    assert_eq!(o.orbits[0].instances, 4);
    let steps = translation_steps(&o);
    assert_eq!(steps.len(), 1);
    assert_eq!(steps[0].len(), 1);
    let err = close_up_to_sign(steps[0][0], g);
    assert!(err < 0.01 * h, "step error {err} vs h {h}");
}

#[test]
fn plate_with_bumps_on_a_2d_grid() {
    let (mesh, g1, g2) = grid_2d();
    let h = mesh.mean_edge_length();
    let o = pipeline(&mesh, Par::Rayon);
    assert_eq!(o.orbits.len(), 1);
    assert_eq!(o.orbits[0].instances, 6);
    let steps = translation_steps(&o);
    assert_eq!(steps[0].len(), 2);
    // the fitted basis is {g1, g2} up to signs and order
    let s = &steps[0];
    let e1 = close_up_to_sign(s[0], g1).min(close_up_to_sign(s[1], g1));
    let e2 = close_up_to_sign(s[0], g2).min(close_up_to_sign(s[1], g2));
    assert!(e1 < 0.01 * h && e2 < 0.01 * h, "errors {e1} {e2}, h {h}");
}

#[test]
fn ring_of_seven_bumps() {
    let mesh = ring(7);
    let o = pipeline(&mesh, Par::Rayon);
    assert_eq!(o.orbits.len(), 1);
    let Generator::Rotation {
        axis,
        angle_deg,
        order,
        center,
    } = &o.orbits[0].generator
    else {
        panic!("not a rotation")
    };
    assert_eq!(*order, 7);
    assert!((angle_deg - 360.0 / 7.0).abs() < 1.0, "{angle_deg}");
    assert!(axis[2].abs().acos().to_degrees() < 1.0, "{axis:?}");
    let h = mesh.mean_edge_length();
    assert!(center[0].hypot(center[1]) < 0.5 * h, "{center:?}");
}

#[test]
fn mirror_symmetric_plate() {
    let mesh = mirrored_pair();
    let o = pipeline(&mesh, Par::Rayon);
    assert_eq!(o.orbits.len(), 1);
    let Generator::Reflection { normal, offset } = &o.orbits[0].generator else {
        panic!("not a reflection")
    };
    assert!(normal[0].abs().acos().to_degrees() < 1.0, "{normal:?}");
    let h = mesh.mean_edge_length();
    assert!(offset.abs() < 0.01 * h, "{offset}");
}

#[test]
fn plate_pipeline_is_identical_sequential_and_parallel() {
    let (mesh, _) = grid_1d();
    let field = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Seq)
        .unwrap()
        .field;
    let net = trace(&mesh, &field, &TraceParams::default(), Par::Seq)
        .unwrap()
        .network;
    let a = blast(&net, &mesh, &BlastParams::default(), Par::Seq).unwrap();
    let b = blast(&net, &mesh, &BlastParams::default(), Par::Rayon).unwrap();
    assert!(!a.matches.is_empty());
    assert_eq!(a, b);
    let ca = cluster(&a, &ClusterParams::default(), Par::Seq).unwrap();
    let cb = cluster(&b, &ClusterParams::default(), Par::Rayon).unwrap();
    assert_eq!(ca, cb);
    let oa = orbits(&ca, &OrbitParams::default(), Par::Seq).unwrap();
    let ob = orbits(&cb, &OrbitParams::default(), Par::Rayon).unwrap();
    assert_eq!(oa, ob);
}

/// The four shapes of the noise experiments.
fn noise_cases() -> Vec<(&'static str, TriMesh)> {
    vec![
        ("grid_1d", grid_1d().0),
        ("grid_2d", grid_2d().0),
        ("ring_7", ring(7)),
        ("mirror", mirrored_pair()),
    ]
}

/// Whether the generator of case `name` is among the orbits: same kind, translation steps
/// within one mean edge length h, rotation angle within 1°, mirror normal within 1° and plane
/// within h.
fn generator_found(name: &str, o: &Orbits, h: f64) -> bool {
    o.orbits.iter().any(|orb| match (&orb.generator, name) {
        (Generator::Translation { steps }, "grid_1d") => {
            close_up_to_sign(steps[0], [6.0, 0.0, 0.0]) < h && orb.instances == 4
        }
        (Generator::Translation { steps }, "grid_2d") => {
            let (g1, g2) = ([6.0, 0.0, 0.0], [0.0, 5.0, 0.0]);
            steps.len() == 2
                && orb.instances == 6
                && close_up_to_sign(steps[0], g1).min(close_up_to_sign(steps[1], g1)) < h
                && close_up_to_sign(steps[0], g2).min(close_up_to_sign(steps[1], g2)) < h
        }
        (
            Generator::Rotation {
                order, angle_deg, ..
            },
            "ring_7",
        ) => *order == 7 && (angle_deg - 360.0 / 7.0).abs() < 1.0,
        (Generator::Reflection { normal, offset }, "mirror") => {
            normal[0].abs().acos().to_degrees() < 1.0 && offset.abs() < h
        }
        _ => false,
    })
}

/// Denoising before the curvature fit: 10 explicit steps x ← x + ½ (Σ w_j x_j / Σ w_j − x)
/// with cotangent weights recomputed at every step; boundary vertices stay fixed.
fn denoise(mesh: &TriMesh) -> TriMesh {
    let n = mesh.n_vertices();
    let mut edges: BTreeMap<(u32, u32), u32> = BTreeMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut fixed = vec![false; n];
    for (&(a, b), &c) in &edges {
        if c == 1 {
            fixed[a as usize] = true;
            fixed[b as usize] = true;
        }
    }
    let mut x = mesh.positions.clone();
    for _ in 0..10 {
        let mut acc = vec![[0.0; 3]; n];
        let mut wsum = vec![0.0; n];
        for t in &mesh.triangles {
            for k in 0..3 {
                let (i, j, o) = (
                    t[k] as usize,
                    t[(k + 1) % 3] as usize,
                    t[(k + 2) % 3] as usize,
                );
                let (u, v) = (sub(x[i], x[o]), sub(x[j], x[o]));
                let area2 = norm(cross(u, v));
                if area2 <= 0.0 {
                    continue;
                }
                let w = 0.5 * dot(u, v) / area2;
                acc[i] = add(acc[i], scale(x[j], w));
                acc[j] = add(acc[j], scale(x[i], w));
                wsum[i] += w;
                wsum[j] += w;
            }
        }
        for v in 0..n {
            if !fixed[v] && wsum[v] > 0.0 {
                let target = scale(acc[v], 1.0 / wsum[v]);
                x[v] = add(x[v], scale(sub(target, x[v]), 0.5));
            }
        }
    }
    mesh.with_positions(x)
}

/// Which of the four generators are found at Gaussian vertex noise of σ = `level` × the
/// bounding box diagonal (seeded), with or without denoising first.
fn recall(level: f64, smooth: bool) -> Vec<&'static str> {
    let mut found = Vec::new();
    for (seed, (name, mesh)) in noise_cases().into_iter().enumerate() {
        let noisy = add_noise(&mesh, level * mesh.bbox_diagonal(), 17 + seed as u64);
        let input = if smooth { denoise(&noisy) } else { noisy };
        let h = input.mean_edge_length();
        let o = pipeline(&input, Par::Rayon);
        let ok = generator_found(name, &o, h);
        println!(
            "noise {level}, smoothing {smooth}: {name}: found {ok}, other orbits {}",
            o.orbits.len() - usize::from(ok)
        );
        if ok {
            found.push(name);
        }
    }
    found
}

/// Recall under Gaussian vertex noise of σ = 0.05 % and 0.1 % of the bounding box diagonal
/// (thesis Fig. 5.5; σ is then 0.1–0.2 mean edge lengths on these plates), with the curvature
/// fitted after 10 steps of cotangent smoothing. Noise fragments the traced crests (a 78 h
/// crest breaks into pieces of 10–25 h), and on the raw noisy mesh only the ring is found at
/// 0.05 % (see `noise_recall_without_denoising`).
#[test]
fn noise_recall_with_denoising() {
    assert_eq!(
        recall(0.0005, true),
        vec!["grid_1d", "grid_2d", "ring_7", "mirror"]
    );
    assert_eq!(recall(0.001, true), vec!["ring_7", "mirror"]);
}

/// The same without smoothing (the ridges are traced on the noisy surface).
#[test]
#[ignore]
fn noise_recall_without_denoising() {
    assert_eq!(recall(0.0005, false), vec!["ring_7"]);
    assert_eq!(recall(0.001, false), Vec::<&str>::new());
}
