//! Unit tests of `transfer.rs` and `render_colors.rs`.

use super::*;
use crate::curve_constrained::tests::basis_of;
use crate::render_colors::{render_pair, RenderColorsParams};
use crestflow_geom::shapes::sphere;

fn identity_points(n: usize) -> PointMap {
    PointMap {
        target_to_source: (0..n as u32).collect(),
        n_source: n,
    }
}

#[test]
fn identity_point_map_copies_the_colours() {
    let mesh = sphere(1.0, 2).unwrap();
    let c = transfer(
        &mesh,
        &mesh,
        Some(&identity_points(mesh.n_vertices())),
        None,
        &TransferParams::default(),
        Par::Seq,
    )
    .unwrap();
    assert_eq!(c.source, c.target);
    // Coordinates: the vertex with the largest x is the reddest.
    let xmax = (0..mesh.n_vertices())
        .max_by(|&a, &b| mesh.positions[a][0].total_cmp(&mesh.positions[b][0]))
        .unwrap();
    assert!((c.source[xmax][0] - 1.0).abs() < 1e-12);
}

#[test]
fn identity_functional_map_reproduces_a_smooth_field() {
    // Bounding-box coordinates are linear in x, y, z: on a sphere they lie in the span of the
    // first four eigenfunctions, so C = I with k = 9 carries them almost exactly.
    let mesh = sphere(1.0, 3).unwrap();
    let eb = basis_of(&mesh, 9);
    let mut m = vec![0.0; 81];
    for i in 0..9 {
        m[i * 9 + i] = 1.0;
    }
    let fm = FunctionalMap {
        k_source: 9,
        k_target: 9,
        matrix: m,
        energy: 0.0,
        iterations: 0,
    };
    let p = TransferParams {
        via: TransferVia::Functional,
        ..Default::default()
    };
    let c = transfer(&mesh, &mesh, None, Some((&fm, &eb, &eb)), &p, Par::Rayon).unwrap();
    let err = c
        .source
        .iter()
        .zip(&c.target)
        .flat_map(|(a, b)| (0..3).map(move |i| (a[i] - b[i]).abs()))
        .fold(0.0, f64::max);
    assert!(err < 0.02, "max colour error {err}");
}

#[test]
fn bad_point_maps_and_missing_inputs_are_errors() {
    let mesh = sphere(1.0, 1).unwrap();
    let n = mesh.n_vertices();
    let short = PointMap {
        target_to_source: vec![0; n - 1],
        n_source: n,
    };
    let e = transfer(
        &mesh,
        &mesh,
        Some(&short),
        None,
        &TransferParams::default(),
        Par::Seq,
    )
    .unwrap_err();
    assert!(
        matches!(e, FmapError::PointMapSize { have, want } if have == n - 1 && want == n),
        "{e}"
    );
    let mut far = identity_points(n);
    far.target_to_source[3] = 1000;
    let e = transfer(
        &mesh,
        &mesh,
        Some(&far),
        None,
        &TransferParams::default(),
        Par::Seq,
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::PointMapOutOfRange {
                target: 3,
                source_vertex: 1000,
                ..
            }
        ),
        "{e}"
    );
    let e = transfer(
        &mesh,
        &mesh,
        None,
        None,
        &TransferParams::default(),
        Par::Seq,
    )
    .unwrap_err();
    assert!(matches!(e, FmapError::Param { field: "via", .. }), "{e}");
}

#[test]
fn side_by_side_picture_shows_both_shapes() {
    let mesh = sphere(1.0, 2).unwrap();
    let c = transfer(
        &mesh,
        &mesh,
        Some(&identity_points(mesh.n_vertices())),
        None,
        &TransferParams::default(),
        Par::Seq,
    )
    .unwrap();
    let p = RenderColorsParams {
        width: 64,
        height: 48,
        ..Default::default()
    };
    let img = render_pair(&mesh, &mesh, &c, (None, None), &p, Par::Seq).unwrap();
    assert_eq!((img.width, img.height), (128, 48));
    // The centre of each panel is covered (not the white background), and the two panels are
    // the same picture.
    assert_ne!(img.get(32, 24), [255, 255, 255]);
    assert_eq!(img.get(32, 24), img.get(96, 24));
    let mut bad = c.clone();
    bad.target.pop();
    let e = render_pair(&mesh, &mesh, &bad, (None, None), &p, Par::Seq).unwrap_err();
    assert!(e.to_string().contains("target colours"), "{e}");
}
