//! A small software rasterizer: orthographic camera framed from the bounding box, z-buffer,
//! deferred Lambert shading, and depth-tested thick polylines drawn over the shaded mesh.
//!
//! Bands of rows run in parallel, but every sample sees the triangles and segments in the same
//! order as in one piece, so the pixels are the same on every machine and at every thread
//! count.

use crestflow_flow::Par;
use crestflow_geom::vec3::{self, V3};

/// An RGB image, 8 bits per channel, rows top to bottom.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbImage {
    pub width: u32,
    pub height: u32,
    /// `3 * width * height` bytes.
    pub pixels: Vec<u8>,
}

impl RgbImage {
    /// The colour of pixel (x, y).
    pub fn get(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]]
    }
}

/// Which world axis points up on screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum UpAxis {
    X,
    Y,
    Z,
}

/// Where the camera looks from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// World axis shown upwards.
    pub up: UpAxis,
    /// Degrees around the up axis; 0 looks at the front.
    pub azimuth_deg: f64,
    /// Degrees above the horizontal plane.
    pub elevation_deg: f64,
    /// Empty border on each side, as a fraction of the image size.
    pub margin: f64,
}

/// An orthographic camera: world point -> (pixel x, pixel y, depth). Smaller depth is nearer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Unit vector from the scene towards the camera.
    pub towards_eye: V3,
    pub right: V3,
    pub up: V3,
    /// World point shown at the image centre.
    pub center: V3,
    /// Pixels per world unit.
    pub scale: f64,
    pub width: f64,
    pub height: f64,
}

impl Camera {
    /// Looks at the box `(lo, hi)` from `view`, scaled so that the projected box fills a
    /// `width` × `height` image up to the view's margin.
    pub fn framing(lo: V3, hi: V3, view: &View, width: f64, height: f64) -> Camera {
        let (up_axis, azimuth_deg, elevation_deg, margin) =
            (view.up, view.azimuth_deg, view.elevation_deg, view.margin);
        // (up, front, side) per up axis: azimuth 0 looks at the front, positive azimuth turns
        // the camera towards the side axis.
        let (u, f, s): (V3, V3, V3) = match up_axis {
            UpAxis::Y => ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
            UpAxis::Z => ([0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]),
            UpAxis::X => ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        };
        let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
        let horiz = vec3::add(vec3::scale(f, az.cos()), vec3::scale(s, az.sin()));
        let towards_eye = vec3::normalize(vec3::add(
            vec3::scale(horiz, el.cos()),
            vec3::scale(u, el.sin()),
        ));
        let right = vec3::normalize(vec3::cross(u, towards_eye));
        let cam_up = vec3::cross(towards_eye, right);

        // Frame the eight corners of the box.
        let mut min = [f64::INFINITY; 2];
        let mut max = [f64::NEG_INFINITY; 2];
        for k in 0..8 {
            let c = [
                if k & 1 == 0 { lo[0] } else { hi[0] },
                if k & 2 == 0 { lo[1] } else { hi[1] },
                if k & 4 == 0 { lo[2] } else { hi[2] },
            ];
            let xy = [vec3::dot(c, right), vec3::dot(c, cam_up)];
            for i in 0..2 {
                min[i] = min[i].min(xy[i]);
                max[i] = max[i].max(xy[i]);
            }
        }
        let mid = [0.5 * (min[0] + max[0]), 0.5 * (min[1] + max[1])];
        let box_center = vec3::scale(vec3::add(lo, hi), 0.5);
        let depth_c = vec3::dot(box_center, towards_eye);
        let center = vec3::add(
            vec3::add(vec3::scale(right, mid[0]), vec3::scale(cam_up, mid[1])),
            vec3::scale(towards_eye, depth_c),
        );
        let ext = [(max[0] - min[0]).max(1e-300), (max[1] - min[1]).max(1e-300)];
        let usable = 1.0 - 2.0 * margin;
        let scale = (usable * width / ext[0]).min(usable * height / ext[1]);
        Camera {
            towards_eye,
            right,
            up: cam_up,
            center,
            scale,
            width,
            height,
        }
    }

    /// Pixel coordinates (x right, y down; pixel (i, j) covers [i, i+1) × [j, j+1)) and depth.
    #[inline]
    pub fn project(&self, p: V3) -> [f64; 3] {
        let d = vec3::sub(p, self.center);
        [
            0.5 * self.width + self.scale * vec3::dot(d, self.right),
            0.5 * self.height - self.scale * vec3::dot(d, self.up),
            -vec3::dot(d, self.towards_eye),
        ]
    }

    /// The same camera on an image `factor` times larger in each direction.
    pub fn scaled(&self, factor: f64) -> Camera {
        Camera {
            scale: self.scale * factor,
            width: self.width * factor,
            height: self.height * factor,
            ..*self
        }
    }
}

/// What the rasterizer needs per triangle corner.
pub struct Scene<'a> {
    pub positions: &'a [V3],
    pub triangles: &'a [[u32; 3]],
    /// One shading normal per corner (`3 * n_faces`).
    pub corner_normals: &'a [V3],
    /// One linear RGB colour per vertex, components in [0, 1].
    pub vertex_colors: &'a [[f64; 3]],
}

/// A line segment to draw: world endpoints and an RGB colour.
pub struct Segment {
    pub a: V3,
    pub b: V3,
    pub color: [u8; 3],
}

/// Drawing settings.
pub struct Style {
    pub background: [u8; 3],
    pub ambient: f64,
    /// Line width in output pixels.
    pub line_width: f64,
    /// World-space distance a curve may lie behind the visible surface and still be drawn.
    pub depth_offset: f64,
    /// Samples per pixel side (1 = no anti-aliasing).
    pub supersample: u32,
}

/// Coverage figures of a render, in output pixels (sums of sub-sample fractions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RasterStats {
    pub mesh_pixels: f64,
    pub curve_pixels: f64,
}

/// Output rows per band: the unit of parallel work (a fixed split, so the pixels do not depend
/// on the thread count).
const BAND_ROWS: usize = 16;

/// Rasterizes `scene` and `segments` with `camera` (sized for the output image).
///
/// The image is cut into bands of rows that run in parallel: first the z-buffer of every
/// band (each band sees its triangles in index order), then the shading, the curves (each
/// band sees its segments in order; the depth test may read a neighbouring band) and the
/// downsampling. Every sample goes through the same operations in the same order as in one
/// piece, so the pixels are the same at every thread count.
pub fn rasterize(
    scene: &Scene,
    segments: &[Segment],
    camera: &Camera,
    style: &Style,
    par: Par,
) -> (RgbImage, RasterStats) {
    rasterize_in_bands(scene, segments, camera, style, BAND_ROWS, par)
}

/// A triangle in sample coordinates with its reciprocal doubled area and its bounding box.
struct ScreenTriangle {
    p: [[f64; 3]; 3],
    inv: f64,
    xs: (usize, usize),
    ys: (usize, usize),
}

/// A curve segment in sample coordinates with its bounding box (widened by the half width).
struct ScreenSegment {
    a: [f64; 3],
    b: [f64; 3],
    xs: (usize, usize),
    ys: (usize, usize),
    color: [f32; 3],
}

/// The z-buffer of one band: rows `rows.0..rows.1` of the supersampled image.
struct BandBuffer {
    rows: (usize, usize),
    depth: Vec<f64>,
    face_of: Vec<u32>,
    bary: Vec<[f32; 2]>,
}

/// Indices of the items whose row ranges `ys` meet each band of `band_h` rows, in order.
fn bin_by_band(
    ys: impl Iterator<Item = (usize, usize)>,
    band_h: usize,
    n_bands: usize,
) -> Vec<Vec<u32>> {
    let mut bins = vec![Vec::new(); n_bands];
    for (i, (y0, y1)) in ys.enumerate() {
        if y0 < y1 {
            for bin in &mut bins[y0 / band_h..=((y1 - 1) / band_h).min(n_bands - 1)] {
                bin.push(i as u32);
            }
        }
    }
    bins
}

fn rasterize_in_bands(
    scene: &Scene,
    segments: &[Segment],
    camera: &Camera,
    style: &Style,
    band_rows: usize,
    par: Par,
) -> (RgbImage, RasterStats) {
    let ss = style.supersample.max(1) as usize;
    let (w_out, h_out) = (camera.width as usize, camera.height as usize);
    let (w, h) = (w_out * ss, h_out * ss);
    let cam = camera.scaled(ss as f64);
    // Whole output rows per band, so that each band downsamples on its own.
    let band_h = band_rows.max(1) * ss;
    let n_bands = h.div_ceil(band_h).max(1);

    let projected: Vec<[f64; 3]> = scene.positions.iter().map(|&p| cam.project(p)).collect();
    let tris: Vec<Option<ScreenTriangle>> = par.map_collect(scene.triangles.len(), |f| {
        let t = scene.triangles[f];
        let p = [
            projected[t[0] as usize],
            projected[t[1] as usize],
            projected[t[2] as usize],
        ];
        let area =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
        if area == 0.0 || !area.is_finite() {
            return None;
        }
        let lo = |k: usize| p.iter().map(|q| q[k]).fold(f64::INFINITY, f64::min);
        let hi = |k: usize| p.iter().map(|q| q[k]).fold(f64::NEG_INFINITY, f64::max);
        Some(ScreenTriangle {
            p,
            inv: 1.0 / area,
            xs: (
                lo(0).floor().max(0.0) as usize,
                hi(0).ceil().min(w as f64) as usize,
            ),
            ys: (
                lo(1).floor().max(0.0) as usize,
                hi(1).ceil().min(h as f64) as usize,
            ),
        })
    });
    let band_tris = bin_by_band(
        tris.iter().map(|t| t.as_ref().map_or((0, 0), |t| t.ys)),
        band_h,
        n_bands,
    );

    let bands: Vec<BandBuffer> = par.map_collect(n_bands, |band| {
        let rows = (band * band_h, ((band + 1) * band_h).min(h));
        let n = (rows.1 - rows.0) * w;
        let mut buf = BandBuffer {
            rows,
            depth: vec![f64::INFINITY; n],
            face_of: vec![u32::MAX; n],
            bary: vec![[0.0f32; 2]; n],
        };
        for &f in &band_tris[band] {
            let Some(t) = &tris[f as usize] else {
                continue;
            };
            let (p, inv) = (&t.p, t.inv);
            for y in t.ys.0.max(rows.0)..t.ys.1.min(rows.1) {
                let py = y as f64 + 0.5;
                for x in t.xs.0..t.xs.1 {
                    let px = x as f64 + 0.5;
                    // Barycentric coordinates of the sample centre (either winding: two-sided).
                    let b1 = ((px - p[0][0]) * (p[2][1] - p[0][1])
                        - (p[2][0] - p[0][0]) * (py - p[0][1]))
                        * inv;
                    let b2 = ((p[1][0] - p[0][0]) * (py - p[0][1])
                        - (px - p[0][0]) * (p[1][1] - p[0][1]))
                        * inv;
                    let b0 = 1.0 - b1 - b2;
                    if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 {
                        continue;
                    }
                    let z = b0 * p[0][2] + b1 * p[1][2] + b2 * p[2][2];
                    let i = (y - rows.0) * w + x;
                    if z < buf.depth[i] {
                        buf.depth[i] = z;
                        buf.face_of[i] = f;
                        buf.bary[i] = [b1 as f32, b2 as f32];
                    }
                }
            }
        }
        buf
    });
    let depth_at = |x: usize, y: usize| {
        let b = &bands[y / band_h];
        b.depth[(y - b.rows.0) * w + x]
    };

    // Curves: a sample within half the line width of a segment takes the segment's colour when
    // the segment's nearest point is not hidden behind the surface seen at that point's pixel.
    let half = 0.5 * style.line_width * ss as f64;
    let segs: Vec<ScreenSegment> = segments
        .iter()
        .map(|seg| {
            let a = cam.project(seg.a);
            let b = cam.project(seg.b);
            ScreenSegment {
                a,
                b,
                xs: (
                    (a[0].min(b[0]) - half).floor().max(0.0) as usize,
                    ((a[0].max(b[0]) + half).ceil().max(0.0) as usize).min(w),
                ),
                ys: (
                    (a[1].min(b[1]) - half).floor().max(0.0) as usize,
                    ((a[1].max(b[1]) + half).ceil().max(0.0) as usize).min(h),
                ),
                color: seg.color.map(|v| v as f32 / 255.0),
            }
        })
        .collect();
    let band_segs = bin_by_band(segs.iter().map(|s| s.ys), band_h, n_bands);

    // Deferred shading: one Lambert evaluation per visible sample (two-sided).
    let light = vec3::normalize(vec3::add(
        vec3::add(cam.towards_eye, vec3::scale(cam.up, 0.5)),
        vec3::scale(cam.right, -0.3),
    ));
    let bg = style.background.map(|c| c as f32 / 255.0);
    let norm = 1.0 / (ss * ss) as f64;
    let shaded: Vec<(Vec<u8>, usize, usize)> = par.map_collect(n_bands, |band| {
        let buf = &bands[band];
        let rows = buf.rows;
        let n = (rows.1 - rows.0) * w;
        let mut color = vec![bg; n];
        let mut mesh_samples = 0usize;
        for (i, sample) in color.iter_mut().enumerate() {
            let f = buf.face_of[i];
            if f == u32::MAX {
                continue;
            }
            mesh_samples += 1;
            let f = f as usize;
            let [b1, b2] = buf.bary[i].map(f64::from);
            let b0 = 1.0 - b1 - b2;
            let cn = &scene.corner_normals[3 * f..3 * f + 3];
            let mut nrm = vec3::normalize(vec3::add(
                vec3::add(vec3::scale(cn[0], b0), vec3::scale(cn[1], b1)),
                vec3::scale(cn[2], b2),
            ));
            if vec3::dot(nrm, cam.towards_eye) < 0.0 {
                nrm = vec3::scale(nrm, -1.0);
            }
            // A key light from above left plus a headlight fill, so faces turned away from
            // the key light keep their shape.
            let lambert = 0.7 * vec3::dot(nrm, light).max(0.0)
                + 0.3 * vec3::dot(nrm, cam.towards_eye).max(0.0);
            let shade = style.ambient + (1.0 - style.ambient) * lambert;
            let t = scene.triangles[f];
            let c = [
                scene.vertex_colors[t[0] as usize],
                scene.vertex_colors[t[1] as usize],
                scene.vertex_colors[t[2] as usize],
            ];
            let mut out = [0.0; 3];
            for k in 0..3 {
                out[k] = (b0 * c[0][k] + b1 * c[1][k] + b2 * c[2][k]) * shade;
            }
            *sample = out.map(|v| v as f32);
        }

        let mut line_depth = vec![f64::INFINITY; n];
        let mut curve_samples = 0usize;
        for &si in &band_segs[band] {
            let seg = &segs[si as usize];
            let (a, b) = (seg.a, seg.b);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len2 = dx * dx + dy * dy;
            for y in seg.ys.0.max(rows.0)..seg.ys.1.min(rows.1) {
                let py = y as f64 + 0.5;
                for x in seg.xs.0..seg.xs.1 {
                    let px = x as f64 + 0.5;
                    let t = if len2 > 0.0 {
                        (((px - a[0]) * dx + (py - a[1]) * dy) / len2).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let (cx, cy) = (a[0] + t * dx, a[1] + t * dy);
                    let d2 = (px - cx) * (px - cx) + (py - cy) * (py - cy);
                    if d2 > half * half {
                        continue;
                    }
                    let z = a[2] + t * (b[2] - a[2]);
                    let (ix, iy) = (cx.floor(), cy.floor());
                    if ix < 0.0 || iy < 0.0 || ix >= w as f64 || iy >= h as f64 {
                        continue;
                    }
                    let surface = depth_at(ix as usize, iy as usize);
                    if z > surface + style.depth_offset {
                        continue;
                    }
                    let i = (y - rows.0) * w + x;
                    if z < line_depth[i] {
                        if line_depth[i] == f64::INFINITY {
                            curve_samples += 1;
                        }
                        line_depth[i] = z;
                        color[i] = seg.color;
                    }
                }
            }
        }

        // Box-filter the samples down to the output size.
        let out_rows = (rows.1 - rows.0) / ss;
        let mut pixels = Vec::with_capacity(3 * w_out * out_rows);
        for y in 0..out_rows {
            for x in 0..w_out {
                let mut acc = [0.0; 3];
                for sy in 0..ss {
                    for sx in 0..ss {
                        let c = color[(y * ss + sy) * w + x * ss + sx];
                        for k in 0..3 {
                            acc[k] += f64::from(c[k]);
                        }
                    }
                }
                for a in acc {
                    pixels.push((a * norm * 255.0).round().clamp(0.0, 255.0) as u8);
                }
            }
        }
        (pixels, mesh_samples, curve_samples)
    });
    let mut pixels = Vec::with_capacity(3 * w_out * h_out);
    let (mut mesh_samples, mut curve_samples) = (0usize, 0usize);
    for (p, m, c) in shaded {
        pixels.extend_from_slice(&p);
        mesh_samples += m;
        curve_samples += c;
    }
    let stats = RasterStats {
        mesh_pixels: mesh_samples as f64 * norm,
        curve_pixels: curve_samples as f64 * norm,
    };
    (
        RgbImage {
            width: w_out as u32,
            height: h_out as u32,
            pixels,
        },
        stats,
    )
}

#[cfg(test)]
#[path = "raster_test.rs"]
mod tests;
