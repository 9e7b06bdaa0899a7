//! Unit tests of `curve_matching_eval.rs`.

use super::*;
use crate::descriptor::DescriptorKind;

fn matching(d: Vec<f64>, n: usize, m: usize) -> CurveMatching {
    let nearest = (0..n)
        .map(|i| {
            let row = &d[i * m..(i + 1) * m];
            let j = (0..m).min_by(|&a, &b| row[a].total_cmp(&row[b]));
            j.map(|j| j as u32)
        })
        .collect();
    let hungarian = crate::match_curves::assignment(&d, n, m);
    CurveMatching {
        kind: DescriptorKind::Gics,
        n_source: n,
        n_target: m,
        distances: d,
        nearest,
        hungarian,
    }
}

#[test]
fn accuracy_and_roc_of_a_known_matrix() {
    // Rows 0 and 1 both prefer column 0 (nearest: one of two right); the assignment
    // (0->0, 1->1) costs 0.1 + 0.5 < 0.9 + 0.2, so Hungarian gets both right.
    let d = vec![0.1, 0.9, 0.2, 0.5];
    let m = matching(d, 2, 2);
    let e = curve_matching_eval(&m, &[]).unwrap();
    assert_eq!(e.accuracy_nearest, 0.5);
    assert_eq!(e.accuracy_hungarian, 1.0);
    // Sorted: 0.1 (+), 0.2 (-), 0.5 (+), 0.9 (-).
    assert_eq!(
        e.roc,
        vec![(0.0, 0.0), (0.0, 0.5), (0.5, 0.5), (0.5, 1.0), (1.0, 1.0)]
    );
    assert!((e.auc - 0.75).abs() < 1e-15);
}

#[test]
fn pairs_out_of_range_are_named() {
    let m = matching(vec![0.0; 4], 2, 2);
    let err = curve_matching_eval(&m, &[[0, 0], [1, 5]]).unwrap_err();
    assert!(matches!(
        err,
        EvalError::PairOutOfRange {
            index: 1,
            s: 1,
            t: 5,
            n_source: 2,
            n_target: 2
        }
    ));
}

#[test]
fn roc_png_is_written() {
    let dir = std::env::temp_dir().join(format!("crestflow-roc-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("roc.png");
    write_roc_png(&[(0.0, 0.0), (0.01, 0.8), (1.0, 1.0)], &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    std::fs::remove_dir_all(&dir).unwrap();
}
