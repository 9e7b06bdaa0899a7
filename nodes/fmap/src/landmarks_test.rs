//! Unit tests of `landmarks.rs`.

use super::*;

#[test]
fn parses_pairs_comments_and_lines() {
    let lm = parse_landmarks("# header\n3 4\n\n 10,20 \n7\t8\n", "lm.txt").unwrap();
    assert_eq!(lm.pairs, vec![[3, 4], [10, 20], [7, 8]]);
    assert_eq!(lm.lines, vec![2, 4, 5]);
}

#[test]
fn bad_field_count_names_the_line() {
    let err = parse_landmarks("1 2\n3 4 5\n", "lm.txt").unwrap_err();
    match &err {
        FmapError::Parse { line, .. } => assert_eq!(*line, 2),
        e => panic!("unexpected {e}"),
    }
    assert!(err.to_string().starts_with("lm.txt:2:"), "{err}");
}

#[test]
fn negative_or_text_index_is_an_error() {
    let err = parse_landmarks("1 2\n-1 4\n", "a").unwrap_err();
    assert!(matches!(err, FmapError::Parse { line: 2, .. }), "{err}");
    let err = parse_landmarks("x 4\n", "a").unwrap_err();
    assert!(
        err.to_string().contains("`x` is not a vertex index"),
        "{err}"
    );
}

#[test]
fn empty_file_is_an_error() {
    let err = parse_landmarks("# nothing\n\n", "empty.txt").unwrap_err();
    assert!(matches!(err, FmapError::NoLandmarks { .. }), "{err}");
}

#[test]
fn missing_file_is_an_error() {
    let err = read_landmarks(Path::new("does/not/exist.txt")).unwrap_err();
    assert!(matches!(err, FmapError::Io { .. }), "{err}");
}

#[test]
fn reads_the_cat_lion_file() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(
        "../../../shared/data/meshes/correspondence/sumner_cat_lion/pyfm_landmarks_cat_lion.txt",
    );
    let lm = read_landmarks(&p).unwrap();
    assert_eq!(lm.pairs.len(), 20);
    assert_eq!(lm.pairs[0], [3177, 1685]);
}
