//! Rigid transformations x ↦ R x + t and the Kabsch best rotation (thesis §3.2.2: the rotation
//! between two curve segments, "similar to ICP" \[BM92\]; Kabsch 1976).
//!
//! Rotations are stored as 3×3 matrices and exposed as unit quaternions (w, x, y, z) with
//! w ≥ 0, since q and −q are the same rotation (the 7-D voting space of §3.2.2).

use crestflow_geom::vec3::{add, cross, dot, norm, scale, sub, V3};
use serde::{Deserialize, Serialize};

/// A proper rigid transformation x ↦ R x + t (det R = +1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RigidTransform {
    /// Row-major rotation matrix.
    pub rotation: [[f64; 3]; 3],
    pub translation: V3,
}

impl Default for RigidTransform {
    fn default() -> Self {
        Self::identity()
    }
}

fn mat_vec(m: &[[f64; 3]; 3], v: V3) -> V3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

fn mat_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    out
}

fn transpose(a: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in a.iter().enumerate() {
        for (j, x) in row.iter().enumerate() {
            out[j][i] = *x;
        }
    }
    out
}

impl RigidTransform {
    pub fn identity() -> Self {
        RigidTransform {
            rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            translation: [0.0; 3],
        }
    }
    pub fn translation(t: V3) -> Self {
        RigidTransform {
            translation: t,
            ..Self::identity()
        }
    }
    /// Rotation by `angle` radians about the line through `center` with direction `axis`.
    pub fn rotation_about(axis: V3, angle: f64, center: V3) -> Self {
        let n = norm(axis);
        let a = if n > 0.0 {
            scale(axis, 1.0 / n)
        } else {
            [0.0, 0.0, 1.0]
        };
        let (s, c) = (0.5 * angle).sin_cos();
        let r = Self::from_quaternion([c, a[0] * s, a[1] * s, a[2] * s]);
        // x ↦ R (x − c) + c
        let t = sub(center, mat_vec(&r.rotation, center));
        RigidTransform {
            rotation: r.rotation,
            translation: t,
        }
    }
    pub fn apply(&self, p: V3) -> V3 {
        add(mat_vec(&self.rotation, p), self.translation)
    }
    /// Applies the rotation only (for directions).
    pub fn rotate(&self, v: V3) -> V3 {
        mat_vec(&self.rotation, v)
    }
    /// `self ∘ other`: first `other`, then `self`.
    pub fn compose(&self, other: &RigidTransform) -> RigidTransform {
        RigidTransform {
            rotation: mat_mul(&self.rotation, &other.rotation),
            translation: add(mat_vec(&self.rotation, other.translation), self.translation),
        }
    }
    pub fn inverse(&self) -> RigidTransform {
        let rt = transpose(&self.rotation);
        RigidTransform {
            rotation: rt,
            translation: scale(mat_vec(&rt, self.translation), -1.0),
        }
    }
    /// `self` applied `k` times (k ≥ 0).
    pub fn power(&self, k: u32) -> RigidTransform {
        let mut out = Self::identity();
        for _ in 0..k {
            out = self.compose(&out);
        }
        out
    }
    /// Unit quaternion (w, x, y, z) of the rotation with w ≥ 0.
    pub fn quaternion(&self) -> [f64; 4] {
        let m = &self.rotation;
        let tr = m[0][0] + m[1][1] + m[2][2];
        // Shepperd's method: divide by the largest of the four candidates for stability.
        let q = if tr > 0.0 {
            let s = (tr + 1.0).sqrt() * 2.0;
            [
                0.25 * s,
                (m[2][1] - m[1][2]) / s,
                (m[0][2] - m[2][0]) / s,
                (m[1][0] - m[0][1]) / s,
            ]
        } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
            let s = (1.0 + m[0][0] - m[1][1] - m[2][2]).max(0.0).sqrt() * 2.0;
            [
                (m[2][1] - m[1][2]) / s,
                0.25 * s,
                (m[0][1] + m[1][0]) / s,
                (m[0][2] + m[2][0]) / s,
            ]
        } else if m[1][1] > m[2][2] {
            let s = (1.0 + m[1][1] - m[0][0] - m[2][2]).max(0.0).sqrt() * 2.0;
            [
                (m[0][2] - m[2][0]) / s,
                (m[0][1] + m[1][0]) / s,
                0.25 * s,
                (m[1][2] + m[2][1]) / s,
            ]
        } else {
            let s = (1.0 + m[2][2] - m[0][0] - m[1][1]).max(0.0).sqrt() * 2.0;
            [
                (m[1][0] - m[0][1]) / s,
                (m[0][2] + m[2][0]) / s,
                (m[1][2] + m[2][1]) / s,
                0.25 * s,
            ]
        };
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        let sgn = if q[0] < 0.0 { -1.0 } else { 1.0 };
        [
            sgn * q[0] / n,
            sgn * q[1] / n,
            sgn * q[2] / n,
            sgn * q[3] / n,
        ]
    }
    /// The rotation of a unit quaternion (normalised first).
    pub fn from_quaternion(q: [f64; 4]) -> RigidTransform {
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        let [w, x, y, z] = if n > 0.0 {
            [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
        } else {
            [1.0, 0.0, 0.0, 0.0]
        };
        RigidTransform {
            rotation: [
                [
                    1.0 - 2.0 * (y * y + z * z),
                    2.0 * (x * y - w * z),
                    2.0 * (x * z + w * y),
                ],
                [
                    2.0 * (x * y + w * z),
                    1.0 - 2.0 * (x * x + z * z),
                    2.0 * (y * z - w * x),
                ],
                [
                    2.0 * (x * z - w * y),
                    2.0 * (y * z + w * x),
                    1.0 - 2.0 * (x * x + y * y),
                ],
            ],
            translation: [0.0; 3],
        }
    }
    /// Rotation angle in degrees, in [0, 180].
    pub fn angle_deg(&self) -> f64 {
        let q = self.quaternion();
        2.0 * q[0].clamp(-1.0, 1.0).acos().to_degrees()
    }
    /// Unit rotation axis (any unit vector for the identity); the angle about it is
    /// [`RigidTransform::angle_deg`].
    pub fn axis(&self) -> V3 {
        let q = self.quaternion();
        let v = [q[1], q[2], q[3]];
        let n = norm(v);
        if n > 1e-15 {
            scale(v, 1.0 / n)
        } else {
            [0.0, 0.0, 1.0]
        }
    }
    /// A point on the screw axis (the one nearest the origin's projection) and the slide along
    /// the axis: x ↦ R x + t is a rotation about the line through `center` followed by a
    /// translation `slide · axis`. Meaningless for (near) pure translations.
    pub fn screw(&self) -> (V3, f64) {
        let n = self.axis();
        let theta = self.angle_deg().to_radians();
        let t = self.translation;
        let slide = dot(t, n);
        let tp = sub(t, scale(n, slide));
        // In the plane ⟂ n, a rotation by θ about c moves the origin by t = (I − R) c, whose
        // solution is c = ½ (t + cot(θ/2) n × t).
        let cot = if theta.abs() > 1e-12 {
            1.0 / (0.5 * theta).tan()
        } else {
            0.0
        };
        let c = scale(add(tp, scale(cross(n, tp), cot)), 0.5);
        (c, slide)
    }
}

/// The mirror M used to look for reflections: p ↦ (2·x0 − p.x, p.y, p.z), the reflection in
/// the plane x = x0. A reflection symmetry is then a rigid motion between the curves and their
/// mirror images.
pub fn mirror_in_x(x0: f64, p: V3) -> V3 {
    [2.0 * x0 - p[0], p[1], p[2]]
}

/// Angle in degrees between two rotations given as unit quaternions (q ≡ −q).
pub fn quat_angle_deg(a: [f64; 4], b: [f64; 4]) -> f64 {
    let d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]).abs();
    2.0 * d.clamp(0.0, 1.0).acos().to_degrees()
}

/// The best rotation R (det +1) minimising Σ w_i |R a_i − b_i|² for vectors already expressed
/// relative to their centres (Kabsch). Returns R and the two leading singular values of the
/// cross-covariance, which tell how well the rotation is determined (a straight segment leaves
/// the spin about itself free).
pub fn kabsch(a: &[V3], b: &[V3], w: Option<&[f64]>) -> ([[f64; 3]; 3], [f64; 3]) {
    let mut h = nalgebra::Matrix3::<f64>::zeros();
    for (i, (p, q)) in a.iter().zip(b).enumerate() {
        let wi = w.map_or(1.0, |w| w[i]);
        for r in 0..3 {
            for c in 0..3 {
                h[(r, c)] += wi * p[r] * q[c];
            }
        }
    }
    let svd = h.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return (RigidTransform::identity().rotation, [0.0; 3]);
    };
    let v = vt.transpose();
    let d = (v * u.transpose()).determinant();
    let mut diag = nalgebra::Matrix3::<f64>::identity();
    if d < 0.0 {
        diag[(2, 2)] = -1.0;
    }
    let r = v * diag * u.transpose();
    let mut sv = [
        svd.singular_values[0],
        svd.singular_values[1],
        svd.singular_values[2],
    ];
    sv.sort_by(|x, y| y.total_cmp(x));
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = r[(i, j)];
        }
    }
    (out, sv)
}

/// The best rigid transformation mapping points `a` onto `b` (weighted least squares).
pub fn fit_rigid(a: &[V3], b: &[V3], w: Option<&[f64]>) -> RigidTransform {
    let mut wsum = 0.0;
    let mut ca = [0.0; 3];
    let mut cb = [0.0; 3];
    for (i, (p, q)) in a.iter().zip(b).enumerate() {
        let wi = w.map_or(1.0, |w| w[i]);
        wsum += wi;
        ca = add(ca, scale(*p, wi));
        cb = add(cb, scale(*q, wi));
    }
    if wsum <= 0.0 {
        return RigidTransform::identity();
    }
    ca = scale(ca, 1.0 / wsum);
    cb = scale(cb, 1.0 / wsum);
    let ra: Vec<V3> = a.iter().map(|p| sub(*p, ca)).collect();
    let rb: Vec<V3> = b.iter().map(|q| sub(*q, cb)).collect();
    let (r, _) = kabsch(&ra, &rb, w);
    let t = sub(cb, mat_vec(&r, ca));
    RigidTransform {
        rotation: r,
        translation: t,
    }
}

/// Weighted mean of rigid transformations: translations averaged, quaternions sign-aligned to
/// the first one, averaged and normalised (accurate for the small spreads of a cluster).
pub fn mean_transform(items: &[(RigidTransform, f64)]) -> RigidTransform {
    let Some((first, _)) = items.first() else {
        return RigidTransform::identity();
    };
    let q0 = first.quaternion();
    let mut q = [0.0; 4];
    let mut t = [0.0; 3];
    let mut wsum = 0.0;
    for (tr, w) in items {
        let qi = tr.quaternion();
        let s = if qi.iter().zip(&q0).map(|(a, b)| a * b).sum::<f64>() < 0.0 {
            -w
        } else {
            *w
        };
        for k in 0..4 {
            q[k] += s * qi[k];
        }
        t = add(t, scale(tr.translation, *w));
        wsum += w;
    }
    let mut out = RigidTransform::from_quaternion(q);
    out.translation = if wsum > 0.0 {
        scale(t, 1.0 / wsum)
    } else {
        first.translation
    };
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crestflow_geom::vec3::dist;

    #[test]
    fn compose_inverse_and_quaternion_round_trip() {
        let a = RigidTransform::rotation_about([1.0, 2.0, 0.5], 0.7, [0.3, -1.0, 2.0]);
        let b = RigidTransform::translation([1.0, 0.0, -2.0]);
        let p = [0.4, 0.1, -0.9];
        let ab = a.compose(&b);
        assert!(dist(ab.apply(p), a.apply(b.apply(p))) < 1e-12);
        assert!(dist(a.inverse().apply(a.apply(p)), p) < 1e-12);
        assert!((a.angle_deg() - 0.7f64.to_degrees()).abs() < 1e-9);
        let q = a.quaternion();
        let r = RigidTransform::from_quaternion(q);
        for i in 0..3 {
            for j in 0..3 {
                assert!((r.rotation[i][j] - a.rotation[i][j]).abs() < 1e-12);
            }
        }
        // the screw axis passes through the given centre (up to sliding along the axis)
        let (c, slide) = a.screw();
        assert!(slide.abs() < 1e-12);
        assert!(dist(a.apply(c), c) < 1e-12);
        // T³ of a 120° rotation is the identity
        let r3 = RigidTransform::rotation_about(
            [0.0, 0.0, 1.0],
            2.0 * std::f64::consts::PI / 3.0,
            [1.0, 2.0, 0.0],
        );
        assert!(r3.power(3).angle_deg() < 1e-6);
        assert!(dist(r3.power(3).translation, [0.0; 3]) < 1e-12);
    }

    #[test]
    fn fit_rigid_recovers_a_known_transform() {
        let t = RigidTransform::rotation_about([0.2, -1.0, 0.4], 1.1, [2.0, 0.0, 1.0]);
        let a: Vec<V3> = (0..20)
            .map(|i| {
                let s = i as f64 * 0.3;
                [s.cos(), s.sin() * 2.0, 0.1 * s * s]
            })
            .collect();
        let b: Vec<V3> = a.iter().map(|p| t.apply(*p)).collect();
        let f = fit_rigid(&a, &b, None);
        assert!(quat_angle_deg(f.quaternion(), t.quaternion()) < 1e-6);
        assert!(dist(f.translation, t.translation) < 1e-9);
    }
}
