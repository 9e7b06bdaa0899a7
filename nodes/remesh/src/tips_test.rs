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
    let cube = unit_cube();
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

/// The unit cube as eight vertices and twelve triangles.
fn unit_cube() -> TriMesh {
    TriMesh::new(
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
    )
}

#[test]
fn box_corners_are_part_corners_one_per_target_length() {
    let cube = unit_cube();
    let all: Vec<u32> = (0..8).collect();
    assert_eq!(part_corners(&cube, 0.5, 30.0, &[], &[], &[]), all);
    // At L = 1.5 the first corner (all equal: lowest index) hides every corner within 1.5,
    // which leaves the opposite one, √3 away.
    assert_eq!(part_corners(&cube, 1.5, 30.0, &[], &[], &[]), vec![0, 6]);
    // A corner within L of a tip taken already is that tip's.
    assert_eq!(
        part_corners(&cube, 0.5, 30.0, &[], &[], &[0]),
        (1..8).collect::<Vec<u32>>()
    );
    // A feature vertex closer than 4/5 L hides a corner: at L = 1.5 (clearance 1.2) the
    // feature vertex 0 hides itself and its three neighbours, not 2, 5, 7 (√2 away) and 6;
    // of those, 2 comes first and hides the others (all within 1.5 of it).
    let mut feature = vec![false; 8];
    feature[0] = true;
    assert_eq!(
        part_corners(&cube, 1.5, 30.0, &feature, &feature, &[]),
        vec![2]
    );
    // At L = 1 (clearance 0.8) only vertex 0 itself is hidden; the rest are 1 apart or more
    // and all kept.
    assert_eq!(
        part_corners(&cube, 0.99, 30.0, &feature, &feature, &[]),
        (1..8).collect::<Vec<u32>>()
    );
    // Edges of 90° are creases only below a threshold of 90°.
    assert!(part_corners(&cube, 0.5, 95.0, &[], &[], &[]).is_empty());
}

#[test]
fn smooth_surfaces_rims_and_tips_are_not_part_corners() {
    let sphere = shapes::sphere(1.0, 3).unwrap();
    assert!(part_corners(&sphere, 0.1, 30.0, &[], &[], &[]).is_empty());
    // Closing by much more than a quarter turn, but smoothly: no creases.
    assert!(part_corners(&cigar(), 0.1, 30.0, &[], &[], &[]).is_empty());
    // The rims of a capped cylinder are creases of 90°, but each rim vertex has two of them
    // and closes the surface by a fraction of 2π/(vertices per rim) only.
    let cyl = shapes::AnalyticShape::Cylinder {
        radius: 0.5,
        height: 1.0,
    }
    .mesh(3000, 0.0, 1)
    .unwrap();
    assert!(part_corners(&cyl, 0.1, 30.0, &[], &[], &[]).is_empty());
}

#[test]
fn fandisk_corners_convex_and_concave() {
    // cgal_fandisk (bundled): the 22 vertices where three creases meet and the surface turns
    // by 0.44–0.51 π, found with trimesh's face angles and dihedral angles; 15 close the
    // surface (box corners such as 4745 at (0.46, 0.256, −0.5)), 7 open it (concave corners
    // such as 4124). All lie farther than 2 % of the diagonal apart.
    let path = format!("{}/../../data/cgal_fandisk.off", env!("CARGO_MANIFEST_DIR"));
    let m = crestflow_geom::io::load_mesh(&path, &Default::default())
        .unwrap()
        .mesh;
    let l = 0.02 * m.bbox_diagonal();
    let expected = vec![
        900, 903, 1078, 1081, 1167, 1358, 1450, 1972, 2012, 2145, 2366, 3243, 3444, 4037, 4121,
        4124, 4192, 4745, 5331, 5367, 5526, 5598,
    ];
    assert_eq!(part_corners(&m, l, 30.0, &[], &[], &[]), expected);
    let d = angle_deficits(&m, Par::Seq);
    let convex = expected.iter().filter(|&&v| d[v as usize] > 0.0).count();
    assert_eq!(convex, 15);
    assert!(d[4745] > 0.0 && d[4124] < 0.0);
}

#[test]
fn tips_within_four_fifths_of_l_of_a_fixed_vertex_give_way() {
    // The cigar's two tips at L = 0.1; a fixed vertex 0.06 from the one at x = 1 removes it
    // (0.06 < 0.08), one 0.09 away does not.
    let m = cigar();
    let tips = tip_vertices(&m, 0.1, &[], Par::Seq);
    assert_eq!(tips.len(), 2);
    let right = *tips
        .iter()
        .max_by(|&&a, &&b| m.positions[a as usize][0].total_cmp(&m.positions[b as usize][0]))
        .unwrap();
    let apex = m.positions[right as usize];
    let at = |d: f64| {
        let mut fixed = vec![false; m.n_vertices()];
        let v = (0..m.n_vertices())
            .min_by(|&a, &b| {
                let da = (vec3::dist(m.positions[a], apex) - d).abs();
                let db = (vec3::dist(m.positions[b], apex) - d).abs();
                da.total_cmp(&db)
            })
            .unwrap();
        fixed[v] = true;
        (vec3::dist(m.positions[v], apex), fixed)
    };
    let (d, fixed) = at(0.06);
    assert!(d < 0.08, "{d}");
    let left: Vec<u32> = tips.iter().copied().filter(|&t| t != right).collect();
    assert_eq!(clear_of_fixed(&m, &tips, &fixed, 0.1), left);
    let (d, fixed) = at(0.09);
    assert!(d > 0.08, "{d}");
    assert_eq!(clear_of_fixed(&m, &tips, &fixed, 0.1), tips);
}
