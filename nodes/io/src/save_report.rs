//! `io.save_report`: writes a [`Report`] (the named numbers evaluation nodes produce, e.g. the
//! curvature errors of thesis §2.4's estimators) as pretty JSON, for scripts and later
//! comparison.

use std::path::{Path, PathBuf};

use crestflow_flow::{
    Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Report, Validate,
};
use serde::{Deserialize, Serialize};

/// Parameters of `io.save_report`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SaveReportParams {
    /// Output file (`.json`), relative to the pipeline file's folder. Folders are created.
    /// Required.
    pub path: PathBuf,
}

impl Default for SaveReportParams {
    fn default() -> Self {
        SaveReportParams {
            path: PathBuf::new(),
        }
    }
}

impl Validate for SaveReportParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let ext = self
            .path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        if self.path.as_os_str().is_empty() {
            vec![ParamIssue::new("path", "an output file is required")]
        } else if ext.as_deref() != Some("json") {
            vec![ParamIssue::new(
                "path",
                "reports are written as JSON: use a .json file",
            )]
        } else {
            Vec::new()
        }
    }
}

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum SaveReportError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: cannot encode the report: {source}", path.display())]
    Json {
        path: PathBuf,
        source: serde_json::Error,
    },
}

/// Writes `report` to `path` (already resolved) as pretty JSON (`Report::to_json`: numbers stay
/// numbers, NaN and infinities become null), through a temporary file renamed over the target.
pub fn save_report(report: &Report, path: &Path, _par: Par) -> Result<(), SaveReportError> {
    let io = |source| SaveReportError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut text = serde_json::to_string_pretty(&report.to_json()).map_err(|source| {
        SaveReportError::Json {
            path: path.to_path_buf(),
            source,
        }
    })?;
    text.push('\n');
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".partial");
    let tmp = path.with_file_name(name);
    std::fs::write(&tmp, text).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(io)
}

/// `io.save_report`.
pub struct SaveReportNode;

impl NodeKind for SaveReportNode {
    type Params = SaveReportParams;
    const KIND: &'static str = "io.save_report";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Writes a Report (named numbers and texts, e.g. the curvature \
        errors of the thesis §2.4 estimators) to a pretty-printed JSON object.";

    fn inputs() -> Vec<Port> {
        vec![Port::of::<Report>("report", "the report to write")]
    }
    fn outputs() -> Vec<Port> {
        Vec::new()
    }
    fn output_files(params: &Self::Params) -> Vec<PathBuf> {
        vec![params.path.clone()]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let report = inputs.get::<Report>("report")?;
        save_report(report, &ctx.resolve(&params.path), ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new())
    }
}
