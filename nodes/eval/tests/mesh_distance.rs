//! `eval.mesh_distance` against brute force and closed-form cases.

use crestflow_flow::{Par, Validate};
use crestflow_geom::shapes::{ellipsoid, sphere};
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::TriMesh;
use crestflow_nodes_eval::mesh_distance::{
    closest_point_on_triangle, distances, mesh_distance, sample_surface, MeshDistanceError,
    MeshDistanceParams, TriangleBvh,
};

/// Closest distance by trying every triangle.
fn brute_force(mesh: &TriMesh, p: V3) -> f64 {
    (0..mesh.n_faces())
        .map(|f| {
            let [a, b, c] = mesh.face_points(f);
            closest_point_on_triangle(p, a, b, c).0
        })
        .fold(f64::INFINITY, f64::min)
        .sqrt()
}

/// A flat n × n grid in the plane z = `z`, spanning [0, 1]².
fn grid(n: usize, z: f64) -> TriMesh {
    let mut pos = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            pos.push([i as f64 / n as f64, j as f64 / n as f64, z]);
        }
    }
    let mut tris = Vec::new();
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    TriMesh::new(pos, tris)
}

#[test]
fn point_triangle_distance_matches_dense_sampling() {
    let (a, b, c) = ([0.0, 0.0, 0.0], [2.0, 0.2, 0.1], [0.3, 1.5, -0.2]);
    // Queries in every Voronoi region: near corners, beyond sides, above the interior.
    let queries: [V3; 8] = [
        [-1.0, -1.0, 0.5],
        [3.0, 0.0, 0.0],
        [0.2, 2.5, 1.0],
        [1.0, -1.0, 0.3],
        [1.5, 1.5, -0.4],
        [-0.8, 0.7, 0.0],
        [0.6, 0.5, 2.0],
        [0.6, 0.5, -0.01],
    ];
    let n = 400;
    for q in queries {
        let (d2, bary) = closest_point_on_triangle(q, a, b, c);
        assert!(bary.iter().all(|&w| (-1e-12..=1.0 + 1e-12).contains(&w)));
        assert!((bary.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        // The exact minimum is below every sampled point, and a fine sampling gets close.
        let mut best = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                let p = vec3::add(
                    a,
                    vec3::add(
                        vec3::scale(vec3::sub(b, a), u),
                        vec3::scale(vec3::sub(c, a), v),
                    ),
                );
                best = best.min(vec3::dist(p, q));
            }
        }
        let d = d2.sqrt();
        assert!(d <= best + 1e-12, "{q:?}: exact {d} > sampled {best}");
        assert!(best - d < 5e-3, "{q:?}: exact {d} far below sampled {best}");
    }
}

/// Two jittered ellipsoids of one subdivision level, and the first one's BVH.
fn two_ellipsoids(level: u32) -> (TriMesh, TriMesh, TriangleBvh) {
    let target = ellipsoid(1.0, 0.7, 0.5, level, 0.3, 7).unwrap();
    let other = ellipsoid(1.1, 0.6, 0.55, level, 0.3, 11).unwrap();
    let bvh = TriangleBvh::new(&target);
    (target, other, bvh)
}

#[test]
fn seeded_queries_in_curve_order_equal_plain_queries_bit_for_bit() {
    // Several query chunks; the samples of one surface against the other, plus far points
    // and points on the target itself (distance 0, ties between faces at shared vertices).
    let (target, other, bvh) = two_ellipsoids(3);
    let mut points = sample_surface(&other, 6000, 5, Par::Rayon);
    points.extend(target.positions.iter().copied());
    points.push([5.0, -3.0, 2.0]);
    points.push([0.0, 0.0, 0.0]);
    assert!(points.len() > 3 * 2048);
    let want: Vec<u64> = points
        .iter()
        .map(|&p| bvh.closest(p).distance.to_bits())
        .collect();
    for par in [Par::Seq, Par::Rayon] {
        let got: Vec<u64> = distances(&points, &bvh, par)
            .iter()
            .map(|d| d.to_bits())
            .collect();
        assert_eq!(got, want, "{par:?}");
    }
}

#[test]
fn bvh_equals_brute_force() {
    let (target, other, bvh) = two_ellipsoids(2);
    let mut points = sample_surface(&other, 300, 3, Par::Seq);
    // Points far away and inside too.
    points.push([5.0, -3.0, 2.0]);
    points.push([0.0, 0.0, 0.0]);
    for p in points {
        let got = bvh.closest(p);
        let want = brute_force(&target, p);
        assert_eq!(got.distance, want, "at {p:?}");
        // The reported face and barycentrics give a point at that distance.
        let [a, b, c] = target.face_points(got.face as usize);
        let q = [
            got.bary[0] * a[0] + got.bary[1] * b[0] + got.bary[2] * c[0],
            got.bary[0] * a[1] + got.bary[1] * b[1] + got.bary[2] * c[1],
            got.bary[0] * a[2] + got.bary[1] * b[2] + got.bary[2] * c[2],
        ];
        assert!((vec3::dist(p, q) - want).abs() < 1e-12);
    }
}

#[test]
fn report_matches_brute_force_figures() {
    let a = ellipsoid(1.0, 0.8, 0.6, 1, 0.2, 1).unwrap();
    let b = ellipsoid(1.05, 0.75, 0.62, 2, 0.2, 2).unwrap();
    // The sampled figures alone (the refinement is tested below).
    let params = MeshDistanceParams {
        samples: 500,
        seed: 9,
        tolerance: 0.0,
    };
    let r = mesh_distance(&a, &b, &params, Par::Seq).unwrap();
    assert_eq!(r.num("hausdorff_upper_rel"), None);
    // Same samples as the node draws (the second mesh uses a derived seed).
    let pa = sample_surface(&a, 500, 9, Par::Seq);
    let pb = sample_surface(&b, 500, 9 ^ 0x5A5A_5A5A_5A5A_5A5A, Par::Rayon);
    let da: Vec<f64> = pa.iter().map(|&p| brute_force(&b, p)).collect();
    let db: Vec<f64> = pb.iter().map(|&p| brute_force(&a, p)).collect();
    let diag = a.bbox_diagonal();
    let max = da.iter().chain(&db).cloned().fold(0.0, f64::max);
    let mean = (da.iter().sum::<f64>() + db.iter().sum::<f64>()) / (da.len() + db.len()) as f64;
    let rms = ((da.iter().map(|x| x * x).sum::<f64>() + db.iter().map(|x| x * x).sum::<f64>())
        / (da.len() + db.len()) as f64)
        .sqrt();
    let close = |name: &str, want: f64| {
        let got = r.num(name).unwrap();
        assert!(
            (got - want).abs() <= 1e-12 * want.abs().max(1e-300),
            "{name}: {got} vs {want}"
        );
    };
    close("hausdorff_rel", max / diag);
    close("mean_rel", mean / diag);
    close("rms_rel", rms / diag);
    close(
        "a_to_b.hausdorff_rel",
        da.iter().cloned().fold(0.0, f64::max) / diag,
    );
    close(
        "b_to_a.mean_rel",
        db.iter().sum::<f64>() / db.len() as f64 / diag,
    );
    assert_eq!(r.num("samples_a"), Some((a.n_vertices() + 500) as f64));
    assert_eq!(r.num("samples_b"), Some((b.n_vertices() + 500) as f64));
}

#[test]
fn sphere_against_scaled_sphere() {
    // The scaled mesh's vertices sit exactly 0.01 r above the original's, and every other
    // point of either surface is closer: the Hausdorff distance is 0.01 r exactly.
    let r0 = 2.0;
    let a = sphere(r0, 3).unwrap();
    let b = a.with_positions(a.positions.iter().map(|&p| vec3::scale(p, 1.01)).collect());
    let params = MeshDistanceParams {
        samples: 20_000,
        seed: 1,
        ..Default::default()
    };
    let rep = mesh_distance(&a, &b, &params, Par::Rayon).unwrap();
    let h = rep.num("hausdorff_abs").unwrap();
    assert!((h - 0.01 * r0).abs() < 1e-12, "hausdorff {h}");
    assert!(
        (rep.num("b_to_a.hausdorff_rel").unwrap() * a.bbox_diagonal() - 0.01 * r0).abs() < 1e-12
    );
    // Every distance is 0.01 × (distance of the face plane from the centre), which lies
    // between the inradius of the mesh and r.
    let inradius = (0..a.n_faces())
        .map(|f| {
            let [p, _, _] = a.face_points(f);
            vec3::dot(p, vec3::normalize(a.face_normal_raw(f))).abs()
        })
        .fold(f64::INFINITY, f64::min);
    let mean = rep.num("mean_rel").unwrap() * a.bbox_diagonal();
    assert!(
        mean <= 0.01 * r0 && mean >= 0.01 * inradius * 0.999,
        "mean {mean}"
    );
    assert!(rep.num("a_to_b.hausdorff_rel").unwrap() < rep.num("b_to_a.hausdorff_rel").unwrap());
}

/// The unit square as two triangles at z = 0, and a 40 × 40 grid of it with a conical pit of
/// depth 0.1 and radius 0.2 around the centre: the square's farthest point from the pit lies
/// above its bottom, far from every corner of the square.
fn square_over_a_pit() -> (TriMesh, TriMesh) {
    let square = grid(1, 0.0);
    let pit = grid(40, 0.0);
    let positions = pit
        .positions
        .iter()
        .map(|&[x, y, _]| {
            let r = ((x - 0.5).powi(2) + (y - 0.5).powi(2)).sqrt();
            [x, y, -0.1 * (1.0 - r / 0.2).max(0.0)]
        })
        .collect();
    (square.clone(), pit.with_positions(positions))
}

#[test]
fn refinement_finds_the_far_point_that_samples_miss() {
    let (square, pit) = square_over_a_pit();
    let diag = square.bbox_diagonal();
    let tol = 1e-4;
    let only_vertices = MeshDistanceParams {
        samples: 0,
        seed: 0,
        tolerance: 0.0,
    };
    let refined = MeshDistanceParams {
        tolerance: tol,
        ..only_vertices.clone()
    };
    // The square's corners lie on the pitted grid: from them alone, no distance at all.
    let r0 = mesh_distance(&square, &pit, &only_vertices, Par::Seq).unwrap();
    assert_eq!(r0.num("a_to_b.hausdorff_rel"), Some(0.0));
    let r = mesh_distance(&square, &pit, &refined, Par::Rayon).unwrap();
    let found = r.num("a_to_b.hausdorff_rel").unwrap() * diag;
    let upper = r.num("a_to_b.hausdorff_upper_rel").unwrap() * diag;
    // Brute force over a fine grid of the square: the largest distance lies between what the
    // refinement found and its upper bound, which are within the tolerance of each other.
    let n = 200;
    let mut dense = 0.0f64;
    for j in 0..=n {
        for i in 0..=n {
            let p = [i as f64 / n as f64, j as f64 / n as f64, 0.0];
            dense = dense.max(brute_force(&pit, p));
        }
    }
    let centre = brute_force(&pit, [0.5, 0.5, 0.0]);
    assert!(
        dense >= centre && centre > 0.08,
        "centre {centre}, dense {dense}"
    );
    assert!(
        found <= dense + 1e-12,
        "found {found} beyond the dense maximum {dense}"
    );
    assert!(found >= dense - tol * diag, "found {found}, dense {dense}");
    assert!(
        upper >= dense,
        "upper {upper} below the dense maximum {dense}"
    );
    assert!(upper - found <= tol * diag + 1e-15, "{found} .. {upper}");
    assert_eq!(r.num("faces_unrefined"), Some(0.0));
    assert!(r.num("refined_points").unwrap() > 0.0);
    // Every point of the pitted grid is within 0.1 of the plane, and its bottom is at 0.1.
    let back = r.num("b_to_a.hausdorff_rel").unwrap() * diag;
    assert!((back - 0.1).abs() < 1e-12, "{back}");
    // Where: above the pit's bottom, and the bottom itself.
    let at = |side: &str| ["x", "y", "z"].map(|a| r.num(&format!("{side}.farthest_{a}")).unwrap());
    let top = at("a_to_b");
    assert!(vec3::dist(top, [0.5, 0.5, 0.0]) < 0.01, "{top:?}");
    assert_eq!(brute_force(&pit, top), found);
    assert_eq!(at("b_to_a"), [0.5, 0.5, -0.1]);
    // The same figures at any thread count.
    assert_eq!(r, mesh_distance(&square, &pit, &refined, Par::Seq).unwrap());
}

#[test]
fn a_tolerance_below_what_the_meshes_resolve_stops_at_the_budget() {
    // Parallel planes 0.125 apart, triangulated differently: where a piece of one face lies
    // over two faces of the other, the bound from a single face exceeds 0.125 by the square
    // of the in-plane offset, so a tolerance of 1e-12 cannot be met before the cuts run out.
    let a = grid(4, 0.0);
    let b = grid(7, 0.125);
    let p = MeshDistanceParams {
        tolerance: 1e-12,
        ..Default::default()
    };
    let rep = mesh_distance(&a, &b, &p, Par::Rayon).unwrap();
    let diag = a.bbox_diagonal();
    let h = rep.num("hausdorff_rel").unwrap() * diag;
    let upper = rep.num("hausdorff_upper_rel").unwrap() * diag;
    assert!((h - 0.125).abs() < 1e-12, "{h} {rep:?}");
    assert!(rep.num("faces_unrefined").unwrap() > 0.0, "{rep:?}");
    // What is left uncut is small: the bound over it stays close to the distance.
    assert!((0.125..0.125 + 1e-3).contains(&upper), "{upper}");
    assert_eq!(rep, mesh_distance(&a, &b, &p, Par::Seq).unwrap());
}

#[test]
fn offset_plane_is_at_constant_distance() {
    let a = grid(10, 0.0);
    let b = grid(7, 0.125);
    let rep = mesh_distance(&a, &b, &MeshDistanceParams::default(), Par::Rayon).unwrap();
    let diag = a.bbox_diagonal();
    for name in ["hausdorff_rel", "mean_rel", "rms_rel"] {
        let v = rep.num(name).unwrap() * diag;
        assert!((v - 0.125).abs() < 1e-12, "{name}: {v}");
    }
    assert_eq!(diag, 2f64.sqrt());
}

#[test]
fn identical_meshes_are_at_zero_distance() {
    let a = ellipsoid(1.0, 0.5, 0.3, 2, 0.3, 5).unwrap();
    let rep = mesh_distance(&a, &a.clone(), &MeshDistanceParams::default(), Par::Rayon).unwrap();
    assert!(rep.num("hausdorff_rel").unwrap() < 1e-15);
}

#[test]
fn sequential_equals_parallel() {
    let a = ellipsoid(1.0, 0.7, 0.5, 3, 0.3, 1).unwrap();
    let b = ellipsoid(1.02, 0.69, 0.52, 2, 0.3, 2).unwrap();
    let p = MeshDistanceParams {
        samples: 5000,
        seed: 4,
        ..Default::default()
    };
    let s = mesh_distance(&a, &b, &p, Par::Seq).unwrap();
    let r = mesh_distance(&a, &b, &p, Par::Rayon).unwrap();
    assert_eq!(s, r);
    let other_seed = mesh_distance(&a, &b, &MeshDistanceParams { seed: 5, ..p }, Par::Seq).unwrap();
    assert_ne!(s.num("mean_rel"), other_seed.num("mean_rel"));
}

#[test]
fn bad_inputs_are_named() {
    let good = grid(2, 0.0);
    let p = MeshDistanceParams::default();
    let empty = TriMesh::new(vec![[0.0; 3]], vec![]);
    assert_eq!(
        mesh_distance(&good, &empty, &p, Par::Seq).unwrap_err(),
        MeshDistanceError::NoFaces {
            mesh: "b",
            vertices: 1
        }
    );
    let mut bad = good.clone();
    bad.triangles[5][1] = 99;
    let bad = TriMesh::new(bad.positions, bad.triangles);
    let e = mesh_distance(&bad, &good, &p, Par::Seq).unwrap_err();
    assert_eq!(
        e,
        MeshDistanceError::IndexOutOfRange {
            mesh: "a",
            face: 5,
            index: 99,
            n_vertices: 9
        }
    );
    assert!(e.to_string().contains("face 5 references vertex 99"));
    let mut pos = good.positions.clone();
    pos[4][2] = f64::NAN;
    let nan = TriMesh::new(pos, good.triangles.clone());
    match mesh_distance(&good, &nan, &p, Par::Seq).unwrap_err() {
        MeshDistanceError::NonFinite { mesh, vertex, .. } => assert_eq!((mesh, vertex), ("b", 4)),
        e => panic!("unexpected {e}"),
    }
    let flat = TriMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
        vec![[0, 1, 2]],
    );
    assert_eq!(
        mesh_distance(&good, &flat, &p, Par::Seq).unwrap_err(),
        MeshDistanceError::ZeroArea { mesh: "b" }
    );
    let too_many = MeshDistanceParams {
        samples: 60_000_000,
        seed: 0,
        tolerance: 0.0,
    };
    assert_eq!(too_many.validate().len(), 1);
    for tolerance in [-1e-4, f64::NAN, 2.0] {
        let bad = MeshDistanceParams {
            tolerance,
            ..Default::default()
        };
        let issues = bad.validate();
        assert_eq!(issues.len(), 1, "{tolerance}");
        assert_eq!(issues[0].field, "tolerance");
        assert!(matches!(
            mesh_distance(&good, &good, &bad, Par::Seq),
            Err(MeshDistanceError::Params(m)) if m.starts_with("tolerance")
        ));
    }
    assert!(matches!(
        mesh_distance(&good, &good, &too_many, Par::Seq),
        Err(MeshDistanceError::Params(_))
    ));
}
