//! Unit tests of `raster.rs`.

use super::*;
use crestflow_geom::shapes::sphere;

/// Positions, triangles, corner normals, vertex colours and segments of a test scene.
type Parts = (Vec<V3>, Vec<[u32; 3]>, Vec<V3>, Vec<[f64; 3]>, Vec<Segment>);

/// Two overlapping spheres (depth tests across many bands) and a few long segments, some in
/// front, some behind.
fn scene_parts() -> Parts {
    let a = sphere(1.0, 3).unwrap();
    let n = a.positions.len() as u32;
    let mut positions = a.positions.clone();
    positions.extend(
        a.positions
            .iter()
            .map(|p| [0.6 * p[0] + 0.7, 0.6 * p[1] - 0.4, 0.6 * p[2] + 0.5]),
    );
    let mut triangles = a.triangles.clone();
    triangles.extend(a.triangles.iter().map(|t| t.map(|v| v + n)));
    let corner_normals: Vec<V3> = triangles
        .iter()
        .flat_map(|t| t.map(|v| vec3::normalize(positions[v as usize])))
        .collect();
    let colors: Vec<[f64; 3]> = positions
        .iter()
        .map(|p| {
            [
                0.5 + 0.4 * p[0].clamp(-1.0, 1.0),
                0.6,
                0.5 - 0.4 * p[1].clamp(-1.0, 1.0),
            ]
        })
        .collect();
    let segments = (0..12)
        .map(|i| {
            let t = i as f64 * 0.5;
            Segment {
                a: [1.05 * t.cos(), 1.05 * t.sin(), 0.3 * (t - 3.0)],
                b: [1.05 * (t + 0.5).cos(), -1.05 * (t + 0.5).sin(), -0.2 * t],
                color: [200, 30, 30 + 10 * i as u8],
            }
        })
        .collect();
    (positions, triangles, corner_normals, colors, segments)
}

#[test]
fn bands_and_threads_do_not_change_a_pixel() {
    let (positions, triangles, corner_normals, vertex_colors, segments) = scene_parts();
    let scene = Scene {
        positions: &positions,
        triangles: &triangles,
        corner_normals: &corner_normals,
        vertex_colors: &vertex_colors,
    };
    let view = View {
        up: UpAxis::Y,
        azimuth_deg: 20.0,
        elevation_deg: 15.0,
        margin: 0.05,
    };
    let camera = Camera::framing([-1.0, -1.1, -1.0], [1.4, 1.0, 1.2], &view, 160.0, 123.0);
    for ss in [1, 2, 3] {
        let style = Style {
            background: [255, 255, 255],
            ambient: 0.2,
            line_width: 2.5,
            depth_offset: 0.01,
            supersample: ss,
        };
        // One band holding the whole image: every sample in one piece.
        let (whole, whole_stats) =
            rasterize_in_bands(&scene, &segments, &camera, &style, 1000, Par::Seq);
        assert!(whole_stats.mesh_pixels > 0.2 * 160.0 * 123.0);
        assert!(whole_stats.curve_pixels > 100.0);
        for rows in [1, 3, 7, 16] {
            for par in [Par::Seq, Par::Rayon] {
                let (img, stats) =
                    rasterize_in_bands(&scene, &segments, &camera, &style, rows, par);
                assert_eq!(
                    img, whole,
                    "supersample {ss}, bands of {rows} rows, {par:?}"
                );
                assert_eq!(stats, whole_stats);
            }
        }
    }
}
