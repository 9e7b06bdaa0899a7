//! Unit tests of `orient.rs`.

use super::*;
use crestflow_geom::shapes::{analytic_curvature_field, AnalyticShape};

#[test]
fn random_flips_are_undone_on_the_torus() {
    // The torus' principal directions are a smooth, orientable field: after random flips,
    // orientation must leave no obtuse edge, and every flip must be matched in e_max.
    let shape = AnalyticShape::Torus {
        major: 2.0,
        minor: 0.7,
    };
    let mesh = shape.mesh(3000, 0.3, 5).unwrap();
    let mut field = analytic_curvature_field(&mesh, &shape);
    // A distinct e_max per vertex, so that a flip missed in e_max shows.
    for v in 0..field.len() {
        field.e_max[v] = 1.0 + v as f64;
    }
    let reference = field.clone();
    let mut state = 12345u64;
    for v in 0..field.len() {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        if state >> 63 == 1 {
            field.t_max[v] = vec3::scale(field.t_max[v], -1.0);
            field.e_max[v] = -field.e_max[v];
            field.t_min[v] = vec3::scale(field.t_min[v], -1.0);
            field.e_min[v] = -field.e_min[v];
        }
    }
    let seams = orient_directions(&mesh, &mut field);
    assert_eq!(seams, 0);
    // Either all vertices agree with the reference or all are reversed.
    let s = vec3::dot(field.t_max[0], reference.t_max[0]).signum();
    for v in 0..field.len() {
        assert!(vec3::dot(field.t_max[v], reference.t_max[v]) * s > 0.99);
        assert_eq!(field.e_max[v], s * reference.e_max[v]);
        assert!(vec3::dot(vec3::cross(field.t_max[v], field.t_min[v]), field.normal[v]) > 0.99);
    }
}
