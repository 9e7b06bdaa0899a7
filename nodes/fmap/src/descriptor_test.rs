//! Unit tests of `descriptor.rs`.

use super::*;
use crate::curve_constrained::tests::basis_of;
use crestflow_geom::shapes::ellipsoid;

#[test]
fn same_shape_gives_the_identity_for_hks_and_wks() {
    // Identical descriptors and spectra: C = I has zero energy; distinct eigenvalues (a
    // jittered ellipsoid) make the minimiser unique.
    let mesh = ellipsoid(1.3, 1.0, 0.6, 3, 0.2, 4).unwrap();
    let eb = basis_of(&mesh, 20);
    let lm = crate::landmarks::parse_landmarks("0 0\n100 100\n400 400\n", "lm").unwrap();
    for (kind, landmarks) in [
        (DescriptorKind::Hks, None),
        (DescriptorKind::Wks, Some(&lm)),
    ] {
        let p = DescriptorMapParams {
            k: 20,
            descriptor: kind,
            count: 40,
            ..Default::default()
        };
        let m = descriptor_map(&eb, &eb, landmarks, &p, Par::Rayon).unwrap();
        let mut err: f64 = 0.0;
        for j in 0..20 {
            for i in 0..20 {
                let want = if i == j { 1.0 } else { 0.0 };
                err = err.max((m.get(i, j) - want).abs());
            }
        }
        assert!(err < 1e-6, "{kind:?}: max |C − I| = {err}");
        assert!(m.energy.abs() < 1e-10, "{kind:?}: energy {}", m.energy);
    }
}

#[test]
fn hks_times_span_the_spectrum() {
    let t = hks_times(&[0.0, 2.0, 5.0, 40.0], 3);
    let c = 4.0 * 10f64.ln();
    assert!((t[0] - c / 40.0).abs() < 1e-12);
    assert!((t[2] - c / 2.0).abs() < 1e-12);
    assert!((t[1] - (c / 40.0 * c / 2.0).sqrt()).abs() < 1e-12);
}

#[test]
fn out_of_range_landmark_and_small_basis_are_errors() {
    let mesh = ellipsoid(1.3, 1.0, 0.6, 2, 0.2, 4).unwrap();
    let eb = basis_of(&mesh, 10);
    let lm = crate::landmarks::parse_landmarks("0 0\n1 5000\n", "lm.txt").unwrap();
    let p = DescriptorMapParams {
        k: 10,
        ..Default::default()
    };
    let e = descriptor_map(&eb, &eb, Some(&lm), &p, Par::Seq).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "lm.txt:2: target vertex 5000 is out of range: the target mesh has {} vertices",
            mesh.n_vertices()
        )
    );
    let big = DescriptorMapParams {
        k: 11,
        ..Default::default()
    };
    let e = descriptor_map(&eb, &eb, None, &big, Par::Seq).unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::BasisTooSmall {
                have: 10,
                asked: 11,
                ..
            }
        ),
        "{e}"
    );
}
