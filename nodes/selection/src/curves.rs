//! Helpers shared by the selection nodes: curves resampled at a fixed arc-length step, an
//! R-tree over all samples with closest-point queries on the polylines, and isometries that may
//! include the mirror of the symmetry family (reflections are stored as `T ∘ M`).

use crestflow_geom::vec3::{add, dist, dot, scale, sub, V3};
use crestflow_geom::FeatureCurveNetwork;
use crestflow_nodes_symmetry::RigidTransform;
use rstar::primitives::GeomWithData;
use rstar::RTree;
use serde::{Deserialize, Serialize};

/// A rigid motion, or a reflection `transform ∘ M` with the mirror M(p) = (2 mx − p.x, p.y, p.z).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Iso {
    pub transform: RigidTransform,
    /// `Some(mx)` for an improper isometry `transform ∘ M`.
    pub mirror_x: Option<f64>,
}

impl Iso {
    pub fn rigid(t: RigidTransform) -> Self {
        Iso {
            transform: t,
            mirror_x: None,
        }
    }
    /// x ↦ T(M(x)).
    pub fn apply(&self, p: V3) -> V3 {
        let q = match self.mirror_x {
            Some(mx) => [2.0 * mx - p[0], p[1], p[2]],
            None => p,
        };
        self.transform.apply(q)
    }
    /// y ↦ M(T⁻¹(y)) (M is its own inverse).
    pub fn apply_inverse(&self, p: V3) -> V3 {
        let q = self.transform.inverse().apply(p);
        match self.mirror_x {
            Some(mx) => [2.0 * mx - q[0], q[1], q[2]],
            None => q,
        }
    }
    pub fn is_finite(&self) -> bool {
        self.transform.translation.iter().all(|x| x.is_finite())
            && self
                .transform
                .rotation
                .iter()
                .flatten()
                .all(|x| x.is_finite())
            && self.mirror_x.is_none_or(|m| m.is_finite())
    }
}

/// One curve resampled at a fixed step: positions and interpolated strengths.
#[derive(Clone, Debug)]
pub struct Sampled {
    pub pts: Vec<V3>,
    pub strength: Vec<f64>,
    pub closed: bool,
}

/// Samples of a polyline at arc-length `step` (a closed one at the nearest step dividing its
/// length); the end point of an open polyline is always included.
pub fn resample(points: &[V3], values: &[f64], closed: bool, step: f64) -> Sampled {
    let n = points.len();
    if n == 0 {
        return Sampled {
            pts: Vec::new(),
            strength: Vec::new(),
            closed,
        };
    }
    let nseg = if closed && n > 2 { n } else { n - 1 };
    let mut cum = vec![0.0];
    for k in 0..nseg {
        let last = cum[cum.len() - 1];
        cum.push(last + dist(points[k], points[(k + 1) % n]));
    }
    let total = cum[nseg];
    if nseg == 0 || total <= 0.0 {
        return Sampled {
            pts: vec![points[0]],
            strength: vec![values[0]],
            closed: false,
        };
    }
    let (count, h) = if closed && n > 2 {
        let c = (total / step).round().max(3.0) as usize;
        (c, total / c as f64)
    } else {
        let c = (total / step).ceil().max(1.0) as usize;
        (c + 1, total / c as f64)
    };
    let mut pts = Vec::with_capacity(count);
    let mut strength = Vec::with_capacity(count);
    let mut seg = 0;
    for k in 0..count {
        let s = (k as f64 * h).min(total);
        while seg + 1 < nseg && cum[seg + 1] < s {
            seg += 1;
        }
        let len = cum[seg + 1] - cum[seg];
        let t = if len > 0.0 {
            ((s - cum[seg]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (a, b) = (seg, (seg + 1) % n);
        pts.push(add(points[a], scale(sub(points[b], points[a]), t)));
        strength.push(values[a] + t * (values[b] - values[a]));
    }
    Sampled {
        pts,
        strength,
        closed: closed && n > 2,
    }
}

/// Every curve of `net` resampled at `step`.
pub fn sample_network(net: &FeatureCurveNetwork, step: f64) -> Vec<Sampled> {
    (0..net.curves.len())
        .map(|c| {
            let pts = net.curve_points(c);
            let vals: Vec<f64> = net.curves[c]
                .vertices
                .iter()
                .map(|&v| net.vertices[v as usize].strength)
                .collect();
            resample(&pts, &vals, net.curves[c].closed, step)
        })
        .collect()
}

/// (curve, sample index) of every sample point.
pub type SampleTree = RTree<GeomWithData<V3, (u32, u32)>>;

pub fn sample_tree(curves: &[Sampled]) -> SampleTree {
    let mut items = Vec::new();
    for (c, s) in curves.iter().enumerate() {
        for (i, p) in s.pts.iter().enumerate() {
            items.push(GeomWithData::new(*p, (c as u32, i as u32)));
        }
    }
    RTree::bulk_load(items)
}

/// The curve nearest to `p`, the distance from `p` to that curve's polyline (on the segments
/// next to its nearest sample) and the closest point there.
pub fn nearest_curve(tree: &SampleTree, curves: &[Sampled], p: V3) -> Option<(u32, f64, V3)> {
    let near = tree.nearest_neighbor(p)?;
    let (c, i) = near.data;
    let s = &curves[c as usize];
    let n = s.pts.len();
    let i = i as usize;
    let mut best = (dist(p, s.pts[i]), s.pts[i]);
    let mut segs = Vec::with_capacity(2);
    if i + 1 < n || (s.closed && n > 1) {
        segs.push((i, (i + 1) % n));
    }
    if i > 0 || (s.closed && n > 1) {
        segs.push(((i + n - 1) % n, i));
    }
    for (a, b) in segs {
        let (x, y) = (s.pts[a], s.pts[b]);
        let e = sub(y, x);
        let ee = dot(e, e);
        if ee <= 0.0 {
            continue;
        }
        let t = (dot(sub(p, x), e) / ee).clamp(0.0, 1.0);
        let q = add(x, scale(e, t));
        let d = dist(p, q);
        if d < best.0 {
            best = (d, q);
        }
    }
    Some((c, best.0, best.1))
}

/// Length of a polyline (with its closing edge when `closed`).
pub fn polyline_length(pts: &[V3], closed: bool) -> f64 {
    let mut l: f64 = pts.windows(2).map(|w| dist(w[0], w[1])).sum();
    if closed && pts.len() > 2 {
        l += dist(pts[pts.len() - 1], pts[0]);
    }
    l
}

/// Lagrange–Gauss reduction of a 2-D lattice basis: the same lattice spanned by its shortest,
/// most orthogonal pair (a sheared basis such as (−6, 5), (12, −5) becomes (6, 0), (0, 5)).
/// One vector (or a degenerate pair) is returned unchanged.
pub fn reduce_basis(steps: &[V3]) -> Vec<V3> {
    if steps.len() != 2 {
        return steps.to_vec();
    }
    let (mut a, mut b) = (steps[0], steps[1]);
    for _ in 0..64 {
        if dot(b, b) < dot(a, a) {
            std::mem::swap(&mut a, &mut b);
        }
        let aa = dot(a, a);
        if aa <= 0.0 {
            return steps.to_vec();
        }
        let mu = (dot(a, b) / aa).round();
        if mu == 0.0 {
            break;
        }
        b = sub(b, scale(a, mu));
    }
    vec![a, b]
}
