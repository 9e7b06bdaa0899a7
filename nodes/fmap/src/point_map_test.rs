//! Unit tests of `point_map.rs`.

use super::*;
use crate::curve_constrained::tests::basis_of;
use crestflow_geom::shapes::{ellipsoid, sphere};
use crestflow_geom::TriMesh;

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

#[test]
fn blocked_search_equals_brute_force() {
    let mut s = 7;
    let (nq, nr, d) = (700, 2500, 13);
    let q: Vec<f64> = (0..nq * d).map(|_| lcg(&mut s)).collect();
    let r: Vec<f64> = (0..nr * d).map(|_| lcg(&mut s)).collect();
    let fast = nearest_neighbors(&q, nq, &r, nr, d, Par::Rayon);
    let seq = nearest_neighbors(&q, nq, &r, nr, d, Par::Seq);
    assert_eq!(fast, seq);
    for y in 0..nq {
        let mut best = (f64::INFINITY, 0);
        for x in 0..nr {
            let dd: f64 = (0..d)
                .map(|j| (q[j * nq + y] - r[j * nr + x]).powi(2))
                .sum();
            if dd < best.0 {
                best = (dd, x);
            }
        }
        assert_eq!(fast[y] as usize, best.1, "query {y}");
    }
}

#[test]
fn several_blocks_with_ties_across_blocks_equal_brute_force() {
    // More queries than three query blocks and sources over several source blocks and scan
    // chunks, none a multiple of the block sizes; every 97th source row duplicates row 5 and
    // every 7th query sits on it, so ties span blocks and chunks and the smallest index wins.
    let mut s = 11;
    let (nq, nr, d) = (2 * QUERY_BLOCK + 333, 3 * REF_BLOCK + 77, 7);
    let mut q: Vec<f64> = (0..nq * d).map(|_| lcg(&mut s)).collect();
    let mut r: Vec<f64> = (0..nr * d).map(|_| lcg(&mut s)).collect();
    for x in (5..nr).step_by(97) {
        for j in 0..d {
            r[j * nr + x] = r[j * nr + 5];
        }
    }
    for y in (0..nq).step_by(7) {
        for j in 0..d {
            q[j * nq + y] = r[j * nr + 5];
        }
    }
    let fast = nearest_neighbors(&q, nq, &r, nr, d, Par::Rayon);
    let seq = nearest_neighbors(&q, nq, &r, nr, d, Par::Seq);
    assert_eq!(fast, seq);
    for y in 0..nq {
        let mut best = (f64::INFINITY, 0);
        for x in 0..nr {
            let dd: f64 = (0..d)
                .map(|j| (q[j * nq + y] - r[j * nr + x]).powi(2))
                .sum();
            if dd < best.0 {
                best = (dd, x);
            }
        }
        assert_eq!(fast[y] as usize, best.1, "query {y}");
        if y % 7 == 0 {
            assert_eq!(fast[y], 5, "query {y} sits on row 5");
        }
    }
}

fn identity(k: usize) -> FunctionalMap {
    let mut m = vec![0.0; k * k];
    for i in 0..k {
        m[i * k + i] = 1.0;
    }
    FunctionalMap {
        k_source: k,
        k_target: k,
        matrix: m,
        energy: 0.0,
        iterations: 0,
    }
}

#[test]
fn identity_map_gives_the_identity_point_map() {
    let mesh = ellipsoid(1.2, 1.0, 0.7, 3, 0.3, 5).unwrap();
    let eb = basis_of(&mesh, 30);
    let (pm, _) = point_map(
        &eb,
        &eb,
        &identity(30),
        &PointMapParams::default(),
        Par::Rayon,
    )
    .unwrap();
    let id: Vec<u32> = (0..mesh.n_vertices() as u32).collect();
    assert_eq!(pm.target_to_source, id);
    // ZoomOut from 10 to 30 keeps it.
    let z = PointMapParams {
        zoomout: Some(ZoomOutParams {
            k_start: 10,
            k_end: 30,
            step: 5,
        }),
    };
    let (pz, fz) = point_map(&eb, &eb, &identity(30), &z, Par::Seq).unwrap();
    assert_eq!(pz.target_to_source, id);
    assert_eq!(fz.k_source, 30);
    assert_eq!(fz.iterations, 4);
    for i in 0..30 {
        assert!((fz.get(i, i) - 1.0).abs() < 1e-9);
    }
}

/// The mesh with vertex `v` renamed `perm[v]`.
fn permuted(mesh: &TriMesh, perm: &[u32]) -> TriMesh {
    let mut pos = vec![[0.0; 3]; mesh.n_vertices()];
    for (v, &p) in perm.iter().enumerate() {
        pos[p as usize] = mesh.positions[v];
    }
    let tris = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| perm[v as usize]))
        .collect();
    TriMesh::new(pos, tris)
}

#[test]
fn a_known_permutation_is_recovered_exactly() {
    // The target is the source with its vertices renumbered: its eigenbasis is the source's,
    // permuted, so the identity functional map gives back the permutation exactly.
    let mesh = ellipsoid(1.2, 1.0, 0.7, 3, 0.3, 5).unwrap();
    let n = mesh.n_vertices();
    let perm: Vec<u32> = (0..n as u32).map(|v| (v * 37 + 11) % n as u32).collect();
    let target = permuted(&mesh, &perm);
    let e1 = basis_of(&mesh, 20);
    let e2 = basis_of(&target, 20);
    // Eigenvectors agree up to the permutation (their signs are fixed by the largest entry).
    for i in 0..20 {
        for (v, &pv) in perm.iter().enumerate() {
            let a = e1.vector(i)[v];
            let b = e2.vector(i)[pv as usize];
            assert!((a - b).abs() < 1e-6, "function {i} vertex {v}: {a} vs {b}");
        }
    }
    let (pm, _) = point_map(
        &e1,
        &e2,
        &identity(20),
        &PointMapParams::default(),
        Par::Rayon,
    )
    .unwrap();
    for (v, &pv) in perm.iter().enumerate() {
        assert_eq!(pm.target_to_source[pv as usize], v as u32);
    }
}

#[test]
fn points_to_map_of_the_identity_is_the_identity() {
    let mesh = sphere(1.0, 3).unwrap();
    let eb = basis_of(&mesh, 16);
    let b = crate::dense::Basis::new(&eb, 16, "source").unwrap();
    let id: Vec<u32> = (0..mesh.n_vertices() as u32).collect();
    let c = points_to_map(&b, &b, &id, 16, Par::Rayon);
    for j in 0..16 {
        for i in 0..16 {
            let want = if i == j { 1.0 } else { 0.0 };
            assert!((c[j * 16 + i] - want).abs() < 1e-9);
        }
    }
}

#[test]
fn mismatched_sizes_are_errors() {
    let mesh = sphere(1.0, 2).unwrap();
    let eb = basis_of(&mesh, 10);
    let e = point_map(
        &eb,
        &eb,
        &identity(12),
        &PointMapParams::default(),
        Par::Seq,
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::MapSizeMismatch {
                rows: 12,
                cols: 12,
                ..
            }
        ),
        "{e}"
    );
    let z = PointMapParams {
        zoomout: Some(ZoomOutParams {
            k_start: 5,
            k_end: 11,
            step: 2,
        }),
    };
    let e = point_map(&eb, &eb, &identity(10), &z, Par::Seq).unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::Param {
                field: "zoomout.k_end",
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn ties_and_near_ties_are_resolved_exactly() {
    // Duplicated source rows: the smallest index wins. Rows 1e-7 apart (below f32 resolution
    // at this scale) are still told apart by the exact f64 pass.
    let d = 5;
    let nr = 6;
    let base = [3.0, -2.0, 1.5, 0.25, 7.0];
    let mut r = vec![0.0; nr * d];
    for x in 0..nr {
        for j in 0..d {
            r[j * nr + x] = base[j] + 10.0 * x as f64;
        }
    }
    // Rows 4 and 2 duplicate row 1; row 5 is row 3 shifted by 1e-7 in one coordinate.
    for j in 0..d {
        r[j * nr + 4] = r[j * nr + 1];
        r[j * nr + 2] = r[j * nr + 1];
        r[j * nr + 5] = r[j * nr + 3];
    }
    r[nr * 2 + 5] += 1e-7;
    let q_at = |x: usize, shift: f64| -> Vec<f64> {
        let mut q = vec![0.0; d];
        for j in 0..d {
            q[j] = r[j * nr + x];
        }
        q[2] += shift;
        q
    };
    assert_eq!(
        nearest_neighbors(&q_at(4, 0.0), 1, &r, nr, d, Par::Seq),
        vec![1]
    );
    // A query just past row 5 (in the shifted coordinate) goes to row 5, not row 3.
    assert_eq!(
        nearest_neighbors(&q_at(5, 1e-7), 1, &r, nr, d, Par::Seq),
        vec![5]
    );
    assert_eq!(
        nearest_neighbors(&q_at(3, -1e-7), 1, &r, nr, d, Par::Seq),
        vec![3]
    );
}
