//! `fmap.landmarks`: corresponding vertex pairs read from a text file.
//!
//! Format: one pair per line, `source_vertex target_vertex` (0-based mesh vertex indices,
//! separated by white space or a comma). Empty lines and lines starting with `#` are skipped.
//! The indices are checked against the meshes where they are used (`curves.shortest_path`),
//! with the file line in the message.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crestflow_flow::{Ctx, Inputs, NodeError, NodeKind, Outputs, ParamIssue, Port, Validate};

use crate::types::{FmapError, LandmarkPairs};

/// Parameters of `fmap.landmarks`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LandmarksParams {
    /// The landmark file, relative to the pipeline file (required).
    pub path: PathBuf,
}

impl Validate for LandmarksParams {
    fn validate(&self) -> Vec<ParamIssue> {
        if self.path.as_os_str().is_empty() {
            vec![ParamIssue::new("path", "the landmark file is not set")]
        } else {
            Vec::new()
        }
    }
}

/// Parses landmark pairs from `text`; `origin` names the text in errors.
pub fn parse_landmarks(text: &str, origin: &str) -> Result<LandmarkPairs, FmapError> {
    let mut out = LandmarkPairs {
        origin: origin.to_string(),
        ..Default::default()
    };
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let s = raw.trim();
        if s.is_empty() || s.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = s
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|f| !f.is_empty())
            .collect();
        if fields.len() != 2 {
            return Err(FmapError::Parse {
                origin: origin.to_string(),
                line,
                message: format!(
                    "expected two vertex indices `source target`, found {} fields in `{s}`",
                    fields.len()
                ),
            });
        }
        let mut pair = [0u32; 2];
        for (slot, f) in pair.iter_mut().zip(&fields) {
            *slot = f.parse::<u32>().map_err(|_| FmapError::Parse {
                origin: origin.to_string(),
                line,
                message: format!("`{f}` is not a vertex index (a non-negative integer)"),
            })?;
        }
        out.pairs.push(pair);
        out.lines.push(line);
    }
    if out.pairs.is_empty() {
        return Err(FmapError::NoLandmarks {
            origin: origin.to_string(),
        });
    }
    Ok(out)
}

/// Reads landmark pairs from a file.
pub fn read_landmarks(path: &Path) -> Result<LandmarkPairs, FmapError> {
    let text = crestflow_geom::io::read_text_file(path).map_err(|e| FmapError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string());
    parse_landmarks(&text, &name)
}

/// `count` landmarks by farthest-point sampling on `mesh` with edge-length (Dijkstra)
/// distances, starting from vertex `start`; paired with the same vertex index on the target
/// (for two meshes with one connectivity, such as the SMPL man and woman). Deterministic:
/// ties go to the smallest vertex index.
pub fn farthest_point_landmarks(
    mesh: &crestflow_geom::TriMesh,
    count: usize,
    start: u32,
) -> LandmarkPairs {
    use crestflow_geom::vec3::dist;
    let n = mesh.n_vertices();
    let topo = mesh.topology();
    let mut d = vec![f64::INFINITY; n];
    let mut out = LandmarkPairs {
        origin: format!("farthest-point sampling from vertex {start}"),
        ..Default::default()
    };
    let mut next = start.min(n.saturating_sub(1) as u32);
    for i in 0..count.min(n) {
        out.pairs.push([next, next]);
        out.lines.push(i + 1);
        // Dijkstra from `next`, keeping the minimum over all chosen landmarks.
        let mut heap = std::collections::BinaryHeap::new();
        d[next as usize] = 0.0;
        heap.push((std::cmp::Reverse(OrdF64(0.0)), next));
        while let Some((std::cmp::Reverse(OrdF64(du)), v)) = heap.pop() {
            if du > d[v as usize] {
                continue;
            }
            for &w in topo.neighbors(v) {
                let nd = du + dist(mesh.positions[v as usize], mesh.positions[w as usize]);
                if nd < d[w as usize] {
                    d[w as usize] = nd;
                    heap.push((std::cmp::Reverse(OrdF64(nd)), w));
                }
            }
        }
        let mut best = (f64::NEG_INFINITY, 0u32);
        for (v, &dv) in d.iter().enumerate() {
            if dv.is_finite() && dv > best.0 {
                best = (dv, v as u32);
            }
        }
        next = best.1;
    }
    out
}

#[derive(Clone, Copy, PartialEq)]
struct OrdF64(f64);
impl Eq for OrdF64 {}
impl PartialOrd for OrdF64 {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for OrdF64 {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

/// Node wrapper of [`read_landmarks`].
pub struct LandmarksNode;

impl NodeKind for LandmarksNode {
    type Params = LandmarksParams;
    const KIND: &'static str = "fmap.landmarks";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Reads corresponding vertex pairs `source_vertex target_vertex` \
        (0-based, one pair per line, `#` comments) from a text file: the endpoints from which \
        curves.shortest_path traces corresponding curves (thesis §5.2.2).";

    fn inputs() -> Vec<Port> {
        Vec::new()
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<LandmarkPairs>(
            "landmarks",
            "the vertex pairs with their file lines",
        )]
    }
    fn input_files(params: &Self::Params) -> Vec<PathBuf> {
        vec![params.path.clone()]
    }
    fn run(params: &Self::Params, _inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let lm = read_landmarks(&ctx.resolve(&params.path)).map_err(FmapError::into_node)?;
        Ok(Outputs::new().with("landmarks", lm))
    }
}

#[cfg(test)]
#[path = "landmarks_test.rs"]
mod tests;
