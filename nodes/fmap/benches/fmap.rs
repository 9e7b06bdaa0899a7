//! Functional-map benchmarks and accuracy study (release build):
//!
//!   cargo bench -p crestflow-nodes-fmap --bench fmap              # everything
//!   cargo bench -p crestflow-nodes-fmap --bench fmap -- timing    # CG and point-map timings
//!   cargo bench -p crestflow-nodes-fmap --bench fmap -- accuracy  # error table
//!
//! Timing: CG for k = 120 with 20 curve pairs (system build and solve separately), adding one
//! pair to a solved 19-pair system (warm start), the direct solve for comparison, and the
//! point map at 30k × 30k × k = 120 (random embeddings: the cost does not depend on the data).
//!
//! Accuracy: cat pose → pose (identity ground truth), cat → lion (pyfm_lion2cat.txt), SMPL
//! man → woman (identity; landmarks by farthest-point sampling on the man, 20 points from
//! vertex 0, mapped by identity). For 5, 10 and 20 curves (the first q curves of the closed
//! landmark chain) the curve-constrained map and the WKS descriptor map (with the heat kernel
//! maps of the landmarks that are endpoints of those curves), each by nearest neighbours and
//! with ZoomOut 30 → 120 (step 5); Princeton mean geodesic error and cumulative fractions.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_geom::TriMesh;
use crestflow_nodes_fmap::curve_constrained::{bases, build_system, restrict, solve_system};
use crestflow_nodes_fmap::eval_correspondence::{
    evaluate_correspondence, read_ground_truth, EvalCorrespondenceParams,
};
use crestflow_nodes_fmap::point_map::{nearest_neighbors, ZoomOutParams};
use crestflow_nodes_fmap::*;
use crestflow_nodes_spectral::{
    eigenbasis, laplacian, EigenBasis, EigenbasisParams, LaplacianParams,
};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/meshes/correspondence")
}

fn load(p: &Path) -> TriMesh {
    load_mesh(p, &LoadOptions::default()).unwrap().mesh
}

fn basis(mesh: &TriMesh, k: usize) -> (EigenBasis, f64) {
    let t = Instant::now();
    let op = laplacian(mesh, &LaplacianParams::default(), Par::Rayon).unwrap();
    let eb = eigenbasis(
        &op,
        &EigenbasisParams {
            k,
            ..Default::default()
        },
        Par::Rayon,
    )
    .unwrap();
    (eb, t.elapsed().as_secs_f64())
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

struct Pair {
    name: &'static str,
    source: TriMesh,
    target: TriMesh,
    landmarks: LandmarkPairs,
    gt: Option<Vec<u32>>,
}

fn pairs() -> Vec<Pair> {
    let d = data();
    let cat = load(&d.join("sumner_cat_lion/cat-poses/cat-reference.obj"));
    let cat2 = load(&d.join("sumner_cat_lion/cat-poses/cat-05.obj"));
    let lion = load(&d.join("sumner_cat_lion/lion-poses/lion-reference.obj"));
    let lm = read_landmarks(&d.join("sumner_cat_lion/pyfm_landmarks_cat_lion.txt")).unwrap();
    let mut cat_lm = lm.clone();
    cat_lm.pairs.iter_mut().for_each(|p| p[1] = p[0]);
    let gt = read_ground_truth(
        &d.join("sumner_cat_lion/pyfm_lion2cat.txt"),
        cat.n_vertices(),
    )
    .unwrap();
    let man = load(&d.join("smpl_man_woman/human_man.obj"));
    let woman = load(&d.join("smpl_man_woman/human_woman.obj"));
    let smpl_lm = farthest_point_landmarks(&man, 20, 0);
    vec![
        Pair {
            name: "cat-reference -> cat-05",
            source: cat.clone(),
            target: cat2,
            landmarks: cat_lm,
            gt: None,
        },
        Pair {
            name: "cat -> lion",
            source: cat,
            target: lion,
            landmarks: lm,
            gt: Some(gt),
        },
        Pair {
            name: "SMPL man -> woman",
            source: man,
            target: woman,
            landmarks: smpl_lm,
            gt: None,
        },
    ]
}

fn timing() {
    println!(
        "== timing (release, {} rayon threads)",
        rayon::current_num_threads()
    );
    let d = data();
    let cat = load(&d.join("sumner_cat_lion/cat-poses/cat-reference.obj"));
    let lion = load(&d.join("sumner_cat_lion/lion-poses/lion-reference.obj"));
    let lm = read_landmarks(&d.join("sumner_cat_lion/pyfm_landmarks_cat_lion.txt")).unwrap();
    let (e1, t1) = basis(&cat, 120);
    let (e2, t2) = basis(&lion, 120);
    println!("eigenbasis k=120: cat {t1:.2} s, lion {t2:.2} s");
    let sp = |side| ShortestPathParams {
        side,
        curves: 20,
        ..Default::default()
    };
    let t = Instant::now();
    let n1 = shortest_paths(&cat, &lm, None, &sp(Side::Source), Par::Rayon).unwrap();
    let n2 = shortest_paths(&lion, &lm, None, &sp(Side::Target), Par::Rayon).unwrap();
    println!("shortest paths (20 curves on both shapes): {:.2} ms", ms(t));
    let params = CurveConstrainedParams::default();
    for rep in 0..3 {
        let t = Instant::now();
        let (b1, b2) = bases(&e1, &e2, 120).unwrap();
        let tb = ms(t);
        let t = Instant::now();
        let sys = build_system(&b1, &b2, &cat, &lion, &n1, &n2, &params, Par::Rayon).unwrap();
        let tsys = ms(t);
        let t = Instant::now();
        let m = solve_system(&sys, None, &params, Par::Rayon).unwrap();
        let tcg = ms(t);
        let mut plain = params.clone();
        plain.precondition = false;
        let t = Instant::now();
        let mp = solve_system(&sys, None, &plain, Par::Rayon).unwrap();
        let tplain = ms(t);
        let mut direct = params.clone();
        direct.solver = CurveMapSolver::Direct;
        let t = Instant::now();
        let md = solve_system(&sys, None, &direct, Par::Rayon).unwrap();
        let tdir = ms(t);
        let diff = m
            .matrix
            .iter()
            .zip(&md.matrix)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let dmax = md.matrix.iter().map(|x| x.abs()).fold(0.0, f64::max);
        println!(
            "[{rep}] k=120, 20 pairs: bases {tb:.2} ms, restrict+k×k terms {tsys:.2} ms, \
             PCG {tcg:.2} ms ({} it), plain CG {tplain:.2} ms ({} it), direct {tdir:.2} ms; \
             max|C_cg − C_direct| / max|C| = {:.2e}",
            m.iterations,
            mp.iterations,
            diff / dmax
        );
        // Add one pair to a solved 19-pair system.
        let mut p19 = params.clone();
        p19.samples = params.samples;
        let mut n1_19 = n1.clone();
        let mut n2_19 = n2.clone();
        n1_19.curves.truncate(19);
        n2_19.curves.truncate(19);
        let mut sys19 =
            build_system(&b1, &b2, &cat, &lion, &n1_19, &n2_19, &p19, Par::Rayon).unwrap();
        let m19 = solve_system(&sys19, None, &p19, Par::Rayon).unwrap();
        let t = Instant::now();
        let r1 = restrict(&b1, &cat, &n1, 19, params.samples, "source").unwrap();
        let r2 = restrict(&b2, &lion, &n2, 19, params.samples, "target").unwrap();
        sys19.add_pair(&r1, &r2, params.samples);
        let tadd = ms(t);
        let t = Instant::now();
        let m20 = solve_system(&sys19, Some(&m19), &params, Par::Rayon).unwrap();
        let twarm = ms(t);
        let t = Instant::now();
        let m20c = solve_system(&sys19, None, &params, Par::Rayon).unwrap();
        let tcold = ms(t);
        let mut plain_warm = plain.clone();
        plain_warm.max_iterations = 100_000;
        let t = Instant::now();
        let m20p = solve_system(&sys19, Some(&m19), &plain_warm, Par::Rayon).unwrap();
        let tpw = ms(t);
        println!(
            "[{rep}] add pair 20: restrict+terms {tadd:.2} ms, warm PCG {twarm:.2} ms ({} it) vs \
             cold PCG {tcold:.2} ms ({} it); warm plain CG {tpw:.2} ms ({} it)",
            m20.iterations, m20c.iterations, m20p.iterations
        );
    }
    point_map_timing();
}

fn point_map_timing() {
    // Point map at 30k × 30k × 120.
    let n = 30_000;
    let k = 120;
    let mut s = 0x1234_5678_u64;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let q: Vec<f64> = (0..n * k).map(|_| rnd()).collect();
    let r: Vec<f64> = (0..n * k).map(|_| rnd()).collect();
    for rep in 0..3 {
        let t = Instant::now();
        let nn = nearest_neighbors(&q, n, &r, n, k, Par::Rayon);
        let tp = ms(t);
        println!(
            "[{rep}] point map 30000 × 30000 × k=120: {tp:.0} ms (checksum {})",
            nn.iter().map(|&x| x as u64).sum::<u64>()
        );
    }
    let t = Instant::now();
    let nn_seq = nearest_neighbors(&q[..2000 * k], 2000, &r, n, k, Par::Seq);
    let nn_par = nearest_neighbors(&q[..2000 * k], 2000, &r, n, k, Par::Rayon);
    assert_eq!(nn_seq, nn_par);
    println!("seq == rayon on 2000 queries ({:.0} ms)", ms(t));
}

fn accuracy() {
    println!("== accuracy (Princeton: geodesic error / sqrt(source area), all target vertices)");
    println!("pair | method | curves | NN mean | cum@0.025 | cum@0.05 | cum@0.1 | cum@0.25 | ZoomOut mean | ZO cum@0.05 | map ms | NN ms | ZO ms");
    for pair in pairs() {
        let (e1, _) = basis(&pair.source, 120);
        let (e2, _) = basis(&pair.target, 120);
        let eval = |pm: &PointMap| {
            evaluate_correspondence(
                &pair.source,
                pm,
                pair.gt.as_deref(),
                &EvalCorrespondenceParams::default(),
                Par::Rayon,
                &|| false,
            )
            .unwrap()
        };
        let zo = PointMapParams {
            zoomout: Some(ZoomOutParams {
                k_start: 30,
                k_end: 120,
                step: 5,
            }),
        };
        for q in [5usize, 10, 20] {
            let sp = |side| ShortestPathParams {
                side,
                curves: q,
                ..Default::default()
            };
            let n1 = shortest_paths(
                &pair.source,
                &pair.landmarks,
                None,
                &sp(Side::Source),
                Par::Rayon,
            )
            .unwrap();
            let n2 = shortest_paths(
                &pair.target,
                &pair.landmarks,
                None,
                &sp(Side::Target),
                Par::Rayon,
            )
            .unwrap();
            // Landmarks that are endpoints of the q curves: 0..=q (chain), all when q = L.
            let mut used = pair.landmarks.clone();
            let keep = (q + 1).min(used.pairs.len());
            used.pairs.truncate(keep);
            used.lines.truncate(keep);
            let t = Instant::now();
            let cc = curve_constrained(
                &e1,
                &e2,
                &pair.source,
                &pair.target,
                &n1,
                &n2,
                None,
                &CurveConstrainedParams::default(),
                Par::Rayon,
            )
            .unwrap();
            let tcc = ms(t);
            let t = Instant::now();
            let cc60 = curve_constrained(
                &e1,
                &e2,
                &pair.source,
                &pair.target,
                &n1,
                &n2,
                None,
                &CurveConstrainedParams {
                    k: 60,
                    ..Default::default()
                },
                Par::Rayon,
            )
            .unwrap();
            let tcc60 = ms(t);
            let t = Instant::now();
            let dm = descriptor_map(
                &e1,
                &e2,
                Some(&used),
                &DescriptorMapParams::default(),
                Par::Rayon,
            )
            .unwrap();
            let tdm = ms(t);
            for (name, m, tm) in [
                ("curves k=120", &cc, tcc),
                ("curves k=60", &cc60, tcc60),
                ("descriptor WKS+lm", &dm, tdm),
            ] {
                let t = Instant::now();
                let (pm, _) =
                    point_map(&e1, &e2, m, &PointMapParams::default(), Par::Rayon).unwrap();
                let tnn = ms(t);
                let t = Instant::now();
                let (pz, _) = point_map(&e1, &e2, m, &zo, Par::Rayon).unwrap();
                let tzo = ms(t);
                let r = eval(&pm);
                let rz = eval(&pz);
                println!(
                    "{} | {name} | {q} | {:.4} | {:.3} | {:.3} | {:.3} | {:.3} | {:.4} | {:.3} | {tm:.1} | {tnn:.0} | {tzo:.0}",
                    pair.name,
                    r.num("mean").unwrap(),
                    r.num("cum_0.025").unwrap(),
                    r.num("cum_0.05").unwrap(),
                    r.num("cum_0.1").unwrap(),
                    r.num("cum_0.25").unwrap(),
                    rz.num("mean").unwrap(),
                    rz.num("cum_0.05").unwrap(),
                );
            }
        }
        // Descriptor map without landmarks.
        let dm =
            descriptor_map(&e1, &e2, None, &DescriptorMapParams::default(), Par::Rayon).unwrap();
        let (pm, _) = point_map(&e1, &e2, &dm, &PointMapParams::default(), Par::Rayon).unwrap();
        let r = eval(&pm);
        println!(
            "{} | descriptor WKS only | 0 | {:.4} | {:.3} | {:.3} | {:.3} | {:.3} | | | | |",
            pair.name,
            r.num("mean").unwrap(),
            r.num("cum_0.025").unwrap(),
            r.num("cum_0.05").unwrap(),
            r.num("cum_0.1").unwrap(),
            r.num("cum_0.25").unwrap()
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let all = args.is_empty();
    if all || args.iter().any(|a| a == "timing") {
        timing();
    }
    if args.iter().any(|a| a == "pointmap") {
        point_map_timing();
    }
    if all || args.iter().any(|a| a == "accuracy") {
        accuracy();
    }
}
