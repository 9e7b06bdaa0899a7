//! Step 2 of each round of [`super`] (Botsch & Kobbelt 2004): edges shorter than 4/5 of the
//! local target collapse, in sweeps in slot order, under the feature rules of thesis §5.1.1
//! ([`super::feature_rules`]), the link condition, the longest new edge, the normal turn and
//! the 20° angle rule. Also the collapse test and the collapse itself for the later passes.

use super::*;

impl State<'_> {
    /// [`HalfEdgeMesh::collapse_topology_ok`] without allocating: no boundary pinch, the link
    /// condition (a and b share no neighbour but the apexes of the edge's triangles), the
    /// apexes keep enough edges, and something is left.
    pub(super) fn collapse_topology_ok(&self, h: u32) -> bool {
        let he = &self.he;
        let g = he.opp(h);
        let (a, b) = (he.from(h), he.to(h));
        let c = he.from(halfedge::prev(h));
        let d = if g == NONE {
            NONE
        } else {
            he.from(halfedge::prev(g))
        };
        if g != NONE && he.is_boundary_vertex(a) && he.is_boundary_vertex(b) {
            return false;
        }
        let mut nb = [NONE; 64];
        let mut n = 0;
        for x in self.neighbor_iter(b) {
            if n == nb.len() {
                return he.collapse_topology_ok(h).is_ok();
            }
            nb[n] = x;
            n += 1;
        }
        let nb = &nb[..n];
        for x in self.neighbor_iter(a) {
            if x != b && x != c && x != d && nb.contains(&x) {
                return false;
            }
        }
        let min_val = |v: u32| if he.is_boundary_vertex(v) { 3 } else { 4 };
        if he.valence(c) < min_val(c) || (d != NONE && he.valence(d) < min_val(d)) {
            return false;
        }
        he.n_live_faces() > 2
    }

    /// No edge longer than 4/3 L may appear at the merged vertex `p`. For a chain vertex only
    /// the chain's own edges count: off-chain edges that grow are split again, while a chain
    /// that keeps short edges would pin thin triangles along the feature.
    fn lengths_ok(&self, v: u32, p: V3, hp: f64, chain_only: bool, stretch2: f64) -> bool {
        let far = |x: u32| {
            let d = vec3::sub(self.he.position(x), p);
            vec3::dot(d, d) > stretch2 * Self::split_len2(self.size[x as usize], hp)
        };
        let mut last = NONE;
        for h in self.he.outgoing(v) {
            last = h;
            if (!chain_only || self.he.tag(h) != NONE) && far(self.he.to(h)) {
                return false;
            }
        }
        // The boundary edge ending at `v` (not in the outgoing sweep).
        if last != NONE {
            let q = halfedge::prev(last);
            if self.he.opp(q) == NONE
                && (!chain_only || self.he.tag(q) != NONE)
                && far(self.he.from(q))
            {
                return false;
            }
        }
        true
    }

    /// Whether collapsing `h` (origin into target) is allowed: feature rules, no long edges,
    /// no two feature edges fused, topology and geometry.
    fn collapse_allowed(&self, h: u32) -> bool {
        self.collapse_allowed_with(h, 1.0, false)
    }

    /// [`Self::collapse_allowed`] with new edges up to `stretch2` times the squared split
    /// length; with `improve`, the smallest angle of every triangle around the edge (the
    /// removed ones included) must grow instead of staying above 20°.
    pub(super) fn collapse_allowed_with(&self, h: u32, stretch2: f64, improve: bool) -> bool {
        self.collapse_allowed_at(h, stretch2, improve, COS_COLLAPSE_MIN_ANGLE)
    }

    /// [`Self::collapse_allowed_with`] where a collapse may leave no angle smaller than the
    /// one of cosine `cos_min` (unless a smaller one was there before).
    pub(super) fn collapse_allowed_at(
        &self,
        h: u32,
        stretch2: f64,
        improve: bool,
        cos_min: f64,
    ) -> bool {
        self.merge_allowed(h, false, stretch2, improve, cos_min)
    }

    /// [`Self::collapse_allowed_at`] for the edge of `h`, with its origin `a` removed into its
    /// target `b`, or with `into_origin` the other way round (a boundary edge has only this
    /// one half-edge; see [`HalfEdgeMesh::collapse_keeping_origin`]).
    pub(super) fn merge_allowed(
        &self,
        h: u32,
        into_origin: bool,
        stretch2: f64,
        improve: bool,
        cos_min: f64,
    ) -> bool {
        self.merge_allowed_to(h, into_origin, None, stretch2, improve, cos_min)
    }

    /// [`Self::collapse_allowed_at`] with the merged vertex at `p` instead of
    /// [`Self::merged_position`].
    pub(super) fn collapse_allowed_to(&self, h: u32, p: V3, stretch2: f64, cos_min: f64) -> bool {
        self.merge_allowed_to(h, false, Some(p), stretch2, false, cos_min)
    }

    /// [`Self::merge_allowed`] with the merged vertex at `at`, or where the merge puts it.
    fn merge_allowed_to(
        &self,
        h: u32,
        into_origin: bool,
        at: Option<V3>,
        stretch2: f64,
        improve: bool,
        cos_min: f64,
    ) -> bool {
        let (mut a, mut b) = (self.he.from(h), self.he.to(h));
        if into_origin {
            std::mem::swap(&mut a, &mut b);
        }
        if !self.removable_into(h, a, b) {
            return false;
        }
        // The two sides of each removed triangle fuse into one edge: never two features.
        let g = self.he.opp(h);
        for k in [h, g] {
            if k != NONE
                && self.he.tag(halfedge::next(k)) != NONE
                && self.he.tag(halfedge::prev(k)) != NONE
            {
                return false;
            }
        }
        let p = at.unwrap_or_else(|| self.merged_position_into(a, b));
        let chain = matches!(self.role[a as usize], Role::Chain(_));
        let hm = self.size[a as usize].min(self.size[b as usize]);
        self.lengths_ok(a, p, hm, chain, stretch2)
            && self.lengths_ok(b, p, hm, chain, stretch2)
            && self.collapse_topology_ok(h)
            && {
                // Smallest angle of the surviving triangles around a and b, before and after
                // (as cosines): a collapse may not create an angle below both the old one
                // and 20°.
                let mut new = -1.0;
                if improve {
                    self.fan_ok(a, b, p, &mut new)
                        && self.fan_ok(b, a, p, &mut new)
                        && new
                            < self
                                .fan_min_angle_cos(a, NONE)
                                .max(self.fan_min_angle_cos(b, NONE))
                } else {
                    // The old angles come with the same sweeps (most collapses need them).
                    let (mut old_a, mut old_b) = (-1.0f64, -1.0f64);
                    self.fan_ok_with_old(a, b, p, &mut new, Some(&mut old_a), f64::INFINITY)
                        && self.fan_ok_with_old(b, a, p, &mut new, Some(&mut old_b), f64::INFINITY)
                        && (new <= cos_min || new <= old_a || new <= old_b)
                }
            }
    }

    /// Collapses `pick` into its target, which takes the merged position and the smaller
    /// local target length, and marks the target as touched in this sweep.
    pub(super) fn apply_collapse(&mut self, pick: u32, touched: &mut [bool]) {
        self.apply_merge(pick, false, touched);
    }

    /// [`Self::apply_collapse`] with the merged vertex at `p`, on input face `face`.
    pub(super) fn apply_collapse_to(&mut self, pick: u32, p: V3, face: u32, touched: &mut [bool]) {
        let b = self.he.to(pick);
        self.apply_merge(pick, false, touched);
        self.he.set_position(b, p);
        self.hint[b as usize] = face;
    }

    /// [`Self::apply_collapse`], or with `into_origin` the other way round: the target of
    /// boundary half-edge `h` goes into its origin ([`Self::merge_allowed`]).
    pub(super) fn apply_merge(&mut self, h: u32, into_origin: bool, touched: &mut [bool]) {
        let (mut a, mut b) = (self.he.from(h), self.he.to(h));
        if into_origin {
            std::mem::swap(&mut a, &mut b);
        }
        let p = self.merged_position_into(a, b);
        self.size[b as usize] = self.size[a as usize].min(self.size[b as usize]);
        if into_origin {
            self.he.collapse_keeping_origin(h);
        } else {
            self.he.collapse(h);
        }
        self.he.set_position(b, p);
        touched[b as usize] = true;
        self.collapses += 1;
        if self.role[a as usize] == Role::Corner {
            self.corners_merged += 1;
        }
    }

    pub(super) fn collapse_short(&mut self) {
        // Whether an edge may collapse depends only on the one-rings of its ends and of the
        // apexes of its triangles (positions, connectivity, local sizes). A collapse into `b`
        // changes the one-rings of `b` and its new neighbours only; those get the collapse's
        // number in `changed`, and an edge refused after the last change of its four vertices
        // is refused again without looking (same outcome, far fewer tries in the later sweeps).
        let mut collapses = 0u32;
        let nh = self.he.n_halfedge_slots();
        let mut changed = vec![0u32; self.he.n_vertex_slots()];
        let mut refused = vec![0u32; nh];
        // After the first sweep, an edge none of whose four vertices changed since it was
        // last looked at is skipped by every test below (long, refused, or gone; an end
        // touched by a collapse is such a change): when a sweep changed few vertices, the
        // next one visits only the edges of the faces around them (a bit per half-edge),
        // and, within that sweep, the edges that its own collapses change further on.
        let mut todo: Option<Vec<u64>> = None;
        // A few sweeps per round: edges left short now are retried in the next round, after
        // relaxation has moved their neighbours.
        const SWEEPS: usize = 4;
        for sweep in 0..SWEEPS {
            let mut any = false;
            let first_stamp = collapses + 2;
            // A vertex takes part in one collapse per sweep: the sweep thins the mesh evenly
            // instead of merging a growing vertex again and again.
            let mut touched = vec![false; self.he.n_vertex_slots()];
            let mut h = 0u32;
            loop {
                // The next half-edge to look at: every one, or the next marked one (debug
                // builds look at every one and check that the unmarked ones are skipped).
                if !cfg!(debug_assertions) {
                    if let Some(bits) = &todo {
                        match next_marked(bits, h) {
                            Some(k) => h = k,
                            None => break,
                        }
                    }
                }
                if h as usize >= nh {
                    break;
                }
                let cur = h;
                h += 1;
                if todo.as_ref().is_some_and(|bits| !is_marked(bits, cur)) {
                    debug_assert!(
                        !self.worth_trying(cur, &touched, &refused, &changed),
                        "an unmarked edge is worth trying"
                    );
                    continue;
                }
                if !self.worth_trying(cur, &touched, &refused, &changed) {
                    continue;
                }
                let (a, b) = (self.he.from(cur), self.he.to(cur));
                let g = self.he.opp(cur);
                // Remove the vertex with fewer edges when both ways are allowed, else the one
                // that is allowed.
                let (first, second) = if g != NONE && self.he.valence(b) < self.he.valence(a) {
                    (g, cur)
                } else {
                    (cur, g)
                };
                // Between two free vertices both ways merge at the middle and test the same
                // triangles (up to the rounding of the middle): when the first way is refused,
                // the second is not tried.
                let both_free =
                    self.role[a as usize] == Role::Free && self.role[b as usize] == Role::Free;
                let pick = if self.collapse_allowed(first) {
                    first
                } else if second != NONE && !both_free && self.collapse_allowed(second) {
                    second
                } else {
                    // States are numbered from 1 (the state after `collapses` collapses is
                    // `collapses + 1`); 0 means "never refused".
                    refused[cur as usize] = collapses + 1;
                    continue;
                };
                let target = self.he.to(pick);
                self.apply_collapse(pick, &mut touched);
                collapses += 1;
                changed[target as usize] = collapses + 1;
                for u in self.neighbor_iter(target) {
                    changed[u as usize] = collapses + 1;
                }
                if let Some(bits) = &mut todo {
                    self.mark_edges_around(target, bits, cur + 1);
                    for u in self.neighbor_iter(target) {
                        self.mark_edges_around(u, bits, cur + 1);
                    }
                }
                any = true;
            }
            if !any || sweep + 1 == SWEEPS {
                break;
            }
            let stamped: Vec<u32> = (0..changed.len() as u32)
                .filter(|&v| changed[v as usize] >= first_stamp && self.he.is_vertex_alive(v))
                .collect();
            todo = (stamped.len() * 8 <= changed.len()).then(|| {
                let mut bits = vec![0u64; nh.div_ceil(64)];
                for &v in &stamped {
                    self.mark_edges_around(v, &mut bits, 0);
                }
                bits
            });
        }
    }

    /// Whether a collapse sweep tries the edge of canonical half-edge `h`: alive, no end
    /// collapsed into in this sweep (`touched`), shorter than the collapse length, and not
    /// refused since the last change of its ends and apexes.
    fn worth_trying(&self, h: u32, touched: &[bool], refused: &[u32], changed: &[u32]) -> bool {
        if !self.he.is_halfedge_alive(h) || !self.he.is_canonical(h) {
            return false;
        }
        let (a, b) = (self.he.from(h), self.he.to(h));
        if touched[a as usize] || touched[b as usize] {
            return false;
        }
        let lo = 4.0 / 5.0 * (0.5 * (self.size[a as usize] + self.size[b as usize]));
        if self.len2(a, b) >= lo * lo {
            return false;
        }
        if refused[h as usize] > 0 {
            let g = self.he.opp(h);
            let apex = |k: u32| self.he.from(halfedge::prev(k));
            let mut last = changed[a as usize]
                .max(changed[b as usize])
                .max(changed[apex(h) as usize]);
            if g != NONE {
                last = last.max(changed[apex(g) as usize]);
            }
            // Refused in state `refused[h]`, which included every change up to it.
            if refused[h as usize] >= last {
                debug_assert!(
                    !self.collapse_allowed(h) && (g == NONE || !self.collapse_allowed(g)),
                    "a collapse skipped as refused before is allowed now"
                );
                return false;
            }
        }
        true
    }

    /// Marks in `bits` the half-edges (and their twins) of the faces around `v` from index
    /// `from` on: the edges that have `v` as an end or as the apex of one of their triangles.
    fn mark_edges_around(&self, v: u32, bits: &mut [u64], from: u32) {
        let mut mark = |k: u32| {
            if k != NONE && k >= from {
                bits[(k / 64) as usize] |= 1 << (k % 64);
            }
        };
        for o in self.he.outgoing(v) {
            let f = halfedge::face_of(o);
            for k in [3 * f, 3 * f + 1, 3 * f + 2] {
                mark(k);
                mark(self.he.opp(k));
            }
        }
    }
}

fn is_marked(bits: &[u64], k: u32) -> bool {
    bits[(k / 64) as usize] & (1 << (k % 64)) != 0
}

/// The first half-edge at or after `from` whose bit is set in `bits`.
fn next_marked(bits: &[u64], from: u32) -> Option<u32> {
    let mut w = (from / 64) as usize;
    let mut word = *bits.get(w)? & (u64::MAX << (from % 64));
    loop {
        if word != 0 {
            return Some(w as u32 * 64 + word.trailing_zeros());
        }
        w += 1;
        word = *bits.get(w)?;
    }
}
