use super::*;
use crestflow_geom::shapes;
use std::f64::consts::PI;

#[test]
fn deficits_add_up_to_two_pi_times_the_euler_characteristic() {
    // Gauss–Bonnet: 4π on a sphere (χ = 2), 0 on a torus (χ = 0), for any triangulation.
    let sphere = shapes::sphere(1.0, 3).unwrap();
    let total: f64 = angle_deficits(&sphere, Par::Seq).iter().sum();
    assert!((total - 4.0 * PI).abs() < 1e-9, "sphere {total}");
    let torus = shapes::torus(1.0, 0.3, 40, 16, 0.0, 1).unwrap();
    let total: f64 = angle_deficits(&torus, Par::Rayon).iter().sum();
    assert!(total.abs() < 1e-9, "torus {total}");
    // Boundary vertices carry none: a flat grid has nothing anywhere.
    let flat = TriMesh::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 0.0],
        ],
        vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
    );
    for d in angle_deficits(&flat, Par::Seq) {
        assert!(d.abs() < 1e-12, "{d}");
    }
}

/// The cigar x² + (y² + z²) / 0.12² = 1: its ends curve with radius 0.0144.
fn cigar() -> TriMesh {
    shapes::ellipsoid(1.0, 0.12, 0.12, 5, 0.0, 1).unwrap()
}

#[test]
fn the_ends_of_a_cigar_are_its_tips() {
    let m = cigar();
    for par in [Par::Seq, Par::Rayon] {
        let tips = tip_vertices(&m, 0.1, &[], par);
        assert_eq!(tips.len(), 2, "{tips:?}");
        let mut ends: Vec<V3> = tips.iter().map(|&t| m.positions[t as usize]).collect();
        ends.sort_by(|a, b| a[0].total_cmp(&b[0]));
        // The mesh vertices nearest the apexes (±1, 0, 0) lie 0.0095 from them.
        for (p, x) in ends.iter().zip([-1.0, 1.0]) {
            let d = vec3::dist(*p, [x, 0.0, 0.0]);
            assert!(d < 0.012, "tip {p:?} is {d} from the apex at x = {x}");
        }
    }
    // Coarser than the cigar is thick, the whole end is still one tip; at a target that
    // resolves the end (radius 0.0144 against L/2 = 0.005) it is not.
    assert_eq!(tip_vertices(&m, 0.3, &[], Par::Seq).len(), 2);
    assert!(tip_vertices(&m, 0.01, &[], Par::Seq).is_empty());
}

#[test]
fn smooth_surfaces_and_cube_corners_have_none() {
    // A unit sphere at L = 0.1: a disk of radius 0.05 holds π · 0.05² ≈ 0.008.
    let sphere = shapes::sphere(1.0, 4).unwrap();
    assert!(tip_vertices(&sphere, 0.1, &[], Par::Seq).is_empty());
    let torus = shapes::torus(1.0, 0.3, 60, 24, 0.0, 1).unwrap();
    assert!(tip_vertices(&torus, 0.1, &[], Par::Seq).is_empty());
    // A cube's corner closes the surface by π/2 only.
    let cube = TriMesh::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        ],
        vec![
            [0, 2, 1],
            [0, 3, 2],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 5],
            [0, 5, 4],
            [1, 2, 6],
            [1, 6, 5],
            [2, 3, 7],
            [2, 7, 6],
            [3, 0, 4],
            [3, 4, 7],
        ],
    );
    let d = angle_deficits(&cube, Par::Seq);
    assert!(d.iter().all(|x| (x - PI / 2.0).abs() < 1e-12), "{d:?}");
    assert!(tip_vertices(&cube, 0.5, &[], Par::Seq).is_empty());
}

#[test]
fn a_spike_is_a_tip_at_its_apex_and_excluded_vertices_are_not() {
    // A closed square pyramid 1 wide and 3 high: its apex closes the surface by 2π minus
    // four angles of 18.7°, about 5.0; each base corner by 1.9 only, and the disk of radius
    // L/2 = 0.25 around it holds no other vertex. (At a target much larger than the base,
    // the whole base would be a blunt tip too.)
    let (h, w) = (3.0, 0.5);
    let m = TriMesh::new(
        vec![
            [-w, -w, 0.0],
            [w, -w, 0.0],
            [w, w, 0.0],
            [-w, w, 0.0],
            [0.0, 0.0, h],
        ],
        vec![
            [0, 2, 1],
            [0, 3, 2],
            [0, 1, 4],
            [1, 2, 4],
            [2, 3, 4],
            [3, 0, 4],
        ],
    );
    assert_eq!(tip_vertices(&m, 0.5, &[], Par::Seq), vec![4]);
    let mut excluded = vec![false; 5];
    excluded[4] = true;
    assert!(tip_vertices(&m, 0.5, &excluded, Par::Seq).is_empty());
}
