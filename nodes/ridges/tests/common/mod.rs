//! Shared helpers of the ridge tests: distances between traced networks and reference curves.

#![allow(dead_code)]

use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{CurveLabel, FeatureCurveNetwork};

/// Distance from `p` to segment `ab`.
pub fn point_segment(p: V3, a: V3, b: V3) -> f64 {
    let ab = vec3::sub(b, a);
    let l2 = vec3::dot(ab, ab);
    let t = if l2 > 0.0 {
        (vec3::dot(vec3::sub(p, a), ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    vec3::dist(p, vec3::lerp(a, b, t))
}

/// The segments of the curves of `net` with `label` (all labels if `None`).
pub fn segments(net: &FeatureCurveNetwork, label: Option<CurveLabel>) -> Vec<(V3, V3)> {
    let mut out = Vec::new();
    for c in 0..net.curves.len() {
        if label.is_some_and(|l| l != net.curves[c].label) {
            continue;
        }
        for (a, b) in net.curve_edges(c) {
            out.push((
                net.vertices[a as usize].position,
                net.vertices[b as usize].position,
            ));
        }
    }
    out
}

/// Distance from `p` to the nearest segment (infinity when there is none).
pub fn dist_to_segments(p: V3, segs: &[(V3, V3)]) -> f64 {
    segs.iter()
        .map(|&(a, b)| point_segment(p, a, b))
        .fold(f64::INFINITY, f64::min)
}

/// Fraction of the reference polyline `reference` (closed) whose points lie within `tol` of the
/// segments `segs`, measured by length (each reference edge is weighted by its length and
/// counted by its midpoint).
pub fn coverage(reference: &[V3], segs: &[(V3, V3)], tol: f64) -> f64 {
    let mut covered = 0.0;
    let mut total = 0.0;
    for i in 0..reference.len() {
        let (a, b) = (reference[i], reference[(i + 1) % reference.len()]);
        let l = vec3::dist(a, b);
        total += l;
        if dist_to_segments(vec3::lerp(a, b, 0.5), segs) <= tol {
            covered += l;
        }
    }
    covered / total
}

/// Distance from `p` to the closed polyline `reference`.
pub fn dist_to_polyline(p: V3, reference: &[V3]) -> f64 {
    (0..reference.len())
        .map(|i| point_segment(p, reference[i], reference[(i + 1) % reference.len()]))
        .fold(f64::INFINITY, f64::min)
}

use crestflow_geom::{CurvatureField, TriMesh};

/// Deterministic uniform numbers in [-1, 1) (SplitMix64).
pub struct Rng(pub u64);
impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 * (2.0 / (1u64 << 53) as f64) - 1.0
    }
}

/// A profile z = f(x) over the square [-1, 1]²: `f` returns (f, f', f'').
pub struct Profile<F: Fn(f64) -> (f64, f64, f64)>(pub F);

impl<F: Fn(f64) -> (f64, f64, f64)> Profile<F> {
    /// Normal curvature across the profile (along x), positive where the surface bends away
    /// from its upward normal: κ = −f'' / (1 + f'²)^{3/2}.
    pub fn kappa(&self, x: f64) -> f64 {
        let (_, d1, d2) = (self.0)(x);
        -d2 / (1.0 + d1 * d1).powf(1.5)
    }

    /// The extremality of the profile curvature at x: dκ/ds = κ'(x) / w (central differences).
    pub fn extremality(&self, x: f64) -> f64 {
        let (_, d1, _) = (self.0)(x);
        let hx = 1e-5;
        (self.kappa(x + hx) - self.kappa(x - hx)) / (2.0 * hx) / (1.0 + d1 * d1).sqrt()
    }

    /// Positions of the local extrema of |κ| in (−1, 1), by a fine scan (steps of 1e-5).
    pub fn extrema(&self) -> Vec<f64> {
        let n = 200_000;
        let xs: Vec<f64> = (0..=n).map(|i| -1.0 + 2.0 * i as f64 / n as f64).collect();
        let k: Vec<f64> = xs.iter().map(|&x| self.kappa(x).abs()).collect();
        (1..n)
            .filter(|&i| k[i] > k[i - 1] && k[i] >= k[i + 1])
            .map(|i| xs[i])
            .collect()
    }

    /// Bound on the error of the zero of the linear interpolant of e between x_a and x_b
    /// around a root x0: |x* − x0| ≤ max|e''| / (2 min|e'|) · |x_a − x0| · |x_b − x0|.
    pub fn interpolation_bound(&self, xa: f64, xb: f64, x0: f64) -> f64 {
        let (lo, hi) = (xa.min(xb), xa.max(xb));
        let d = 1e-3;
        let (mut m1, mut m2) = (f64::INFINITY, 0.0f64);
        for i in 0..=200 {
            let x = lo + (hi - lo) * i as f64 / 200.0;
            let (em, e0, ep) = (
                self.extremality(x - d),
                self.extremality(x),
                self.extremality(x + d),
            );
            m1 = m1.min(((ep - em) / (2.0 * d)).abs());
            m2 = m2.max(((ep - 2.0 * e0 + em) / (d * d)).abs());
        }
        m2 / (2.0 * m1) * (xa - x0).abs() * (xb - x0).abs()
    }

    /// A jittered grid of `n` × `n` vertices (interior vertices move by up to `jitter` of the
    /// spacing; boundary vertices slide along the boundary only), lifted onto the surface.
    pub fn mesh(&self, n: usize, jitter: f64, seed: u64) -> TriMesh {
        let mut rng = Rng(seed);
        let h = 2.0 / (n - 1) as f64;
        let mut pos = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                let (mut x, mut y) = (-1.0 + i as f64 * h, -1.0 + j as f64 * h);
                let (dx, dy) = (rng.next() * jitter * h, rng.next() * jitter * h);
                if i > 0 && i < n - 1 {
                    x += dx;
                }
                if j > 0 && j < n - 1 {
                    y += dy;
                }
                pos.push([x, y, (self.0)(x).0]);
            }
        }
        let mut tris = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let v = |a: usize, b: usize| (b * n + a) as u32;
                let (p00, p10, p01, p11) = (v(i, j), v(i + 1, j), v(i, j + 1), v(i + 1, j + 1));
                if (i + j) % 2 == 0 {
                    tris.push([p00, p10, p11]);
                    tris.push([p00, p11, p01]);
                } else {
                    tris.push([p00, p10, p01]);
                    tris.push([p10, p11, p01]);
                }
            }
        }
        TriMesh::new(pos, tris)
    }

    /// The exact curvature field of the surface at the mesh vertices. The profile direction is
    /// t_x = (1, 0, f')/w, the ruling direction (0, 1, 0) has curvature 0; the extremality of
    /// the profile curvature is dκ/ds = κ'(x)/w (central differences of the closed form), that
    /// of the ruling is 0.
    pub fn field(&self, mesh: &TriMesh) -> CurvatureField {
        let mut f = CurvatureField {
            method: "analytic.profile".into(),
            ..Default::default()
        };
        for p in &mesh.positions {
            let x = p[0];
            let (_, d1, _) = (self.0)(x);
            let w = (1.0 + d1 * d1).sqrt();
            let k = self.kappa(x);
            let dk = self.extremality(x);
            let tx = [1.0 / w, 0.0, d1 / w];
            let ty = [0.0, 1.0, 0.0];
            f.normal.push([-d1 / w, 0.0, 1.0 / w]);
            if k >= 0.0 {
                f.k_max.push(k);
                f.t_max.push(tx);
                f.e_max.push(dk);
                f.k_min.push(0.0);
                f.t_min.push(ty);
                f.e_min.push(0.0);
            } else {
                f.k_max.push(0.0);
                f.t_max.push(ty);
                f.e_max.push(0.0);
                f.k_min.push(k);
                f.t_min.push(tx);
                f.e_min.push(dk);
            }
        }
        f
    }
}

/// `z = s · sqrt(x² + δ²)`: a smooth crease along the y axis, a ridge for s = −1 and a ravine
/// for s = +1, with |κ(0)| = 1/δ.
pub fn crease(s: f64, delta: f64) -> Profile<impl Fn(f64) -> (f64, f64, f64)> {
    Profile(move |x: f64| {
        let r = (x * x + delta * delta).sqrt();
        (s * r, s * x / r, s * delta * delta / (r * r * r))
    })
}
