//! Arc resampling (thesis §4.3.3.2, "Feature Curve Resampling"): an arc is densely sampled, and
//! the polyline through a subset of the samples whose edges all have their length in
//! S = [r_min, r_max] and whose integral deviation from the arc is smallest is found as a
//! shortest path in the DAG of sample pairs (i < j with |p_i p_j| in S, weight
//! Σ_{i<k<j} d(p_k, [p_i, p_j]) · Δs_k). Samples are visited in order, so Dijkstra reduces to one
//! pass of dynamic programming.
//!
//! When no such path exists the arc gets a special edge: a *long* edge (> r_max) at its end
//! when the rest of the arc can be resampled, otherwise one edge joining its two ends (*short*
//! when the ends are closer than r_min). Closed loops are tried from several start samples
//! and the cheapest one is kept.

use crestflow_geom::vec3::{self, V3};

use crate::conflicts::{point_segment_distance, Scale};

/// One dense sample of an arc.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    pub pos: V3,
    pub strength: f64,
    /// The input curve the sample lies on.
    pub src: u32,
    /// The network vertex the sample is, if it is one.
    pub orig: Option<u32>,
    /// Arc length from the first sample.
    pub s: f64,
}

/// One vertex of an arc polyline handed to [`dense_samples`].
#[derive(Clone, Debug, PartialEq)]
pub struct ArcPoint {
    pub pos: V3,
    pub strength: f64,
    pub orig: u32,
}

/// Dense samples along the polyline `pts` (for a closed arc the first point is repeated at the
/// end by this function), at most `h` apart. `seg_src[k]` is the input curve of segment k.
/// Vertices closer than h/2 (along the arc) to the previous sample are skipped, so very dense
/// input arcs are thinned to spacing about h.
pub fn dense_samples(pts: &[ArcPoint], seg_src: &[u32], closed: bool, h: f64) -> Vec<Sample> {
    let mut out: Vec<Sample> = Vec::new();
    if pts.is_empty() {
        return out;
    }
    let n_seg = if closed { pts.len() } else { pts.len() - 1 };
    out.push(Sample {
        pos: pts[0].pos,
        strength: pts[0].strength,
        src: seg_src.first().copied().unwrap_or(0),
        orig: Some(pts[0].orig),
        s: 0.0,
    });
    let mut s = 0.0;
    for k in 0..n_seg {
        let a = &pts[k];
        let b = &pts[(k + 1) % pts.len()];
        let src = seg_src[k];
        let len = vec3::dist(a.pos, b.pos);
        let pieces = if len > h {
            (len / h).ceil() as usize
        } else {
            1
        };
        for t in 1..pieces {
            let f = t as f64 / pieces as f64;
            out.push(Sample {
                pos: vec3::lerp(a.pos, b.pos, f),
                strength: a.strength + f * (b.strength - a.strength),
                src,
                orig: None,
                s: s + f * len,
            });
        }
        s += len;
        let last = k + 1 == n_seg;
        let gap = s - out.last().map_or(0.0, |x| x.s);
        if last || gap >= 0.5 * h {
            out.push(Sample {
                pos: b.pos,
                strength: b.strength,
                src,
                orig: Some(b.orig),
                s,
            });
        }
    }
    out
}

fn deviation(sm: &[Sample], i: usize, j: usize) -> f64 {
    let (a, b) = (sm[i].pos, sm[j].pos);
    let mut d = 0.0;
    for k in i + 1..j {
        let ds = 0.5 * (sm[k + 1].s - sm[k - 1].s);
        d += point_segment_distance(sm[k].pos, a, b) * ds;
    }
    d
}

/// The cheapest path from sample 0 to the last sample with every edge in S, or with one long
/// edge at the end when none exists (`allow_long`). Returns the sample indices and the cost.
/// Candidate edges span at most 3 r_max of arc length and `max_window` samples.
pub fn shortest_path(
    sm: &[Sample],
    s: &Scale,
    allow_long: bool,
    max_window: usize,
) -> Option<(Vec<usize>, f64)> {
    let n = sm.len();
    if n < 2 {
        return None;
    }
    let span = 3.0 * s.r_max;
    let mut cost = vec![f64::INFINITY; n];
    let mut pred = vec![usize::MAX; n];
    cost[0] = 0.0;
    for j in 1..n {
        let mut i = j;
        while i > 0 {
            i -= 1;
            if sm[j].s - sm[i].s > span || j - i > max_window {
                break;
            }
            if !cost[i].is_finite() || !s.in_range(vec3::dist(sm[i].pos, sm[j].pos)) {
                continue;
            }
            let c = cost[i] + deviation(sm, i, j);
            if c < cost[j] {
                cost[j] = c;
                pred[j] = i;
            }
        }
    }
    let last = n - 1;
    if !cost[last].is_finite() {
        if !allow_long {
            return None;
        }
        let mut best: Option<(f64, usize)> = None;
        let mut i = last;
        while i > 0 {
            i -= 1;
            if sm[last].s - sm[i].s > span || last - i > max_window {
                break;
            }
            if !cost[i].is_finite() || !s.is_long(vec3::dist(sm[i].pos, sm[last].pos)) {
                continue;
            }
            let c = cost[i] + deviation(sm, i, last);
            if best.is_none_or(|(b, _)| c < b) {
                best = Some((c, i));
            }
        }
        let (c, i) = best?;
        cost[last] = c;
        pred[last] = i;
    }
    let mut path = vec![last];
    let mut k = last;
    while k != 0 {
        k = pred[k];
        path.push(k);
    }
    path.reverse();
    Some((path, cost[last]))
}

/// Spacing of the dense samples: a quarter of min(r_min, r_max − r_min), so that every
/// length in S is within a sample of a candidate edge.
pub fn sample_spacing(s: &Scale) -> f64 {
    (s.r_min.min(s.r_max - s.r_min) / 4.0).max(s.r_min * 1e-3)
}

/// The resampled polyline of an arc as sample indices into the returned samples, or `None` for
/// a closed loop that cannot be represented at this scale (fewer than three edges in S).
pub fn resample_arc(
    pts: &[ArcPoint],
    seg_src: &[u32],
    closed: bool,
    s: &Scale,
    starts: usize,
) -> Option<(Vec<Sample>, Vec<usize>)> {
    let h = sample_spacing(s);
    let max_window = 4000;
    if !closed {
        let sm = dense_samples(pts, seg_src, false, h);
        let path = shortest_path(&sm, s, true, max_window)
            .map(|(p, _)| p)
            .unwrap_or_else(|| vec![0, sm.len() - 1]);
        return Some((sm, path));
    }
    let mut best: Option<(f64, Vec<Sample>, Vec<usize>)> = None;
    let m = pts.len();
    let starts = starts.clamp(1, m);
    for t in 0..starts {
        let k0 = t * m / starts;
        let rot: Vec<ArcPoint> = (0..m).map(|k| pts[(k0 + k) % m].clone()).collect();
        let rsrc: Vec<u32> = (0..m).map(|k| seg_src[(k0 + k) % m]).collect();
        let sm = dense_samples(&rot, &rsrc, true, h);
        if let Some((path, c)) = shortest_path(&sm, s, false, max_window) {
            if path.len() >= 4 && best.as_ref().is_none_or(|(b, _, _)| c < *b) {
                best = Some((c, sm, path));
            }
        }
    }
    best.map(|(_, sm, mut path)| {
        // The last sample repeats the first one.
        path.pop();
        (sm, path)
    })
}
