//! Step 3 of each round of [`super`]: flips toward the target valences (6 inside, by sector
//! at corners and on the boundary), flips that raise a pair's smallest angle below 30°, the
//! valence-neutral ("sideways") flips that move 5–7 pairs until they cancel, and the guards
//! against chords off the surface. Feature edges are never flipped (thesis §5.1.1).

use super::*;

impl State<'_> {
    /// The valence that gives vertex `v` angles closest to 60°: 6 inside a smooth region and
    /// inside a feature chain away from the boundary (three triangles on each side of a
    /// crease); at a corner or on the boundary, each sector between two feature edges of angle
    /// θ wants max(1, round(θ / 60°)) triangles, plus one edge on the boundary (4 on a
    /// straight boundary, 3 at a square corner of a boundary, 6 at a cube corner).
    pub(super) fn target_valence(&self, v: u32) -> i64 {
        let boundary = self.he.is_boundary_vertex(v);
        if !boundary && matches!(self.role[v as usize], Role::Free | Role::Chain(_)) {
            return 6;
        }
        // The fan's half-edges on the stack (this runs for every corner in every flip sweep);
        // a longer fan than the buffer holds goes to the heap.
        let mut buf = [NONE; 32];
        let mut n = 0;
        let mut heap: Vec<u32> = Vec::new();
        for h in self.he.outgoing(v) {
            if n < buf.len() {
                buf[n] = h;
            } else {
                if heap.is_empty() {
                    heap.extend_from_slice(&buf);
                }
                heap.push(h);
            }
            n += 1;
        }
        let hs: &[u32] = if heap.is_empty() { &buf[..n] } else { &heap };
        if n == 0 {
            return 6;
        }
        let tagged = |i: usize| self.he.tag(hs[i % n]) != NONE;
        // A corner without feature edges is a tip: its whole fan is one sector, closed around
        // the apex.
        let tip = !boundary && !(0..n).any(tagged);
        let start = if boundary || tip {
            0
        } else {
            (0..n).find(|&i| tagged(i)).unwrap_or(0)
        };
        let p = self.he.position(v);
        let sixty = std::f64::consts::PI / 3.0;
        let (mut tris, mut acc) = (0i64, 0.0);
        for i in start..start + n {
            let h = hs[i % n];
            let u = vec3::sub(self.he.position(self.he.to(h)), p);
            let w = vec3::sub(self.he.position(self.he.from(halfedge::prev(h))), p);
            acc += crestflow_geom::mesh::corner_angle(u, w);
            let closes = if boundary || tip {
                i + 1 == n || tagged(i + 1)
            } else {
                tagged(i + 1)
            };
            if closes {
                tris += ((acc / sixty).round() as i64).max(1);
                acc = 0.0;
            }
        }
        if tip {
            // At least three triangles close a cone.
            return tris.max(3);
        }
        tris + boundary as i64
    }

    /// Whether an edge `new` that replaces the edge `old` is longer than both the split length
    /// (`split2`, squared) and `old`, and its middle lies farther than [`FAR_POINT`]·L from
    /// the input surface and farther than the middle of `old`. The middles are projected
    /// from the input faces recorded for the vertices `hints` (new, old).
    pub(super) fn chord_leaves_surface(
        &self,
        new: [V3; 2],
        old: [V3; 2],
        hints: [u32; 2],
        split2: f64,
    ) -> bool {
        let len2 = |e: [V3; 2]| {
            let d = vec3::sub(e[0], e[1]);
            vec3::dot(d, d)
        };
        let l2 = len2(new);
        if l2 <= split2 || l2 <= len2(old) {
            return false;
        }
        let off = |e: [V3; 2], v: u32| {
            let mid = vec3::lerp(e[0], e[1], 0.5);
            self.proj
                .project(mid, self.hint[v as usize], self.l)
                .hit
                .dist2
        };
        let far = off(new, hints[0]);
        far > (FAR_POINT * self.l).powi(2) && far > off(old, hints[1])
    }

    /// Whether flipping the edge `a`–`b` to `c`–`d` makes an edge longer than the split length
    /// (and than `a`–`b`) whose middle lies farther than [`FAR_POINT`]·L from the input surface
    /// and farther than the middle of `a`–`b`.
    fn long_flip_leaves_surface(&self, a: u32, b: u32, c: u32, d: u32) -> bool {
        let p = |v: u32| self.he.position(v);
        let split2 = Self::split_len2(self.size[c as usize], self.size[d as usize]);
        self.chord_leaves_surface([p(c), p(d)], [p(a), p(b)], [c, a], split2)
    }

    /// Whether flipping the folded pair `a`–`b` (face normals `n1`, `n2`) to `c`–`d` puts the
    /// edge back on the input: the middle of `a`–`b` lies farther than [`FAR_POINT`]·L from
    /// the input surface, that of `c`–`d` within half that distance (and neither new triangle
    /// turns over: `flip_ok`, checked by the caller). Such a pair spans a crease of the input
    /// (a ridge running from `c` to `d`) as a chord.
    fn flip_follows_crease(&self, a: u32, b: u32, c: u32, d: u32) -> bool {
        match (self.chord_off2(a, b), self.chord_off2(c, d)) {
            (Some(old), Some(new)) => old > (FAR_POINT * self.l).powi(2) && new <= 0.25 * old,
            _ => false,
        }
    }

    /// The cosine of the smallest angle of the two triangles that flipping `a`–`b` (opposite
    /// corners `c` and `d`) makes; with the diagonals swapped (`c, d, a, b`), of the two it
    /// replaces.
    pub(super) fn flipped_min_angle_cos(&self, a: u32, b: u32, c: u32, d: u32) -> f64 {
        let p = |v: u32| self.he.position(v);
        min_angle_cos(p(d), p(b), p(c)).max(min_angle_cos(p(c), p(a), p(d)))
    }

    /// The squared distance of the middle of `x`–`y` from the input, by the projection walk
    /// from `x`'s face; `None` where the walk gives up (the flip tests that ask are not worth
    /// building the BVH for).
    fn chord_off2(&self, x: u32, y: u32) -> Option<f64> {
        let mid = vec3::lerp(self.he.position(x), self.he.position(y), 0.5);
        self.proj
            .project_walk(mid, self.hint[x as usize], self.l)
            .map(|hit| hit.dist2)
    }

    /// One flip sweep (module docs, step 3). With `neutral`, a flip that leaves the valence
    /// deviation of an irregular quad unchanged is made as well: it moves a 5–7 pair
    /// one edge, and pairs that meet a pair of the opposite orientation cancel in later
    /// sweeps, which flips that must lower the deviation never do.
    pub(super) fn equalize_valences(&mut self, par: Par, neutral: bool) {
        let n = self.he.n_halfedge_slots() as u32;
        let cos_turn = self.max_turn.cos();
        let (target, mut valence): (Vec<i64>, Vec<i64>) = {
            let st = &*self;
            par.map_collect(st.he.n_vertex_slots(), |v| {
                if st.he.is_vertex_alive(v as u32) {
                    (st.target_valence(v as u32), st.he.valence(v as u32) as i64)
                } else {
                    (6, 0)
                }
            })
            .into_iter()
            .unzip()
        };
        // Per face, the cosine of its smallest angle and its unnormalised normal: each face
        // belongs to three pairs (positions do not move during the sweep, and the two faces
        // of every flip are refreshed). `min_angle_cos` does not depend on the corners' order.
        let mut faces: Vec<(f64, V3)> = {
            let he = &self.he;
            par.map_collect(n as usize / 3, |f| {
                let f = f as u32;
                if !he.is_face_alive(f) {
                    return (1.0, [0.0; 3]);
                }
                let [x, y, z] = he.face_vertices(f).map(|u| he.position(u));
                (min_angle_cos(x, y, z), he.face_normal_raw(f))
            })
        };
        for h in 0..n {
            if !self.he.is_halfedge_alive(h)
                || !self.he.is_canonical(h)
                || self.he.is_boundary_edge(h)
                || self.he.tag(h) != NONE
            {
                continue;
            }
            let g = self.he.opp(h);
            let (a, b) = (self.he.from(h), self.he.to(h));
            let c = self.he.from(halfedge::prev(h));
            let d = self.he.from(halfedge::prev(g));
            let (fh, fg) = (halfedge::face_of(h), halfedge::face_of(g));
            let dev = |v: u32, delta: i64| {
                let x = valence[v as usize] + delta - target[v as usize];
                x * x
            };
            let before = dev(a, 0) + dev(b, 0) + dev(c, 0) + dev(d, 0);
            let after = dev(a, -1) + dev(b, -1) + dev(c, 1) + dev(d, 1);
            let old = faces[fh as usize].0.max(faces[fg as usize].0);
            // Keep the surface: no flip across a fold steeper than the collapse limit, unless
            // the pair cuts across a crease of the input that the other diagonal follows
            // (then whatever the valences, if the angles allow).
            let (n1, n2) = (faces[fh as usize].1, faces[fg as usize].1);
            if vec3::dot(n1, n2) < cos_turn * vec3::norm(n1) * vec3::norm(n2) {
                let new = self.flipped_min_angle_cos(a, b, c, d);
                if new <= old.max(COS_FLIP_MIN_ANGLE)
                    && self.flip_follows_crease(a, b, c, d)
                    && self.he.flip_ok(h)
                {
                    self.flip_counted(h, &mut valence);
                    self.refresh_faces(&mut faces, [fh, fg]);
                }
                continue;
            }
            let maybe_sideways = neutral && after == before && before > 0;
            if after >= before && !maybe_sideways && !(old > COS_FLIP_MIN_ANGLE) {
                continue;
            }
            let new = self.flipped_min_angle_cos(a, b, c, d);
            // Valence flips keep the smallest angle of the pair above 30° (or do not lower
            // it); a pair with a smaller angle is flipped whenever that raises it (then no
            // flip can undo another, so the sweeps terminate). Angles as cosines.
            let keeps_angles = new <= old.max(COS_FLIP_MIN_ANGLE);
            // A sideways flip needs the angle test above, and an angle-raising flip passes it
            // too: where it fails, whether the flip would be sideways does not matter, and
            // the roles of the four rings are not looked at (most pairs with equal valence
            // deviations before and after end here).
            let sideways = maybe_sideways
                && keeps_angles
                && [a, b, c, d].iter().all(|&v| {
                    self.role[v as usize] == Role::Free
                        && self
                            .neighbor_iter(v)
                            .all(|u| self.role[u as usize] == Role::Free)
                });
            let valence_better = after < before || sideways;
            if !valence_better && !(old > COS_FLIP_MIN_ANGLE) {
                continue;
            }
            let ok = if valence_better {
                keeps_angles
            } else {
                new < old - 1e-6
            };
            if !ok {
                continue;
            }
            // After the last splits, a flip that makes an edge the split rule would cut may
            // not put its middle farther than FAR_POINT·L from the input (where the far-point
            // step counts the surface as cut off), unless the old edge's middle was farther: a
            // long diagonal of a curved pair otherwise spans the surface as a chord (on the
            // armadillo at 1 %, 0.46 L off it, the largest distance of the output).
            if self.no_split_follows && self.long_flip_leaves_surface(a, b, c, d) {
                continue;
            }
            // A sideways flip changes the surface a curved pair stands for, for no valence
            // gain (near the tip of a thin cigar they cut it off further): only where the
            // pair folds by less than 25° and the normals at its corners agree within 40°.
            if sideways && {
                let nn = vec3::normalize(vec3::add(n1, n2));
                vec3::dot(n1, n2) < COS_SIDEWAYS_FLAT * vec3::norm(n1) * vec3::norm(n2)
                    || [a, b, c, d].iter().any(|&v| {
                        let vn = self
                            .he
                            .outgoing(v)
                            .map(|k| self.he.face_normal_raw(halfedge::face_of(k)))
                            .fold([0.0; 3], vec3::add);
                        vec3::dot(vec3::normalize(vn), nn) < COS_SIDEWAYS_NORMALS
                    })
            } {
                continue;
            }
            if self.he.flip_ok(h) {
                self.flip_counted(h, &mut valence);
                self.refresh_faces(&mut faces, [fh, fg]);
            }
        }
    }

    /// After the far-point step ([`State::pull_to_far_points`]), which pulls the output toward
    /// input points it cuts off, the other direction: an edge whose middle lies farther than
    /// [`FAR_POINT`]·L from the input, where the other diagonal of its pair lies within half
    /// that distance (the pair spans a rim, a tip or a crease of the input as a chord), is
    /// flipped when the two new triangles keep 30° (or do not lower the pair's smallest angle)
    /// and do not turn over, whatever the valences: the rule of the rounds' flips for folded
    /// pairs ([`State::flip_follows_crease`]), now for every pair. Such chords are left by
    /// the vertex moves after the last flip sweep (on the subdivided armadillo at 1 %, scale
    /// conforming: 6 flips, among them a chord 0.45 L off across an ear's rim). Returns the
    /// flips made.
    ///
    /// Positions do not change here, so the pairs that pass are found on the pool and
    /// flipped in edge order; a flip changes the pairs of the four edges around it, which are
    /// tested again right after it.
    pub(super) fn flip_far_chords(&mut self, par: Par) -> usize {
        let candidates: Vec<u32> = {
            let st = &*self;
            par.map_collect(st.he.n_halfedge_slots(), |h| {
                let h = h as u32;
                (st.he.is_halfedge_alive(h) && st.he.is_canonical(h) && st.far_chord_flip_ok(h))
                    .then_some(h)
            })
            .into_iter()
            .flatten()
            .collect()
        };
        let mut count = 0;
        let mut stack: Vec<u32> = Vec::new();
        // Each flip halves the distance of a chord, but two ends' walks may disagree on it:
        // a cap, so that no input can make flips undo each other for ever.
        let cap = self.he.n_halfedge_slots();
        for h in candidates {
            stack.push(h);
            while let Some(h) = stack.pop() {
                if count >= cap {
                    return count;
                }
                // An earlier flip may have changed this pair, or given the slot to another
                // edge.
                if !self.far_chord_flip_ok(h) {
                    continue;
                }
                let g = self.he.opp(h);
                self.he.flip(h);
                self.flips += 1;
                count += 1;
                // After the flip, `h`, `next(h)`, `g` and `next(g)` hold the four sides of
                // the new pair ([`HalfEdgeMesh::flip`]).
                stack.extend([halfedge::next(g), g, halfedge::next(h), h]);
            }
        }
        count
    }

    /// Whether [`State::flip_far_chords`] flips the edge of half-edge `h` (either side) as
    /// its pair is now.
    fn far_chord_flip_ok(&self, h: u32) -> bool {
        if !self.he.is_halfedge_alive(h) || self.he.is_boundary_edge(h) || self.he.tag(h) != NONE {
            return false;
        }
        let g = self.he.opp(h);
        let (a, b) = (self.he.from(h), self.he.to(h));
        let c = self.he.from(halfedge::prev(h));
        let d = self.he.from(halfedge::prev(g));
        // The angle test first: it is cheap, and most pairs fail it.
        let old = self.flipped_min_angle_cos(c, d, a, b);
        let new = self.flipped_min_angle_cos(a, b, c, d);
        // Then whether an end's input face is near the middle, which settles most of the
        // pairs left without a walk.
        let mid = vec3::lerp(self.he.position(a), self.he.position(b), 0.5);
        let limit2 = (FAR_POINT * self.l).powi(2);
        let far_from = |v: u32| {
            self.proj
                .dist2_to_face(self.hint[v as usize], mid)
                .is_none_or(|d2| d2 > limit2)
        };
        new <= old.max(COS_FLIP_MIN_ANGLE)
            && far_from(a)
            && far_from(b)
            && self.flip_follows_crease(a, b, c, d)
            && self.he.flip_ok(h)
    }

    /// Recomputes the smallest-angle cosine and normal of faces `fs` in a flip sweep's table.
    fn refresh_faces(&self, faces: &mut [(f64, V3)], fs: [u32; 2]) {
        for f in fs {
            let [x, y, z] = self.he.face_vertices(f).map(|u| self.he.position(u));
            faces[f as usize] = (min_angle_cos(x, y, z), self.he.face_normal_raw(f));
        }
    }

    /// Flips the edge of `h` and updates the valences of its quad's corners in `valence`.
    fn flip_counted(&mut self, h: u32, valence: &mut [i64]) {
        let (a, b) = (self.he.from(h), self.he.to(h));
        let c = self.he.from(halfedge::prev(h));
        let d = self.he.from(halfedge::prev(self.he.opp(h)));
        self.he.flip(h);
        valence[a as usize] -= 1;
        valence[b as usize] -= 1;
        valence[c as usize] += 1;
        valence[d as usize] += 1;
        self.flips += 1;
    }
}

/// cos 25°: the largest fold between the pair of triangles of a sideways (valence-neutral)
/// flip. Until version 28 the limits were 5° and 10°: on curved organic shapes most 5–7
/// pairs then could not move (the scale-conforming armadillo at 1 % kept 0.77–0.78 of its
/// vertices regular over six axis orders, 0.80–0.81 with these limits; Hausdorff median
/// 0.00448 → 0.00440).
const COS_SIDEWAYS_FLAT: f64 = 0.906_307_787_036_649_9;

/// cos 40°: how far the vertex normals of its four corners may turn from the pair's normal.
const COS_SIDEWAYS_NORMALS: f64 = 0.766_044_443_118_978;
