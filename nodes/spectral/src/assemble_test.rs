//! Unit tests of `assemble.rs`.

use super::*;
use crate::sparse::laplacian_and_mass;
use crestflow_geom::shapes::ellipsoid;

#[test]
fn equals_the_spectral_operator_bit_for_bit() {
    let base = ellipsoid(1.0, 0.7, 0.4, 3, 0.4, 2).unwrap();
    let (asm, mut l, mut m) = CotanAssembler::new(&base, MassKind::Voronoi, Par::Seq).unwrap();
    // The pattern built from the edges and the first values match too.
    let (l0, m0) = laplacian_and_mass(&base, &LaplacianOptions::default(), Par::Seq).unwrap();
    assert_eq!(l, l0);
    assert_eq!(m, m0);
    // New positions, one triangle squashed flat so that mollification kicks in.
    let mut x: Vec<V3> = base
        .positions
        .iter()
        .map(|p| {
            [
                p[0] * 1.1 + 0.05 * p[1],
                p[1] * 0.9,
                p[2] + 0.1 * p[0] * p[0],
            ]
        })
        .collect();
    let t = base.triangles[10];
    let mid = [
        0.5 * (x[t[1] as usize][0] + x[t[2] as usize][0]),
        0.5 * (x[t[1] as usize][1] + x[t[2] as usize][1]),
        0.5 * (x[t[1] as usize][2] + x[t[2] as usize][2]),
    ];
    x[t[0] as usize] = mid;
    let moved = base.with_positions(x.clone());
    for kind in [MassKind::Voronoi, MassKind::Barycentric] {
        let opts = LaplacianOptions {
            mass: kind,
            ..Default::default()
        };
        let asm = CotanAssembler {
            opts,
            slots: asm.slots.clone(),
        };
        asm.assemble(&moved.triangles, &x, &mut l, &mut m, Par::Rayon);
        let (l_ref, m_ref) = laplacian_and_mass(&moved, &opts, Par::Seq).unwrap();
        assert_eq!(l, l_ref, "{kind:?}");
        assert_eq!(m, m_ref, "{kind:?}");
    }
}
