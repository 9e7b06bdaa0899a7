//! After the rounds of [`super`]: collapses and vertex splits for the valences, where no flip
//! lowers the squared valence deviation (a 5–5 edge between two 7s becomes one regular
//! vertex; a 7 between two 5s, or an 8, splits in two).

use super::*;

impl State<'_> {
    /// After the rounds: collapses between two free vertices that lower the valence
    /// deviation of the four corners of the edge's pair. A 5–5 edge between two 7s becomes
    /// one regular vertex with two regular apexes (a 4 beside two 7s likewise), which no flip
    /// reaches: flipping that edge makes 4s and 8s. Such collapses may leave edges up to
    /// [`VALENCE_COLLAPSE_STRETCH`]·L and no angle below 30° that was not there, and the two
    /// vertices removed must lie within [`VALENCE_COLLAPSE_OFF`]·L of the triangles that
    /// replace them (on a curved patch or a thin part one vertex fewer cuts the surface).
    /// The merged vertex goes to the middle of the edge; where that fails the tests, to the
    /// centroid of its ring on the input, where the relaxation after these collapses would
    /// take it anyway (the middle of an edge across a curved patch lies below the surface,
    /// and its fan cuts under the two vertices it replaces).
    /// A few sweeps; a vertex next to a collapse waits for the next one. Returns the number
    /// of collapses.
    pub(super) fn collapse_for_valence(&mut self, par: Par) -> usize {
        let mut valence: Vec<i64> = {
            let he = &self.he;
            par.map_collect(he.n_vertex_slots(), |v| he.valence(v as u32) as i64)
        };
        // `lengths_ok` compares with the split length, 4/3 L.
        let stretch2 = (VALENCE_COLLAPSE_STRETCH * 0.75).powi(2);
        let off2 = (VALENCE_COLLAPSE_OFF * self.l).powi(2);
        let mut done = 0;
        for _ in 0..3 {
            let mut touched = vec![false; self.he.n_vertex_slots()];
            let mut any = false;
            for h in 0..self.he.n_halfedge_slots() as u32 {
                if !self.he.is_halfedge_alive(h)
                    || !self.he.is_canonical(h)
                    || self.he.is_boundary_edge(h)
                    || self.he.tag(h) != NONE
                {
                    continue;
                }
                let (a, b) = (self.he.from(h), self.he.to(h));
                if touched[a as usize]
                    || touched[b as usize]
                    || !self.movable(a)
                    || !self.movable(b)
                {
                    continue;
                }
                let c = self.he.from(halfedge::prev(h));
                let d = self.he.from(halfedge::prev(self.he.opp(h)));
                // a and b are free, off the boundary: their target is 6.
                let (va, vb) = (valence[a as usize], valence[b as usize]);
                let dc = valence[c as usize] - self.target_valence(c);
                let dd = valence[d as usize] - self.target_valence(d);
                let before = (va - 6).pow(2) + (vb - 6).pow(2) + dc * dc + dd * dd;
                let after = (va + vb - 10).pow(2) + (dc - 1).pow(2) + (dd - 1).pow(2);
                if after >= before {
                    continue;
                }
                if self.collapse_allowed_at(h, stretch2, false, COS_FLIP_MIN_ANGLE)
                    && self.merge_stays_within(h, off2)
                {
                    self.apply_collapse(h, &mut touched);
                } else if let Some((p, face)) = self.merged_ring_centroid(h).filter(|&(p, _)| {
                    self.collapse_allowed_to(h, p, stretch2, COS_FLIP_MIN_ANGLE)
                        && self.merge_stays_within_at(h, p, off2)
                }) {
                    self.apply_collapse_to(h, p, face, &mut touched);
                    self.valence_collapses_recentred += 1;
                } else {
                    continue;
                }
                valence[b as usize] = va + vb - 4;
                valence[c as usize] -= 1;
                valence[d as usize] -= 1;
                for u in self.neighbor_iter(b) {
                    touched[u as usize] = true;
                }
                done += 1;
                any = true;
            }
            if !any {
                break;
            }
        }
        done
    }

    /// Vertex splits for the valences, after the valence collapses (their inverse): a free
    /// vertex `v` of valence 7 or more becomes two joined vertices, `v` keeping the arc of
    /// its ring from `r_p` to `r_q` and a new vertex the rest, so that `r_p` and `r_q` gain an
    /// edge each. A 7 between two 5s becomes a 5 and a 6 between two 6s, an 8 two 6s. Made
    /// where it lowers the squared valence deviation of `v`, `r_p` and `r_q` (targets as for
    /// the flips), where the two vertices at their rings' centroids, on the input, make
    /// triangles that keep 30° (or the fan's smallest angle), turn by at most 60° and have
    /// sides between 0.6 and 4/3 of the local target, where `v`'s old place lies within 0.1 L
    /// of them, and where no input vertex nearby ends up farther than before and than
    /// [`VALENCE_SPLIT_NEAR`]·L ([`State::split_keeps_input_close`]). Three sweeps at most;
    /// the rings of a split wait for the next sweep. Made in slot order (planned ahead on the
    /// pool, see below): the same bits at any thread count.
    pub(super) fn split_for_valence(&mut self, input: &TriMesh, par: Par) -> usize {
        let off2 = (VALENCE_COLLAPSE_OFF * self.l).powi(2);
        let n_in = input.n_vertices();
        let mut stamp = vec![0u32; n_in];
        let mut generation = 0u32;
        let mut done = 0;
        // After the first sweep, only vertices whose two-ring a split changed are planned
        // again (the plan of any other would be refused again).
        let mut last: Option<Vec<bool>> = None;
        for _ in 0..3 {
            let slots = self.he.n_vertex_slots();
            let candidates: Vec<u32> = (0..slots as u32)
                .filter(|&v| {
                    self.he.is_vertex_alive(v) && self.movable(v) && self.he.valence(v) >= 7
                })
                .filter(|&v| match &last {
                    Some(t) => {
                        let changed = |u: u32| t.get(u as usize).is_none_or(|&x| x);
                        changed(v) || self.neighbor_iter(v).any(changed)
                    }
                    None => true,
                })
                .collect();
            // Every candidate is planned on the pool against the sweep's first state; few
            // plans succeed. A split at w changes the positions, valences and fans of w, its
            // ring and the new vertex only (all `touched`), and the plan of v reads v, its
            // ring, their valences and the faces around the ring: a plan whose vertex and ring
            // are untouched is what planning it in order would give. The others are planned
            // again when their turn comes, in slot order as before.
            // (On one thread that would only add the plans of vertices touched before their
            // turn.)
            let mut plans: Option<Vec<Option<VertexSplit>>> = (par == Par::Rayon).then(|| {
                let st = &*self;
                par.map_init_collect(
                    candidates.len(),
                    || (vec![0u32; n_in], 0u32),
                    |(stamp, generation), k| {
                        st.plan_vertex_split(candidates[k], off2, input, stamp, generation)
                    },
                )
            });
            let mut touched = vec![false; slots];
            let mut any = false;
            for (k, &v) in candidates.iter().enumerate() {
                if touched[v as usize] {
                    continue;
                }
                let made_ahead = plans.as_mut().filter(|_| {
                    !self
                        .neighbor_iter(v)
                        .any(|u| touched.get(u as usize).is_none_or(|&t| t))
                });
                let plan = if let Some(plans) = made_ahead {
                    let plan = plans[k].take();
                    debug_assert_eq!(
                        plan,
                        self.plan_vertex_split(v, off2, input, &mut stamp, &mut generation),
                        "a plan made ahead differs from the plan in order"
                    );
                    plan
                } else {
                    self.plan_vertex_split(v, off2, input, &mut stamp, &mut generation)
                };
                let Some(plan) = plan else {
                    continue;
                };
                for &u in &plan.ring {
                    touched[u as usize] = true;
                }
                touched[v as usize] = true;
                self.apply_vertex_split(v, &plan);
                done += 1;
                any = true;
            }
            if !any {
                break;
            }
            last = Some(touched);
        }
        done
    }

    /// The best vertex split of `v` for the valences that passes the geometric tests of
    /// [`State::split_for_valence`], if any.
    fn plan_vertex_split(
        &self,
        v: u32,
        off2: f64,
        input: &TriMesh,
        stamp: &mut [u32],
        generation: &mut u32,
    ) -> Option<VertexSplit> {
        let ring: Vec<u32> = self.he.outgoing(v).map(|h| self.he.to(h)).collect();
        let n = ring.len();
        // A ring that meets itself (or a fan that is not closed) is left alone.
        if n < 7 || n != self.he.valence(v) {
            return None;
        }
        for i in 0..n {
            if ring[i + 1..].contains(&ring[i]) {
                return None;
            }
        }
        let dev: Vec<i64> = ring
            .iter()
            .map(|&u| self.he.valence(u) as i64 - self.target_valence(u))
            .collect();
        let nv = n as i64;
        // (gain, p, q): v keeps r_p ..= r_q (forward), the new vertex r_q ..= r_p.
        let mut cands: Vec<(i64, usize, usize)> = Vec::new();
        for p in 0..n {
            for q in p + 2..n {
                let s1 = (q - p - 1) as i64;
                let s2 = nv - 2 - s1;
                if s2 < 1 {
                    continue;
                }
                let before = (nv - 6).pow(2) + dev[p].pow(2) + dev[q].pow(2);
                let after =
                    (s1 - 3).pow(2) + (s2 - 3).pow(2) + (dev[p] + 1).pow(2) + (dev[q] + 1).pow(2);
                if after < before {
                    cands.push((before - after, p, q));
                }
            }
        }
        cands.sort_by(|x, y| y.0.cmp(&x.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        let pos = |u: u32| self.he.position(u);
        let pv = pos(v);
        let old: Vec<[V3; 3]> = (0..n)
            .map(|k| [pv, pos(ring[k]), pos(ring[(k + 1) % n])])
            .collect();
        let old_cos = old
            .iter()
            .map(|t| min_angle_cos(t[0], t[1], t[2]))
            .fold(COS_FLIP_MIN_ANGLE, f64::max);
        let n_v = old.iter().fold([0.0; 3], |s, t| {
            vec3::add(s, vec3::cross(vec3::sub(t[1], t[0]), vec3::sub(t[2], t[0])))
        });
        let h = self.size[v as usize];
        let (lo2, hi2) = ((0.6 * h).powi(2), (4.0 / 3.0 * h).powi(2));
        for &(_, p, q) in cands.iter().take(VALENCE_SPLIT_TRIES) {
            let arc_a: Vec<usize> = (p..=q).collect();
            let arc_b: Vec<usize> = (q..=p + n).map(|k| k % n).collect();
            // The two ring centroids, each with the other vertex in its ring: a 2 × 2 system
            // per coordinate, solved exactly.
            let sum = |arc: &[usize]| {
                arc.iter()
                    .fold([0.0; 3], |s, &k| vec3::add(s, pos(ring[k])))
            };
            let (sa, sb) = (sum(&arc_a), sum(&arc_b));
            let (al, be) = ((arc_a.len() + 1) as f64, (arc_b.len() + 1) as f64);
            let det = al * be - 1.0;
            let a0 = vec3::scale(vec3::add(vec3::scale(sa, be), sb), 1.0 / det);
            let b0 = vec3::scale(vec3::add(vec3::scale(sb, al), sa), 1.0 / det);
            // The triangles of the split with its two vertices at `pa` and `pb` (each with the
            // normal of the old triangle it replaces), when their shapes pass.
            let shaped = |pa: V3, pb: V3| -> Option<Vec<([V3; 3], V3)>> {
                let mut new: Vec<([V3; 3], V3)> = Vec::with_capacity(n + 2);
                for (arc, x) in [(&arc_a, pa), (&arc_b, pb)] {
                    for w in arc.windows(2) {
                        let o = &old[w[0]];
                        new.push((
                            [x, o[1], o[2]],
                            vec3::cross(vec3::sub(o[1], pv), vec3::sub(o[2], pv)),
                        ));
                    }
                }
                new.push(([pa, pos(ring[q]), pb], n_v));
                new.push(([pa, pb, pos(ring[p])], n_v));
                let d2 = |x: V3, y: V3| {
                    let d = vec3::sub(x, y);
                    vec3::dot(d, d)
                };
                let ok = new.iter().all(|(t, n_old)| {
                    min_angle_cos(t[0], t[1], t[2]) <= old_cos
                        && keeps_orientation(*n_old, *t, self.cos_turn)
                }) && arc_a
                    .iter()
                    .all(|&k| (lo2..=hi2).contains(&d2(pa, pos(ring[k]))))
                    && arc_b
                        .iter()
                        .all(|&k| (lo2..=hi2).contains(&d2(pb, pos(ring[k]))))
                    && (lo2..=hi2).contains(&d2(pa, pb));
                ok.then_some(new)
            };
            // Off the surface first (no projection needed where that fails), then on it.
            if shaped(a0, b0).is_none() {
                continue;
            }
            let ra = self.proj.project(a0, self.hint[v as usize], self.l);
            let rb = self.proj.project(b0, self.hint[v as usize], self.l);
            let (pa, pb) = (ra.hit.point, rb.hit.point);
            let Some(new) = shaped(pa, pb) else {
                continue;
            };
            let ok = dist2_within(pv, new.iter().map(|(t, _)| *t), off2) <= off2
                && self.split_keeps_input_close(v, &ring, &old, &new, input, stamp, generation);
            if ok {
                return Some(VertexSplit {
                    ring,
                    p,
                    q,
                    a: (pa, ra.hit.face),
                    b: (pb, rb.hit.face),
                });
            }
        }
        None
    }

    /// Whether no input vertex near the fan of `v` ends farther from the triangles `new` (or
    /// from the faces around the fan, which stay) than it was and than [`VALENCE_SPLIT_NEAR`]·L:
    /// a split may not cut off a tip the fan reached.
    #[allow(clippy::too_many_arguments)]
    fn split_keeps_input_close(
        &self,
        v: u32,
        ring: &[u32],
        old: &[[V3; 3]],
        new: &[([V3; 3], V3)],
        input: &TriMesh,
        stamp: &mut [u32],
        generation: &mut u32,
    ) -> bool {
        let Some(t) = input.triangles.get(self.hint[v as usize] as usize) else {
            return false;
        };
        *generation += 1;
        let pv = self.he.position(v);
        let limit = VALENCE_SPLIT_NEAR * self.l;
        let near = self.input_near(
            pv,
            pv,
            ring,
            self.hint[v as usize],
            t[0],
            limit,
            input,
            stamp,
            *generation,
        );
        // The faces around the fan stay: a point closer to one of them keeps that distance.
        let fan: Vec<u32> = self.he.outgoing(v).map(halfedge::face_of).collect();
        let mut around: Vec<[V3; 3]> = Vec::new();
        let mut seen: Vec<u32> = Vec::new();
        for &u in ring {
            for h in self.he.outgoing(u) {
                let f = halfedge::face_of(h);
                if !fan.contains(&f) && !seen.contains(&f) {
                    seen.push(f);
                    around.push(self.he.face_vertices(f).map(|w| self.he.position(w)));
                }
            }
        }
        let limit2 = limit * limit;
        near.iter().all(|&k| {
            let x = input.positions[k as usize];
            let d_new = dist2_within(x, new.iter().map(|(t, _)| *t), limit2);
            if d_new <= limit2 {
                return true;
            }
            let d_around = dist2_to_triangles(x, around.iter().copied());
            let d_new = d_new.min(d_around);
            d_new <= limit2 || d_new <= dist2_to_triangles(x, old.iter().copied()).min(d_around)
        })
    }

    /// Makes the split planned by [`State::plan_vertex_split`]: the edge `v`–`r_{q+1}` is split
    /// and the edges from `v` to `r_{q+2}`, …, `r_{p-1}` flipped over to the new vertex.
    fn apply_vertex_split(&mut self, v: u32, s: &VertexSplit) {
        let n = s.ring.len();
        let h = self.he.find_edge(v, s.ring[(s.q + 1) % n]);
        let m = self.he.split_edge(h, s.b.0);
        self.role.push(Role::Free);
        self.param.push(0.0);
        self.hint.push(s.b.1);
        self.size.push(self.size[v as usize]);
        self.origin.push(self.origin[v as usize]);
        let mut k = s.q + 2;
        while k % n != s.p {
            let e = self.he.find_edge(v, s.ring[k % n]);
            self.he.flip(e);
            k += 1;
        }
        self.he.set_position(v, s.a.0);
        self.hint[v as usize] = s.a.1;
        debug_assert_eq!(self.he.valence(v), s.q - s.p + 2);
        debug_assert_eq!(self.he.valence(m), n - (s.q - s.p) + 2);
    }

    /// Whether both ends of `h` keep their old places within `√off2` of the triangles that
    /// replace them when `h` collapses (at [`Self::merged_position`]).
    pub(super) fn merge_stays_within(&self, h: u32, off2: f64) -> bool {
        self.merge_stays_within_at(h, self.merged_position(h), off2)
    }

    /// [`Self::merge_stays_within`] with the merged vertex at `p`.
    fn merge_stays_within_at(&self, h: u32, p: V3, off2: f64) -> bool {
        let (a, b) = (self.he.from(h), self.he.to(h));
        self.merged_fan_dist2(a, b, p, self.he.position(a)) <= off2
            && self.merged_fan_dist2(a, b, p, self.he.position(b)) <= off2
    }

    /// Where the relaxation would take the vertex that merges the two ends of `h`: the
    /// centroid of their joint ring, projected onto the input (point, input face).
    fn merged_ring_centroid(&self, h: u32) -> Option<(V3, u32)> {
        let (a, b) = (self.he.from(h), self.he.to(h));
        let mut ring: Vec<u32> = self.neighbor_iter(a).filter(|&u| u != b).collect();
        for u in self.neighbor_iter(b) {
            // The two apexes are in both rings: counted once.
            if u != a && !ring.contains(&u) {
                ring.push(u);
            }
        }
        if ring.is_empty() {
            return None;
        }
        let sum = ring
            .iter()
            .fold([0.0; 3], |s, &u| vec3::add(s, self.he.position(u)));
        let c = vec3::scale(sum, 1.0 / ring.len() as f64);
        // The walk only: where it gives up, no such place (the BVH is not built for it).
        let hit = self.proj.project_walk(c, self.hint[b as usize], self.l)?;
        Some((hit.point, hit.face))
    }

    /// Squared distance from `q` to the triangles that stay around `a` and `b` when they
    /// merge at `p` (those of the edge a–b itself go).
    fn merged_fan_dist2(&self, a: u32, b: u32, p: V3, q: V3) -> f64 {
        let stay = [(a, b), (b, a)].into_iter().flat_map(|(v, other)| {
            self.he
                .outgoing(v)
                .map(|k| self.he.face_vertices(halfedge::face_of(k)))
                .filter(move |t| !t.contains(&other))
                .map(move |t| t.map(|u| if u == v { p } else { self.he.position(u) }))
        });
        dist2_to_triangles(q, stay)
    }
}

/// A vertex split planned by [`State::plan_vertex_split`]: the ring of the vertex, the two
/// ring positions that become the apexes of the new edge, and the two vertices' places (point,
/// input face).
#[derive(Debug, PartialEq)]
struct VertexSplit {
    ring: Vec<u32>,
    p: usize,
    q: usize,
    a: (V3, u32),
    b: (V3, u32),
}

/// Longest edge, in target lengths, that a collapse for the valences may leave
/// ([`State::collapse_for_valence`]); the relaxation after it evens them out.
const VALENCE_COLLAPSE_STRETCH: f64 = 1.5;

/// How far (in target lengths) a vertex split for the valences may leave an input vertex near
/// it when that is farther than before ([`State::split_keeps_input_close`]). With the far-point
/// limit (0.3 L) in its place, the relaxation after the splits left the bunny at 2 % 0.33 L
/// from an input vertex (0.30 L without the splits); with 0.15 L, 0.30 L.
const VALENCE_SPLIT_NEAR: f64 = 0.15;

/// How many ways to split one vertex for the valences are tried, the largest gains first
/// ([`State::plan_vertex_split`]). A vertex of valence n has about n²/2 and each test costs
/// about n: a fan of hundreds of triangles (left by a fuzz run without relaxation steps,
/// `feature_tolerance: 0` and `feature_grading: 0.3`) took 40 s to plan. A vertex of valence
/// 12 or less has fewer than 64 ways.
const VALENCE_SPLIT_TRIES: usize = 64;
