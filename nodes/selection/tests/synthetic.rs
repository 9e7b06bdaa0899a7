//! The co-completion benchmark of thesis §4.2 (Fig. 4.5) on a mesh built here: a plate with a
//! 3 × 2 grid of identical chiral bumps. The ridges and ravines traced on the clean plate are the
//! ground truth (every bump sits on the same mesh vertices up to a translation, so its curves
//! repeat exactly). The input network is that ground truth with random gaps cut into its
//! curves and random short noise curves (walks along mesh edges with random strengths) added.
//! symmetry.{blast, cluster, orbits} → selection.{model, complete} must recover ≥ 95 % of the
//! ground-truth length (recall) with ≥ 90 % of its output on the ground truth (precision); the
//! same scores are printed for thresholding the input curves by their sharpness at three
//! thresholds (the local denoising of thesis Fig. 4.5).
//!
//!   cargo test -p crestflow-nodes-selection --test synthetic -- --nocapture

use crestflow_flow::Par;
use crestflow_geom::vec3::{dist, V3};
use crestflow_geom::{
    CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint, TriMesh,
};
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_ridges::{trace, TraceParams};
use crestflow_nodes_selection::{complete, select_model, CompleteParams, ModelParams};
use crestflow_nodes_symmetry::{
    blast, cluster, orbits, BlastParams, ClusterParams, Generator, OrbitParams,
};

/// Grid spacing of the plate.
const A: f64 = 0.1;
/// Bump spacing along x and y (multiples of A, so every bump has the same triangulation).
const SX: f64 = 60.0 * A;
const SY: f64 = 50.0 * A;

/// SplitMix64.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: usize) -> usize {
        (self.unit() * n as f64) as usize
    }
}

/// A compactly supported profile: (1 − r²)³ inside the unit disc, 0 outside (C² at the rim),
/// so the plate between the bumps is exactly flat and carries no curves.
fn profile(r2: f64) -> f64 {
    if r2 < 1.0 {
        (1.0 - r2).powi(3)
    } else {
        0.0
    }
}

/// A chiral bump: a long ridge along x and a shorter one at 55° beside it.
fn bump(x: f64, y: f64) -> f64 {
    let long = profile((x / 2.4).powi(2) + (y / 0.5).powi(2));
    let (s, c) = 55f64.to_radians().sin_cos();
    let (dx, dy) = (x - 1.0, y - 0.9);
    let (u, v) = (c * dx + s * dy, -s * dx + c * dy);
    let short = profile((u / 1.8).powi(2) + (v / 0.45).powi(2));
    0.5 * long + 0.4 * short
}

/// The plate [−3, 2 SX + 3] × [−2.5, SY + 2.5] with a 3 × 2 grid of bumps; also nx.
fn plate() -> (TriMesh, usize) {
    let (x0, x1, y0, y1) = (-3.0, 2.0 * SX + 3.0, -2.5, SY + 2.5);
    let nx = ((x1 - x0) / A).round() as usize + 1;
    let ny = ((y1 - y0) / A).round() as usize + 1;
    let mut pos = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let (x, y) = (x0 + i as f64 * A, y0 + j as f64 * A);
            let mut z = 0.0;
            for a in 0..3 {
                for b in 0..2 {
                    z += bump(x - a as f64 * SX, y - b as f64 * SY);
                }
            }
            pos.push([x, y, z]);
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
    (TriMesh::new(pos, tris), nx)
}

/// Appends curve `c` of `src`, vertices `range` only.
fn copy_part(
    dst: &mut FeatureCurveNetwork,
    src: &FeatureCurveNetwork,
    c: usize,
    range: std::ops::Range<usize>,
) {
    if range.len() < 2 {
        return;
    }
    let base = dst.vertices.len() as u32;
    for &v in &src.curves[c].vertices[range.clone()] {
        dst.vertices.push(src.vertices[v as usize].clone());
    }
    dst.curves.push(FeatureCurve {
        vertices: (base..base + range.len() as u32).collect(),
        closed: false,
        label: src.curves[c].label,
    });
}

/// The ground truth with random gaps (in 70 % of the curves, 15–35 % of their vertices cut
/// out) and `noise` random short walks along mesh edges (3–10 edges) with random strengths.
fn corrupt(
    truth: &FeatureCurveNetwork,
    mesh: &TriMesh,
    nx: usize,
    noise: usize,
    seed: u64,
) -> FeatureCurveNetwork {
    let mut rng = Rng(seed);
    let mut out = FeatureCurveNetwork::default();
    for c in 0..truth.curves.len() {
        let n = truth.curves[c].vertices.len();
        if n >= 10 && rng.unit() < 0.7 {
            let gap = ((0.15 + 0.2 * rng.unit()) * n as f64).round().max(2.0) as usize;
            let start = 1 + rng.below(n - gap - 1);
            copy_part(&mut out, truth, c, 0..start);
            copy_part(&mut out, truth, c, start + gap..n);
        } else {
            copy_part(&mut out, truth, c, 0..n);
        }
    }
    let strengths: Vec<f64> = truth.vertices.iter().map(|v| v.strength).collect();
    let smax = strengths.iter().cloned().fold(0.0, f64::max);
    let nv = mesh.n_vertices();
    let ny = nv / nx;
    let moves: [(i64, i64); 6] = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1)];
    for _ in 0..noise {
        let mut i = 5 + rng.below(nx - 10) as i64;
        let mut j = 5 + rng.below(ny - 10) as i64;
        let steps = 3 + rng.below(8);
        let dir = moves[rng.below(6)];
        let strength = smax * (0.1 + 0.9 * rng.unit());
        let mut path = vec![(i, j)];
        for _ in 0..steps {
            // Mostly straight on, sometimes a turn.
            let d = if rng.unit() < 0.7 {
                dir
            } else {
                moves[rng.below(6)]
            };
            i = (i + d.0).clamp(0, nx as i64 - 1);
            j = (j + d.1).clamp(0, ny as i64 - 1);
            if path.last() != Some(&(i, j)) && !path.contains(&(i, j)) {
                path.push((i, j));
            }
        }
        if path.len() < 2 {
            continue;
        }
        let base = out.vertices.len() as u32;
        for &(i, j) in &path {
            let v = (j as usize * nx + i as usize) as u32;
            out.vertices.push(FcnVertex {
                position: mesh.positions[v as usize],
                location: SurfacePoint::Vertex(v),
                strength: strength * (0.8 + 0.4 * rng.unit()),
            });
        }
        out.curves.push(FeatureCurve {
            vertices: (base..base + path.len() as u32).collect(),
            closed: false,
            label: if rng.unit() < 0.5 {
                CurveLabel::Ridge
            } else {
                CurveLabel::Ravine
            },
        });
    }
    out
}

/// Length of the curves of `a` within `tol` of the curves of `b`, and the total length of `a`
/// (every edge split into pieces of at most tol / 4, each tested at its midpoint).
fn covered(a: &FeatureCurveNetwork, b: &FeatureCurveNetwork, tol: f64) -> (f64, f64) {
    let mut bpts: Vec<V3> = Vec::new();
    for c in 0..b.curves.len() {
        let p = b.curve_points(c);
        for w in p.windows(2) {
            let k = (dist(w[0], w[1]) / (0.25 * tol)).ceil().max(1.0) as usize;
            for s in 0..=k {
                let t = s as f64 / k as f64;
                bpts.push([
                    w[0][0] + t * (w[1][0] - w[0][0]),
                    w[0][1] + t * (w[1][1] - w[0][1]),
                    w[0][2] + t * (w[1][2] - w[0][2]),
                ]);
            }
        }
        if p.len() == 1 {
            bpts.push(p[0]);
        }
    }
    let tree = rstar::RTree::bulk_load(bpts);
    let (mut hit, mut total) = (0.0, 0.0);
    for c in 0..a.curves.len() {
        for (x, y) in a.curve_edges(c) {
            let (p, q) = (
                a.vertices[x as usize].position,
                a.vertices[y as usize].position,
            );
            let l = dist(p, q);
            let k = (l / (0.25 * tol)).ceil().max(1.0) as usize;
            for s in 0..k {
                let t = (s as f64 + 0.5) / k as f64;
                let m = [
                    p[0] + t * (q[0] - p[0]),
                    p[1] + t * (q[1] - p[1]),
                    p[2] + t * (q[2] - p[2]),
                ];
                total += l / k as f64;
                if let Some(n) = tree.nearest_neighbor(m) {
                    if dist(*n, m) <= tol {
                        hit += l / k as f64;
                    }
                }
            }
        }
    }
    (hit, total)
}

fn scores(out: &FeatureCurveNetwork, truth: &FeatureCurveNetwork, tol: f64) -> (f64, f64) {
    let (rh, rt) = covered(truth, out, tol);
    let (ph, pt) = covered(out, truth, tol);
    (
        if rt > 0.0 { rh / rt } else { 0.0 },
        if pt > 0.0 { ph / pt } else { 0.0 },
    )
}

#[test]
fn gapped_noisy_grid_is_completed() {
    let (mesh, nx) = plate();
    let h = mesh.mean_edge_length();
    let field = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon)
        .unwrap()
        .field;
    let truth = trace(&mesh, &field, &TraceParams::default(), Par::Rayon)
        .unwrap()
        .network;
    // The same curves on every bump.
    assert!(
        truth.curves.len() >= 6 && truth.curves.len().is_multiple_of(6),
        "{} curves",
        truth.curves.len()
    );
    let lengths: Vec<String> = (0..truth.curves.len() / 6)
        .map(|k| format!("{:.0}", truth.curve_length(k) / h))
        .collect();
    eprintln!("curves of one bump ... lengths in h: {lengths:?}");
    for seed in [7, 8, 9, 10, 11] {
        run(seed, &mesh, nx, &truth);
    }
}

fn run(seed: u64, mesh: &TriMesh, nx: usize, truth: &FeatureCurveNetwork) {
    let mesh = mesh.clone();
    let truth = truth.clone();
    let h = mesh.mean_edge_length();
    let input = corrupt(&truth, &mesh, nx, 40, seed);
    let tol = 2.0 * h;

    // The bumps' curves are 22–37 h long on this coarse plate: l0 = 10 h (the thesis' 20–30 h
    // is for dense scans).
    let bp = BlastParams {
        l0: 10.0,
        ..Default::default()
    };
    let m = blast(&input, &mesh, &bp, Par::Rayon).unwrap();
    let c = cluster(&m, &ClusterParams::default(), Par::Rayon).unwrap();
    let o = orbits(&c, &OrbitParams::default(), Par::Rayon).unwrap();
    for orb in &o.orbits {
        eprintln!(
            "orbit {} instances {} support {:.1} {:?}",
            orb.generator.kind(),
            orb.instances,
            orb.support,
            orb.generator
        );
    }
    assert!(
        o.orbits
            .iter()
            .any(|x| matches!(x.generator, Generator::Translation { .. })),
        "no translation orbit"
    );
    let mp = ModelParams {
        l0: 10.0,
        ..Default::default()
    };
    let model = select_model(&input, &c, Some(&o), &mp, Par::Rayon).unwrap();
    eprintln!("kept {:?}, removal steps {:?}", model.kept, model.steps);
    let done = complete(&input, &model, &CompleteParams::default(), Par::Rayon).unwrap();

    let (r_in, p_in) = scores(&input, &truth, tol);
    let (r, p) = scores(&done.network, &truth, tol);
    println!(
        "\nseed {seed}: ground truth {} curves, {:.2} long (h = {h:.4}); input {} curves ({} noise), {:.2} long",
        truth.curves.len(),
        truth.total_length(),
        input.curves.len(),
        40,
        input.total_length()
    );
    println!("\n| method | curves | recall | precision |\n|---|---|---|---|");
    println!(
        "| input (gapped + noise) | {} | {:.1} % | {:.1} % |",
        input.curves.len(),
        100.0 * r_in,
        100.0 * p_in
    );
    // Thresholds on the sharpness w_κ relative to κ_avg of the input (thesis Fig. 4.5).
    let (mut num, mut den) = (0.0, 0.0);
    for k in 0..input.curves.len() {
        let l = input.curve_length(k);
        num += input.curve_strength(k) * l;
        den += l;
    }
    let kappa_avg = num / den;
    let mut best_threshold = (0.0f64, 0.0f64);
    for f in [0.5, 1.0, 1.5] {
        let mut kept = FeatureCurveNetwork::default();
        for k in 0..input.curves.len() {
            if input.curve_strength(k) >= f * kappa_avg {
                copy_part(&mut kept, &input, k, 0..input.curves[k].vertices.len());
            }
        }
        let (rt, pt) = scores(&kept, &truth, tol);
        best_threshold = (best_threshold.0.max(rt), best_threshold.1.max(pt));
        println!(
            "| curvature threshold w_κ ≥ {f} κ_avg | {} | {:.1} % | {:.1} % |",
            kept.curves.len(),
            100.0 * rt,
            100.0 * pt
        );
    }
    println!(
        "| co-completion (selection.model → selection.complete) | {} | {:.1} % | {:.1} % |",
        done.network.curves.len(),
        100.0 * r,
        100.0 * p
    );
    println!(
        "templates {} (curves {}), noise curves removed {}, strong kept {}, cells {:?}",
        done.per_template.len(),
        done.templates.curves.len(),
        done.noise_curves_removed,
        done.strong_curves_kept,
        done.per_template
            .iter()
            .map(|t| t.cells.len())
            .collect::<Vec<_>>()
    );
    // Gaps cannot be closed by thresholding: its recall stays below the input's.
    assert!(r >= 0.95, "seed {seed}: recall {r}");
    assert!(p >= 0.90, "seed {seed}: precision {p}");
    assert!(best_threshold.0 <= r_in + 1e-12);
    assert!(
        r > r_in,
        "completion must add the cut-out pieces: {r} vs {r_in}"
    );
}
