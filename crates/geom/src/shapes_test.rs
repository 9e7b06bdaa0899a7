//! Unit tests of `shapes.rs`.

use super::*;

fn signed_volume(m: &TriMesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| m.positions[i as usize]);
            vec3::dot(a, vec3::cross(b, c)) / 6.0
        })
        .sum()
}

fn closed_manifold(m: &TriMesh) -> bool {
    let t = m.topology();
    t.boundary_edge_count() == 0 && t.nonmanifold_edges.is_empty()
}

#[test]
fn icosphere_counts_orientation_and_radius() {
    for level in 0..4 {
        let m = sphere(2.0, level).unwrap();
        assert_eq!(m.n_vertices(), icosphere_vertex_count(level));
        assert_eq!(m.n_faces(), 20 * 4usize.pow(level));
        assert!(closed_manifold(&m));
        assert!(m
            .positions
            .iter()
            .all(|p| (vec3::norm(*p) - 2.0).abs() < 1e-12));
        // Outward orientation: positive volume, approaching 4/3 π r³ from below.
        let vol = signed_volume(&m);
        assert!(vol > 0.0 && vol < 4.0 / 3.0 * PI * 8.0);
    }
    let fine = signed_volume(&sphere(2.0, 5).unwrap());
    assert!((fine / (4.0 / 3.0 * PI * 8.0) - 1.0).abs() < 2e-3);
    assert_eq!(icosphere_level_for(40_000).unwrap(), 6);
    assert_eq!(icosphere_level_for(12).unwrap(), 0);
}

#[test]
fn sphere_curvature_is_inverse_radius() {
    let shape = AnalyticShape::Sphere { radius: 0.5 };
    let m = shape.mesh(700, 0.3, 1).unwrap();
    let f = analytic_curvature_field(&m, &shape);
    for v in 0..m.n_vertices() {
        assert_eq!(f.k_max[v], 2.0);
        assert_eq!(f.k_min[v], 2.0);
        assert!(f.e_max[v].abs() < 1e-9 && f.e_min[v].abs() < 1e-9);
        let radial = vec3::normalize(m.positions[v]);
        assert!(vec3::dist(f.normal[v], radial) < 1e-12);
        assert!(vec3::dot(f.t_max[v], f.normal[v]).abs() < 1e-12);
        assert!(vec3::dot(f.t_min[v], f.t_max[v]).abs() < 1e-12);
    }
    assert!(shape.is_umbilic([1.0, 2.0, 3.0], 1e-9));
}

#[test]
fn torus_textbook_curvature_on_irregular_samples() {
    let (r_big, r) = (3.0, 1.0);
    let shape = AnalyticShape::Torus {
        major: r_big,
        minor: r,
    };
    let m = shape.mesh(2000, 0.4, 7).unwrap();
    assert!(closed_manifold(&m));
    assert!(signed_volume(&m) > 0.0);
    // Volume of the torus 2π²Rr², approached from below by the inscribed mesh.
    let exact = 2.0 * PI * PI * r_big * r * r;
    assert!((signed_volume(&m) / exact - 1.0).abs() < 0.03);
    let f = analytic_curvature_field(&m, &shape);
    for (v, p) in m.positions.iter().enumerate() {
        let rho = p[0].hypot(p[1]);
        // cos v = (ρ − R)/r with ρ the distance to the axis.
        let cos_v = (rho - r_big) / r;
        let k_par = cos_v / (r_big + r * cos_v);
        assert!((f.k_max[v] - 1.0 / r).abs() < 1e-12);
        assert!((f.k_min[v] - k_par).abs() < 1e-12, "vertex {v}");
        // Gaussian curvature of the torus: cos v / (r (R + r cos v)).
        assert!((f.gaussian(v) - cos_v / (r * (r_big + r * cos_v))).abs() < 1e-12);
        // Constant along the lines of curvature: zero extremality.
        assert!(f.e_max[v].abs() < 1e-7 && f.e_min[v].abs() < 1e-7);
        // t_min runs along the parallel (horizontal), t_max along the meridian.
        assert!(f.t_min[v][2].abs() < 1e-12);
        assert!(vec3::dot(f.t_max[v], [-p[1], p[0], 0.0]).abs() < 1e-9);
    }
    // Jitter actually moves samples off the regular grid.
    let regular = shape.mesh(2000, 0.0, 7).unwrap();
    assert_eq!(regular.n_vertices(), m.n_vertices());
    assert!(m.positions != regular.positions);
    // Same seed, same mesh; another seed, another mesh.
    assert_eq!(shape.mesh(2000, 0.4, 7).unwrap(), m);
    assert!(shape.mesh(2000, 0.4, 8).unwrap() != m);
}

#[test]
fn cylinder_open_with_known_curvature() {
    let shape = AnalyticShape::Cylinder {
        radius: 2.0,
        height: 3.0,
    };
    let m = shape.mesh(1500, 0.3, 3).unwrap();
    let topo = m.topology();
    assert!(topo.nonmanifold_edges.is_empty());
    let rim = topo.is_boundary_vertex.iter().filter(|&&b| b).count();
    let n_around = m.positions.iter().filter(|p| p[2] == -1.5).count();
    assert_eq!(rim, 2 * n_around);
    let f = analytic_curvature_field(&m, &shape);
    for (v, p) in m.positions.iter().enumerate() {
        assert!((p[0].hypot(p[1]) - 2.0).abs() < 1e-12);
        assert_eq!((f.k_max[v], f.k_min[v]), (0.5, 0.0));
        assert!(vec3::dot(f.normal[v], [p[0], p[1], 0.0]) > 0.0);
        assert!((f.t_min[v][2].abs() - 1.0).abs() < 1e-12);
    }
    // Outward triangles: each face normal points away from the axis.
    for t in 0..m.n_faces() {
        let c = m
            .face_points(t)
            .iter()
            .fold([0.0; 3], |a, p| vec3::add(a, *p));
        assert!(vec3::dot(m.face_normal_raw(t), [c[0], c[1], 0.0]) > 0.0);
    }
}

#[test]
fn ellipsoid_curvature_formulas() {
    let (a, b, c) = (3.0, 2.0, 1.0);
    let shape = AnalyticShape::Ellipsoid { a, b, c };
    let m = shape.mesh(2600, 0.3, 11).unwrap();
    assert!(closed_manifold(&m));
    assert!(signed_volume(&m) > 0.0);
    let f = analytic_curvature_field(&m, &shape);
    for (v, p) in m.positions.iter().enumerate() {
        let on = (p[0] / a).powi(2) + (p[1] / b).powi(2) + (p[2] / c).powi(2);
        assert!((on - 1.0).abs() < 1e-12);
        // K = 1 / (a²b²c² (x²/a⁴ + y²/b⁴ + z²/c⁴)²).
        let s = (p[0] / (a * a)).powi(2) + (p[1] / (b * b)).powi(2) + (p[2] / (c * c)).powi(2);
        let gauss = 1.0 / ((a * b * c).powi(2) * s * s);
        assert!((f.gaussian(v) / gauss - 1.0).abs() < 1e-9, "vertex {v}");
        // H = (a² + b² + c² − |p|²) / (2 a²b²c² s^{3/2}).
        let mean =
            (a * a + b * b + c * c - vec3::dot(*p, *p)) / (2.0 * (a * b * c).powi(2) * s.powf(1.5));
        assert!((f.mean(v) / mean - 1.0).abs() < 1e-9, "vertex {v}");
        assert!(f.k_max[v] >= f.k_min[v]);
    }
    // Vertices: k at the end of the longest axis are a/b² and a/c².
    let tip = shape.principal([3.0, 0.0, 0.0]);
    assert!((tip.k_max - a / (c * c)).abs() < 1e-12);
    assert!((tip.k_min - a / (b * b)).abs() < 1e-12);
    assert!((tip.t_max[2].abs() - 1.0).abs() < 1e-12);
    // Umbilics of a > b > c lie in the y = 0 plane at
    // x² = a²(a² − b²)/(a² − c²), z² = c²(b² − c²)/(a² − c²).
    let ux = (a * a * (a * a - b * b) / (a * a - c * c)).sqrt();
    let uz = (c * c * (b * b - c * c) / (a * a - c * c)).sqrt();
    for (sx, sz) in [(1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)] {
        assert!(shape.is_umbilic([sx * ux, 0.0, sz * uz], 1e-9));
    }
    assert!(!shape.is_umbilic([0.0, 0.0, 1.0], 1e-3));
    assert!(!shape.is_umbilic([ux, 0.0, -uz * 0.9], 1e-3));
}

#[test]
fn ellipsoid_extremality_matches_derivative_along_direction() {
    // On the principal ellipse in the z = 0 plane, k_max runs along z and is extremal by
    // symmetry: e_max = 0 there, and e_max changes sign across it.
    let shape = AnalyticShape::Ellipsoid {
        a: 3.0,
        b: 2.0,
        c: 1.0,
    };
    let on = shape.project([1.0, 1.5, 0.0]);
    let (e_on, _) = shape.extremality(on);
    assert!(e_on.abs() < 1e-8);
    let above = shape.project([1.0, 1.5, 0.1]);
    let below = shape.project([1.0, 1.5, -0.1]);
    let t_above = shape.principal(above).t_max;
    let t_below = shape.principal(below).t_max;
    let (mut ea, mut eb) = (shape.extremality(above).0, shape.extremality(below).0);
    // Express both along the same (upward) orientation before comparing signs.
    if t_above[2] < 0.0 {
        ea = -ea;
    }
    if t_below[2] < 0.0 {
        eb = -eb;
    }
    assert!(
        ea * eb < 0.0,
        "e_max should change sign across the ridge: {ea} {eb}"
    );
    // A wider finite difference of k_max agrees with the reported value.
    let pr = shape.principal(above);
    let h = 1e-3;
    let kp = shape
        .principal(vec3::add(above, vec3::scale(pr.t_max, h)))
        .k_max;
    let km = shape
        .principal(vec3::sub(above, vec3::scale(pr.t_max, h)))
        .k_max;
    let coarse = (kp - km) / (2.0 * h);
    assert!((coarse - shape.extremality(above).0).abs() < 1e-3 * coarse.abs().max(1.0));
}

#[test]
fn projection_lands_on_surface() {
    let shape = AnalyticShape::Ellipsoid {
        a: 2.0,
        b: 1.0,
        c: 0.5,
    };
    for p in [
        [3.0, 1.0, -1.0],
        [0.1, 0.2, 0.05],
        [0.0, 0.0, 2.0],
        [1.0, 0.0, 0.0],
    ] {
        let q = shape.project(p);
        let g = (q[0] / 2.0).powi(2) + q[1].powi(2) + (q[2] / 0.5).powi(2);
        assert!((g - 1.0).abs() < 1e-12);
        // Closest point: p − q is parallel to the normal.
        let n = shape.principal(q).normal;
        let d = vec3::sub(p, q);
        assert!(vec3::norm(vec3::cross(d, n)) < 1e-9 * (1.0 + vec3::norm(d)));
    }
}

#[test]
fn bad_parameters_are_rejected() {
    assert!(matches!(
        AnalyticShape::Torus {
            major: 1.0,
            minor: 2.0
        }
        .check(),
        Err(ShapeError::InvalidParameter { name: "major", .. })
    ));
    assert!(matches!(
        AnalyticShape::Sphere { radius: f64::NAN }.check(),
        Err(ShapeError::InvalidParameter { name: "radius", .. })
    ));
    assert!(matches!(
        AnalyticShape::Sphere { radius: 1.0 }.mesh(5, 0.0, 0),
        Err(ShapeError::VertexCount { requested: 5, .. })
    ));
    assert!(matches!(
        torus(2.0, 1.0, 10, 10, 0.6, 0),
        Err(ShapeError::InvalidParameter { name: "jitter", .. })
    ));
    assert!(matches!(
        sphere(1.0, 40),
        Err(ShapeError::VertexCount { .. })
    ));
}
