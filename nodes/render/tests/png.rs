//! `render.png` on analytic shapes: exact silhouette area, depth-tested curves, determinism.

use std::f64::consts::PI;

use crestflow_flow::Par;
use crestflow_geom::shapes;
use crestflow_geom::{
    CurvatureField, CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint, TriMesh,
};
use crestflow_nodes_render::{render, write_png, RenderError, RenderParams, UpAxis};

fn unit_sphere() -> TriMesh {
    shapes::sphere(1.0, 4).expect("valid sphere")
}

/// Two circles of radius 0.5 on the unit sphere: one on the +z cap (ridge), one on the -z cap
/// (ravine).
fn front_and_back_circles() -> FeatureCurveNetwork {
    let mut net = FeatureCurveNetwork::default();
    let n = 64;
    for (z, label) in [
        (0.75f64.sqrt(), CurveLabel::Ridge),
        (-(0.75f64.sqrt()), CurveLabel::Ravine),
    ] {
        let start = net.vertices.len() as u32;
        for i in 0..n {
            let t = 2.0 * PI * i as f64 / n as f64;
            net.vertices.push(FcnVertex {
                position: [0.5 * t.cos(), 0.5 * t.sin(), z],
                location: SurfacePoint::Free,
                strength: 1.0,
            });
        }
        net.curves.push(FeatureCurve {
            vertices: (start..start + n).collect(),
            closed: true,
            label,
        });
    }
    net
}

fn front_params() -> RenderParams {
    // Looking down -z from +z.
    RenderParams {
        azimuth: 0.0,
        elevation: 0.0,
        up: UpAxis::Y,
        width: 320,
        height: 240,
        ..RenderParams::default()
    }
}

fn count_color(img: &crestflow_nodes_render::RgbImage, c: [u8; 3]) -> usize {
    img.pixels.chunks(3).filter(|p| p == &c).count()
}

#[test]
fn sphere_coverage_matches_disc_area() {
    let mesh = unit_sphere();
    for ss in [1, 2] {
        let params = RenderParams {
            supersample: ss,
            ..front_params()
        };
        let out = render(&mesh, None, None, &params, Par::Rayon).unwrap();
        let r_px = out.camera.scale; // radius 1 in world units
        let expected = PI * r_px * r_px;
        let rel = (out.stats.mesh_pixels - expected).abs() / expected;
        assert!(
            rel < 0.02,
            "ss {ss}: {} covered pixels, disc area {expected}, rel {rel}",
            out.stats.mesh_pixels
        );
        // The framing puts the box (side 2) into the shorter image side minus margins.
        let expected_scale = (1.0 - 2.0 * params.margin) * 240.0 / 2.0;
        assert!((r_px - expected_scale).abs() < 1e-9 * expected_scale);
        // The non-background pixels tell the same story from the image itself.
        let bg = count_color(&out.image, params.background);
        let covered = (320 * 240 - bg) as f64;
        assert!(
            (covered - expected).abs() / expected < 0.03,
            "{covered} vs {expected}"
        );
    }
}

#[test]
fn front_curve_drawn_and_hidden_curve_not() {
    let mesh = unit_sphere();
    let net = front_and_back_circles();
    let p = front_params();
    let front = render(&mesh, Some(&net), None, &p, Par::Rayon).unwrap();
    let ridge_px = count_color(&front.image, p.ridge_color);
    let ravine_px = count_color(&front.image, p.ravine_color);
    // Circle of radius 0.5 (in pixels: 0.5 · scale), 2.5 px wide: roughly 2π · 0.5 · s · 2.5.
    let expected = 2.0 * PI * 0.5 * front.camera.scale * p.line_width;
    assert!(
        ridge_px as f64 > 0.5 * expected,
        "front ridge: {ridge_px} px of ~{expected}"
    );
    assert_eq!(ravine_px, 0, "the circle behind the sphere must be hidden");

    // Turned around, the roles swap: the same code draws the other circle.
    let back = render(
        &mesh,
        Some(&net),
        None,
        &RenderParams {
            azimuth: 180.0,
            ..p.clone()
        },
        Par::Rayon,
    )
    .unwrap();
    assert!(count_color(&back.image, p.ravine_color) as f64 > 0.5 * expected);
    assert_eq!(count_color(&back.image, p.ridge_color), 0);

    // Without depth testing slack the front curve still shows (it lies on the surface).
    let tight = render(
        &mesh,
        Some(&net),
        None,
        &RenderParams {
            depth_offset: 0.001,
            ..p.clone()
        },
        Par::Rayon,
    )
    .unwrap();
    assert!(count_color(&tight.image, p.ridge_color) as f64 > 0.5 * expected);
}

#[test]
fn curvature_colors_the_surface() {
    let mesh = unit_sphere();
    let n = mesh.n_vertices();
    // A field with positive mean curvature on the upper half and negative on the lower half:
    // warm pixels above the centre row, cool below.
    let mut k = CurvatureField {
        method: "test".into(),
        ..Default::default()
    };
    for p in &mesh.positions {
        let h = if p[1] > 0.0 { 1.0 } else { -1.0 };
        k.k_max.push(h);
        k.k_min.push(h);
        k.t_max.push([1.0, 0.0, 0.0]);
        k.t_min.push([0.0, 1.0, 0.0]);
        k.normal.push(*p);
        k.e_max.push(0.0);
        k.e_min.push(0.0);
    }
    assert_eq!(k.len(), n);
    let p = front_params();
    let out = render(&mesh, None, Some(&k), &p, Par::Rayon).unwrap();
    let centre = |dy: i64| out.image.get(160, (120 + dy) as u32);
    let (up, down) = (centre(-40), centre(40));
    assert!(up[0] > up[2], "upper half should be warm: {up:?}");
    assert!(down[2] > down[0], "lower half should be cool: {down:?}");
}

#[test]
fn output_is_deterministic_and_png_round_trips() {
    let mesh = shapes::ellipsoid(2.0, 1.0, 0.6, 3, 0.3, 7).unwrap();
    let net = front_and_back_circles();
    let p = RenderParams {
        width: 200,
        height: 150,
        ..RenderParams::default()
    };
    let a = render(&mesh, Some(&net), None, &p, Par::Rayon).unwrap();
    let b = render(&mesh, Some(&net), None, &p, Par::Rayon).unwrap();
    assert_eq!(a.image, b.image);

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub/out.png");
    write_png(&a.image, &path).unwrap();
    let bytes1 = std::fs::read(&path).unwrap();
    write_png(&b.image, &path).unwrap();
    assert_eq!(bytes1, std::fs::read(&path).unwrap());

    let decoder = png::Decoder::new(std::io::Cursor::new(bytes1));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (200, 150));
    assert_eq!(&buf[..info.buffer_size()], &a.image.pixels[..]);
}

#[test]
fn bad_inputs_give_specific_errors() {
    let p = front_params();
    let empty = TriMesh::new(vec![], vec![]);
    assert!(matches!(
        render(&empty, None, None, &p, Par::Rayon),
        Err(RenderError::EmptyMesh)
    ));

    let mut mesh = unit_sphere();
    mesh.positions[17][1] = f64::NAN;
    match render(&mesh, None, None, &p, Par::Rayon) {
        Err(RenderError::NonFinitePosition { vertex, .. }) => assert_eq!(vertex, 17),
        other => panic!("expected NonFinitePosition, got {other:?}"),
    }

    let bad = TriMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2], [0, 2, 5]],
    );
    match render(&bad, None, None, &p, Par::Rayon) {
        Err(RenderError::FaceIndex {
            face,
            index,
            n_vertices,
        }) => assert_eq!((face, index, n_vertices), (1, 5, 3)),
        other => panic!("expected FaceIndex, got {other:?}"),
    }

    let mesh = unit_sphere();
    let short = CurvatureField {
        k_max: vec![0.0; 3],
        k_min: vec![0.0; 3],
        ..Default::default()
    };
    assert!(matches!(
        render(&mesh, None, Some(&short), &p, Par::Rayon),
        Err(RenderError::FieldSize { field: 3, .. })
    ));

    let mut net = front_and_back_circles();
    net.curves[1].vertices.push(999);
    assert!(matches!(
        render(&mesh, Some(&net), None, &p, Par::Rayon),
        Err(RenderError::CurveIndex {
            curve: 1,
            index: 999,
            ..
        })
    ));

    let dir = tempfile::tempdir().unwrap();
    let img = render(&mesh, None, None, &p, Par::Rayon).unwrap().image;
    // A file where a folder is needed.
    std::fs::write(dir.path().join("file"), b"x").unwrap();
    assert!(matches!(
        write_png(&img, &dir.path().join("file/out.png")),
        Err(RenderError::Io { .. })
    ));
}

#[test]
fn params_are_validated() {
    use crestflow_flow::Validate;
    let p = RenderParams {
        width: 0,
        elevation: 95.0,
        supersample: 9,
        path: "".into(),
        ..RenderParams::default()
    };
    let fields: Vec<String> = p.validate().into_iter().map(|i| i.field).collect();
    for f in ["width", "elevation", "supersample", "path"] {
        assert!(
            fields.iter().any(|x| x == f),
            "{f} not reported in {fields:?}"
        );
    }
    assert!(RenderParams::default().validate().is_empty());
    // The pure function refuses them as well (before allocating anything).
    let mesh = unit_sphere();
    match render(&mesh, None, None, &p, Par::Rayon) {
        Err(RenderError::Params(text)) => assert!(
            text.contains("width") && text.contains("supersample"),
            "{text}"
        ),
        other => panic!("{other:?}"),
    }
    let huge = RenderParams {
        width: 16384,
        height: 16384,
        supersample: 2,
        ..RenderParams::default()
    };
    let issues = huge.validate();
    assert_eq!(issues.len(), 1);
    assert!(
        issues[0].message.contains("samples"),
        "{}",
        issues[0].message
    );
}
