//! Unit tests of `sparse.rs`.

use super::*;
use crestflow_geom::shapes::sphere;

fn right_triangle() -> TriMesh {
    TriMesh::new(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    )
}

#[test]
fn triplets_sum_duplicates_and_check_input() {
    let m = CsrMatrix::from_triplets(2, 3, &[(1, 2, 1.0), (0, 1, 2.0), (1, 2, 0.5)]).unwrap();
    assert_eq!(m.nnz(), 2);
    assert_eq!(m.get(1, 2), 1.5);
    assert_eq!(m.get(0, 1), 2.0);
    assert_eq!(m.get(0, 0), 0.0);
    assert_eq!(m.transpose().get(2, 1), 1.5);
    assert_eq!(
        CsrMatrix::from_triplets(2, 2, &[(2, 0, 1.0)]),
        Err(SparseError::IndexOutOfRange {
            row: 2,
            col: 0,
            nrows: 2,
            ncols: 2
        })
    );
    assert!(matches!(
        CsrMatrix::from_triplets(2, 2, &[(0, 1, f64::NAN)]),
        Err(SparseError::NonFinite { row: 0, col: 1, .. })
    ));
    assert!(matches!(
        CsrMatrix::from_raw(2, 2, vec![0, 1, 1], vec![5], vec![1.0]),
        Err(SparseError::IndexOutOfRange { row: 0, col: 5, .. })
    ));
}

#[test]
fn right_triangle_weights_and_voronoi_mass() {
    // Angles 90° at vertex 0 and 45° at 1 and 2: cot = 0, 1, 1.
    let m = right_triangle();
    let l = cotan_laplacian(&m).unwrap();
    let expected = [[1.0, -0.5, -0.5], [-0.5, 0.5, 0.0], [-0.5, 0.0, 0.5]];
    for (i, row) in expected.iter().enumerate() {
        for (j, &e) in row.iter().enumerate() {
            assert!(
                (l.get(i, j) - e).abs() < 1e-12,
                "L[{i}][{j}] = {}",
                l.get(i, j)
            );
        }
    }
    let mass = lumped_mass(&m).unwrap();
    for (got, want) in mass.iter().zip([0.25, 0.125, 0.125]) {
        assert!((got - want).abs() < 1e-12, "{mass:?}");
    }
    // An obtuse triangle: half the area to the obtuse corner, a quarter to the others.
    let obtuse = TriMesh::new(
        vec![[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 0.2, 0.0]],
        vec![[0, 1, 2]],
    );
    let mass = lumped_mass(&obtuse).unwrap();
    for (got, want) in mass.iter().zip([0.05, 0.05, 0.1]) {
        assert!((got - want).abs() < 1e-12, "{mass:?}");
    }
}

#[test]
fn sphere_operator_properties() {
    let mesh = sphere(1.0, 4).unwrap();
    let (l, m) = laplacian_and_mass(&mesh, &LaplacianOptions::default(), Par::Seq).unwrap();
    assert!(l.asymmetry() < 1e-14);
    for i in 0..l.nrows() {
        let s: f64 = l.row(i).map(|(_, v)| v).sum();
        assert!(s.abs() < 1e-12, "row {i} sums to {s}");
    }
    // Both lumpings partition the area.
    let area = mesh.total_area();
    assert!((m.iter().sum::<f64>() - area).abs() < 1e-10 * area);
    let bary = LaplacianOptions {
        mass: MassKind::Barycentric,
        ..Default::default()
    };
    let (_, mb) = laplacian_and_mass(&mesh, &bary, Par::Seq).unwrap();
    assert!((mb.iter().sum::<f64>() - area).abs() < 1e-10 * area);
    // −Δx = 2x on the unit sphere: L x ≈ 2 M x for each coordinate function.
    for c in 0..3 {
        let x: Vec<f64> = mesh.positions.iter().map(|p| p[c]).collect();
        let mut lx = vec![0.0; x.len()];
        l.mul_vec(&x, &mut lx, Par::Seq).unwrap();
        let num: f64 = lx
            .iter()
            .zip(&x)
            .zip(&m)
            .map(|((a, b), w)| (a - 2.0 * w * b).powi(2))
            .sum();
        let den: f64 = x.iter().zip(&m).map(|(b, w)| (2.0 * w * b).powi(2)).sum();
        assert!(
            (num / den).sqrt() < 0.01,
            "coordinate {c}: {}",
            (num / den).sqrt()
        );
    }
    // No near-degenerate triangle: mollification changes nothing.
    let plain = LaplacianOptions {
        mollify: 0.0,
        ..Default::default()
    };
    let (l0, _) = laplacian_and_mass(&mesh, &plain, Par::Seq).unwrap();
    assert_eq!(l0, l);
    let (lr, mr) = laplacian_and_mass(&mesh, &LaplacianOptions::default(), Par::Rayon).unwrap();
    assert_eq!((lr, mr), (l, m));
}

#[test]
fn spd_solver_solves_refactors_and_reports() {
    let mesh = sphere(1.0, 4).unwrap();
    let (l, m) = laplacian_and_mass(&mesh, &LaplacianOptions::default(), Par::Seq).unwrap();
    let n = m.len();
    let a = l.add_diagonal(&m).unwrap();
    let mut solver = SpdSolver::new(&a, Par::Seq).unwrap();
    let b: Vec<f64> = (0..n)
        .map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5)
        .collect();
    let residual = |a: &CsrMatrix, x: &[f64]| {
        let mut ax = vec![0.0; n];
        a.mul_vec(x, &mut ax, Par::Seq).unwrap();
        ax.iter()
            .zip(&b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max)
    };
    let mut x = b.clone();
    solver.solve_in_place(&mut x).unwrap();
    assert!(residual(&a, &x) < 1e-10, "residual {}", residual(&a, &x));
    // New values on the same pattern: L + 10 M.
    let a2 = l
        .add_scaled(1.0, &CsrMatrix::from_diagonal(&m).unwrap(), 10.0)
        .unwrap();
    solver.refactor(&a2, Par::Seq).unwrap();
    let mut x2 = b.clone();
    solver.solve_in_place(&mut x2).unwrap();
    assert!(residual(&a2, &x2) < 1e-10);
    assert!(
        residual(&a, &x2) > 1e-3,
        "the refactorisation must change the solution"
    );
    // Many right-hand sides: every column solved, same bits with any Par.
    let many: Vec<f64> = (0..n * 11).map(|i| b[i % n] * (1 + i / n) as f64).collect();
    let mut s = many.clone();
    let mut r = many.clone();
    solver.solve_many(&mut s, 11, Par::Seq).unwrap();
    solver.solve_many(&mut r, 11, Par::Rayon).unwrap();
    assert_eq!(s, r);
    // A column's bits do not depend on the columns solved with it.
    for c in [0usize, 5, 10] {
        let mut one = many[c * n..(c + 1) * n].to_vec();
        solver.solve_many(&mut one, 1, Par::Seq).unwrap();
        assert_eq!(one, s[c * n..(c + 1) * n]);
    }
    for c in 0..11 {
        let scale = (1 + c) as f64;
        for i in 0..n {
            assert!((s[c * n + i] - scale * x2[i]).abs() < 1e-9 * scale);
        }
    }
    assert_eq!(
        solver.solve_in_place(&mut [0.0; 3]),
        Err(SparseError::DimensionMismatch {
            what: "the right-hand side",
            got: 3,
            expected: n
        })
    );
    // −I is not positive definite.
    let neg = CsrMatrix::from_diagonal(&[-1.0, -1.0]).unwrap();
    assert!(matches!(
        SpdSolver::new(&neg, Par::Seq),
        Err(SparseError::NotPositiveDefinite { .. })
    ));
}

#[test]
fn bad_meshes_are_rejected_with_the_element() {
    let mut m = right_triangle();
    m.triangles.push([0, 1, 7]);
    assert_eq!(
        cotan_laplacian(&m),
        Err(OperatorError::IndexOutOfRange {
            face: 1,
            index: 7,
            n_vertices: 3
        })
    );
    let mut m = right_triangle();
    m.positions[2][1] = f64::INFINITY;
    assert!(matches!(
        lumped_mass(&m),
        Err(OperatorError::NonFinitePosition { vertex: 2, .. })
    ));
    let empty = TriMesh::new(vec![[0.0; 3]], vec![]);
    assert_eq!(cotan_laplacian(&empty), Err(OperatorError::NoTriangles));
    let mut m = right_triangle();
    m.triangles[0] = [0, 1, 1];
    assert_eq!(
        cotan_laplacian(&m),
        Err(OperatorError::RepeatedVertex { face: 0, vertex: 1 })
    );
    // Finite coordinates whose areas overflow or underflow: an error naming the size, not a
    // NaN or an empty operator.
    let exact =
        laplacian_and_mass(&right_triangle(), &LaplacianOptions::default(), Par::Seq).unwrap();
    for scale in [1e100, 1e-100] {
        let mut m = right_triangle();
        for p in &mut m.positions {
            *p = p.map(|c| c * scale);
        }
        let err = laplacian_and_mass(&m, &LaplacianOptions::default(), Par::Seq).unwrap_err();
        assert!(matches!(err, OperatorError::Scale { .. }), "{err:?}");
        assert!(err.to_string().contains("scale the mesh"), "{err}");
    }
    // Within the range the cotangent weights are scale-free and the masses scale as areas.
    for scale in [1e60, 1e-60] {
        let mut m = right_triangle();
        for p in &mut m.positions {
            *p = p.map(|c| c * scale);
        }
        let (l, mass) = laplacian_and_mass(&m, &LaplacianOptions::default(), Par::Seq).unwrap();
        for (a, b) in l.values().iter().zip(exact.0.values()) {
            assert!((a - b).abs() < 1e-9, "{a} {b}");
        }
        for (a, b) in mass.iter().zip(&exact.1) {
            assert!((a / (scale * scale) - b).abs() < 1e-9 * b, "{a} {b}");
        }
    }
}

/// Two unit spheres side by side (a forest: the elimination tree has two roots).
#[test]
fn indefinite_solver_counts_the_eigenvalues_below_the_shift() {
    // The unit sphere's eigenvalues lie near l(l + 1) with multiplicity 2l + 1: below σ = 4
    // lie 1 + 3 of them, below σ = 7 another 5, per sphere. Level 5 is large enough for the
    // split (parallel) solves.
    for (mesh, spheres) in [(sphere(1.0, 5).unwrap(), 1), (two_spheres(5), 2)] {
        let (l, m) = laplacian_and_mass(&mesh, &LaplacianOptions::default(), Par::Seq).unwrap();
        let n = m.len();
        for (sigma, below) in [(4.0, 4), (7.0, 9)] {
            let a = l
                .add_diagonal(&m.iter().map(|x| -sigma * x).collect::<Vec<_>>())
                .unwrap();
            let solver = SpdSolver::new_indefinite(&a, Par::Seq).unwrap();
            assert_eq!(solver.negative_pivots(), below * spheres, "σ = {sigma}");
            let b: Vec<f64> = (0..n * 5)
                .map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5)
                .collect();
            let mut x = b.clone();
            let mut y = b.clone();
            solver.solve_many(&mut x, 5, Par::Rayon).unwrap();
            solver.solve_many(&mut y, 5, Par::Seq).unwrap();
            assert_eq!(x, y);
            let ax = a.mul_dense(&x, 5, Par::Seq).unwrap();
            let worst = ax
                .iter()
                .zip(&b)
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-10, "σ = {sigma}: residual {worst}");
        }
    }
    // A zero pivot is an error, not a division by zero; a positive definite matrix has no
    // negative pivot.
    let singular = CsrMatrix::from_diagonal(&[1.0, 0.0, 2.0]).unwrap();
    assert!(matches!(
        SpdSolver::new_indefinite(&singular, Par::Seq),
        Err(SparseError::Factorization(_))
    ));
    let mut diag = SpdSolver::new_indefinite(
        &CsrMatrix::from_diagonal(&[1.0, -2.0, 4.0]).unwrap(),
        Par::Seq,
    )
    .unwrap();
    assert_eq!(diag.negative_pivots(), 1);
    let mut x = vec![1.0, 1.0, 1.0];
    diag.solve_in_place(&mut x).unwrap();
    assert_eq!(x, [1.0, -0.5, 0.25]);
    diag.refactor(
        &CsrMatrix::from_diagonal(&[1.0, 2.0, 4.0]).unwrap(),
        Par::Seq,
    )
    .unwrap();
    assert_eq!(diag.negative_pivots(), 0);
}

fn two_spheres(level: u32) -> TriMesh {
    let a = sphere(1.0, level).unwrap();
    let n = a.positions.len() as u32;
    let mut positions = a.positions.clone();
    positions.extend(a.positions.iter().map(|p| [p[0] + 3.0, p[1], p[2]]));
    let mut triangles = a.triangles.clone();
    triangles.extend(a.triangles.iter().map(|t| [t[0] + n, t[1] + n, t[2] + n]));
    TriMesh::new(positions, triangles)
}

#[test]
fn split_triangular_solves_are_exact_and_thread_independent() {
    for (mesh, components) in [(sphere(1.0, 5).unwrap(), 1), (two_spheres(5), 2)] {
        let (l, m) = laplacian_and_mass(&mesh, &LaplacianOptions::default(), Par::Seq).unwrap();
        let n = m.len();
        let a = l.add_diagonal(&m).unwrap();
        let solver = SpdSolver::new(&a, Par::Seq).unwrap();
        let sched = &solver.schedule;
        // Large enough to be split: several subtrees below a non-empty separator part, the
        // subtrees and the separators covering every supernode once.
        assert!(
            solver.factor_nnz() >= SPLIT_MIN_VALUES,
            "{}",
            solver.factor_nnz()
        );
        assert!(
            sched.subtrees.len() >= 4,
            "{} subtrees",
            sched.subtrees.len()
        );
        assert!(!sched.top.is_empty());
        let covered: usize = sched
            .subtrees
            .iter()
            .map(|t| t.last + 1 - t.first)
            .sum::<usize>()
            + sched.top.len();
        let SymbolicCholeskyRaw::Supernodal(sym) = solver.symbolic.raw() else {
            panic!("supernodal factor expected");
        };
        assert_eq!(covered, sym.n_supernodes());
        let b: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5)
            .collect();
        let mut seq = b.clone();
        solver.solve_in_place(&mut seq).unwrap();
        let mut par = b.clone();
        solver.solve_many(&mut par, 1, Par::Rayon).unwrap();
        assert_eq!(
            seq, par,
            "one right-hand side: same bits with and without threads"
        );
        let res = max_residual(&a, &seq, &b);
        assert!(res < 1e-10, "residual {res}");
        // Inside a block of three the column has the same bits again.
        let mut block: Vec<f64> = b.iter().chain(&b).chain(&b).map(|v| v * 2.0).collect();
        solver.solve_many(&mut block, 3, Par::Rayon).unwrap();
        let doubled: Vec<f64> = seq.iter().map(|v| v * 2.0).collect();
        let mut twice = b.iter().map(|v| v * 2.0).collect::<Vec<_>>();
        solver.solve_in_place(&mut twice).unwrap();
        assert_eq!(&block[n..2 * n], &twice[..]);
        // Eight columns (summed row by row in the forward solve) give the bits of one
        // (summed column by column).
        let mut eight: Vec<f64> = (0..8).flat_map(|_| b.iter().copied()).collect();
        solver.solve_many(&mut eight, 8, Par::Seq).unwrap();
        for col in eight.chunks(n) {
            assert_eq!(col, &seq[..]);
        }
        // Blocks on the pool, whose separator part is solved in two halves of columns side
        // by side: every column has the bits of its solve alone.
        for m in [2usize, 4, 5, 8] {
            let cols: Vec<Vec<f64>> = (0..m)
                .map(|j| {
                    b.iter()
                        .map(|v| v * (j + 1) as f64 - 0.01 * j as f64)
                        .collect()
                })
                .collect();
            let mut block: Vec<f64> = cols.concat();
            solver.solve_many(&mut block, m, Par::Rayon).unwrap();
            for (j, col) in cols.iter().enumerate() {
                let mut alone = col.clone();
                solver.solve_in_place(&mut alone).unwrap();
                assert_eq!(&block[j * n..(j + 1) * n], &alone[..], "column {j} of {m}");
            }
        }
        for (p, q) in twice.iter().zip(&doubled) {
            assert!((p - q).abs() <= 1e-12 * q.abs().max(1.0));
        }
        // A point source: its forward solve skips the supernodes it cannot reach, and gives
        // the bits of the full solve it gets beside a dense column.
        let mut delta = vec![0.0; n];
        delta[n / 3] = 1.0;
        let mut alone = delta.clone();
        solver.solve_many(&mut alone, 1, Par::Rayon).unwrap();
        let mut beside: Vec<f64> = delta.iter().chain(&b).copied().collect();
        solver.solve_many(&mut beside, 2, Par::Seq).unwrap();
        assert_eq!(&beside[..n], &alone[..]);
        let res = max_residual(&a, &alone, &delta);
        assert!(res < 1e-10, "residual {res}");
        // Positive on the source's sphere (M + L is an M-matrix on an icosphere: no obtuse
        // angles), exactly zero on the other one.
        let reach = n / components;
        assert!(alone[..reach].iter().all(|&v| v > 0.0));
        assert!(alone[reach..].iter().all(|&v| v == 0.0));
    }
}

#[test]
fn triplets_are_summed_in_the_given_order() {
    // Reference: a map from (row, col) to the running sum, adding in the order given.
    let mut state = 12345u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        state >> 33
    };
    let (nrows, ncols) = (37, 23);
    let trip: Vec<(usize, usize, f64)> = (0..5000)
        .map(|_| {
            let r = (next() % nrows as u64) as usize;
            let c = (next() % ncols as u64) as usize;
            // Values of very different magnitudes: a different summation order would show.
            let v = (next() % 1000) as f64 * 10f64.powi((next() % 12) as i32 - 6);
            (r, c, v)
        })
        .collect();
    let mut reference = std::collections::BTreeMap::new();
    for &(r, c, v) in &trip {
        *reference.entry((r, c)).or_insert(0.0) += v;
    }
    let m = CsrMatrix::from_triplets(nrows, ncols, &trip).unwrap();
    assert_eq!(m.nnz(), reference.len());
    let mut k = 0;
    for i in 0..nrows {
        for (j, v) in m.row(i) {
            let (&(ri, rj), &rv) = reference.iter().nth(k).unwrap();
            assert_eq!((i, j), (ri, rj));
            assert_eq!(v.to_bits(), rv.to_bits(), "entry ({i}, {j})");
            k += 1;
        }
    }
}

#[test]
fn row_assembly_equals_the_triplet_sum_bit_for_bit() {
    // Two spheres (several row tasks), the vertices renumbered at random so that face order
    // and row order disagree, one vertex no face uses, and a few faces repeated (three or
    // more terms per off-diagonal entry, where the order of the sum shows in the bits).
    let base = two_spheres(4);
    let n = base.positions.len();
    assert!(n > ROWS_PER_TASK);
    let mut state = 99u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as usize
    };
    let mut perm: Vec<u32> = (0..n as u32 + 1).collect();
    for i in (1..perm.len()).rev() {
        perm.swap(i, next() % (i + 1));
    }
    let mut positions = vec![[0.0; 3]; n + 1];
    for (v, p) in base.positions.iter().enumerate() {
        positions[perm[v] as usize] = *p;
    }
    positions[perm[n] as usize] = [9.0, 9.0, 9.0];
    let mut triangles: Vec<[u32; 3]> = base
        .triangles
        .iter()
        .map(|t| t.map(|v| perm[v as usize]))
        .collect();
    for f in [3usize, 500, 7000] {
        let t = triangles[f];
        triangles.push(t);
        triangles.push([t[1], t[2], t[0]]);
    }
    // Jitter, so that the cotangents differ from face to face.
    for p in positions.iter_mut() {
        for x in p.iter_mut() {
            *x += 1e-2 * ((next() % 1000) as f64 / 1000.0 - 0.5);
        }
    }
    let mesh = TriMesh::new(positions, triangles);
    for kind in [MassKind::Voronoi, MassKind::Barycentric] {
        let opts = LaplacianOptions {
            mass: kind,
            ..Default::default()
        };
        // The reference: twelve triplets per face, summed in face order.
        let terms = all_face_terms(&mesh, &opts, Par::Seq).unwrap();
        let mut trip = Vec::new();
        for (t, ft) in mesh.triangles.iter().zip(&terms) {
            for i in 0..3 {
                let (j, k) = (t[(i + 1) % 3] as usize, t[(i + 2) % 3] as usize);
                let w = 0.5 * ft.cot[i];
                trip.extend([(j, k, -w), (k, j, -w), (j, j, w), (k, k, w)]);
            }
        }
        let l_ref = CsrMatrix::from_triplets(n + 1, n + 1, &trip).unwrap();
        let m_ref = assemble_mass(&mesh, &terms);
        for par in [Par::Seq, Par::Rayon] {
            let (l, m) = laplacian_and_mass(&mesh, &opts, par).unwrap();
            assert_eq!(l.row_ptr(), l_ref.row_ptr(), "{kind:?} {par:?}");
            assert_eq!(l.col_idx(), l_ref.col_idx(), "{kind:?} {par:?}");
            let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(l.values()), bits(l_ref.values()), "{kind:?} {par:?}");
            assert_eq!(bits(&m), bits(&m_ref), "{kind:?} {par:?}");
            // The unused vertex: an empty row and no mass.
            let u = perm[n] as usize;
            assert_eq!(l.row(u).count(), 0);
            assert_eq!(m[u], 0.0);
        }
    }
}

/// `max |A x − b|`.
fn max_residual(a: &CsrMatrix, x: &[f64], b: &[f64]) -> f64 {
    let mut ax = vec![0.0; b.len()];
    a.mul_vec(x, &mut ax, Par::Seq).unwrap();
    ax.iter()
        .zip(b)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max)
}

/// The solver refactorised by faer's own numeric factorisation, and the largest difference
/// between the two factors' lower parts (the upper part of each diagonal block is not read by
/// the solves) with the largest magnitude of ours.
fn against_faer(solver: &SpdSolver, a: &CsrMatrix) -> (SpdSolver, f64, f64) {
    let mut faer_solver = solver.clone();
    faer_solver.numeric_faer(a).unwrap();
    let SymbolicCholeskyRaw::Supernodal(sym) = solver.symbolic.raw() else {
        panic!("expected a supernodal factor");
    };
    let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
    let (rptr, vptr) = (sym.col_ptr_for_row_idx(), sym.col_ptr_for_val());
    let (mut worst, mut max) = (0.0f64, 0.0f64);
    for s in 0..begin.len() {
        let nc = end[s] - begin[s];
        let ld = nc + rptr[s + 1] - rptr[s];
        for j in 0..nc {
            let col = vptr[s] + j * ld + j..vptr[s] + (j + 1) * ld;
            for (x, y) in solver.factor[col.clone()]
                .iter()
                .zip(&faer_solver.factor[col])
            {
                worst = worst.max((x - y).abs());
                max = max.max(x.abs());
            }
        }
    }
    (faer_solver, worst, max)
}

#[test]
fn multifrontal_factor_matches_faer_and_ignores_the_thread_count() {
    // The unit sphere's eigenvalues are l(l + 1) with multiplicity 2l + 1: 0, 2 (3), 6 (5),
    // 12 (7). Two spheres double the counts.
    for (mesh, spheres) in [(sphere(1.0, 5).unwrap(), 1), (two_spheres(4), 2)] {
        let (l, m) = laplacian_and_mass(&mesh, &LaplacianOptions::default(), Par::Seq).unwrap();
        for (sigma, below) in [(-1.0, 0), (4.0, 4), (9.0, 9)] {
            let a = l
                .add_diagonal(&m.iter().map(|x| -sigma * x).collect::<Vec<_>>())
                .unwrap();
            let mut seq = if sigma < 0.0 {
                SpdSolver::new(&a, Par::Seq).unwrap()
            } else {
                SpdSolver::new_indefinite(&a, Par::Seq).unwrap()
            };
            assert!(seq.scatter.is_some(), "the multifrontal path ran");
            assert!(seq.schedule.subtrees.len() >= 2 || spheres == 2);
            assert_eq!(seq.negative_pivots(), below * spheres, "σ = {sigma}");
            let mut pool = seq.clone();
            pool.refactor(&a, Par::Rayon).unwrap();
            assert!(
                pool.factor
                    .iter()
                    .zip(&seq.factor)
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
                "σ = {sigma}: the pool changed the factor"
            );
            assert_eq!(pool.negative, seq.negative);
            // Against faer's own left-looking factorisation of the same analysis.
            let (faer_solver, worst, max) = against_faer(&seq, &a);
            assert_eq!(faer_solver.negative, seq.negative, "σ = {sigma}");
            // Positive definite: the two agree to rounding. Inside the spectrum the pivots
            // grow (largest entry 30 against 2 at σ = 9) and so do rounding differences; the
            // solves below bound the backward error instead.
            let tol = if sigma < 0.0 { 1e-13 } else { 1e-9 };
            assert!(worst <= tol * max, "σ = {sigma}: {worst:e} of {max:e}");
            // And the solves of the new factor are exact.
            let n = m.len();
            let b: Vec<f64> = (0..n)
                .map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5)
                .collect();
            let mut x = b.clone();
            seq.solve_in_place(&mut x).unwrap();
            let worst = max_residual(&a, &x, &b);
            assert!(worst < 1e-10, "σ = {sigma}: residual {worst}");
            seq.refactor(&a, Par::Seq).unwrap();
        }
    }
}

#[test]
fn multifrontal_factor_reports_the_failing_pivot() {
    // A positive definite Laplacian + mass with one vertex's diagonal made very negative:
    // the positive definite factorisation names a pivot, the indefinite one succeeds.
    let mesh = sphere(1.0, 5).unwrap();
    let (l, m) = laplacian_and_mass(&mesh, &LaplacianOptions::default(), Par::Seq).unwrap();
    let mut d = m.clone();
    d[77] = -1e6;
    let a = l.add_diagonal(&d).unwrap();
    for par in [Par::Seq, Par::Rayon] {
        match SpdSolver::new(&a, par) {
            Err(SparseError::NotPositiveDefinite { pivot, n }) => {
                assert_eq!(n, m.len());
                assert!(pivot < n);
            }
            other => panic!("expected NotPositiveDefinite, got {other:?}"),
        }
        // The negative pivot lies in a front of 17 columns and 73 rows below (the blocked
        // kernel): its sign reaches the update of the rows above it.
        let s = SpdSolver::new_indefinite(&a, par).unwrap();
        assert_eq!(s.negative_pivots(), 1);
        let (_, worst, max) = against_faer(&s, &a);
        assert!(worst <= 1e-13 * max, "{worst:e} of {max:e}");
        let b: Vec<f64> = (0..m.len()).map(|i| (i % 7) as f64 - 3.0).collect();
        let mut x = b.clone();
        s.solve_in_place(&mut x).unwrap();
        assert!(max_residual(&a, &x, &b) < 1e-9 * 1e6);
    }
    // A pivot that overflows to infinity stops both (NaN cannot reach a CsrMatrix).
    let mut d = m.clone();
    d[5000] = f64::MAX;
    let mut a = l.add_diagonal(&d).unwrap();
    let (rp, ci) = (a.row_ptr().to_vec(), a.col_idx().to_vec());
    let at = (rp[5000]..rp[5001]).find(|&e| ci[e] != 5000).unwrap();
    let j = ci[at];
    let back = (rp[j]..rp[j + 1]).find(|&e| ci[e] == 5000).unwrap();
    a.values_mut()[at] = f64::MAX;
    a.values_mut()[back] = f64::MAX;
    for par in [Par::Seq, Par::Rayon] {
        assert!(matches!(
            SpdSolver::new(&a, par),
            Err(SparseError::NotPositiveDefinite { .. })
        ));
        match SpdSolver::new_indefinite(&a, par) {
            Err(SparseError::Factorization(msg)) => assert!(msg.contains("pivot"), "{msg}"),
            other => panic!("expected a pivot error, got {other:?}"),
        }
    }
}

#[test]
fn negative_pivots_in_small_fronts_update_with_their_sign() {
    // A chain (tridiagonal) matrix: every front is a few columns wide with a row or two
    // below, so the negative pivots (every 7th diagonal entry is −2.5) go through the
    // unblocked kernel.
    let n = 600;
    let mut trip = Vec::new();
    for i in 0..n {
        trip.push((i, i, if i % 7 == 3 { -2.5 } else { 2.5 }));
        if i + 1 < n {
            trip.push((i, i + 1, 1.0));
            trip.push((i + 1, i, 1.0));
        }
    }
    let a = CsrMatrix::from_triplets(n, n, &trip).unwrap();
    let s = SpdSolver::new_indefinite(&a, Par::Seq).unwrap();
    assert!(s.scatter.is_some(), "the multifrontal path ran");
    let (faer_solver, worst, max) = against_faer(&s, &a);
    assert!(s.negative_pivots() > 0);
    assert_eq!(s.negative, faer_solver.negative);
    assert!(worst <= 1e-13 * max, "{worst:e} of {max:e}");
    let b: Vec<f64> = (0..n).map(|i| (i % 5) as f64 - 2.0).collect();
    let mut x = b.clone();
    s.solve_in_place(&mut x).unwrap();
    assert!(max_residual(&a, &x, &b) < 1e-12);
}

/// Same bits from a solve's plain and AVX2 copies (`with_avx2_copy`).
fn same_bits(x: &[f64], y: &[f64]) -> bool {
    x.len() == y.len() && x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits())
}

#[cfg(target_arch = "x86_64")]
#[test]
fn avx2_copies_give_the_bits_of_the_plain_code() {
    if !avx2() {
        eprintln!("this processor has no AVX2: only the plain code runs here");
        return;
    }
    let mesh = sphere(1.0, 5).unwrap();
    let (l, m) = laplacian_and_mass(&mesh, &LaplacianOptions::default(), Par::Seq).unwrap();
    let n = m.len();
    // Below the spectrum (L Lᵀ) and inside it (L S Lᵀ, nine negative pivots).
    for sigma in [-1.0, 9.0] {
        let a = l
            .add_diagonal(&m.iter().map(|x| -sigma * x).collect::<Vec<_>>())
            .unwrap();
        let s = if sigma < 0.0 {
            SpdSolver::new(&a, Par::Seq).unwrap()
        } else {
            SpdSolver::new_indefinite(&a, Par::Seq).unwrap()
        };
        let SymbolicCholeskyRaw::Supernodal(sym) = s.symbolic.raw() else {
            panic!("expected a supernodal factor");
        };
        let scatter = s.scatter.as_deref().unwrap();
        let factor = |simd: bool| {
            multifrontal::factorize(
                sym,
                &s.schedule,
                scatter,
                &a.values,
                s.indefinite,
                Par::Seq,
                simd,
            )
            .unwrap()
        };
        let (plain, simd) = (factor(false), factor(true));
        assert!(same_bits(&plain.0, &simd.0), "σ = {sigma}: factor");
        assert_eq!(plain.1, simd.1, "σ = {sigma}: negative pivots");
        assert_eq!(plain.1.len(), if sigma < 0.0 { 0 } else { 9 });
        // The solves at every width, on one thread and over the subtrees.
        assert!(s.schedule.subtrees.len() >= 2);
        let rhs: Vec<f64> = (0..8 * n)
            .map(|i| ((i * 7919) % 1009) as f64 / 1009.0 - 0.5)
            .collect();
        for par in [Par::Seq, Par::Rayon] {
            for cols in [1usize, 2, 3, 4, 8] {
                let mut x = rhs[..cols * n].to_vec();
                let mut y = x.clone();
                match cols {
                    1 => {
                        s.solve_block_w_base::<1>(&mut x, cols, par);
                        unsafe { s.solve_block_w_avx2::<1>(&mut y, cols, par) };
                    }
                    2 => {
                        s.solve_block_w_base::<2>(&mut x, cols, par);
                        unsafe { s.solve_block_w_avx2::<2>(&mut y, cols, par) };
                    }
                    3 | 4 => {
                        s.solve_block_w_base::<4>(&mut x, cols, par);
                        unsafe { s.solve_block_w_avx2::<4>(&mut y, cols, par) };
                    }
                    _ => {
                        s.solve_block_w_base::<8>(&mut x, cols, par);
                        unsafe { s.solve_block_w_avx2::<8>(&mut y, cols, par) };
                    }
                }
                assert!(same_bits(&x, &y), "σ = {sigma}, {cols} columns, {par:?}");
                // And they solve the system.
                let worst = max_residual(&a, &x[..n], &rhs[..n]);
                assert!(worst < 1e-10, "σ = {sigma}: residual {worst}");
            }
        }
    }
}
