//! The geometric tests of scale conformity (thesis §4.3.2): the scale interval S = [r_min, r_max],
//! the feasible angle intervals of adjacent edges (§4.3.2.1), the triangulation configurations
//! (c) and (d) of Fig. 4.9 for nearby non-adjacent edges, and the search for every conflicting
//! edge pair and vertex pair of a network given as a plain edge list.
//!
//! `scale.conform` and `scale.check` share these predicates, so whatever the first returns the
//! second accepts.
//!
//! Angles. Every triangle of an extension M_sc has its edges in S, so its angles lie in
//! [θ_min, θ_max] with θ_min = min(arccos(r_max / 2 r_min), 2 arcsin(r_min / 2 r_max)) (the
//! thesis' triangle types (a) and (b)) and θ_max = 2 arcsin(min(1, r_max / 2 r_min)) (two
//! shortest sides around the longest one). Two feature edges at a common vertex are separated by
//! one, two or three triangles, so their angle must lie in ∪_{k=1..3} [k θ_min, k θ_max]
//! (capped at π).
//!
//! Non-adjacent edges e_i = (a, b), e_j = (c, d) closer than r_min (segment to segment) conflict
//! unless one of two triangulations between them has all its edges at least r_min long:
//! - (c) a strip of two triangles: the sides (a, c), (b, d) (or (a, d), (b, c)) and one
//!   diagonal at least r_min long, and the two triangles not folded over each other (their
//!   normals agree, which rules out crossing edges);
//! - (d) one triangle on one edge with the nearer end point of the other edge as apex: both
//!   apex edges at least r_min long, and the angles β_1, β_2 between the other edge and the
//!   apex edges both at least 2 θ_min, so that two more triangles fit between them.
//!
//! Vertex conflicts: two extraordinary vertices (valence 1 or ≥ 3) closer than r_min.

use crestflow_flow::Par;
use crestflow_geom::vec3::{self, V3};

/// Relative slack of every length and angle comparison (floating-point noise only).
pub const EPS: f64 = 1e-9;

/// The scale interval S = [r_min, r_max] and the angle intervals it implies.
#[derive(Clone, Debug, PartialEq)]
pub struct Scale {
    pub r_min: f64,
    pub r_max: f64,
    pub theta_min: f64,
    pub theta_max: f64,
    /// Disjoint, sorted feasible angle intervals in [0, π].
    pub angles: Vec<(f64, f64)>,
    /// Whether special long edges are allowed ([`Scale::is_special_long`]; off by default).
    pub special_long: bool,
}

impl Scale {
    /// `r_min > 0`, `aspect = r_max / r_min > 1`.
    pub fn new(r_min: f64, aspect: f64) -> Scale {
        let r_max = r_min * aspect;
        let ta = (r_max / (2.0 * r_min)).min(1.0).acos();
        let tb = 2.0 * (r_min / (2.0 * r_max)).min(1.0).asin();
        let theta_min = ta.min(tb);
        let theta_max = 2.0 * (r_max / (2.0 * r_min)).min(1.0).asin();
        let pi = std::f64::consts::PI;
        let mut angles: Vec<(f64, f64)> = Vec::new();
        for k in 1..=3 {
            let lo = k as f64 * theta_min;
            let hi = (k as f64 * theta_max).min(pi);
            if lo > pi {
                break;
            }
            match angles.last_mut() {
                Some(last) if lo <= last.1 => last.1 = last.1.max(hi),
                _ => angles.push((lo, hi)),
            }
        }
        Scale {
            r_min,
            r_max,
            theta_min,
            theta_max,
            angles,
            special_long: false,
        }
    }
    /// The same scale with special long edges allowed or not.
    pub fn with_special_long(self, on: bool) -> Scale {
        Scale {
            special_long: on,
            ..self
        }
    }
    pub fn is_short(&self, len: f64) -> bool {
        len < self.r_min * (1.0 - EPS)
    }
    pub fn is_long(&self, len: f64) -> bool {
        len > self.r_max * (1.0 + EPS)
    }
    /// Whether an edge of length `len` is a special *long* edge (thesis §4.3.3.2), when they
    /// are allowed: longer than r_max but shorter than 2 r_min, so that it can be neither one
    /// edge of S nor two.
    pub fn is_special_long(&self, len: f64) -> bool {
        self.special_long && self.is_long(len) && len < 2.0 * self.r_min * (1.0 - EPS)
    }
    pub fn in_range(&self, len: f64) -> bool {
        !self.is_short(len) && !self.is_long(len)
    }
    /// Whether two edges meeting at a vertex with angle `a` (radians, in [0, π]) can be kept.
    pub fn angle_ok(&self, a: f64) -> bool {
        self.angles
            .iter()
            .any(|&(lo, hi)| a >= lo * (1.0 - EPS) && a <= hi * (1.0 + EPS))
    }
    /// Closer than r_min (with the comparison slack).
    pub fn too_close(&self, d: f64) -> bool {
        d < self.r_min * (1.0 - EPS)
    }
}

/// Angle between the vectors `u` and `v` in [0, π] (0 for a zero vector).
pub fn angle(u: V3, v: V3) -> f64 {
    let nu = vec3::norm(u);
    let nv = vec3::norm(v);
    if nu <= 0.0 || nv <= 0.0 {
        return 0.0;
    }
    (vec3::dot(u, v) / (nu * nv)).clamp(-1.0, 1.0).acos()
}

/// Smallest distance between the segments [p0, p1] and [q0, q1].
pub fn segment_distance(p0: V3, p1: V3, q0: V3, q1: V3) -> f64 {
    let d1 = vec3::sub(p1, p0);
    let d2 = vec3::sub(q1, q0);
    let r = vec3::sub(p0, q0);
    let a = vec3::dot(d1, d1);
    let e = vec3::dot(d2, d2);
    let f = vec3::dot(d2, r);
    let (s, t);
    if a <= f64::MIN_POSITIVE && e <= f64::MIN_POSITIVE {
        return vec3::norm(r);
    }
    if a <= f64::MIN_POSITIVE {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = vec3::dot(d1, r);
        if e <= f64::MIN_POSITIVE {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = vec3::dot(d1, d2);
            let denom = a * e - b * b;
            let mut s0 = if denom > 1e-14 * a * e {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t0 = 0.0;
                s0 = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t0 = 1.0;
                s0 = ((b - c) / a).clamp(0.0, 1.0);
            }
            s = s0;
            t = t0;
        }
    }
    let cp = vec3::add(p0, vec3::scale(d1, s));
    let cq = vec3::add(q0, vec3::scale(d2, t));
    vec3::dist(cp, cq)
}

/// Distance from `p` to the segment [a, b].
pub fn point_segment_distance(p: V3, a: V3, b: V3) -> f64 {
    let ab = vec3::sub(b, a);
    let l2 = vec3::dot(ab, ab);
    if l2 <= f64::MIN_POSITIVE {
        return vec3::dist(p, a);
    }
    let t = (vec3::dot(vec3::sub(p, a), ab) / l2).clamp(0.0, 1.0);
    vec3::dist(p, vec3::add(a, vec3::scale(ab, t)))
}

fn tri_normal(a: V3, b: V3, c: V3) -> V3 {
    vec3::cross(vec3::sub(b, a), vec3::sub(c, a))
}

/// Configuration (c): the strip a-b-d-c (a paired with c, b with d).
fn strip_ok(s: &Scale, a: V3, b: V3, c: V3, d: V3) -> bool {
    let far = |x: V3, y: V3| !s.too_close(vec3::dist(x, y));
    if !far(a, c) || !far(b, d) {
        return false;
    }
    // Diagonal (a, d): triangles (a, b, d) and (a, d, c); diagonal (b, c): (a, b, c), (b, d, c).
    let unfolded = |n1: V3, n2: V3| vec3::dot(n1, n2) > 0.0;
    (far(a, d) && unfolded(tri_normal(a, b, d), tri_normal(a, d, c)))
        || (far(b, c) && unfolded(tri_normal(a, b, c), tri_normal(b, d, c)))
}

/// Configuration (d): triangle (a, b, apex) with `apex` an end of the other edge, `other` its
/// other end.
fn fan_ok(s: &Scale, a: V3, b: V3, apex: V3, other: V3) -> bool {
    let far = |x: V3, y: V3| !s.too_close(vec3::dist(x, y));
    if !far(apex, a) || !far(apex, b) {
        return false;
    }
    let t = vec3::sub(other, apex);
    let min_beta = 2.0 * s.theta_min * (1.0 - EPS);
    angle(t, vec3::sub(a, apex)) >= min_beta && angle(t, vec3::sub(b, apex)) >= min_beta
}

/// Whether two edges without a common vertex (and not joined by a short edge) conflict.
pub fn nonadjacent_conflict(s: &Scale, a: V3, b: V3, c: V3, d: V3) -> bool {
    if !s.too_close(segment_distance(a, b, c, d)) {
        return false;
    }
    let resolved = strip_ok(s, a, b, c, d)
        || strip_ok(s, a, b, d, c)
        || fan_ok(s, a, b, c, d)
        || fan_ok(s, a, b, d, c)
        || fan_ok(s, c, d, a, b)
        || fan_ok(s, c, d, b, a);
    !resolved
}

/// Why two edges conflict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ConflictKind {
    /// Adjacent edges whose angle is not representable.
    Angle,
    /// Edges joined by a short edge whose angle (as if the short edge were collapsed) is not
    /// representable.
    AngleAcrossShort,
    /// Non-adjacent edges closer than r_min without a configuration (c) or (d).
    Proximity,
}

/// Every conflict of a network given as vertex positions and edges (vertex index pairs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Conflicts {
    /// (i, j, kind) with i < j edge indices, sorted.
    pub edge_pairs: Vec<(u32, u32, ConflictKind)>,
    /// (u, v) with u < v vertex indices of extraordinary vertices closer than r_min, sorted.
    pub vertex_pairs: Vec<(u32, u32)>,
    /// Non-adjacent edge pairs closer than r_min that configuration (c) or (d) resolves.
    pub near_resolved: usize,
}

/// Incident edges of every vertex, in edge order.
pub fn incidence(n_vertices: usize, edges: &[[u32; 2]]) -> Vec<Vec<u32>> {
    let mut inc = vec![Vec::new(); n_vertices];
    for (e, &[a, b]) in edges.iter().enumerate() {
        inc[a as usize].push(e as u32);
        if b != a {
            inc[b as usize].push(e as u32);
        }
    }
    inc
}

fn other_end(edge: [u32; 2], v: u32) -> u32 {
    if edge[0] == v {
        edge[1]
    } else {
        edge[0]
    }
}

/// Pairs of boxes (expanded by `pad`) that overlap, found by sweeping along x. Each `(lo, hi)`
/// is an axis-aligned box; returns (i, j) with i < j, sorted.
pub fn box_pairs(boxes: &[(V3, V3)], pad: f64, par: Par) -> Vec<(u32, u32)> {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    order.sort_by(|&i, &j| {
        boxes[i as usize].0[0]
            .total_cmp(&boxes[j as usize].0[0])
            .then(i.cmp(&j))
    });
    let per: Vec<Vec<(u32, u32)>> = par.map_collect(order.len(), |k| {
        let i = order[k] as usize;
        let (lo, hi) = boxes[i];
        let mut out = Vec::new();
        for &j in &order[k + 1..] {
            let (lj, hj) = boxes[j as usize];
            if lj[0] > hi[0] + pad {
                break;
            }
            if lj[1] <= hi[1] + pad
                && lo[1] <= hj[1] + pad
                && lj[2] <= hi[2] + pad
                && lo[2] <= hj[2] + pad
            {
                let (a, b) = (i as u32, j);
                out.push((a.min(b), a.max(b)));
            }
        }
        out
    });
    let mut all: Vec<(u32, u32)> = per.into_iter().flatten().collect();
    all.sort_unstable();
    all
}

/// Finds every conflict of the network (`pos`, `edges`) at scale `s`. Short edges join the edges
/// at their two ends as if collapsed (thesis §4.3.2.2).
pub fn find_conflicts(s: &Scale, pos: &[V3], edges: &[[u32; 2]], par: Par) -> Conflicts {
    let inc = incidence(pos.len(), edges);
    let len: Vec<f64> = edges
        .iter()
        .map(|&[a, b]| vec3::dist(pos[a as usize], pos[b as usize]))
        .collect();
    let mut pairs: Vec<(u32, u32, ConflictKind)> = Vec::new();
    // Adjacent pairs (angle test) and pairs across a short edge.
    let mut exempt: Vec<(u32, u32)> = Vec::new();
    for (v, es) in inc.iter().enumerate() {
        for x in 0..es.len() {
            for y in x + 1..es.len() {
                let (ei, ej) = (es[x], es[y]);
                let p = pos[v];
                let u = vec3::sub(pos[other_end(edges[ei as usize], v as u32) as usize], p);
                let w = vec3::sub(pos[other_end(edges[ej as usize], v as u32) as usize], p);
                if !s.angle_ok(angle(u, w)) {
                    pairs.push((ei.min(ej), ei.max(ej), ConflictKind::Angle));
                }
            }
        }
    }
    for (es, &[a, b]) in edges.iter().enumerate() {
        if !s.is_short(len[es]) || a == b {
            continue;
        }
        for &ei in &inc[a as usize] {
            for &ej in &inc[b as usize] {
                if ei == es as u32 || ej == es as u32 || ei == ej {
                    continue;
                }
                exempt.push((ei.min(ej), ei.max(ej)));
                let u = vec3::sub(
                    pos[other_end(edges[ei as usize], a) as usize],
                    pos[a as usize],
                );
                let w = vec3::sub(
                    pos[other_end(edges[ej as usize], b) as usize],
                    pos[b as usize],
                );
                if !s.angle_ok(angle(u, w)) {
                    pairs.push((ei.min(ej), ei.max(ej), ConflictKind::AngleAcrossShort));
                }
            }
        }
    }
    exempt.sort_unstable();
    exempt.dedup();
    // Proximity of non-adjacent edges.
    let boxes: Vec<(V3, V3)> = edges
        .iter()
        .map(|&[a, b]| {
            let (p, q) = (pos[a as usize], pos[b as usize]);
            (
                [p[0].min(q[0]), p[1].min(q[1]), p[2].min(q[2])],
                [p[0].max(q[0]), p[1].max(q[1]), p[2].max(q[2])],
            )
        })
        .collect();
    let cand = box_pairs(&boxes, s.r_min, par);
    let tested: Vec<Option<bool>> = par.map_collect(cand.len(), |k| {
        let (i, j) = cand[k];
        let [a, b] = edges[i as usize];
        let [c, d] = edges[j as usize];
        if a == c || a == d || b == c || b == d {
            return None;
        }
        if exempt.binary_search(&(i, j)).is_ok() {
            return None;
        }
        let (pa, pb, pc, pd) = (
            pos[a as usize],
            pos[b as usize],
            pos[c as usize],
            pos[d as usize],
        );
        if !s.too_close(segment_distance(pa, pb, pc, pd)) {
            return None;
        }
        // A special long edge is remeshed as two halves: its middle becomes a vertex that
        // the triangulations (c)/(d) must reach too. Other edges stand as themselves (fixed
        // arrays: no allocation per candidate pair).
        let halves = |p: V3, q: V3, l: f64| -> ([(V3, V3); 2], usize) {
            if s.is_special_long(l) {
                let m = vec3::lerp(p, q, 0.5);
                ([(p, m), (m, q)], 2)
            } else {
                ([(p, q); 2], 1)
            }
        };
        let (hi, ni) = halves(pa, pb, len[i as usize]);
        let (hj, nj) = halves(pc, pd, len[j as usize]);
        Some(hi[..ni].iter().any(|&(p, q)| {
            hj[..nj]
                .iter()
                .any(|&(r, t)| nonadjacent_conflict(s, p, q, r, t))
        }))
    });
    let mut near_resolved = 0;
    for (k, t) in tested.iter().enumerate() {
        match t {
            Some(true) => pairs.push((cand[k].0, cand[k].1, ConflictKind::Proximity)),
            Some(false) => near_resolved += 1,
            None => {}
        }
    }
    pairs.sort_unstable();
    pairs.dedup_by(|x, y| x.0 == y.0 && x.1 == y.1);
    // Vertex conflicts among extraordinary vertices.
    let extra: Vec<u32> = (0..pos.len() as u32)
        .filter(|&v| {
            let k = inc[v as usize].len();
            k == 1 || k >= 3
        })
        .collect();
    let vboxes: Vec<(V3, V3)> = extra
        .iter()
        .map(|&v| (pos[v as usize], pos[v as usize]))
        .collect();
    let mut vertex_pairs: Vec<(u32, u32)> = box_pairs(&vboxes, s.r_min, par)
        .into_iter()
        .filter_map(|(i, j)| {
            let (u, v) = (extra[i as usize], extra[j as usize]);
            s.too_close(vec3::dist(pos[u as usize], pos[v as usize]))
                .then_some((u.min(v), u.max(v)))
        })
        .collect();
    vertex_pairs.sort_unstable();
    Conflicts {
        edge_pairs: pairs,
        vertex_pairs,
        near_resolved,
    }
}
