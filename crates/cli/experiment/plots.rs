//! Plots of an experiment (DESIGN §6): for each numeric swept param, one PNG with a panel per
//! metric, the metric against the param, one line per combination of the other settings
//! (variant, input, …). Drawn with plotters into an RGB buffer and encoded with `png`; text
//! uses an embedded DejaVu Sans (no system fonts).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use super::{fmt_sig, Experiment, RunResult};
use crate::batch::ron_text_as_string;

const FONT: &str = "sans-serif";
const PANEL_W: u32 = 460;
const PANEL_H: u32 = 320;
const MAX_PANELS: usize = 12;

fn init_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // A broken embedded font only loses the labels; plotting reports the error.
        let _ = register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
    });
}

/// Swept params with numeric values and at least two of them, in file order.
pub fn numeric_sweeps(exp: &Experiment) -> Vec<String> {
    exp.grid
        .iter()
        .chain(&exp.zip)
        .filter(|(_, vals)| {
            let nums: Option<Vec<f64>> = vals
                .iter()
                .map(|v| ron_text_as_string(v).parse::<f64>().ok())
                .collect();
            nums.is_some_and(|n| {
                let d: BTreeSet<u64> = n.iter().map(|x| x.to_bits()).collect();
                d.len() > 1
            })
        })
        .map(|(k, _)| k.clone())
        .collect()
}

fn setting(r: &RunResult, k: &str) -> Option<String> {
    r.settings
        .iter()
        .find(|(n, _)| n == k)
        .map(|(_, v)| v.clone())
}

/// Metrics to plot: those asked for, else the numeric ones that vary between runs.
fn metrics_to_plot(exp: &Experiment, results: &[RunResult]) -> Vec<String> {
    if !exp.plot.is_empty() {
        return exp.plot.clone();
    }
    let names: BTreeSet<&String> = results.iter().flat_map(|r| r.metrics.keys()).collect();
    names
        .into_iter()
        .filter(|m| {
            let vals: BTreeSet<u64> = results
                .iter()
                .filter_map(|r| r.metrics.get(*m).and_then(|c| c.num()))
                .map(f64::to_bits)
                .collect();
            vals.len() > 1
        })
        .take(MAX_PANELS)
        .cloned()
        .collect()
}

type Series = BTreeMap<String, Vec<(f64, f64)>>;

/// Writes one PNG per numeric sweep; returns their paths.
pub fn write_plots(
    exp: &Experiment,
    results: &[RunResult],
    out: &Path,
) -> Result<Vec<PathBuf>, (PathBuf, String)> {
    let sweeps = numeric_sweeps(exp);
    let metrics = metrics_to_plot(exp, results);
    if sweeps.is_empty() || metrics.is_empty() {
        return Ok(Vec::new());
    }
    init_font();
    // Settings that differ between runs name the lines.
    let mut names: Vec<String> = Vec::new();
    for r in results {
        for (k, _) in &r.settings {
            if !names.contains(k) {
                names.push(k.clone());
            }
        }
    }
    let differing: Vec<String> = names
        .into_iter()
        .filter(|k| {
            let v: BTreeSet<Option<String>> = results.iter().map(|r| setting(r, k)).collect();
            v.len() > 1
        })
        .collect();
    let mut written = Vec::new();
    for sweep in &sweeps {
        let mut panels: Vec<(String, Series)> = Vec::new();
        for m in &metrics {
            // Settings the metric does not depend on would only draw the same line twice.
            let mut keys: Vec<&String> = differing.iter().filter(|k| *k != sweep).collect();
            let all: Vec<&String> = differing.iter().collect();
            keys.retain(|k| !independent_of(results, m, k, &all));
            let mut series: Series = BTreeMap::new();
            for r in results {
                let Some(x) = setting(r, sweep).and_then(|v| ron_text_as_string(&v).parse().ok())
                else {
                    continue;
                };
                let Some(y) = r.metrics.get(m).and_then(|c| c.num()) else {
                    continue;
                };
                let label = keys
                    .iter()
                    .filter_map(|k| setting(r, k).map(|v| ron_text_as_string(&v)))
                    .collect::<Vec<_>>()
                    .join(", ");
                series.entry(label).or_default().push((x, y));
            }
            for pts in series.values_mut() {
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                pts.dedup_by(|a, b| a.0 == b.0 && a.1 == b.1);
            }
            if !series.is_empty() {
                panels.push((m.clone(), series));
            }
        }
        if panels.is_empty() {
            continue;
        }
        let path = out.join(format!("plot_{}.png", super::safe(sweep)));
        draw(&path, sweep, &panels).map_err(|e| (path.clone(), e))?;
        written.push(path);
    }
    Ok(written)
}

/// Whether `metric` is the same in every two runs that differ only in setting `k`.
fn independent_of(results: &[RunResult], metric: &str, k: &str, all: &[&String]) -> bool {
    let mut by_rest: BTreeMap<Vec<Option<String>>, u64> = BTreeMap::new();
    for r in results {
        let Some(v) = r.metrics.get(metric).and_then(|c| c.num()) else {
            continue;
        };
        let rest: Vec<Option<String>> = all
            .iter()
            .filter(|n| n.as_str() != k)
            .map(|n| setting(r, n))
            .collect();
        if *by_rest.entry(rest).or_insert(v.to_bits()) != v.to_bits() {
            return false;
        }
    }
    true
}

fn range(vals: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in vals {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 * (1.0 + lo.abs()) {
        let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        return (lo - d, hi + d);
    }
    let pad = 0.06 * (hi - lo);
    (lo - pad, hi + pad)
}

fn draw(path: &Path, sweep: &str, panels: &[(String, Series)]) -> Result<(), String> {
    let cols = panels.len().min(3);
    let rows = panels.len().div_ceil(cols);
    let (w, h) = (PANEL_W * cols as u32, PANEL_H * rows as u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let areas = root.split_evenly((rows, cols));
        for ((metric, series), area) in panels.iter().zip(areas.iter()) {
            let (x0, x1) = range(series.values().flatten().map(|p| p.0));
            let (y0, y1) = range(series.values().flatten().map(|p| p.1));
            let mut chart = ChartBuilder::on(area)
                .caption(metric, (FONT, 16))
                .margin(10)
                .x_label_area_size(34)
                .y_label_area_size(62)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc(sweep)
                .x_labels(6)
                .y_labels(6)
                .x_label_formatter(&|v| fmt_sig(*v))
                .y_label_formatter(&|v| fmt_sig(*v))
                .label_style((FONT, 12))
                .axis_desc_style((FONT, 13))
                .draw()
                .map_err(|e| e.to_string())?;
            for (k, (label, pts)) in series.iter().enumerate() {
                let color = Palette99::pick(k).to_rgba();
                chart
                    .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
                    .map_err(|e| e.to_string())?
                    .label(if label.is_empty() { "all" } else { label })
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
                    });
                chart
                    .draw_series(
                        pts.iter()
                            .map(|&(x, y)| Circle::new((x, y), 3, color.filled())),
                    )
                    .map_err(|e| e.to_string())?;
            }
            chart
                .configure_series_labels()
                .label_font((FONT, 11))
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(|e| e.to_string())?;
    writer.write_image_data(&buf).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())?;
    Ok(())
}
