//! The curve descriptor values shared by `descriptors.curve_hks`, `descriptors.curve_gics` and
//! `match.curves`, with the descriptor distances of thesis §3.1.1.1 and §3.1.2.3.

use serde::{Deserialize, Serialize};

/// Which signature a [`CurveDescriptors`] holds: it decides the distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum DescriptorKind {
    /// Curve heat kernel signature (§3.1.1): `values[i]` at time `samples[i]`.
    Hks,
    /// Geodesic iso-curve signature (§3.1.2): iso-contour length `values[i]` at radius
    /// `samples[i]`.
    Gics,
}

/// The descriptor of one curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurveDescriptor {
    pub values: Vec<f64>,
    /// Time steps (HKS) or radii (GICS), ascending.
    pub samples: Vec<f64>,
    /// GICS: the largest distance from the curve, d_max(c); HKS: 0.
    pub d_max: f64,
}

/// Descriptors of all curves of a network, in curve order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurveDescriptors {
    pub kind: DescriptorKind,
    pub curves: Vec<CurveDescriptor>,
}

/// `|a − b| / |a + b|`, 0 when both vanish.
fn normalised_term(a: f64, b: f64) -> f64 {
    let den = (a + b).abs();
    if den > 0.0 {
        (a - b).abs() / den
    } else {
        0.0
    }
}

/// HKS distance (§3.1.1.1): Σ_i |a_i − b_i| / |a_i + b_i| over the common length.
pub fn hks_distance(a: &CurveDescriptor, b: &CurveDescriptor) -> f64 {
    a.values
        .iter()
        .zip(&b.values)
        .map(|(&x, &y)| normalised_term(x, y))
        .sum()
}

/// `l(r)` of a GICS by linear interpolation between its radii (clamped at the ends).
pub fn gics_length_at(d: &CurveDescriptor, r: f64) -> f64 {
    let (s, v) = (&d.samples, &d.values);
    if s.is_empty() {
        return 0.0;
    }
    if r <= s[0] {
        return v[0];
    }
    // First sample ≥ r.
    let j = s.partition_point(|&x| x < r);
    if j >= s.len() {
        return v[s.len() - 1];
    }
    let (r0, r1) = (s[j - 1], s[j]);
    if r1 > r0 {
        let w = (r - r0) / (r1 - r0);
        (1.0 - w) * v[j - 1] + w * v[j]
    } else {
        v[j]
    }
}

/// One-sided GICS distance D(c, c') of §3.1.2.3: the radii of `a` up to
/// i_max = max{i | r_i ≤ min(d_max(c), d_max(c'))}, `b` interpolated at them.
pub fn gics_distance_one_sided(a: &CurveDescriptor, b: &CurveDescriptor) -> f64 {
    let limit = a.d_max.min(b.d_max);
    a.samples
        .iter()
        .zip(&a.values)
        .take_while(|(&r, _)| r <= limit)
        .map(|(&r, &l)| normalised_term(l, gics_length_at(b, r)))
        .sum()
}

/// Symmetric GICS distance (§3.1.2.3): the mean of both one-sided distances.
pub fn gics_distance(a: &CurveDescriptor, b: &CurveDescriptor) -> f64 {
    0.5 * (gics_distance_one_sided(a, b) + gics_distance_one_sided(b, a))
}

/// The distance of two descriptors of `kind`.
pub fn descriptor_distance(kind: DescriptorKind, a: &CurveDescriptor, b: &CurveDescriptor) -> f64 {
    match kind {
        DescriptorKind::Hks => hks_distance(a, b),
        DescriptorKind::Gics => gics_distance(a, b),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn g(samples: &[f64], values: &[f64], d_max: f64) -> CurveDescriptor {
        CurveDescriptor {
            values: values.to_vec(),
            samples: samples.to_vec(),
            d_max,
        }
    }

    #[test]
    fn interpolation_and_imax() {
        let a = g(&[1.0, 2.0, 3.0], &[4.0, 6.0, 2.0], 3.0);
        assert_eq!(gics_length_at(&a, 1.5), 5.0);
        assert_eq!(gics_length_at(&a, 2.75), 3.0);
        assert_eq!(gics_length_at(&a, 0.5), 4.0);
        assert_eq!(gics_length_at(&a, 9.0), 2.0);
        // b has half the radii spacing and d_max 2: only a's radii 1 and 2 count.
        let b = g(&[0.5, 1.0, 1.5, 2.0], &[1.0, 2.0, 3.0, 6.0], 2.0);
        // a->b: r=1: |4-2|/6 = 1/3; r=2: |6-6|/12 = 0.
        assert!((gics_distance_one_sided(&a, &b) - 1.0 / 3.0).abs() < 1e-15);
        // b->a: r=.5: |1-4|/5; r=1: |2-4|/6; r=1.5: |3-5|/8; r=2: 0.
        let ba = 3.0 / 5.0 + 2.0 / 6.0 + 2.0 / 8.0;
        assert!((gics_distance_one_sided(&b, &a) - ba).abs() < 1e-15);
        assert!((gics_distance(&a, &b) - 0.5 * (1.0 / 3.0 + ba)).abs() < 1e-15);
        assert_eq!(gics_distance(&a, &b), gics_distance(&b, &a));
        assert_eq!(gics_distance(&a, &a), 0.0);
    }

    #[test]
    fn hks_distance_is_normalised_l1() {
        let a = g(&[1.0, 2.0], &[1.0, 10.0], 0.0);
        let b = g(&[1.0, 2.0], &[3.0, 10.0], 0.0);
        assert_eq!(hks_distance(&a, &b), 0.5);
    }
}
