//! `match.curves`: correspondences between the curves of two networks from their descriptors
//! (thesis §3.1.4): the nearest curve in descriptor space, and the optimal one-to-one
//! assignment minimising the summed descriptor distance (Hungarian method, Kuhn 1955; the
//! O(n²m) shortest-augmenting-path form with potentials).

use serde::{Deserialize, Serialize};

use crestflow_flow::{Ctx, Inputs, NodeError, NodeKind, Outputs, Par, Port, Validate};

use crate::descriptor::{descriptor_distance, CurveDescriptors, DescriptorKind};

/// Parameters of `match.curves` (none yet).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MatchCurvesParams {}

impl Validate for MatchCurvesParams {}

/// Descriptor distances and the two matchings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurveMatching {
    pub kind: DescriptorKind,
    pub n_source: usize,
    pub n_target: usize,
    /// `n_source × n_target`, row-major: `distances[i · n_target + j] = d(c_i, c'_j)`.
    pub distances: Vec<f64>,
    /// For each source curve, the target curve of smallest distance (lowest index on ties).
    pub nearest: Vec<Option<u32>>,
    /// For each source curve, its partner in a minimum-cost one-to-one assignment (`None`
    /// when there are more source than target curves and it is left out).
    pub hungarian: Vec<Option<u32>>,
}

impl CurveMatching {
    pub fn distance(&self, i: usize, j: usize) -> f64 {
        self.distances[i * self.n_target + j]
    }
}

/// Errors of [`match_curves`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MatchError {
    #[error("cannot compare {source_kind:?} descriptors with {target_kind:?} descriptors")]
    KindMismatch {
        source_kind: DescriptorKind,
        target_kind: DescriptorKind,
    },
    #[error("the distance of source curve {i} and target curve {j} is not finite")]
    NonFinite { i: usize, j: usize },
}

/// Minimum-cost assignment of the rows of the `n × m` row-major `cost` matrix (`n ≤ m`) to
/// distinct columns; returns the column of each row.
pub fn hungarian_rows(cost: &[f64], n: usize, m: usize) -> Vec<usize> {
    debug_assert!(n <= m);
    // Potentials u (rows, 1-based with a virtual row 0) and v (columns); p[j] = row matched
    // to column j; way[j] = previous column on the shortest path.
    let mut u = vec![0.0; n + 1];
    let mut v = vec![0.0; m + 1];
    let mut p = vec![0usize; m + 1];
    let mut way = vec![0usize; m + 1];
    for i in 1..=n {
        p[0] = i;
        let mut j0 = 0usize;
        let mut minv = vec![f64::INFINITY; m + 1];
        let mut used = vec![false; m + 1];
        loop {
            used[j0] = true;
            let i0 = p[j0];
            let mut delta = f64::INFINITY;
            let mut j1 = 0usize;
            for j in 1..=m {
                if !used[j] {
                    let cur = cost[(i0 - 1) * m + (j - 1)] - u[i0] - v[j];
                    if cur < minv[j] {
                        minv[j] = cur;
                        way[j] = j0;
                    }
                    if minv[j] < delta {
                        delta = minv[j];
                        j1 = j;
                    }
                }
            }
            for j in 0..=m {
                if used[j] {
                    u[p[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if p[j0] == 0 {
                break;
            }
        }
        // Flip the augmenting path.
        loop {
            let j1 = way[j0];
            p[j0] = p[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut row_to_col = vec![0usize; n];
    for j in 1..=m {
        if p[j] != 0 {
            row_to_col[p[j] - 1] = j - 1;
        }
    }
    row_to_col
}

/// Minimum-cost one-to-one assignment for any shape: `Some(column)` per row.
pub fn assignment(cost: &[f64], n: usize, m: usize) -> Vec<Option<u32>> {
    if n == 0 || m == 0 {
        return vec![None; n];
    }
    if n <= m {
        hungarian_rows(cost, n, m)
            .into_iter()
            .map(|j| Some(j as u32))
            .collect()
    } else {
        let mut t = vec![0.0; n * m];
        for i in 0..n {
            for j in 0..m {
                t[j * n + i] = cost[i * m + j];
            }
        }
        let cols = hungarian_rows(&t, m, n);
        let mut out = vec![None; n];
        for (j, &i) in cols.iter().enumerate() {
            out[i] = Some(j as u32);
        }
        out
    }
}

/// Distances between all curve pairs, nearest and Hungarian matchings.
pub fn match_curves(
    source: &CurveDescriptors,
    target: &CurveDescriptors,
    _params: &MatchCurvesParams,
    par: Par,
) -> Result<CurveMatching, MatchError> {
    if source.kind != target.kind {
        return Err(MatchError::KindMismatch {
            source_kind: source.kind,
            target_kind: target.kind,
        });
    }
    let (n, m) = (source.curves.len(), target.curves.len());
    let rows = par.map_collect(n, |i| {
        (0..m)
            .map(|j| descriptor_distance(source.kind, &source.curves[i], &target.curves[j]))
            .collect::<Vec<f64>>()
    });
    let mut distances = Vec::with_capacity(n * m);
    for (i, row) in rows.into_iter().enumerate() {
        if let Some(j) = row.iter().position(|d| !d.is_finite()) {
            return Err(MatchError::NonFinite { i, j });
        }
        distances.extend(row);
    }
    let nearest = (0..n)
        .map(|i| {
            let row = &distances[i * m..(i + 1) * m];
            let mut best: Option<(usize, f64)> = None;
            for (j, &d) in row.iter().enumerate() {
                if best.is_none_or(|(_, bd)| d < bd) {
                    best = Some((j, d));
                }
            }
            best.map(|(j, _)| j as u32)
        })
        .collect();
    let hungarian = assignment(&distances, n, m);
    Ok(CurveMatching {
        kind: source.kind,
        n_source: n,
        n_target: m,
        distances,
        nearest,
        hungarian,
    })
}

/// Node wrapper of [`match_curves`].
pub struct MatchCurvesNode;

impl NodeKind for MatchCurvesNode {
    type Params = MatchCurvesParams;
    const KIND: &'static str = "match.curves";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Matches the curves of two networks by their descriptors \
        (thesis §3.1.4): nearest curve in descriptor space and the optimal one-to-one \
        assignment (Hungarian method, Kuhn 1955). Descriptor distances are the normalised L1 \
        distances of §3.1.1.1 (HKS) and §3.1.2.3 (GICS, symmetric, interpolated radii).";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<CurveDescriptors>("source", "descriptors of the first network's curves"),
            Port::of::<CurveDescriptors>("target", "descriptors of the second network's curves"),
        ]
    }

    fn outputs() -> Vec<Port> {
        vec![Port::of::<CurveMatching>(
            "matching",
            "distance matrix, nearest and Hungarian matchings",
        )]
    }

    fn run(_params: &MatchCurvesParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let s = inputs.get::<CurveDescriptors>("source")?;
        let t = inputs.get::<CurveDescriptors>("target")?;
        let out = match_curves(s, t, &MatchCurvesParams::default(), ctx.par)
            .map_err(|e| NodeError::from_source(crestflow_flow::ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new().with("matching", out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force over all injective maps of rows to columns.
    fn brute(cost: &[f64], n: usize, m: usize) -> f64 {
        fn rec(cost: &[f64], n: usize, m: usize, i: usize, used: &mut Vec<bool>) -> f64 {
            if i == n {
                return 0.0;
            }
            let mut best = f64::INFINITY;
            for j in 0..m {
                if !used[j] {
                    used[j] = true;
                    best = best.min(cost[i * m + j] + rec(cost, n, m, i + 1, used));
                    used[j] = false;
                }
            }
            best
        }
        rec(cost, n, m, 0, &mut vec![false; m])
    }

    #[test]
    fn hungarian_matches_brute_force() {
        // Seeded LCG costs, square and rectangular both ways.
        let mut s: u64 = 12345;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for &(n, m) in &[(1, 1), (3, 3), (5, 5), (6, 6), (4, 7), (7, 4), (6, 3)] {
            for _ in 0..5 {
                let cost: Vec<f64> = (0..n * m).map(|_| rnd()).collect();
                let a = assignment(&cost, n, m);
                let mut used = vec![false; m];
                let mut total = 0.0;
                let mut count = 0;
                for (i, j) in a.iter().enumerate() {
                    if let Some(j) = j {
                        assert!(!used[*j as usize], "column used twice");
                        used[*j as usize] = true;
                        total += cost[i * m + *j as usize];
                        count += 1;
                    }
                }
                assert_eq!(count, n.min(m));
                let want = if n <= m {
                    brute(&cost, n, m)
                } else {
                    let mut t = vec![0.0; n * m];
                    for i in 0..n {
                        for j in 0..m {
                            t[j * n + i] = cost[i * m + j];
                        }
                    }
                    brute(&t, m, n)
                };
                assert!((total - want).abs() < 1e-12, "{n}x{m}: {total} vs {want}");
            }
        }
    }

    #[test]
    fn hungarian_beats_greedy_nearest() {
        // Row 0 and row 1 both prefer column 0; the optimum gives it to row 1.
        let cost = [1.0, 2.0, 0.0, 10.0];
        assert_eq!(assignment(&cost, 2, 2), vec![Some(1), Some(0)]);
    }
}
