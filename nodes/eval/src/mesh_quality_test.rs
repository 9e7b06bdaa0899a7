//! Unit tests of `mesh_quality.rs`.

use super::*;
use crestflow_geom::shapes;

/// An n × n grid of the unit square, every square split along the same diagonal: all
/// triangles are right isosceles (45°, 45°, 90°), interior valence exactly 6.
fn grid(n: usize) -> TriMesh {
    let mut p = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            p.push([i as f64, j as f64, 0.0]);
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut t = Vec::new();
    for j in 0..n {
        for i in 0..n {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    TriMesh::new(p, t)
}

#[test]
fn grid_figures_are_exact() {
    let m = grid(4);
    let r = mesh_quality(&m, None, &MeshQualityParams::default(), Par::Seq).unwrap();
    assert!((r.num("min_angle_deg").unwrap() - 45.0).abs() < 1e-9);
    assert!((r.num("max_angle_deg").unwrap() - 90.0).abs() < 1e-9);
    assert_eq!(r.num("frac_angles_lt_30"), Some(0.0));
    assert_eq!(r.num("valence6_share"), Some(1.0));
    assert_eq!(r.num("interior_vertices"), Some(9.0));
    assert_eq!(r.num("boundary_edges"), Some(16.0));
    assert_eq!(r.num("euler_characteristic"), Some(1.0));
    // 40 unit edges and 16 diagonals of √2.
    let mean = (40.0 + 16.0 * 2f64.sqrt()) / 56.0;
    assert!((r.num("edge_mean").unwrap() - mean).abs() < 1e-12);
    let abs = MeshQualityParams {
        target: 1.0,
        relative: false,
        ..Default::default()
    };
    let r = mesh_quality(&m, None, &abs, Par::Seq).unwrap();
    // √2 > 4/3: only the 40 unit edges are in range.
    assert!((r.num("frac_edges_in_range").unwrap() - 40.0 / 56.0).abs() < 1e-12);
    assert!((r.num("edge_mean_over_target").unwrap() - mean).abs() < 1e-12);
}

#[test]
fn hausdorff_to_a_reference_and_thread_independence() {
    let fine = shapes::sphere(1.0, 4).unwrap();
    let coarse = shapes::sphere(1.0, 2).unwrap();
    let p = MeshQualityParams {
        samples: 2000,
        ..Default::default()
    };
    let a = mesh_quality(&coarse, Some(&fine), &p, Par::Seq).unwrap();
    let b = mesh_quality(&coarse, Some(&fine), &p, Par::Rayon).unwrap();
    assert_eq!(a, b);
    // The coarse icosphere's faces sag below the unit sphere: the largest gap is at
    // least the sag of its faces' centres, and at most the circumradius sag of its edges.
    let diag = fine.bbox_diagonal();
    let h = a.num("hausdorff_rel").unwrap() * diag;
    let sag_centre = coarse
        .triangles
        .iter()
        .enumerate()
        .map(|(f, _)| {
            let [x, y, z] = coarse.face_points(f);
            1.0 - vec3::norm(vec3::scale(vec3::add(vec3::add(x, y), z), 1.0 / 3.0))
        })
        .fold(0.0, f64::max);
    assert!(
        h > 0.8 * sag_centre && h < 1.5 * sag_centre,
        "{h} vs {sag_centre}"
    );
    // The farthest point of the coarse mesh lies that far inside the unit sphere (the fine
    // mesh's own sag, under 0.002 at this level, aside).
    let far = ["x", "y", "z"].map(|k| a.num(&format!("farthest_mesh_{k}")).unwrap());
    assert!((1.0 - h - vec3::norm(far)).abs() < 0.002, "{far:?} at {h}");
    // The refined figure comes with a certified bound within the default tolerance.
    let upper = a.num("hausdorff_upper_rel").unwrap() * diag;
    assert!(
        upper >= h && upper - h <= 1e-4 * diag + 1e-15,
        "{h} .. {upper}"
    );
    let icosa_valences = a.num("valence6_share").unwrap();
    // Level-2 icosphere: 162 vertices, the 12 icosahedron corners have valence 5.
    assert!((icosa_valences - 150.0 / 162.0).abs() < 1e-12);
}

#[test]
fn bad_input() {
    let empty = TriMesh::new(vec![[0.0; 3]], vec![]);
    let e = mesh_quality(&empty, None, &MeshQualityParams::default(), Par::Seq).unwrap_err();
    assert!(e.to_string().contains("no faces"), "{e}");
    let p = MeshQualityParams {
        target: -1.0,
        ..Default::default()
    };
    let m = grid(2);
    assert!(matches!(
        mesh_quality(&m, None, &p, Par::Seq).unwrap_err(),
        MeshQualityError::Params(_)
    ));
}
