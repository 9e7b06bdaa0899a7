//! A feature chain as an arc-length parametrised polyline of input vertices: where a feature
//! vertex slides to (thesis §5.1.1: feature vertices move along their curve only), and how far
//! an output edge between two points of the chain strays from the chain between them (an edge
//! may only replace a part of the chain that is straight within a tolerance, so that features
//! are kept exactly).

use crestflow_geom::vec3::{self, V3};

use crate::bvh::closest_on_segment;

/// One chain: its points in order, their arc lengths, and whether it is a loop without a
/// corner (then parameters wrap around; the last point repeats the first).
#[derive(Clone, Debug)]
pub struct Chain {
    pts: Vec<V3>,
    cum: Vec<f64>,
    closed: bool,
}

impl Chain {
    /// `pts` needs at least two points; a `closed` chain repeats its first point at the end.
    pub fn new(pts: Vec<V3>, closed: bool) -> Chain {
        let mut cum = Vec::with_capacity(pts.len());
        let mut s = 0.0;
        for (i, p) in pts.iter().enumerate() {
            if i > 0 {
                s += vec3::dist(pts[i - 1], *p);
            }
            cum.push(s);
        }
        Chain { pts, cum, closed }
    }

    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// Arc length of the whole chain.
    pub fn total(&self) -> f64 {
        self.cum.last().copied().unwrap_or(0.0)
    }

    /// First and last point (equal for loops).
    pub fn ends(&self) -> (V3, V3) {
        (self.pts[0], self.pts[self.pts.len() - 1])
    }

    /// `s` wrapped into [0, total) for loops, clamped into [0, total] otherwise.
    pub fn wrap(&self, s: f64) -> f64 {
        let t = self.total();
        if !(t > 0.0) {
            0.0
        } else if self.closed {
            s.rem_euclid(t)
        } else {
            s.clamp(0.0, t)
        }
    }

    /// The point at arc length `s`.
    pub fn point_at(&self, s: f64) -> V3 {
        let s = self.wrap(s);
        let n = self.pts.len();
        if n < 2 {
            return self.pts[0];
        }
        let i = self.cum.partition_point(|&c| c <= s).clamp(1, n - 1) - 1;
        let len = self.cum[i + 1] - self.cum[i];
        if !(len > 0.0) {
            return self.pts[i];
        }
        vec3::lerp(self.pts[i], self.pts[i + 1], (s - self.cum[i]) / len)
    }

    /// The stretch of chain between parameters `a` and `b`, as `(lo, hi)` with `lo <= hi`; on a
    /// loop, the shorter way round (then `hi` may exceed the total length).
    pub fn interval(&self, a: f64, b: f64) -> (f64, f64) {
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        let t = self.total();
        if self.closed && hi - lo > 0.5 * t {
            (hi, lo + t)
        } else {
            (lo, hi)
        }
    }

    /// The stretch between `a` and `b` (parameters in [0, total)) that contains the parameter
    /// `s`, as `(lo, hi)` with `lo` one of the two and `lo <= hi`: on a loop, the way round
    /// through `s`, long or short (a vertex lies on the stretch joining its two chain
    /// neighbours even when a short loop makes that the longer way); elsewhere
    /// [`Chain::interval`].
    pub fn interval_through(&self, a: f64, b: f64, s: f64) -> (f64, f64) {
        self.arc_by(a, b, s, true)
    }

    /// The stretch between `a` and `b` that does not contain the parameter `s`: on a loop, the
    /// stretch an edge stands for, given a chain vertex off the edge; elsewhere
    /// [`Chain::interval`].
    pub fn interval_avoiding(&self, a: f64, b: f64, s: f64) -> (f64, f64) {
        self.arc_by(a, b, s, false)
    }

    /// The way round a loop between `a` and `b` that contains `s` (`through`) or not; the
    /// shorter one ([`Chain::interval`]) where `s` lies strictly inside neither (at `a` or
    /// `b`: the parameters of a curve chain's vertices may repeat).
    fn arc_by(&self, a: f64, b: f64, s: f64, through: bool) -> (f64, f64) {
        let short = self.interval(a, b);
        if !self.closed {
            return short;
        }
        let [inner, outer] = self.arcs(a, b);
        let long = if short == inner { outer } else { inner };
        let (in_short, in_long) = (self.inside(short, s), self.inside(long, s));
        match (through, in_short, in_long) {
            (true, false, true) | (false, true, false) => long,
            _ => short,
        }
    }

    /// The two ways round a loop between `a` and `b`: `(lo, hi)` and `(hi, lo + total)`.
    fn arcs(&self, a: f64, b: f64) -> [(f64, f64); 2] {
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        [(lo, hi), (hi, lo + self.total())]
    }

    /// Whether `s` lies strictly inside the stretch `(lo, hi)`.
    fn inside(&self, (lo, hi): (f64, f64), s: f64) -> bool {
        let s = self.wrap(s);
        let t = self.total();
        (lo < s && s < hi) || (lo < s + t && s + t < hi)
    }

    /// Middle parameter of the stretch between `a` and `b` (wrapped).
    pub fn middle(&self, a: f64, b: f64) -> f64 {
        let (lo, hi) = self.interval(a, b);
        self.wrap(0.5 * (lo + hi))
    }

    /// The parameter of the point strictly inside the stretch between `a` and `b` where the
    /// chain turns most (`None` when no point lies inside).
    pub fn sharpest_between(&self, a: f64, b: f64) -> Option<f64> {
        let (lo, hi) = self.interval(a, b);
        self.sharpest_over(lo, hi)
    }

    /// [`Chain::sharpest_between`] over the stretch `(lo, hi)` (as [`Chain::interval`] and its
    /// variants give it).
    pub fn sharpest_over(&self, lo: f64, hi: f64) -> Option<f64> {
        let n = self.pts.len();
        let t = self.total();
        let laps = if self.closed { 2 } else { 1 };
        // Cosine of the turn at point i (1 = straight); a loop's first and last point are one.
        let cos_turn = |i: usize| -> Option<f64> {
            let (prev, next) = if i == 0 || i == n - 1 {
                if !self.closed || n < 3 {
                    return None;
                }
                (n - 2, 1)
            } else {
                (i - 1, i + 1)
            };
            let d0 = vec3::sub(self.pts[i], self.pts[prev]);
            let d1 = vec3::sub(self.pts[next], self.pts[i]);
            let l = vec3::norm(d0) * vec3::norm(d1);
            (l > 0.0).then(|| vec3::dot(d0, d1) / l)
        };
        let mut best: Option<(f64, f64)> = None;
        for lap in 0..laps {
            let off = lap as f64 * t;
            let start = self.cum.partition_point(|&c| c + off <= lo);
            for i in start..n {
                if self.cum[i] + off >= hi {
                    break;
                }
                if let Some(c) = cos_turn(i) {
                    if best.is_none_or(|(bc, _)| c < bc) {
                        best = Some((c, self.wrap(self.cum[i] + off)));
                    }
                }
            }
        }
        best.map(|(_, s)| s)
    }

    /// Largest distance from the chain's points strictly inside the stretch between `a` and
    /// `b` to the segment [pa, pb].
    pub fn deviation(&self, a: f64, b: f64, pa: V3, pb: V3) -> f64 {
        let (lo, hi) = self.interval(a, b);
        self.deviation_over(lo, hi, pa, pb)
    }

    /// [`Chain::deviation`] over the stretch `(lo, hi)` (as [`Chain::interval`] and its
    /// variants give it).
    pub fn deviation_over(&self, lo: f64, hi: f64, pa: V3, pb: V3) -> f64 {
        self.farthest_over(lo, hi, pa, pb).map_or(0.0, |(d, _)| d)
    }

    /// The chain's point strictly inside the stretch `(lo, hi)` farthest from the segment
    /// [pa, pb] (the first of equals): its distance and parameter; `None` when no point lies
    /// inside.
    pub fn farthest_over(&self, lo: f64, hi: f64, pa: V3, pb: V3) -> Option<(f64, f64)> {
        let t = self.total();
        let laps = if self.closed { 2 } else { 1 };
        let mut worst: Option<(f64, f64)> = None;
        for lap in 0..laps {
            let off = lap as f64 * t;
            let start = self.cum.partition_point(|&c| c + off <= lo);
            for i in start..self.pts.len() {
                if self.cum[i] + off >= hi {
                    break;
                }
                let (q, _) = closest_on_segment(self.pts[i], pa, pb);
                let d = vec3::dist(q, self.pts[i]);
                if worst.is_none_or(|(w, _)| d > w) {
                    worst = Some((d, self.wrap(self.cum[i] + off)));
                }
            }
        }
        worst
    }
}

impl Chain {
    /// Per point, the longest output edge the chain allows around it: the longest chord over
    /// at most 64 points whose stretch of chain contains the point and stays within `tol` of
    /// the chord, capped at `cap`. On a loop, chords may wrap around but not span more than
    /// half of it.
    pub fn edge_capacity(&self, tol: f64, cap: f64) -> Vec<f64> {
        const WINDOW: usize = 64;
        let n = self.pts.len();
        let total = self.total();
        // A loop repeats its first point at the end: wrap over the n - 1 distinct ones.
        let m = if self.closed {
            n.saturating_sub(1).max(1)
        } else {
            n
        };
        // For each start point, how many points its longest admissible chord spans, and its
        // arc length.
        let reach: Vec<(usize, f64)> = (0..m)
            .map(|a| {
                let sa = self.cum[a];
                let pa = self.pts[a];
                let mut best = (0, 0.0);
                for k in 1..=WINDOW {
                    let j = a + k;
                    let (sj, span) = if self.closed {
                        let sj = self.cum[j % m];
                        (sj, (sj - sa).rem_euclid(total))
                    } else {
                        if j >= n {
                            break;
                        }
                        (self.cum[j], self.cum[j] - sa)
                    };
                    if self.closed && (span > 0.5 * total || k >= m) {
                        break;
                    }
                    if span > cap {
                        // A single segment longer than the cap still allows the cap.
                        if k == 1 {
                            best = (1, cap);
                        }
                        break;
                    }
                    if k > 1 && self.deviation(sa, sj, pa, self.point_at(sj)) > tol {
                        break;
                    }
                    best = (k, span);
                }
                best
            })
            .collect();
        (0..n)
            .map(|i| {
                let i = i % m;
                let mut h: f64 = 0.0;
                for d in 0..=WINDOW.min(if self.closed { m - 1 } else { i }) {
                    let a = (i + m - d) % m;
                    if reach[a].0 >= d {
                        h = h.max(reach[a].1);
                    }
                }
                h.min(cap)
            })
            .collect()
    }

    /// The point index `i` with `cum[i] <= s < cum[i + 1]` (wrapped like [`Chain::point_at`]).
    pub fn segment_at(&self, s: f64) -> usize {
        let s = self.wrap(s);
        let n = self.pts.len();
        if n < 2 {
            return 0;
        }
        self.cum.partition_point(|&c| c <= s).clamp(1, n - 1) - 1
    }
}

#[cfg(test)]
#[path = "chain_test.rs"]
mod tests;
