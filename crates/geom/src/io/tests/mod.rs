//! Readers, validation, repair and writers on small files with known answers.

use std::path::{Path, PathBuf};

use super::*;
use crate::curvature::CurvatureField;
use crate::fcn::{CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint};

fn file(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn load(p: &Path) -> Result<LoadedMesh, MeshError> {
    load_mesh(p, &LoadOptions::default())
}

const TETRA_OFF: &str =
    "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
const TETRA_TRIS: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
const TETRA_POS: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];

#[test]
fn off_tetra_loads_exactly() {
    let d = tempfile::tempdir().unwrap();
    let m = load(&file(&d, "t.off", TETRA_OFF.as_bytes())).unwrap();
    assert_eq!(m.mesh.positions, TETRA_POS.to_vec());
    assert_eq!(m.mesh.triangles, TETRA_TRIS.to_vec());
    let r = &m.report;
    assert_eq!(
        (r.vertices, r.faces, r.boundary_edges, r.components),
        (4, 4, 0, 1)
    );
    assert_eq!(r.inconsistent_edges, 0);
    assert!(r.warnings().is_empty());
}

#[test]
fn off_variants_comments_colours_and_polygons() {
    // COFF with vertex colours, counts on the keyword line, comments, a quad with a colour,
    // and CRLF line ends: a unit square split into a fan of two triangles.
    let text =
        "COFF 5 2 0 # header\r\n# a comment\r\n\r\n0 0 0 255 0 0 255\r\n1 0 0 0 255 0 255\r\n\
                1 1 0 0 0 255 255\r\n0 1 0 9 9 9 255\r\n5 5 5 1 1 1 1\r\n4 0 1 2 3 0.5 0.5 0.5\r\n\
                2 0 1\r\n";
    let d = tempfile::tempdir().unwrap();
    let m = load(&file(&d, "q.OFF", text.as_bytes())).unwrap();
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    let r = &m.report;
    assert_eq!(r.polygons_triangulated, 1);
    assert_eq!(r.degenerate_faces_dropped, 1, "the two-corner face");
    assert_eq!(r.unreferenced_vertices_dropped, 1, "vertex 4");
    assert_eq!(
        (r.file_vertices, r.file_faces, r.vertices, r.faces),
        (5, 2, 4, 2)
    );
    assert_eq!(r.boundary_edges, 4);
    // NOFF: normals after the position are ignored.
    let noff = "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n";
    let m = load(&file(&d, "n.off", noff.as_bytes())).unwrap();
    assert_eq!(m.mesh.positions[2], [0.0, 1.0, 0.0]);
}

#[test]
fn obj_groups_share_vertices_and_indices_resolve() {
    // The tetrahedron split over two groups, with `v//vn` and negative (relative) indices, a
    // line element and an unused vertex. A group-wise re-indexing reader would duplicate the
    // shared vertices and open the surface.
    let text = "# tetra\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 9 9 9\nvn 0 0 1\n\
                g first\nf 1//1 3//1 2//1\nf -5/1/1 -4/1/1 -2/1/1\ng second\nusemtl x\n\
                f 1 4 3\nf 2 \\\n 3 4\nl 1 2\n";
    let d = tempfile::tempdir().unwrap();
    let m = load(&file(&d, "t.obj", text.as_bytes())).unwrap();
    assert_eq!(m.mesh.positions, TETRA_POS.to_vec());
    assert_eq!(m.mesh.triangles, TETRA_TRIS.to_vec());
    assert_eq!(m.report.boundary_edges, 0);
    assert_eq!(m.report.unreferenced_vertices_dropped, 1);
    assert_eq!(m.report.components, 1);
}

#[test]
fn ply_ascii_and_binary_index_types_and_strips() {
    let d = tempfile::tempdir().unwrap();
    // ascii, `vertex_index`, uint list count with ushort indices, extra properties.
    let ascii = "ply\nformat ascii 1.0\ncomment x\nelement vertex 4\nproperty double x\n\
                 property double y\nproperty double z\nproperty uchar red\nelement face 4\n\
                 property list uint ushort vertex_index\nproperty float quality\nend_header\n\
                 0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n3 0 2 1 0.5\n3 0 1 3 0.5\n3 0 3 2 0.5\n\
                 3 1 2 3 0.5\n";
    let m = load(&file(&d, "a.ply", ascii.as_bytes())).unwrap();
    assert_eq!(m.report.format, "ply-ascii");
    assert_eq!(m.mesh.triangles, TETRA_TRIS.to_vec());
    assert_eq!(m.mesh.positions, TETRA_POS.to_vec());

    // Big endian, short coordinates and a `char`-indexed list, plus an element to skip.
    let mut be = b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty short x\n\
                   property short y\nproperty short z\nelement face 4\n\
                   property list uchar char vertex_indices\nelement camera 1\nproperty float f\n\
                   end_header\n"
        .to_vec();
    for p in TETRA_POS {
        for c in p {
            be.extend_from_slice(&(c as i16).to_be_bytes());
        }
    }
    for t in TETRA_TRIS {
        be.push(3);
        be.extend(t.iter().map(|&i| i as u8));
    }
    be.extend_from_slice(&1.5f32.to_be_bytes());
    let m = load(&file(&d, "b.ply", &be)).unwrap();
    assert_eq!(m.report.format, "ply-binary-be");
    assert_eq!(m.mesh.triangles, TETRA_TRIS.to_vec());
    assert_eq!(m.mesh.positions, TETRA_POS.to_vec());

    // Triangle strips: a 2x3 grid strip 0 3 1 4 2 5, then after -1 a single triangle.
    let mut le = b"ply\nformat binary_little_endian 1.0\nelement vertex 7\nproperty float x\n\
                   property float y\nproperty float z\nelement tristrips 1\n\
                   property list int int vertex_indices\nend_header\n"
        .to_vec();
    let grid = [
        [0., 0., 0.],
        [1., 0., 0.],
        [2., 0., 0.],
        [0., 1., 0.],
        [1., 1., 0.],
        [2., 1., 0.],
        [0.5, -5., 0.],
    ];
    for p in grid {
        for c in p {
            le.extend_from_slice(&(c as f32).to_le_bytes());
        }
    }
    let strip: [i32; 10] = [0, 3, 1, 4, 2, 5, -1, 0, 1, 6];
    le.extend_from_slice(&(strip.len() as i32).to_le_bytes());
    for s in strip {
        le.extend_from_slice(&s.to_le_bytes());
    }
    let m = load(&file(&d, "s.ply", &le)).unwrap();
    assert_eq!(
        m.mesh.triangles,
        vec![[0, 3, 1], [1, 3, 4], [1, 4, 2], [2, 4, 5], [0, 1, 6]]
    );
    // Consistent orientation: all faces point the same way (+z or -z).
    let n: Vec<f64> = (0..5)
        .map(|f| m.mesh.face_normal_raw(f)[2].signum())
        .collect();
    assert!(n.iter().all(|&s| s == n[0]), "{n:?}");
    assert_eq!(m.report.inconsistent_edges, 0);
    assert_eq!(m.report.file_faces, 1);
}

fn stl_binary(header: &[u8], tris: &[[[f32; 3]; 3]]) -> Vec<u8> {
    let mut b = vec![b' '; 80];
    b[..header.len()].copy_from_slice(header);
    b.extend_from_slice(&(tris.len() as u32).to_le_bytes());
    for t in tris {
        b.extend_from_slice(&[0u8; 12]);
        for p in t {
            for c in p {
                b.extend_from_slice(&c.to_le_bytes());
            }
        }
        b.extend_from_slice(&[0, 0]);
    }
    b
}

#[test]
fn stl_ascii_and_binary_are_welded() {
    let p = TETRA_POS.map(|p| p.map(|c| c as f32));
    let tris: Vec<[[f32; 3]; 3]> = TETRA_TRIS
        .iter()
        .map(|t| t.map(|i| p[i as usize]))
        .collect();
    let d = tempfile::tempdir().unwrap();
    // Binary whose header starts with "solid ", as many exporters write; -0.0 welds with 0.0.
    let mut signed = tris.clone();
    signed[3][0][1] = -0.0;
    let m = load(&file(
        &d,
        "b.STL",
        &stl_binary(b"solid fooled you", &signed),
    ))
    .unwrap();
    assert_eq!(m.report.format, "stl-binary");
    assert_eq!(
        (m.report.vertices, m.report.faces, m.report.vertices_welded),
        (4, 4, 8)
    );
    // Welded vertices are numbered in order of first appearance.
    let first_seen = [0u32, 2, 1, 3];
    assert_eq!(
        m.mesh.positions,
        first_seen.map(|i| TETRA_POS[i as usize]).to_vec()
    );
    let renumber = |t: [u32; 3]| t.map(|i| first_seen.iter().position(|&j| j == i).unwrap() as u32);
    assert_eq!(m.mesh.triangles, TETRA_TRIS.map(renumber).to_vec());
    assert_eq!(m.report.boundary_edges, 0);

    let mut text = String::from("solid t\n");
    for t in &tris {
        text.push_str("facet normal 0 0 0\nouter loop\n");
        for v in t {
            text.push_str(&format!("vertex {} {} {}\n", v[0], v[1], v[2]));
        }
        text.push_str("endloop\nendfacet\n");
    }
    text.push_str("endsolid t\n");
    let m = load(&file(&d, "a.stl", text.as_bytes())).unwrap();
    assert_eq!(m.report.format, "stl-ascii");
    assert_eq!(m.mesh.triangles, TETRA_TRIS.map(renumber).to_vec());
    assert_eq!(
        m.mesh.positions,
        first_seen.map(|i| TETRA_POS[i as usize]).to_vec()
    );
}

#[test]
fn stl_welds_exporter_noise_but_not_distinct_points() {
    // Two triangles sharing the edge (1,0,0)-(0,1,0); the second's copy of (1,0,0) is off by
    // 2.7e-16 in z (CAD noise), a third triangle has a corner 1e-6 away from (0,0,0) (a real,
    // if tiny, feature: about 350 times the tolerance here).
    let tris = [
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        [[1.0, 0.0, -2.7e-16], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
        [[0.0, 0.0, 1e-6], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]],
    ];
    let d = tempfile::tempdir().unwrap();
    let m = load(&file(&d, "w.stl", &stl_binary(b"", &tris))).unwrap();
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [1, 3, 2], [4, 5, 6]]);
    assert_eq!(
        (
            m.report.vertices,
            m.report.vertices_welded,
            m.report.components
        ),
        (7, 2, 2)
    );
    assert_eq!(
        m.mesh.positions[1],
        [1.0, 0.0, 0.0],
        "the first copy is kept"
    );
    assert_eq!(m.mesh.positions[4], [0.0, 0.0, 1e-6f32 as f64]);
}

#[test]
fn empty_files_are_empty_errors() {
    let d = tempfile::tempdir().unwrap();
    for name in ["e.off", "e.obj", "e.ply", "e.stl"] {
        match load(&file(&d, name, b"  \n")) {
            Err(MeshError::Empty {
                vertices: 0,
                faces: 0,
                path,
            }) => assert!(path.ends_with(name)),
            other => panic!("{name}: {other:?}"),
        }
    }
    // Vertices but no faces.
    match load(&file(&d, "v.obj", b"v 0 0 0\nv 1 0 0\n")) {
        Err(MeshError::Empty {
            vertices: 2,
            faces: 0,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    // Faces that are all degenerate leave nothing.
    match load(&file(
        &d,
        "d.off",
        b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 1\n",
    )) {
        Err(MeshError::Empty { faces: 0, .. }) => {}
        other => panic!("{other:?}"),
    }
}

/// A finite coordinate whose fourth power overflows (1e300, or 1e100) is refused at load,
/// naming the vertex; the largest allowed magnitude loads.
#[test]
fn coordinates_too_large_for_squared_lengths_name_the_vertex() {
    let d = tempfile::tempdir().unwrap();
    let off = TETRA_OFF.replace("0 0 1\n", "0 0 -1e300\n");
    let p = file(&d, "huge.off", off.as_bytes());
    match load(&p) {
        Err(e @ MeshError::CoordinateTooLarge { vertex: 3, .. }) => {
            let text = e.to_string();
            assert!(
                text.contains("huge.off") && text.contains("-1e300"),
                "{text}"
            );
        }
        other => panic!("{other:?}"),
    }
    let off = TETRA_OFF.replace("0 0 1\n", "0 0 1e100\n");
    assert!(matches!(
        load(&file(&d, "big.off", off.as_bytes())),
        Err(MeshError::CoordinateTooLarge { vertex: 3, value, .. }) if value == 1e100
    ));
    let off = TETRA_OFF.replace("0 0 1\n", "0 0 1e60\n");
    let m = load(&file(&d, "edge.off", off.as_bytes())).unwrap().mesh;
    assert_eq!(m.positions[3], [0.0, 0.0, 1e60]);
}

#[test]
fn non_finite_coordinates_name_the_vertex() {
    let d = tempfile::tempdir().unwrap();
    let off = TETRA_OFF.replace("0 1 0\n", "0 nan 0\n");
    match load(&file(&d, "n.off", off.as_bytes())) {
        Err(MeshError::NonFinite {
            vertex: 2, value, ..
        }) => assert!(value.is_nan()),
        other => panic!("{other:?}"),
    }
    match load(&file(
        &d,
        "i.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 -inf\nf 1 2 3\n",
    )) {
        Err(MeshError::NonFinite {
            vertex: 2, value, ..
        }) => assert_eq!(value, f64::NEG_INFINITY),
        other => panic!("{other:?}"),
    }
}

#[test]
fn index_out_of_range_names_face_index_and_line() {
    let d = tempfile::tempdir().unwrap();
    let off = TETRA_OFF.replace("3 0 1 3\n", "3 0 1 7\n");
    let e = load(&file(&d, "o.off", off.as_bytes())).unwrap_err();
    match &e {
        MeshError::IndexOutOfRange {
            face: 1,
            index: 7,
            n_vertices: 4,
            line: Some(8),
            ..
        } => {}
        other => panic!("{other:?}"),
    }
    assert!(
        e.to_string()
            .contains("o.off:8: face 1 references vertex 7 but the mesh has 4 vertices"),
        "{e}"
    );
    match load(&file(
        &d,
        "o.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 5\n",
    )) {
        Err(MeshError::IndexOutOfRange {
            face: 1,
            index: 4,
            n_vertices: 3,
            line: Some(5),
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    match load(&file(&d, "r.obj", b"v 0 0 0\nv 1 0 0\nf 1 2 -3\n")) {
        Err(MeshError::IndexOutOfRange {
            face: 0,
            index: -1,
            line: Some(3),
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n\
               0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 -4\n";
    match load(&file(&d, "o.ply", ply.as_bytes())) {
        Err(MeshError::IndexOutOfRange {
            face: 1,
            index: -4,
            n_vertices: 3,
            line: Some(14),
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
}

/// Two tetrahedra glued along edge (0, 1) (four faces on that edge) and a third one touching
/// the first at vertex 3 only.
fn nonmanifold_off() -> String {
    let v = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 -1 0\n0 0 -1\n1 1 1\n2 1 1\n1 2 1\n";
    let f = "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n\
             3 0 4 1\n3 0 1 5\n3 0 5 4\n3 1 4 5\n\
             3 3 6 7\n3 3 7 8\n3 3 8 6\n3 6 8 7\n";
    format!("OFF\n9 12 0\n{v}{f}")
}

#[test]
fn nonmanifold_is_an_error_without_repair() {
    let d = tempfile::tempdir().unwrap();
    let e = load(&file(&d, "nm.off", nonmanifold_off().as_bytes())).unwrap_err();
    match &e {
        // Edge (0,1); vertices 0 and 1 (two tetrahedra each) and 3 (two tetrahedra).
        MeshError::NonManifold {
            edges: 1,
            vertices: 3,
            ..
        } => {}
        other => panic!("{other:?}"),
    }
    assert!(e.to_string().contains("repair: true"));
}

#[test]
fn nonmanifold_repair_splits_into_closed_manifold_parts() {
    let d = tempfile::tempdir().unwrap();
    let p = file(&d, "nm.off", nonmanifold_off().as_bytes());
    let m = load_mesh(
        &p,
        &LoadOptions {
            repair: true,
            ..Default::default()
        },
    )
    .unwrap();
    let r = &m.report;
    assert_eq!(
        (
            r.nonmanifold_edges,
            r.nonmanifold_vertices,
            r.vertices_split
        ),
        (1, 3, 3)
    );
    assert_eq!((r.vertices, r.faces), (12, 12));
    // Three separate closed tetrahedra.
    assert_eq!(
        (r.components, r.boundary_edges, r.inconsistent_edges),
        (3, 0, 0)
    );
    assert!(find_nonmanifold(m.mesh.n_vertices(), &m.mesh.triangles).is_manifold());
    // Copies sit where their originals do.
    assert_eq!(m.mesh.positions[9], m.mesh.positions[0]);
    assert_eq!(m.mesh.positions[10], m.mesh.positions[1]);
    assert_eq!(m.mesh.positions[11], m.mesh.positions[3]);
    assert_eq!(m.mesh.topology().nonmanifold_edges.len(), 0);
}

#[test]
fn degenerate_and_duplicate_faces() {
    let d = tempfile::tempdir().unwrap();
    let off = TETRA_OFF.replace("4 4 0", "4 7 0") + "3 1 1 2\n3 3 2 1\n4 0 1 1 3\n";
    let p = file(&d, "d.off", off.as_bytes());
    let m = load(&p).unwrap();
    assert_eq!(m.mesh.triangles, TETRA_TRIS.to_vec());
    let r = &m.report;
    // Face 4 and the fan triangle (0,1,1) of the quad are degenerate; face 5 and the other fan
    // triangle (0,1,3) repeat faces 3 and 1.
    assert_eq!(
        (r.degenerate_faces_dropped, r.duplicate_faces_dropped),
        (2, 2)
    );
    assert_eq!(r.polygons_triangulated, 1);
    match load_mesh(
        &p,
        &LoadOptions {
            reject_degenerate: true,
            ..Default::default()
        },
    ) {
        Err(MeshError::DegenerateFace {
            face: 4, vertices, ..
        }) => assert_eq!(vertices, vec![1, 1, 2]),
        other => panic!("{other:?}"),
    }
}

#[test]
fn garbage_and_wrong_extension() {
    let d = tempfile::tempdir().unwrap();
    match load(&file(&d, "m.xyz", TETRA_OFF.as_bytes())) {
        Err(MeshError::UnsupportedFormat { reason, .. }) => {
            assert!(reason.contains("`.xyz`"), "{reason}")
        }
        other => panic!("{other:?}"),
    }
    match load(&file(&d, "noext", TETRA_OFF.as_bytes())) {
        Err(MeshError::UnsupportedFormat { .. }) => {}
        other => panic!("{other:?}"),
    }
    // A text file that is no OFF, and binary bytes in a text format.
    match load(&file(&d, "g.off", b"hello world\n1 2 3\n")) {
        Err(MeshError::Parse {
            line: Some(1),
            message,
            ..
        }) => assert!(message.contains("hello"), "{message}"),
        other => panic!("{other:?}"),
    }
    match load(&file(&d, "g.obj", &[0x76, 0x20, 0xff, 0xfe, 0x00, 0x0a])) {
        Err(MeshError::Parse { line: Some(1), .. }) => {}
        other => panic!("{other:?}"),
    }
    match load(&file(
        &d,
        "g.ply",
        b"ply\nformat nonsense 1.0\nend_header\n",
    )) {
        Err(MeshError::Parse { line: Some(2), .. }) => {}
        other => panic!("{other:?}"),
    }
    match load(&file(&d, "g.stl", b"this is not an stl file")) {
        Err(MeshError::Parse { line: None, .. }) => {}
        other => panic!("{other:?}"),
    }
    // An OFF file given the .ply extension.
    match load(&file(&d, "off.ply", TETRA_OFF.as_bytes())) {
        Err(MeshError::Parse { line: Some(1), .. }) => {}
        other => panic!("{other:?}"),
    }
}

fn binary_tetra_ply() -> Vec<u8> {
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n\
                  property float y\nproperty float z\nelement face 4\n\
                  property list uchar int vertex_indices\nend_header\n"
        .to_vec();
    for p in TETRA_POS {
        for c in p {
            b.extend_from_slice(&(c as f32).to_le_bytes());
        }
    }
    for t in TETRA_TRIS {
        b.push(3);
        for i in t {
            b.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    b
}

#[test]
fn truncated_files_say_how_far_they_got() {
    let d = tempfile::tempdir().unwrap();
    let full = binary_tetra_ply();
    // Cut inside the third face.
    let cut = full.len() - 13 - 5;
    match load(&file(&d, "t.ply", &full[..cut])) {
        Err(MeshError::Truncated {
            expected: 4,
            got: 2,
            what,
            ..
        }) => assert!(what.contains("face"), "{what}"),
        other => panic!("{other:?}"),
    }
    // Cut inside the vertices.
    let header_len = full.len() - 4 * 12 - 4 * 13;
    match load(&file(&d, "v.ply", &full[..header_len + 30])) {
        Err(MeshError::Truncated {
            expected: 4,
            got: 2,
            what,
            ..
        }) => assert!(what.contains("vertex")),
        other => panic!("{other:?}"),
    }
    let off: String = TETRA_OFF
        .lines()
        .take(8)
        .map(|l| format!("{l}\n"))
        .collect();
    match load(&file(&d, "t.off", off.as_bytes())) {
        Err(MeshError::Truncated {
            expected: 4,
            got: 2,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    let p = TETRA_POS.map(|p| p.map(|c| c as f32));
    let stl = stl_binary(b"x", &[[p[0], p[1], p[2]], [p[0], p[1], p[3]]]);
    match load(&file(&d, "t.stl", &stl[..stl.len() - 7])) {
        Err(MeshError::Truncated {
            expected: 2,
            got: 1,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
}

#[test]
fn lying_headers_do_not_allocate_what_they_announce() {
    // Each announces billions of elements in a few bytes; each must fail fast and small.
    let d = tempfile::tempdir().unwrap();
    match load(&file(&d, "h.off", b"OFF\n4000000000 4000000000 0\n0 0 0\n")) {
        Err(MeshError::Truncated {
            expected: 4000000000,
            got: 1,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    let ply =
        b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n\
                property float y\nproperty float z\nelement face 1\n\
                property list uint int vertex_indices\nend_header\n\0\0\0\0";
    match load(&file(&d, "h.ply", ply)) {
        Err(MeshError::Truncated {
            expected: 4000000000,
            got: 0,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    // A face announcing 4e9 corners.
    let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n\
                    property float y\nproperty float z\nelement face 1\n\
                    property list uint int vertex_indices\nend_header\n"
        .to_vec();
    ply.extend_from_slice(&[0u8; 12]);
    ply.extend_from_slice(&u32::MAX.to_le_bytes());
    ply.extend_from_slice(&[0u8; 4]);
    match load(&file(&d, "c.ply", &ply)) {
        Err(MeshError::Truncated {
            expected: 1,
            got: 0,
            what,
            ..
        }) => assert!(what.contains("face")),
        other => panic!("{other:?}"),
    }
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&u32::MAX.to_le_bytes());
    match load(&file(&d, "h.stl", &stl)) {
        Err(MeshError::Truncated {
            expected, got: 0, ..
        }) => assert_eq!(expected, u32::MAX as usize),
        other => panic!("{other:?}"),
    }
}

/// A small deterministic generator for the hand fuzzing below.
fn lcg(state: &mut u64) -> u64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    *state >> 33
}

#[test]
fn cut_and_corrupted_files_never_panic() {
    let d = tempfile::tempdir().unwrap();
    let p = TETRA_POS.map(|p| p.map(|c| c as f32));
    let tris: Vec<[[f32; 3]; 3]> = TETRA_TRIS
        .iter()
        .map(|t| t.map(|i| p[i as usize]))
        .collect();
    let mut ascii_stl = String::from("solid t\n");
    for t in &tris {
        ascii_stl.push_str("facet normal 0 0 0\nouter loop\n");
        for v in t {
            ascii_stl.push_str(&format!("vertex {} {} {}\n", v[0], v[1], v[2]));
        }
        ascii_stl.push_str("endloop\nendfacet\n");
    }
    ascii_stl.push_str("endsolid t\n");
    let mut ascii_ply = String::from(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n",
    );
    for p in TETRA_POS {
        ascii_ply.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
    }
    for t in TETRA_TRIS {
        ascii_ply.push_str(&format!("3 {} {} {}\n", t[0], t[1], t[2]));
    }
    // (extension, bytes, how long a prefix may be and still fail for sure)
    let samples: Vec<(&str, Vec<u8>, usize)> = vec![
        ("off", TETRA_OFF.as_bytes().to_vec(), TETRA_OFF.len() - 1),
        ("ply", binary_tetra_ply(), binary_tetra_ply().len()),
        ("ply", ascii_ply.as_bytes().to_vec(), ascii_ply.len() - 1),
        ("stl", stl_binary(b"solid", &tris), 84 + 50 * 4),
        // Cut inside the closing `endsolid t`, the file is still complete.
        (
            "stl",
            ascii_stl.as_bytes().to_vec(),
            ascii_stl.find("endsolid").unwrap(),
        ),
        (
            "obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n".to_vec(),
            0,
        ),
    ];
    let mut seed = 7u64;
    let opts = LoadOptions::default();
    for (ext, bytes, must_fail_below) in &samples {
        let path = d.path().join(format!("f.{ext}"));
        let format = MeshFormat::from_path(&path).unwrap();
        // The whole file loads; every prefix shorter than `must_fail_below` fails (OBJ has no
        // counts, so its prefixes may be valid meshes; the text formats end in a newline that
        // does not matter).
        std::fs::write(&path, bytes).unwrap();
        assert_eq!(load(&path).unwrap().mesh.n_faces(), 4, "{ext}");
        for cut in 0..bytes.len() {
            let r = load_mesh_bytes(&bytes[..cut], format, &path, &opts);
            if cut < *must_fail_below {
                assert!(r.is_err(), "{ext} cut at {cut} loaded");
            }
        }
        // Random byte corruption: any result but a panic.
        for _ in 0..300 {
            let mut b = bytes.clone();
            for _ in 0..1 + lcg(&mut seed) % 4 {
                let i = (lcg(&mut seed) as usize) % b.len();
                b[i] = lcg(&mut seed) as u8;
            }
            let _ = load_mesh_bytes(&b, format, &path, &opts);
        }
    }
}

fn field_for(n: usize) -> CurvatureField {
    let k_max: Vec<f64> = (0..n).map(|v| v as f64 * 0.5 - 1.0).collect();
    let k_min: Vec<f64> = (0..n).map(|v| -(v as f64) * 0.25).collect();
    CurvatureField {
        k_max,
        k_min,
        method: "test".into(),
        ..Default::default()
    }
}

#[test]
fn mesh_ply_round_trip_keeps_positions_and_curvature() {
    let d = tempfile::tempdir().unwrap();
    let src = load(&file(&d, "t.off", TETRA_OFF.as_bytes())).unwrap().mesh;
    // f32-exact positions are written as float; others as double. Both come back equal.
    let odd = src.with_positions(src.positions.iter().map(|p| p.map(|c| c + 0.1)).collect());
    for mesh in [&src, &odd] {
        let out = d.path().join("out/sub/m.ply");
        let field = field_for(4);
        save_mesh_ply(&out, mesh, Some(&field)).unwrap();
        let back = load(&out).unwrap().mesh;
        assert_eq!(&back, mesh);
        // The properties are there with the written values.
        let bytes = std::fs::read(&out).unwrap();
        let ply = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new()
            .read_ply(&mut &bytes[..])
            .unwrap();
        let colors = curvature_colors(&field);
        for (v, e) in ply.payload["vertex"].iter().enumerate() {
            let get = |n: &str| match e[n] {
                ply_rs_bw::ply::Property::Float(x) => x as f64,
                ref p => panic!("{p:?}"),
            };
            assert_eq!(get("k_max"), field.k_max[v]);
            assert_eq!(get("k_min"), field.k_min[v]);
            // k_max = v/2 - 1, k_min = -v/4: H = v/8 - 1/2, exact in f32.
            assert_eq!(get("quality"), v as f64 / 8.0 - 0.5);
            let rgb = ["red", "green", "blue"].map(|n| match e[n] {
                ply_rs_bw::ply::Property::UChar(x) => x,
                ref p => panic!("{p:?}"),
            });
            assert_eq!(rgb, colors[v]);
        }
        // Without a field, positions and faces only.
        save_mesh_ply(&out, mesh, None).unwrap();
        assert_eq!(&load(&out).unwrap().mesh, mesh);
        assert!(!std::fs::read_to_string(d.path().join("out/sub/m.ply"))
            .is_ok_and(|s| s.contains("k_max")));
    }
    // A field of the wrong length is refused, naming both counts.
    match save_mesh_ply(d.path().join("x.ply"), &src, Some(&field_for(3))) {
        Err(MeshError::InvalidData { message, .. }) => {
            assert!(message.contains("3 values") && message.contains("4 vertices"))
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn mesh_obj_round_trip_is_exact() {
    let d = tempfile::tempdir().unwrap();
    let src = load(&file(&d, "t.off", TETRA_OFF.as_bytes())).unwrap().mesh;
    let mesh = src.with_positions(
        src.positions
            .iter()
            .map(|p| p.map(|c| (c + 0.1) / 3.0))
            .collect(),
    );
    let out = d.path().join("new/m.obj");
    save_mesh_obj(&out, &mesh, Some(&field_for(4))).unwrap();
    assert_eq!(load(&out).unwrap().mesh, mesh);
    save_mesh_obj(&out, &mesh, None).unwrap();
    assert_eq!(load(&out).unwrap().mesh, mesh);
}

#[test]
fn curvature_colors_saturate_at_the_95th_percentile() {
    // Mean curvatures 1..=100 (k_max = k_min = h): the scale is the 95th percentile, 95.
    let h: Vec<f64> = (1..=100).map(|x| x as f64).collect();
    let mut f = CurvatureField {
        k_max: h.clone(),
        k_min: h,
        ..Default::default()
    };
    f.k_max[0] = -95.0;
    f.k_min[0] = -95.0;
    f.k_max[1] = 0.0;
    f.k_min[1] = 0.0;
    let c = curvature_colors(&f);
    assert_eq!(c[0], [59, 76, 192], "H = -95: full blue");
    assert_eq!(c[1], [221, 221, 221], "H = 0: neutral");
    assert_eq!(c[94], [180, 4, 38], "H = 95: full red");
    assert_eq!(c[99], [180, 4, 38], "H = 100: clamped");
    // H = 48 (index 47): t = 48/95 = 0.50526 of the way from grey to red, by hand:
    // 221 - 41 t = 200.28, 221 - 217 t = 111.36, 221 - 183 t = 128.54.
    assert_eq!(c[47], [200, 111, 129]);
}

fn network() -> FeatureCurveNetwork {
    let v = |x: f32, s: f32| FcnVertex {
        position: [x as f64, (x * 0.5) as f64, 1.0],
        location: SurfacePoint::Free,
        strength: s as f64,
    };
    FeatureCurveNetwork {
        vertices: (0..7).map(|i| v(i as f32 * 0.3, i as f32 * 0.25)).collect(),
        curves: vec![
            FeatureCurve {
                vertices: vec![0, 1, 2, 3],
                closed: false,
                label: CurveLabel::Ridge,
            },
            FeatureCurve {
                vertices: vec![3, 4, 5],
                closed: true,
                label: CurveLabel::Ravine,
            },
            // Open, but starting and ending at the same vertex: not a loop.
            FeatureCurve {
                vertices: vec![3, 6, 5, 3],
                closed: false,
                label: CurveLabel::Other,
            },
        ],
    }
}

#[test]
fn curves_ply_round_trip() {
    let d = tempfile::tempdir().unwrap();
    let net = network();
    let out = d.path().join("c/curves.ply");
    save_curves_ply(&out, &net).unwrap();
    assert_eq!(load_curves_ply(&out).unwrap(), net);
    // Positions that are not f32-exact survive too (written as double).
    let mut fine = net.clone();
    fine.vertices[2].position[0] = 0.1;
    save_curves_ply(&out, &fine).unwrap();
    assert_eq!(load_curves_ply(&out).unwrap(), fine);
    // A network pointing past its vertices is refused.
    let mut bad = net;
    bad.curves[1].vertices.push(9);
    match save_curves_ply(&out, &bad) {
        Err(MeshError::InvalidData { message, .. }) => {
            assert!(message.contains("curve 1 references vertex 9"))
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn curves_obj_has_labelled_groups_and_edges() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("curves.obj");
    save_curves_obj(&out, &network()).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    let groups: Vec<&str> = text.lines().filter(|l| l.starts_with("g ")).collect();
    assert_eq!(groups, ["g ridge_0", "g ravine_1", "g other_2"]);
    let lines: Vec<&str> = text.lines().filter(|l| l.starts_with("l ")).collect();
    // Ridge 0-1-2-3, closed ravine 3-4-5(-3), open 3-6-5-3; 1-based.
    let expected = [
        "l 1 2", "l 2 3", "l 3 4", "l 4 5", "l 5 6", "l 6 4", "l 4 7", "l 7 6", "l 6 4",
    ];
    assert_eq!(lines, expected);
    // Each group holds its curve's edges.
    let ravine = text
        .split("g ravine_1\n")
        .nth(1)
        .unwrap()
        .split("g ")
        .next()
        .unwrap();
    assert_eq!(ravine.lines().count(), 3);
    let positions: Vec<[f64; 3]> = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f64> = l.split(' ').map(|t| t.parse().unwrap()).collect();
            [c[0], c[1], c[2]]
        })
        .collect();
    let expected: Vec<[f64; 3]> = network().vertices.iter().map(|v| v.position).collect();
    assert_eq!(positions, expected);
}

/// The OBJ reader against tobj on real files: the same triangles at the same positions.
#[test]
fn obj_reader_agrees_with_tobj_on_shared_meshes() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/meshes");
    let files = [
        "cad/oded_wingnut.obj",
        "correspondence/smpl_man_woman/human_man.obj",
    ];
    if !Path::new(root).is_dir() {
        eprintln!("skipped: {root} not found");
        return;
    }
    for f in files {
        let path = Path::new(root).join(f);
        let ours = load(&path).unwrap().mesh;
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        };
        let (models, _) = tobj::load_obj(&path, &opts).unwrap();
        let mut theirs: Vec<[[u32; 3]; 3]> = Vec::new();
        for m in &models {
            let p = &m.mesh.positions;
            for t in m.mesh.indices.chunks(3) {
                theirs.push([0, 1, 2].map(|k| {
                    let i = t[k] as usize;
                    [
                        p[3 * i].to_bits(),
                        p[3 * i + 1].to_bits(),
                        p[3 * i + 2].to_bits(),
                    ]
                }));
            }
        }
        let mut mine: Vec<[[u32; 3]; 3]> = ours
            .triangles
            .iter()
            .map(|t| t.map(|i| ours.positions[i as usize].map(|c| (c as f32).to_bits())))
            .collect();
        mine.sort_unstable();
        theirs.sort_unstable();
        assert_eq!(mine.len(), theirs.len(), "{f}");
        assert!(mine == theirs, "{f}: triangles differ from tobj's");
    }
}

fn off_text(positions: &[[f64; 3]], tris: &[[u32; 3]]) -> String {
    let mut s = format!("OFF\n{} {} 0\n", positions.len(), tris.len());
    for p in positions {
        s += &format!("{:?} {:?} {:?}\n", p[0], p[1], p[2]);
    }
    for t in tris {
        s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    s
}

fn repair() -> LoadOptions {
    LoadOptions {
        repair: true,
        ..Default::default()
    }
}

fn flipped(t: [u32; 3]) -> [u32; 3] {
    [t[0], t[2], t[1]]
}

#[test]
fn orientation_repair_turns_a_closed_surface_outward() {
    let sphere = crate::shapes::sphere(1.0, 2).unwrap();
    let n = sphere.n_faces();
    let d = tempfile::tempdir().unwrap();
    // Every third face turned over.
    let tris: Vec<[u32; 3]> = (0..n)
        .map(|f| match f % 3 {
            0 => flipped(sphere.triangles[f]),
            _ => sphere.triangles[f],
        })
        .collect();
    let p = file(
        &d,
        "third.off",
        off_text(&sphere.positions, &tris).as_bytes(),
    );
    let plain = load(&p).unwrap();
    assert_eq!(plain.mesh.triangles, tris, "nothing changes without repair");
    assert_eq!(plain.report.faces_flipped, 0);
    assert!(plain.report.inconsistent_edges > 0);
    assert!(plain
        .report
        .warnings()
        .iter()
        .any(|w| w.contains("inconsistently oriented") && w.contains("repair: true")));
    let m = load_mesh(&p, &repair()).unwrap();
    assert_eq!(
        m.mesh.triangles, sphere.triangles,
        "the outward sphere back"
    );
    assert_eq!(m.report.faces_flipped, n.div_ceil(3));
    assert_eq!(m.report.inconsistent_edges, plain.report.inconsistent_edges);
    assert_eq!(m.report.nonorientable_components, 0);
    assert!(m
        .report
        .warnings()
        .iter()
        .any(|w| w.contains("faces flipped")));
    // All faces inside out but the first: the coherent choice that keeps the first face
    // points inward, so the closed surface takes the other one (n − 1 flips).
    let tris: Vec<[u32; 3]> = (0..n)
        .map(|f| match f {
            0 => sphere.triangles[f],
            _ => flipped(sphere.triangles[f]),
        })
        .collect();
    let p = file(
        &d,
        "inside.off",
        off_text(&sphere.positions, &tris).as_bytes(),
    );
    let m = load_mesh(&p, &repair()).unwrap();
    assert_eq!(m.mesh.triangles, sphere.triangles);
    assert_eq!(m.report.faces_flipped, n - 1);
    // A coherent inside-out sphere is not an inconsistency: repair leaves it alone.
    let tris: Vec<[u32; 3]> = sphere.triangles.iter().map(|&t| flipped(t)).collect();
    let p = file(
        &d,
        "inverted.off",
        off_text(&sphere.positions, &tris).as_bytes(),
    );
    let m = load_mesh(&p, &repair()).unwrap();
    assert_eq!(m.mesh.triangles, tris);
    assert_eq!(
        (m.report.inconsistent_edges, m.report.faces_flipped),
        (0, 0)
    );
}

#[test]
fn orientation_repair_flips_the_fewest_faces_of_an_open_surface() {
    // A 10 × 10 grid of the unit square (200 triangles), three of them turned over, and a
    // second, separate grid turned over except for two faces.
    let k = 10u32;
    let mut positions = Vec::new();
    for y in 0..=k {
        for x in 0..=k {
            positions.push([x as f64, y as f64, 0.0]);
        }
    }
    let at = |x: u32, y: u32| y * (k + 1) + x;
    let mut grid = Vec::new();
    for y in 0..k {
        for x in 0..k {
            grid.push([at(x, y), at(x + 1, y), at(x + 1, y + 1)]);
            grid.push([at(x, y), at(x + 1, y + 1), at(x, y + 1)]);
        }
    }
    let nv = positions.len() as u32;
    let lifted: Vec<[f64; 3]> = positions.iter().map(|p| [p[0], p[1], 5.0]).collect();
    positions.extend(lifted);
    let second: Vec<[u32; 3]> = grid.iter().map(|t| t.map(|v| v + nv)).collect();
    let mut tris = grid.clone();
    for f in [0usize, 57, 133] {
        tris[f] = flipped(tris[f]);
    }
    tris.extend(second.iter().enumerate().map(|(f, &t)| match f {
        3 | 90 => t,
        _ => flipped(t),
    }));
    let d = tempfile::tempdir().unwrap();
    let p = file(&d, "grids.off", off_text(&positions, &tris).as_bytes());
    let m = load_mesh(&p, &repair()).unwrap();
    let mut expect = grid.clone();
    expect.extend(second.iter().map(|&t| flipped(t)));
    assert_eq!(m.mesh.triangles, expect);
    assert_eq!((m.report.faces_flipped, m.report.components), (3 + 2, 2));
}

#[test]
fn a_moebius_strip_is_reported_not_orientable() {
    // 24 quads around a circle with a half twist: the last quad joins the first with its
    // two sides swapped.
    let n = 24u32;
    let mut positions = Vec::new();
    for i in 0..n {
        let a = i as f64 / n as f64 * std::f64::consts::TAU;
        let (c, s) = ((a / 2.0).cos() * 0.3, (a / 2.0).sin() * 0.3);
        for side in [-1.0, 1.0] {
            let r = 1.0 + side * c;
            positions.push([r * a.cos(), r * a.sin(), side * s]);
        }
    }
    let mut tris = Vec::new();
    for i in 0..n {
        let (a, b) = (2 * i, 2 * i + 1);
        let (c, d) = if i + 1 == n {
            (1, 0)
        } else {
            (2 * i + 2, 2 * i + 3)
        };
        tris.push([a, c, b]);
        tris.push([b, c, d]);
    }
    let d = tempfile::tempdir().unwrap();
    let p = file(&d, "moebius.off", off_text(&positions, &tris).as_bytes());
    let plain = load(&p).unwrap();
    assert_eq!(plain.report.inconsistent_edges, 1, "the seam");
    let m = load_mesh(&p, &repair()).unwrap();
    assert_eq!(m.report.nonorientable_components, 1);
    assert_eq!(m.mesh.n_faces(), 2 * n as usize);
    assert!(m
        .report
        .warnings()
        .iter()
        .any(|w| w.contains("non-orientable")));
    // Whatever it flipped, one edge still disagrees.
    let topo = m.mesh.topology();
    let disagree = (0..topo.edges.len())
        .filter(|&e| {
            let [f, g] = topo.edge_faces[e];
            g != crate::mesh::NO_FACE
                && super::validate::forward(&m.mesh, topo, f, e)
                    == super::validate::forward(&m.mesh, topo, g, e)
        })
        .count();
    assert!(disagree >= 1);
}

/// Only regular files are read: a folder named like a mesh, and a link to a device (which
/// could be `/dev/zero`, whose reading never ends; `/dev/null` here, which would read as an
/// empty file), are refused by name before anything is read.
#[test]
fn folders_and_devices_are_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("folder.off");
    std::fs::create_dir(&folder).unwrap();
    let mut paths = vec![folder];
    #[cfg(unix)]
    {
        let link = dir.path().join("device.off");
        std::os::unix::fs::symlink("/dev/null", &link).unwrap();
        paths.push(link.clone());
        let err = read_text_file(&link).unwrap_err();
        assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput);
        let link = dir.path().join("curves.ply");
        std::os::unix::fs::symlink("/dev/null", &link).unwrap();
        let err = load_curves_ply(&link).unwrap_err().to_string();
        assert!(
            err.contains("curves.ply") && err.contains("not a regular file"),
            "{err}"
        );
    }
    for p in paths {
        let err = load(&p).unwrap_err();
        assert!(matches!(err, MeshError::Io { .. }), "{err:?}");
        let text = err.to_string();
        assert!(
            text.contains(&*p.to_string_lossy()) && text.contains("not a regular file"),
            "{text}"
        );
    }
    // A link to a regular file is read as that file.
    let real = file(&dir, "tetra.off", TETRA_OFF.as_bytes());
    #[cfg(unix)]
    {
        let link = dir.path().join("link.off");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        assert_eq!(load(&link).unwrap().mesh.triangles, TETRA_TRIS);
    }
    assert_eq!(load(&real).unwrap().mesh.triangles, TETRA_TRIS);
}

/// A UTF-8 byte-order mark before the text (as some Windows editors save files) is skipped in
/// every text format; the first line is read as usual.
#[test]
fn a_byte_order_mark_is_skipped() {
    let d = tempfile::tempdir().unwrap();
    let bom = |text: &str| [&b"\xEF\xBB\xBF"[..], text.as_bytes()].concat();
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
               property float z\nelement face 4\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    let stl = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
               vertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
    for (name, text, vertices, faces) in [
        ("t.obj", obj, 4, 4),
        ("t.off", TETRA_OFF, 4, 4),
        ("t.ply", ply, 4, 4),
        ("t.stl", stl, 3, 1),
    ] {
        let plain = load(&file(&d, name, text.as_bytes())).unwrap().mesh;
        let marked = load(&file(&d, &format!("bom_{name}"), &bom(text)))
            .unwrap_or_else(|e| panic!("{name}: {e}"))
            .mesh;
        assert_eq!(
            (marked.n_vertices(), marked.n_faces()),
            (vertices, faces),
            "{name}"
        );
        assert_eq!(marked, plain, "{name}");
    }
    // The text files of other nodes (landmarks, ground truth, experiments) too.
    let p = file(&d, "pairs.txt", &bom("# pairs\n0 1\n"));
    assert_eq!(read_text_file(&p).unwrap(), "# pairs\n0 1\n");
}
