//! crestflow node family `render`: pictures of meshes and feature curve networks, made headless
//! in pure Rust so that curves (thesis §2.5, Def. 2.1) can be inspected without a 3D program.
//!
//! - `render.png` ([`png::RenderPngNode`]): shaded mesh, optional mean-curvature colours, ridges
//!   and ravines drawn over it, written as a PNG.
//!
//! The rasterizer itself ([`raster`]) is a small z-buffer renderer with an orthographic camera.

use crestflow_flow::Registry;

pub mod png;
pub mod raster;

pub use png::{render, write_png, RenderError, RenderParams, RenderPngNode, Rendered};
pub use raster::{Camera, RgbImage, UpAxis, View};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<RenderPngNode>();
}
