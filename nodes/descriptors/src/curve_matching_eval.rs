//! `eval.curve_matching`: how well a curve matching recovers known correspondences (thesis
//! §3.1.4): the proportion of correct nearest and Hungarian matches (Table 3.1, Table 3.3)
//! and the receiver-operator characteristic over the descriptor distance threshold t_d
//! (Fig. 3.6), drawn as a PNG with a logarithmic false-positive axis.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, ParamIssue, Port, Report, Validate,
};

use crate::match_curves::CurveMatching;

/// Parameters of `eval.curve_matching`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CurveMatchingEvalParams {
    /// Ground-truth pairs (source curve, target curve). Empty (default): curve i corresponds
    /// to curve i, as for one network evaluated on two poses with the same connectivity.
    pub ground_truth: Vec<[u32; 2]>,
    /// Report keys are `accuracy.<label>.nearest` etc., or `accuracy.nearest` when empty
    /// (default).
    pub label: String,
    /// Where to write the ROC curve (PNG); empty (default) writes nothing.
    pub roc_path: String,
}

impl Validate for CurveMatchingEvalParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if !self.roc_path.is_empty() && !self.roc_path.to_ascii_lowercase().ends_with(".png") {
            issues.push(ParamIssue::new(
                "roc_path",
                "the ROC curve is a PNG: use a .png file",
            ));
        }
        if self.label.contains(|c: char| c.is_whitespace()) {
            issues.push(ParamIssue::new("label", "no spaces in a report key"));
        }
        issues
    }
}

/// Errors of [`curve_matching_eval`].
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error("ground-truth pair {index} = ({s}, {t}) is out of range: {n_source} source and {n_target} target curves")]
    PairOutOfRange {
        index: usize,
        s: u32,
        t: u32,
        n_source: usize,
        n_target: usize,
    },
    #[error("no ground-truth pairs (the networks have {n_source} and {n_target} curves)")]
    NoPairs { n_source: usize, n_target: usize },
    #[error("{}: cannot write the ROC image: {source}", path.display())]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: cannot encode the ROC image: {message}", path.display())]
    Encode { path: PathBuf, message: String },
}

/// One ROC point: (false-positive rate, true-positive rate) at a threshold.
pub type RocPoint = (f64, f64);

/// The outcome of an evaluation.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveMatchingEval {
    pub accuracy_nearest: f64,
    pub accuracy_hungarian: f64,
    pub pairs: usize,
    /// ROC from threshold 0 to the largest distance.
    pub roc: Vec<RocPoint>,
    /// Area under the ROC (linear axes).
    pub auc: f64,
}

/// Accuracy and ROC of `matching` against `ground_truth` (identity when empty).
pub fn curve_matching_eval(
    matching: &CurveMatching,
    ground_truth: &[[u32; 2]],
) -> Result<CurveMatchingEval, EvalError> {
    let (n, m) = (matching.n_source, matching.n_target);
    let pairs: Vec<[u32; 2]> = if ground_truth.is_empty() {
        (0..n.min(m) as u32).map(|i| [i, i]).collect()
    } else {
        ground_truth.to_vec()
    };
    if pairs.is_empty() {
        return Err(EvalError::NoPairs {
            n_source: n,
            n_target: m,
        });
    }
    let mut positive = vec![false; n * m];
    for (index, &[s, t]) in pairs.iter().enumerate() {
        if s as usize >= n || t as usize >= m {
            return Err(EvalError::PairOutOfRange {
                index,
                s,
                t,
                n_source: n,
                n_target: m,
            });
        }
        positive[s as usize * m + t as usize] = true;
    }
    let correct = |assign: &[Option<u32>]| {
        pairs
            .iter()
            .filter(|&&[s, t]| assign[s as usize] == Some(t))
            .count() as f64
            / pairs.len() as f64
    };
    let accuracy_nearest = correct(&matching.nearest);
    let accuracy_hungarian = correct(&matching.hungarian);

    // ROC: sort all pairs by distance; sweep the threshold over the distinct values.
    let mut order: Vec<usize> = (0..n * m).collect();
    order.sort_by(|&a, &b| matching.distances[a].total_cmp(&matching.distances[b]));
    let n_pos = positive.iter().filter(|&&p| p).count() as f64;
    let n_neg = (n * m) as f64 - n_pos;
    let mut roc = vec![(0.0, 0.0)];
    let (mut tp, mut fp) = (0.0, 0.0);
    let mut k = 0;
    while k < order.len() {
        let d = matching.distances[order[k]];
        while k < order.len() && matching.distances[order[k]] == d {
            if positive[order[k]] {
                tp += 1.0;
            } else {
                fp += 1.0;
            }
            k += 1;
        }
        let fpr = if n_neg > 0.0 { fp / n_neg } else { 0.0 };
        roc.push((fpr, tp / n_pos));
    }
    let auc = roc
        .windows(2)
        .map(|w| (w[1].0 - w[0].0) * 0.5 * (w[1].1 + w[0].1))
        .sum();
    Ok(CurveMatchingEval {
        accuracy_nearest,
        accuracy_hungarian,
        pairs: pairs.len(),
        roc,
        auc,
    })
}

/// Draws the ROC (x: false-positive rate on a log axis from 1e-3 to 1; y: true-positive
/// rate from 0 to 1) with decade grid lines, and writes it as a PNG. No text: the axes are
/// fixed.
pub fn write_roc_png(roc: &[RocPoint], path: &Path) -> Result<(), EvalError> {
    const W: usize = 480;
    const H: usize = 400;
    const PAD: usize = 30;
    let mut img = vec![255u8; W * H * 3];
    let put = |img: &mut Vec<u8>, x: i64, y: i64, c: [u8; 3]| {
        if x >= 0 && y >= 0 && (x as usize) < W && (y as usize) < H {
            let i = (y as usize * W + x as usize) * 3;
            img[i..i + 3].copy_from_slice(&c);
        }
    };
    let (x0, x1) = (PAD as f64, (W - PAD) as f64);
    let (y0, y1) = ((H - PAD) as f64, PAD as f64);
    let sx = |fpr: f64| x0 + (x1 - x0) * ((fpr.max(1e-3).log10() + 3.0) / 3.0);
    let sy = |tpr: f64| y0 + (y1 - y0) * tpr;
    let line = |img: &mut Vec<u8>, a: (f64, f64), b: (f64, f64), c: [u8; 3], thick: i64| {
        let steps = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).max(1);
        for s in 0..=steps {
            let t = s as f64 / steps as f64;
            let x = (a.0 + t * (b.0 - a.0)).round() as i64;
            let y = (a.1 + t * (b.1 - a.1)).round() as i64;
            for dx in 0..thick {
                for dy in 0..thick {
                    put(img, x + dx, y + dy, c);
                }
            }
        }
    };
    let grey = [210, 210, 210];
    for dec in [1e-3, 1e-2, 1e-1, 1.0] {
        line(&mut img, (sx(dec), y0), (sx(dec), y1), grey, 1);
    }
    for k in 0..=10 {
        let y = sy(k as f64 / 10.0);
        line(&mut img, (x0, y), (x1, y), grey, 1);
    }
    line(&mut img, (x0, y0), (x1, y0), [0, 0, 0], 2);
    line(&mut img, (x0, y0), (x0, y1), [0, 0, 0], 2);
    for w in roc.windows(2) {
        // A step curve: the rate of true positives changes at a fixed false-positive rate.
        let a = (sx(w[0].0), sy(w[0].1));
        let b = (sx(w[1].0), sy(w[1].1));
        line(&mut img, a, b, [200, 30, 30], 2);
    }
    let file = std::fs::File::create(path).map_err(|source| EvalError::Write {
        path: path.to_path_buf(),
        source,
    })?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), W as u32, H as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let encode_err = |e: png::EncodingError| EvalError::Encode {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut writer = enc.write_header().map_err(encode_err)?;
    writer.write_image_data(&img).map_err(encode_err)?;
    writer.finish().map_err(encode_err)?;
    Ok(())
}

/// Node wrapper of [`curve_matching_eval`].
pub struct CurveMatchingEvalNode;

impl NodeKind for CurveMatchingEvalNode {
    type Params = CurveMatchingEvalParams;
    const KIND: &'static str = "eval.curve_matching";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Accuracy of a curve matching against ground-truth pairs \
        (identity by default) for nearest and Hungarian matching, and the ROC over the \
        descriptor distance threshold as a PNG (thesis §3.1.4, Table 3.1, Fig. 3.6). Reports \
        accuracy[.label].nearest, accuracy[.label].hungarian, roc[.label].auc; a `previous` \
        report is merged in so several evaluations end in one report.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<CurveMatching>("matching", "the matching to evaluate"),
            Port::optional::<Report>("previous", "a report to extend"),
        ]
    }

    fn outputs() -> Vec<Port> {
        vec![Port::of::<Report>("report", "accuracies and ROC area")]
    }

    fn output_files(params: &Self::Params) -> Vec<PathBuf> {
        if params.roc_path.is_empty() {
            Vec::new()
        } else {
            vec![PathBuf::from(&params.roc_path)]
        }
    }

    fn run(
        params: &CurveMatchingEvalParams,
        inputs: &Inputs,
        ctx: &Ctx,
    ) -> Result<Outputs, NodeError> {
        let matching = inputs.get::<CurveMatching>("matching")?;
        let eval = curve_matching_eval(matching, &params.ground_truth)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        if !params.roc_path.is_empty() {
            let path = ctx.resolve(&params.roc_path);
            if let Some(dir) = path.parent() {
                std::fs::create_dir_all(dir).map_err(|source| {
                    NodeError::from_source(
                        ErrorKind::InvalidInput,
                        EvalError::Write {
                            path: dir.to_path_buf(),
                            source,
                        },
                    )
                })?;
            }
            write_roc_png(&eval.roc, &path)
                .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        }
        let mut report = inputs
            .opt::<Report>("previous")?
            .cloned()
            .unwrap_or_default();
        let key = |group: &str, what: &str| {
            if params.label.is_empty() {
                format!("{group}.{what}")
            } else {
                format!("{group}.{}.{what}", params.label)
            }
        };
        report.set(key("accuracy", "nearest"), eval.accuracy_nearest);
        report.set(key("accuracy", "hungarian"), eval.accuracy_hungarian);
        report.set(key("roc", "auc"), eval.auc);
        report.set(key("pairs", "count"), eval.pairs);
        Ok(Outputs::new().with("report", report))
    }
}

#[cfg(test)]
#[path = "curve_matching_eval_test.rs"]
mod tests;
