//! The numeric factorisation of [`super::SpdSolver`]: multifrontal, into the supernodal
//! layout of faer's symbolic analysis, with the independent subtrees of the elimination tree
//! on separate threads.
//!
//! Each supernode `s` owns a dense front over its own columns and its pattern rows. The front
//! gathers the entries of `A` in its columns and the update matrices of its children (the
//! children in ascending order), factorises its own columns — `L Lᵀ`, or for an indefinite
//! matrix `L S Lᵀ` with `S = sign(D)` and `L = L_ldl |D|^{1/2}` (an `L D Lᵀ` without
//! pivoting, in the scaled form the triangular solves read) — and leaves its update matrix
//! `F₂₂ − L₂₁ S L₂₁ᵀ` for its parent (Duff & Reid 1983; Liu 1992, "The multifrontal method
//! for sparse matrix solution: theory and practice").
//!
//! faer's own supernodal factorisation is left-looking and runs on one thread (its dense
//! kernels parallelise only inside large supernodes, which a surface mesh has few of).
//! Here the subtrees of [`super::SolveSchedule`] — fixed by the matrix, never by the thread
//! count — are factorised in parallel and the separator supernodes above them after. Every
//! front is computed by the same operations in the same order whichever thread runs it, so
//! the factor has the same bits with `Par::Seq` and `Par::Rayon`.

use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{matmul as tri_matmul, BlockStructure};
use faer::{Accum, MatMut, MatRef};
use rayon::prelude::*;

use crestflow_flow::Par;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;

use super::{CsrMatrix, FactorView, SolveSchedule, NO_PARENT};

/// Fronts with `nc · np²` below this are updated by plain loops; larger ones by faer's
/// packed matrix products (a fixed rule on the sizes, so the bits do not depend on anything
/// else).
const GEMM_MIN_WORK: usize = 16_384;

/// Column block of the panel factorisation of a large front.
const PANEL_BLOCK: usize = 32;

/// Where the entries of `A` that faer's factorisation reads (the lower triangle of its
/// column view, i.e. `a[c][r]` with `r ≥ c`) land in the permuted matrix, grouped by
/// permuted column: rows ascending, with the index of the value in `A`.
#[derive(Debug, Clone, Default)]
pub(super) struct Scatter {
    ptr: Vec<usize>,
    row: Vec<usize>,
    src: Vec<usize>,
}

impl Scatter {
    /// `inv[r]` is the permuted position of original index `r`.
    pub(super) fn new(a: &CsrMatrix, inv: &[usize]) -> Scatter {
        let n = a.nrows();
        let (rp, ci) = (a.row_ptr(), a.col_idx());
        // Each stored entry a[c][r] with r ≥ c, as (permuted column, permuted row).
        let lower = |c: usize, e: usize| -> Option<(usize, usize)> {
            let r = ci[e];
            (r >= c).then(|| {
                let (i, j) = (inv[r], inv[c]);
                if i >= j {
                    (j, i)
                } else {
                    (i, j)
                }
            })
        };
        let mut count = vec![0usize; n + 1];
        for c in 0..n {
            for e in rp[c]..rp[c + 1] {
                if let Some((col, _)) = lower(c, e) {
                    count[col + 1] += 1;
                }
            }
        }
        for j in 0..n {
            count[j + 1] += count[j];
        }
        let mut next = count.clone();
        let mut row = vec![0usize; count[n]];
        let mut src = vec![0usize; count[n]];
        for c in 0..n {
            for e in rp[c]..rp[c + 1] {
                if let Some((col, r)) = lower(c, e) {
                    let k = next[col];
                    next[col] += 1;
                    row[k] = r;
                    src[k] = e;
                }
            }
        }
        // Rows ascending within each column (few per column: insertion sort).
        for j in 0..n {
            for k in count[j] + 1..count[j + 1] {
                let mut m = k;
                while m > count[j] && row[m - 1] > row[m] {
                    row.swap(m - 1, m);
                    src.swap(m - 1, m);
                    m -= 1;
                }
            }
        }
        Scatter {
            ptr: count,
            row,
            src,
        }
    }
}

/// Why a factorisation stopped: a pivot that is zero, not finite, or (for a positive definite
/// factorisation) not positive, at a permuted column; or a pattern that is not closed under
/// the elimination tree (then the caller uses faer's factorisation instead).
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Failure {
    Pivot { column: usize, value: f64 },
    Structure,
}

/// Factorises the values `a_values` (of the matrix `scatter` was built from). Returns the
/// factor in faer's supernodal layout and, for `signed`, the permuted columns whose pivot is
/// negative (ascending).
pub(super) fn factorize(
    sym: &SymbolicSupernodalCholesky<usize>,
    sched: &SolveSchedule,
    scatter: &Scatter,
    a_values: &[f64],
    signed: bool,
    par: Par,
    simd: bool,
) -> Result<(Vec<f64>, Vec<usize>), Failure> {
    // The supernodal structure (no values yet).
    let lay = FactorView {
        begin: sym.supernode_begin(),
        end: sym.supernode_end(),
        rptr: sym.col_ptr_for_row_idx(),
        vptr: sym.col_ptr_for_val(),
        rows: sym.row_idx(),
        values: &[],
    };
    let ns = lay.begin.len();
    let parent = &sched.parent;
    if parent.len() != ns {
        return Err(Failure::Structure);
    }
    // Children of each supernode, ascending (CSR).
    let mut cptr = vec![0usize; ns + 1];
    for &p in parent {
        if p != NO_PARENT {
            cptr[p + 1] += 1;
        }
    }
    for s in 0..ns {
        cptr[s + 1] += cptr[s];
    }
    let mut children = vec![0usize; cptr[ns]];
    let mut fill = cptr.clone();
    for (s, &p) in parent.iter().enumerate() {
        if p != NO_PARENT {
            children[fill[p]] = s;
            fill[p] += 1;
        }
    }
    let kids = |s: usize| &children[cptr[s]..cptr[s + 1]];

    let mut values = vec![0.0; lay.vptr[ns]];
    // Cut the values into the pieces (subtrees, top supernodes) in supernode order.
    enum Piece {
        Subtree(usize),
        Top(usize),
    }
    let mut pieces: Vec<(usize, Piece)> = sched
        .subtrees
        .iter()
        .enumerate()
        .map(|(k, t)| (t.first, Piece::Subtree(k)))
        .chain(sched.top.iter().map(|&s| (s, Piece::Top(s))))
        .collect();
    pieces.sort_unstable_by_key(|p| p.0);
    let mut subtree_values: Vec<Option<&mut [f64]>> =
        (0..sched.subtrees.len()).map(|_| None).collect();
    let mut top_values: Vec<(usize, &mut [f64])> = Vec::with_capacity(sched.top.len());
    {
        let mut rest: &mut [f64] = &mut values;
        let mut at = 0usize;
        for (first, piece) in &pieces {
            let last = match piece {
                Piece::Subtree(k) => sched.subtrees[*k].last,
                Piece::Top(s) => *s,
            };
            if lay.vptr[*first] != at {
                return Err(Failure::Structure);
            }
            let len = lay.vptr[last + 1] - at;
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(len);
            rest = tail;
            at += len;
            match piece {
                Piece::Subtree(k) => subtree_values[*k] = Some(head),
                Piece::Top(s) => top_values.push((*s, head)),
            }
        }
        if at != lay.vptr[ns] {
            return Err(Failure::Structure);
        }
    }

    // Supernode `s`'s front, given its children's update matrices, its panel and its own
    // update matrix.
    let front_of = |s: usize,
                    updates: &[f64],
                    panel: &mut [f64],
                    u: &mut [f64],
                    negative: &mut Vec<usize>,
                    scratch: &mut Scratch| {
        front(
            simd,
            &lay,
            s,
            scatter,
            a_values,
            kids(s),
            updates,
            panel,
            u,
            signed,
            negative,
            scratch,
        )
    };

    // The subtrees: each returns its root's update matrix and its negative pivots.
    let run_subtree = |k: usize, vals: &mut [f64]| -> Result<SubtreeResult, Failure> {
        let t = &sched.subtrees[k];
        let base = lay.vptr[t.first];
        // The stack's largest size, so that it never moves (a reallocation copies it, and
        // freeing the old block costs the other cores a TLB flush).
        let mut peak = 0usize;
        {
            let mut sizes: Vec<usize> = Vec::new();
            let mut held = 0usize;
            for s in t.first..=t.last {
                let np = lay.rptr[s + 1] - lay.rptr[s];
                peak = peak.max(held + np * np);
                for _ in kids(s) {
                    held -= sizes.pop().unwrap_or(0);
                }
                sizes.push(np * np);
                held += np * np;
            }
        }
        let mut stack: Vec<f64> = Vec::with_capacity(peak);
        let mut tops: Vec<usize> = Vec::new(); // offsets of the update matrices on `stack`
        let mut negative = Vec::new();
        let mut scratch = Scratch::default();
        for s in t.first..=t.last {
            // The children's update matrices lie at the top of the stack, in order; this
            // front's goes after them and then moves down in their place.
            let nk = kids(s).len();
            let first_kid = tops.len() - nk;
            let from = if nk > 0 { tops[first_kid] } else { stack.len() };
            let np = lay.rptr[s + 1] - lay.rptr[s];
            let len = stack.len();
            stack.resize(len + np * np, 0.0);
            let (below, u) = stack.split_at_mut(len);
            let panel = &mut vals[lay.vptr[s] - base..lay.vptr[s + 1] - base];
            front_of(s, &below[from..], panel, u, &mut negative, &mut scratch)?;
            stack.copy_within(len.., from);
            stack.truncate(from + np * np);
            tops.truncate(first_kid);
            tops.push(from);
        }
        let root_u = stack.split_off(tops.last().copied().unwrap_or(0));
        Ok((root_u, negative))
    };
    let jobs: Vec<(usize, &mut [f64])> = subtree_values
        .into_iter()
        .enumerate()
        .map(|(k, v)| (k, v.unwrap_or_default()))
        .collect();
    let results: Vec<Result<SubtreeResult, Failure>> = match par {
        Par::Rayon => jobs
            .into_par_iter()
            .map(|(k, v)| run_subtree(k, v))
            .collect(),
        Par::Seq => jobs.into_iter().map(|(k, v)| run_subtree(k, v)).collect(),
    };
    let mut root_update: Vec<Option<Vec<f64>>> = vec![None; ns];
    let mut negative = Vec::new();
    for (k, r) in results.into_iter().enumerate() {
        let (u, neg) = r?;
        negative.extend(neg);
        root_update[sched.subtrees[k].last] = Some(u);
    }

    // The supernodes above the subtrees, in order; a child's update matrix is taken when its
    // parent uses it.
    let mut scratch = Scratch::default();
    for (s, panel) in top_values {
        let np = lay.rptr[s + 1] - lay.rptr[s];
        let mut u = vec![0.0; np * np];
        // (one copy of the children's update matrices, one after the other: there are few
        // separator supernodes.)
        let mut updates = Vec::new();
        for &c in kids(s) {
            updates.extend(root_update[c].take().unwrap_or_default());
        }
        front_of(s, &updates, panel, &mut u, &mut negative, &mut scratch)?;
        root_update[s] = Some(u);
    }
    negative.sort_unstable();
    Ok((values, negative))
}

/// What a subtree leaves: its root's update matrix and its negative pivots.
type SubtreeResult = (Vec<f64>, Vec<usize>);

/// Buffers reused from front to front.
#[derive(Default)]
struct Scratch {
    /// Position of each row of a child's pattern in the parent's front.
    rel: Vec<usize>,
    /// `L₂₁ S` of a large front.
    signed_panel: Vec<f64>,
    /// The signs of the front's pivots.
    signs: Vec<f64>,
}

with_avx2_copy! {
/// Assembles, factorises and updates the front of supernode `s`: `kid_updates` holds the
/// update matrices of its children `kids` one after the other, `panel` is its block of the
/// factor (`nf × nc`, column-major, zero on entry), `u` its update matrix (`np × np`, lower
/// triangle, zero on entry). `simd` (first argument of `front`) runs the AVX2 copy.
#[allow(clippy::too_many_arguments)]
fn front => front_base / front_avx2(
    lay: &FactorView<'_>,
    s: usize,
    scatter: &Scatter,
    a_values: &[f64],
    kids: &[usize],
    kid_updates: &[f64],
    panel: &mut [f64],
    u: &mut [f64],
    signed: bool,
    negative: &mut Vec<usize>,
    scratch: &mut Scratch,
) -> Result<(), Failure> {
    let (b, e) = (lay.begin[s], lay.end[s]);
    let nc = e - b;
    let pat = lay.pattern(s);
    let np = pat.len();
    let nf = nc + np;
    // Front position of a row of the front.
    let local = |r: usize| -> Option<usize> {
        if (b..e).contains(&r) {
            Some(r - b)
        } else {
            pat.binary_search(&r).ok().map(|k| nc + k)
        }
    };
    // Entries of A.
    for j in b..e {
        let col = &mut panel[(j - b) * nf..(j - b + 1) * nf];
        for k in scatter.ptr[j]..scatter.ptr[j + 1] {
            let at = local(scatter.row[k]).ok_or(Failure::Structure)?;
            col[at] += a_values[scatter.src[k]];
        }
    }
    // Children's update matrices (extend-add). Both row lists ascend: one merge walk.
    let mut at_update = 0usize;
    for &c in kids {
        let pc = lay.pattern(c);
        let npc = pc.len();
        let uc = kid_updates
            .get(at_update..at_update + npc * npc)
            .ok_or(Failure::Structure)?;
        at_update += npc * npc;
        scratch.rel.clear();
        let mut q = 0usize;
        for &r in pc {
            let at = if (b..e).contains(&r) {
                r - b
            } else {
                while q < np && pat[q] < r {
                    q += 1;
                }
                if q == np || pat[q] != r {
                    return Err(Failure::Structure);
                }
                nc + q
            };
            scratch.rel.push(at);
        }
        let rel = &scratch.rel;
        for jb in 0..npc {
            let lj = rel[jb];
            let ucol = &uc[jb * npc..(jb + 1) * npc];
            if lj < nc {
                let col = &mut panel[lj * nf..(lj + 1) * nf];
                for ib in jb..npc {
                    col[rel[ib]] += ucol[ib];
                }
            } else {
                let col = &mut u[(lj - nc) * np..(lj - nc + 1) * np];
                for ib in jb..npc {
                    col[rel[ib] - nc] += ucol[ib];
                }
            }
        }
    }
    // The front's own columns.
    scratch.signs.clear();
    let big = nc * np * np >= GEMM_MIN_WORK || nc > PANEL_BLOCK;
    let block = if big { PANEL_BLOCK } else { nc.max(1) };
    let mut jb = 0;
    while jb < nc {
        let je = (jb + block).min(nc);
        for j in jb..je {
            let d = panel[j * nf + j];
            if !d.is_finite() || d == 0.0 || (!signed && d < 0.0) {
                return Err(Failure::Pivot {
                    column: b + j,
                    value: d,
                });
            }
            let sign = if d < 0.0 { -1.0 } else { 1.0 };
            if d < 0.0 {
                negative.push(b + j);
            }
            scratch.signs.push(sign);
            let r = d.abs().sqrt();
            let scale = 1.0 / (sign * r);
            let (done, rest) = panel.split_at_mut((j + 1) * nf);
            let cj = &mut done[j * nf..];
            cj[j] = r;
            cj[j + 1..].iter_mut().for_each(|x| *x *= scale);
            // Right-looking inside the block.
            for l in j + 1..je {
                let f = sign * cj[l];
                let cl = &mut rest[(l - j - 1) * nf..(l - j) * nf];
                for i in l..nf {
                    cl[i] -= f * cj[i];
                }
            }
        }
        if je < nc {
            // The rest of the panel, rows je.., columns je..nc, by the block jb..je.
            let (left, right) = panel.split_at_mut(je * nf);
            let w = signed_copy(
                &left[jb * nf..],
                nf,
                je - jb,
                je,
                nf - je,
                &scratch.signs[jb..je],
                &mut scratch.signed_panel,
            );
            let lhs = MatRef::from_column_major_slice(w, nf - je, je - jb);
            let rhs = MatRef::from_column_major_slice_with_stride(
                &left[jb * nf + je..],
                nc - je,
                je - jb,
                nf,
            );
            let dst = MatMut::from_column_major_slice_with_stride_mut(
                &mut right[je..],
                nf - je,
                nc - je,
                nf,
            );
            matmul(dst, Accum::Add, lhs, rhs.transpose(), -1.0, faer::Par::Seq);
        }
        jb = je;
    }
    // The update matrix: u −= L₂₁ S L₂₁ᵀ (lower triangle).
    if np == 0 {
        return Ok(());
    }
    if big {
        let w = signed_copy(
            panel,
            nf,
            nc,
            nc,
            np,
            &scratch.signs,
            &mut scratch.signed_panel,
        );
        let lhs = MatRef::from_column_major_slice(w, np, nc);
        let rhs = MatRef::from_column_major_slice_with_stride(&panel[nc..], np, nc, nf);
        let dst = MatMut::from_column_major_slice_mut(u, np, np);
        tri_matmul(
            dst,
            BlockStructure::TriangularLower,
            Accum::Add,
            lhs,
            BlockStructure::Rectangular,
            rhs.transpose(),
            BlockStructure::Rectangular,
            -1.0,
            faer::Par::Seq,
        );
    } else {
        for j in 0..nc {
            let cj = &panel[j * nf + nc..(j + 1) * nf];
            let sign = scratch.signs[j];
            for l in 0..np {
                let f = sign * cj[l];
                let ul = &mut u[l * np..(l + 1) * np];
                for i in l..np {
                    ul[i] -= f * cj[i];
                }
            }
        }
    }
    Ok(())
}
}

/// Rows `row0..row0 + nrows` of `ncols` columns (stride `ld`) of `src`, each column times its
/// sign, copied into `buf` (column-major, `nrows × ncols`).
fn signed_copy<'a>(
    src: &'a [f64],
    ld: usize,
    ncols: usize,
    row0: usize,
    nrows: usize,
    signs: &[f64],
    buf: &'a mut Vec<f64>,
) -> &'a [f64] {
    buf.clear();
    for j in 0..ncols {
        let col = &src[j * ld + row0..j * ld + row0 + nrows];
        buf.extend(col.iter().map(|x| x * signs[j]));
    }
    buf
}
