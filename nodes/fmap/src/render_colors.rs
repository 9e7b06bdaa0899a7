//! `fmap.render_colors`: the source and the target side by side, each coloured by its
//! per-vertex colours (thesis Fig. 5.6–5.9), written as a PNG with the rasterizer of the
//! `render` family (orthographic camera, z-buffer, Lambert shading). Optional curve networks
//! are drawn over each shape.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Report, Validate,
};
use crestflow_geom::{FeatureCurveNetwork, TriMesh};
use crestflow_nodes_render::raster::{rasterize, Camera, Scene, Segment, Style, View};
use crestflow_nodes_render::{write_png, RgbImage, UpAxis};

use crate::types::{FmapError, VertexColors};

/// Parameters of `fmap.render_colors`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderColorsParams {
    /// Output PNG, relative to the pipeline file (default `transfer.png`).
    pub path: PathBuf,
    /// Width of each of the two panels (default 640, range 16..=4096).
    pub width: u32,
    /// Height (default 640, range 16..=4096).
    pub height: u32,
    /// Camera azimuth in degrees (default 30, range −360..=360).
    pub azimuth: f64,
    /// Camera elevation in degrees (default 15, range −89..=89).
    pub elevation: f64,
    /// World axis shown upwards (default `Y`).
    pub up: UpAxis,
    /// Curve colour (default red).
    pub curve_color: [u8; 3],
}

impl Default for RenderColorsParams {
    fn default() -> Self {
        RenderColorsParams {
            path: PathBuf::from("transfer.png"),
            width: 640,
            height: 640,
            azimuth: 30.0,
            elevation: 15.0,
            up: UpAxis::Y,
            curve_color: [220, 30, 30],
        }
    }
}

impl Validate for RenderColorsParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        if self.path.as_os_str().is_empty() {
            v.push(ParamIssue::new("path", "the output path is empty"));
        }
        check_range(&mut v, "width", self.width, 16, 4096);
        check_range(&mut v, "height", self.height, 16, 4096);
        check_range(&mut v, "azimuth", self.azimuth, -360.0, 360.0);
        check_range(&mut v, "elevation", self.elevation, -89.0, 89.0);
        v
    }
}

fn panel(
    mesh: &TriMesh,
    colors: &[[f64; 3]],
    curves: Option<&FeatureCurveNetwork>,
    p: &RenderColorsParams,
    par: Par,
) -> RgbImage {
    let vn = mesh.vertex_normals();
    let corner_normals: Vec<_> = mesh
        .triangles
        .iter()
        .flat_map(|t| t.map(|v| vn[v as usize]))
        .collect();
    let (lo, hi) = mesh.bbox();
    let view = View {
        up: p.up,
        azimuth_deg: p.azimuth,
        elevation_deg: p.elevation,
        margin: 0.04,
    };
    let camera = Camera::framing(lo, hi, &view, p.width as f64, p.height as f64);
    let mut segments = Vec::new();
    if let Some(net) = curves {
        for c in 0..net.curves.len() {
            for (a, b) in net.curve_edges(c) {
                let (a, b) = (a as usize, b as usize);
                if a < net.vertices.len() && b < net.vertices.len() {
                    segments.push(Segment {
                        a: net.vertices[a].position,
                        b: net.vertices[b].position,
                        color: p.curve_color,
                    });
                }
            }
        }
    }
    let style = Style {
        background: [255, 255, 255],
        ambient: 0.35,
        line_width: 2.0,
        depth_offset: 0.005 * mesh.bbox_diagonal(),
        supersample: 2,
    };
    let scene = Scene {
        positions: &mesh.positions,
        triangles: &mesh.triangles,
        corner_normals: &corner_normals,
        vertex_colors: colors,
    };
    rasterize(&scene, &segments, &camera, &style, par).0
}

/// Renders both panels into one image (source left, target right).
pub fn render_pair(
    source: &TriMesh,
    target: &TriMesh,
    colors: &VertexColors,
    curves: (Option<&FeatureCurveNetwork>, Option<&FeatureCurveNetwork>),
    params: &RenderColorsParams,
    par: Par,
) -> Result<RgbImage, FmapError> {
    for (side, mesh, c) in [
        ("source", source, &colors.source),
        ("target", target, &colors.target),
    ] {
        if c.len() != mesh.n_vertices() {
            return Err(FmapError::Render(format!(
                "{} {side} colours for a {side} mesh of {} vertices",
                c.len(),
                mesh.n_vertices()
            )));
        }
        if mesh.n_faces() == 0 {
            return Err(FmapError::Render(format!(
                "the {side} mesh has no triangles"
            )));
        }
        mesh.check_data()
            .map_err(|d| FmapError::Render(format!("{side} mesh: {d:?}")))?;
    }
    let a = panel(source, &colors.source, curves.0, params, par);
    let b = panel(target, &colors.target, curves.1, params, par);
    let (w, h) = (params.width as usize, params.height as usize);
    let mut pixels = vec![0u8; 3 * 2 * w * h];
    for y in 0..h {
        let row = &mut pixels[3 * 2 * w * y..3 * 2 * w * (y + 1)];
        row[..3 * w].copy_from_slice(&a.pixels[3 * w * y..3 * w * (y + 1)]);
        row[3 * w..].copy_from_slice(&b.pixels[3 * w * y..3 * w * (y + 1)]);
    }
    Ok(RgbImage {
        width: 2 * params.width,
        height: params.height,
        pixels,
    })
}

/// Node wrapper of [`render_pair`].
pub struct RenderColorsNode;

impl NodeKind for RenderColorsNode {
    type Params = RenderColorsParams;
    const KIND: &'static str = "fmap.render_colors";
    const VERSION: u32 = 1;
    const DOC: &'static str = "PNG of the source and the target side by side, coloured by \
        per-vertex colours (e.g. a field carried by fmap.transfer, thesis Fig. 5.6–5.9), with \
        optional curves drawn over them; uses the render family's rasterizer.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("source_mesh", "left panel"),
            Port::of::<TriMesh>("target_mesh", "right panel"),
            Port::of::<VertexColors>("colors", "per-vertex colours of both meshes"),
            Port::optional::<FeatureCurveNetwork>("source_curves", "drawn on the source"),
            Port::optional::<FeatureCurveNetwork>("target_curves", "drawn on the target"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<Report>("report", "output path and size")]
    }
    fn output_files(params: &Self::Params) -> Vec<PathBuf> {
        vec![params.path.clone()]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let img = render_pair(
            inputs.get("source_mesh")?,
            inputs.get("target_mesh")?,
            inputs.get("colors")?,
            (inputs.opt("source_curves")?, inputs.opt("target_curves")?),
            params,
            ctx.par,
        )
        .map_err(FmapError::into_node)?;
        let path = ctx.resolve(&params.path);
        write_png(&img, &path).map_err(|e| FmapError::Render(e.to_string()).into_node())?;
        let mut r = Report::new();
        r.set("path", path.display().to_string())
            .set("width", img.width as usize)
            .set("height", img.height as usize);
        Ok(Outputs::new().with("report", r))
    }
}
