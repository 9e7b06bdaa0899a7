//! The last pass of [`super`]: where the output cuts off a tip or a thin rim of the input by
//! more than `FAR_POINT`·L, an edge is flipped, a vertex moved onto the far input point or
//! part of the way, or an edge split toward it, each only where the triangles keep their
//! angles and nothing around them ends up farther from the input.

use super::*;

impl State<'_> {
    /// Where the output cuts off a tip or a thin rim of the input (an input vertex farther
    /// than [`FAR_POINT`]·L from the output), a free corner of the output face closest to that
    /// input vertex moves onto it (nearest corner first, then the corners' free neighbours,
    /// nearest first, for a face whose corners are all feature vertices) when
    /// - its triangles turn by at most 60° and their smallest angle stays at least
    ///   30° ([`COS_FAR_MOVE_MIN_ANGLE`]) or does not get smaller, and
    /// - nothing near it ends up farther than before or than the limit: no input vertex near
    ///   its triangles gets farther from them than it was or than FAR_POINT·L (unless it stays
    ///   within [`FAR_TRADE`] times the distance of the point pulled in), and neither do
    ///   seven points on each triangle from the input surface (moving a vertex uncovers the
    ///   place it leaves; without this test the armadillo's largest distance grew).
    ///
    /// Where no vertex qualifies, an edge of that face is split and its new vertex put on the
    /// point under the same conditions ([`State::split_toward`]; e.g. between chains of
    /// feature vertices, or across a strip whose vertices all lie on its boundary); where
    /// no other edge may be split, an edge of an inner feature chain.
    ///
    /// The second condition makes the far points a shrinking set: after the first pass (up
    /// to three; a moved vertex and its neighbours wait for the next) only the far points
    /// left are looked at again, against the triangles that moved. A fourth pass pulls a
    /// vertex part of the way toward the far points still left ([`State::pull_partway`]), and
    /// a last one splits an edge part of the way toward those still left after it
    /// ([`State::split_toward`] with `partway`).
    pub(super) fn pull_to_far_points(&mut self, input: &TriMesh, par: Par) {
        let n_in = input.n_vertices();
        let topo = input.topology();
        // A face of each input vertex (its first; u32::MAX for an unreferenced vertex).
        let input_face: Vec<u32> = (0..n_in as u32)
            .map(|v| topo.vertex_faces(v).first().copied().unwrap_or(u32::MAX))
            .collect();
        let limit = FAR_POINT * self.l;
        let limit2 = limit * limit;
        let tri = |st: &Self, g: u32| st.he.face_vertices(g).map(|u| st.he.position(u));
        let dist2_to_face = |st: &Self, x: V3, g: u32| {
            let [a, b, c] = tri(st, g);
            crestflow_geom::bvh::closest_point_on_triangle(x, a, b, c).0
        };
        // Most input vertices lie within the limit of the triangles around the output vertex
        // nearest to them (in steps over the input's faces from the faces the output
        // vertices were projected onto) or around its neighbours; only the others ask a BVH
        // of the output.
        let mut owner = vec![NONE; input.n_faces()];
        let mut queue: Vec<u32> = Vec::new();
        for v in 0..self.he.n_vertex_slots() as u32 {
            let f = self.hint[v as usize] as usize;
            if self.he.is_vertex_alive(v) && f < owner.len() && owner[f] == NONE {
                owner[f] = v;
                queue.push(f as u32);
            }
        }
        let mut k = 0;
        while k < queue.len() {
            let f = queue[k] as usize;
            k += 1;
            for e in topo.face_edges[f] {
                for g in topo.edge_faces[e as usize] {
                    if g != crestflow_geom::mesh::NO_FACE && owner[g as usize] == NONE {
                        owner[g as usize] = owner[f];
                        queue.push(g);
                    }
                }
            }
        }
        let maybe_far = par.map_collect(n_in, |i| {
            let f = input_face[i];
            if f == u32::MAX {
                return false;
            }
            let v = owner[f as usize];
            if v == NONE {
                return true;
            }
            // The triangles around v, then those around its neighbours; a corner well within
            // the limit settles a fan without its triangles.
            let x = input.positions[i];
            let near_corner = |u: u32| {
                let d = vec3::sub(self.he.position(u), x);
                vec3::dot(d, d) <= NEAR_CORNER * limit2
            };
            let close = |u: u32| {
                self.he
                    .outgoing(u)
                    .any(|k| dist2_to_face(self, x, halfedge::face_of(k)) <= limit2)
            };
            let near = |u: u32| {
                let n = near_corner(u);
                debug_assert!(!n || close(u), "a corner within the limit but no triangle");
                n || close(u)
            };
            !(near(v) || self.neighbor_iter(v).any(near))
        });
        let maybe_far: Vec<u32> = (0..n_in as u32)
            .filter(|&i| maybe_far[i as usize])
            .collect();
        if maybe_far.is_empty() {
            return;
        }
        // Exact distances of those: (distance², input vertex, working-mesh face).
        let (out, _) = self.he.to_trimesh();
        let alive_faces: Vec<u32> = (0..(self.he.n_halfedge_slots() / 3) as u32)
            .filter(|&g| self.he.is_face_alive(g))
            .collect();
        let bvh = crestflow_geom::bvh::TriangleBvh::new_with(&out, par == Par::Rayon);
        let mut far: Vec<(f64, u32, u32)> = par
            .map_collect(maybe_far.len(), |k| {
                let c = bvh.closest(input.positions[maybe_far[k] as usize]);
                (c.dist2, maybe_far[k], alive_faces[c.face as usize])
            })
            .into_iter()
            .filter(|h| h.0 > limit2)
            .collect();
        drop(bvh);
        let mut stamp = vec![0u32; n_in];
        let mut generation = 0u32;
        let mut far_face = vec![NONE; n_in];
        // Up to three passes of full pulls (moves, flips, splits), then one in which far
        // points left may pull a vertex part of the way, and one in which those still left
        // may split an edge part of the way: a partial pull earlier would move vertices that
        // a later full pull of a farther point needs, and a partial split would block the
        // partial moves around it (on the subdivided armadillo at 2 % one did, and a point
        // that such a move brought from 0.52 L to 0.43 L stayed at 0.52 L).
        let mut pass = 0;
        while pass < 5 {
            far.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            for &(_, i, f) in &far {
                far_face[i as usize] = f;
            }
            let mut blocked = vec![false; self.he.n_vertex_slots()];
            let mut moved: Vec<u32> = Vec::new();
            for &(far_d2, i, f) in &far {
                let corners = self.he.face_vertices(f);
                if corners.iter().any(|&v| blocked[v as usize]) {
                    continue;
                }
                let p = input.positions[i as usize];
                let by_distance = |a: &u32, b: &u32| {
                    let da = vec3::dist(self.he.position(*a), p);
                    let db = vec3::dist(self.he.position(*b), p);
                    da.total_cmp(&db).then(a.cmp(b))
                };
                let mut order = corners.to_vec();
                order.sort_by(by_distance);
                // Where the closest triangle's corners all lie on features, a free vertex
                // next to them may still reach the point: the corners' other neighbours,
                // nearest first.
                if !corners.iter().any(|&v| self.movable(v)) {
                    let mut ring: Vec<u32> = corners
                        .iter()
                        .flat_map(|&c| self.neighbor_iter(c))
                        .filter(|u| !corners.contains(u) && !blocked[*u as usize])
                        .collect();
                    ring.sort_by(by_distance);
                    ring.dedup();
                    order.extend(ring);
                }
                let mut pull = FarPull {
                    p,
                    i,
                    p_face: input_face[i as usize],
                    far_d2,
                    limit,
                    far_face: &far_face,
                    input,
                    stamp: &mut stamp,
                    generation: &mut generation,
                };
                if pass == 3 {
                    if let Some(v) = self.pull_partway(&order, &blocked, &mut pull) {
                        self.block_around(&mut blocked, v);
                        moved.push(v);
                    }
                    continue;
                }
                if pass < 3 {
                    if let Some([c, d]) = self.flip_toward(f, &blocked, &mut pull) {
                        for v in [c, d] {
                            self.block_around(&mut blocked, v);
                        }
                        moved.extend([c, d]);
                        continue;
                    }
                    let mut pulled = false;
                    for &v in &order {
                        if !self.movable(v) {
                            continue;
                        }
                        let p_face = pull.p_face;
                        if !self.move_for_far_point(v, p, p_face, false, &mut pull) {
                            continue;
                        }
                        self.block_around(&mut blocked, v);
                        moved.push(v);
                        pulled = true;
                        break;
                    }
                    if pulled {
                        continue;
                    }
                }
                // A split: on the far point in the full passes, part of the way in the last.
                if let Some(m) = self.split_toward(f, &blocked, &mut pull, pass == 4) {
                    blocked.resize(self.he.n_vertex_slots(), false);
                    self.block_around(&mut blocked, m);
                    moved.push(m);
                }
            }
            if pass == 4 || far.is_empty() {
                break;
            }
            if moved.is_empty() {
                // Nothing changed: the next full pass would do the same.
                pass = if pass >= 3 { pass + 1 } else { 3 };
                continue;
            }
            // Only the moved triangles changed: each far point keeps its face (at its new
            // distance) unless one of them is closer now. (Where its own face moved away, a
            // face that did not move may be closer still: then the distance is overstated.)
            let moved_faces: Vec<u32> = moved
                .iter()
                .flat_map(|&v| {
                    self.he
                        .outgoing(v)
                        .map(halfedge::face_of)
                        .collect::<Vec<_>>()
                })
                .collect();
            // A moved face can only be closer than a far point's current face if its box is;
            // the test keeps a relative margin, so that rounding in the exact distance cannot
            // make a face skipped here the closer one. Far points are independent: each is
            // updated on its own, on the pool.
            let boxes: Vec<Aabb> = moved_faces
                .iter()
                .map(|&g| Aabb::around(&tri(self, g)))
                .collect();
            far = {
                let st = &*self;
                let (far, moved_faces, boxes) = (&far, &moved_faces, &boxes);
                // The nearest of its face and the moved ones, skipping those whose box is
                // farther when `boxed`.
                let nearest = |(_, i, f): (f64, u32, u32), boxed: bool| {
                    let x = input.positions[i as usize];
                    let mut h = (dist2_to_face(st, x, f), i, f);
                    for (&g, b) in moved_faces.iter().zip(boxes) {
                        if boxed && b.dist2(x) > h.0 * (1.0 + 1e-9) {
                            continue;
                        }
                        let d2 = dist2_to_face(st, x, g);
                        if d2 < h.0 {
                            h = (d2, i, g);
                        }
                    }
                    h
                };
                // (A few far points are not worth a parallel loop.)
                let par = if far.len() >= 256 { par } else { Par::Seq };
                par.map_collect(far.len(), |j| {
                    let h = nearest(far[j], true);
                    debug_assert!(
                        {
                            // (Below the limit the point is dropped whichever face it
                            // keeps, and the margin may not cover rounding that small.)
                            let all = nearest(far[j], false);
                            all == h || (all.0 <= limit2 && h.0 <= limit2)
                        },
                        "a moved face skipped by its box is the closer one"
                    );
                    h
                })
            };
            for &(_, i, _) in &far {
                far_face[i as usize] = NONE;
            }
            far.retain(|h| h.0 > limit2);
            pass += 1;
        }
    }

    /// Marks `v` and its neighbours as moved in this far-point pass.
    fn block_around(&self, blocked: &mut [bool], v: u32) {
        blocked[v as usize] = true;
        for u in self.neighbor_iter(v) {
            blocked[u as usize] = true;
        }
    }

    /// Moves free vertex `v` to `x` (on input face `x_face`) for the far point of `pull` when
    /// its triangles turn by at most 60°, keep their area, make no long chord off the input,
    /// and keep their smallest angle at 30° or more or no smaller than before (`partway`:
    /// both), and nothing near ends up farther ([`State::move_keeps_distances`]; `partway`:
    /// without the [`FAR_TRADE`] a full pull may make). Returns whether it moved.
    fn move_for_far_point(
        &mut self,
        v: u32,
        x: V3,
        x_face: u32,
        partway: bool,
        pull: &mut FarPull<'_>,
    ) -> bool {
        let old = self.fan_min_angle_cos(v, NONE);
        // The smallest angle may not fall below 30° and the fan's before (part of the way),
        // or below both (the whole way): the new cosine at most `allowed`.
        let allowed = if partway {
            COS_FAR_MOVE_MIN_ANGLE.min(old)
        } else {
            COS_FAR_MOVE_MIN_ANGLE.max(old)
        };
        if self.fan_below(v, x, allowed.next_up()).is_none() || self.move_leaves_surface(v, x) {
            return false;
        }
        let ring: Vec<u32> = self.neighbor_iter(v).collect();
        let (q, q_hint) = (self.he.position(v), self.hint[v as usize]);
        let (tris, hints, faces) = self.fan_move(v, x, x_face);
        if partway && !pull.within_limit_of(tris[1].iter().copied()) {
            return false;
        }
        // A partial pull makes no trade.
        if !self.replacement_keeps_distances(
            q,
            &ring,
            q_hint,
            [&tris[0], &tris[1]],
            [&hints[0], &hints[1]],
            &faces,
            pull,
            !partway,
        ) {
            return false;
        }
        self.he.set_position(v, x);
        self.hint[v as usize] = x_face;
        true
    }

    /// Where no full pull reached the far point, a free vertex of `order` (its face's corners,
    /// nearest first, then their neighbours) moves three quarters, half or a quarter of the
    /// way toward it, projected onto the input, when that brings the point within
    /// [`FAR_POINT`]·L under the tests of [`State::move_for_far_point`] with `partway`.
    /// Returns the vertex moved.
    fn pull_partway(
        &mut self,
        order: &[u32],
        blocked: &[bool],
        pull: &mut FarPull<'_>,
    ) -> Option<u32> {
        for &v in order {
            if !self.movable(v) || blocked[v as usize] {
                continue;
            }
            let q = self.he.position(v);
            for t in [0.75, 0.5, 0.25] {
                let r = self
                    .proj
                    .project(vec3::lerp(q, pull.p, t), self.hint[v as usize], self.l);
                if self.move_for_far_point(v, r.hit.point, r.hit.face, true, pull) {
                    self.far_pulls_partway += 1;
                    return Some(v);
                }
            }
        }
        None
    }

    /// Where the far input point `p` (input vertex `i`, closest to output face `f`) lies
    /// beyond an edge of `f` that cuts across a crease of the input, that edge is flipped:
    /// the edges that are neither features nor on the boundary, the one whose middle is
    /// farthest from `p` first, when the flip brings `p` within [`FAR_TRADE`] times its
    /// distance, the two new triangles keep 30° (or do not lower the pair's smallest angle)
    /// and do not turn over, and nothing near ends up farther
    /// ([`State::move_keeps_distances`]). Returns the new edge's ends.
    fn flip_toward(
        &mut self,
        f: u32,
        blocked: &[bool],
        pull: &mut FarPull<'_>,
    ) -> Option<[u32; 2]> {
        let (p, far_d2) = (pull.p, pull.far_d2);
        let x = |u: u32| self.he.position(u);
        let mut edges: Vec<(f64, u32)> = (0..3)
            .map(|k| 3 * f + k)
            .filter(|&h| self.he.tag(h) == NONE && !self.he.is_boundary_edge(h))
            .map(|h| {
                let mid = vec3::lerp(x(self.he.from(h)), x(self.he.to(h)), 0.5);
                (vec3::dist(mid, p), h)
            })
            .collect();
        edges.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        for &(_, h) in &edges {
            let g = self.he.opp(h);
            let (a, b) = (self.he.from(h), self.he.to(h));
            let c = self.he.from(halfedge::prev(h));
            let d = self.he.from(halfedge::prev(g));
            if [a, b, c, d].iter().any(|&u| blocked[u as usize]) || !self.he.flip_ok(h) {
                continue;
            }
            // Not at the cost of the valences (on the bunny at 2 % the valence-6 share fell
            // from 0.802 to 0.798 without this test).
            let dev = |v: u32, delta: i64| {
                let x = self.he.valence(v) as i64 + delta - self.target_valence(v);
                x * x
            };
            let deviation = dev(a, 0) + dev(b, 0) + dev(c, 0) + dev(d, 0);
            if dev(a, -1) + dev(b, -1) + dev(c, 1) + dev(d, 1) > deviation {
                continue;
            }
            let before = [[x(a), x(b), x(c)], [x(b), x(a), x(d)]];
            let after = [[x(a), x(d), x(c)], [x(b), x(c), x(d)]];
            let bound2 = FAR_TRADE * FAR_TRADE * far_d2;
            if dist2_within(p, after, bound2) > bound2 {
                continue;
            }
            let old = self.flipped_min_angle_cos(c, d, a, b);
            let new = self.flipped_min_angle_cos(a, b, c, d);
            if new > old.max(COS_FAR_MOVE_MIN_ANGLE) {
                continue;
            }
            let hint = |u: u32| self.hint[u as usize];
            let hints_before = [[hint(a), hint(b), hint(c)], [hint(b), hint(a), hint(d)]];
            let hints_after = [[hint(a), hint(d), hint(c)], [hint(b), hint(c), hint(d)]];
            if !self.replacement_keeps_distances(
                vec3::lerp(x(a), x(b), 0.5),
                &[a, b, c, d],
                hint(a),
                [&before, &after],
                [&hints_before, &hints_after],
                &[h / 3, g / 3],
                pull,
                true,
            ) {
                continue;
            }
            self.he.flip(h);
            self.flips += 1;
            return Some([c, d]);
        }
        None
    }

    /// Where no vertex may move onto the far input point `p` (input vertex `i`, closest to
    /// output face `f`), an edge of `f` is split and the new vertex put on `p`: the edges
    /// that are neither features nor on the boundary, the one whose middle is nearest first,
    /// then those of inner feature chains (a chain edge is a chord of the crease it stands
    /// for; where the crease bends tightly, the input bulges beyond it, and the new chain
    /// vertex goes onto the crease), under the same conditions as a moved vertex (the four
    /// triangles turn by at most 60° from the two they replace, their smallest angle is at
    /// least 30°, nothing near ends up farther). A new triangle below that angle may instead
    /// be flipped with its neighbour across its side opposite the new vertex (the new vertex
    /// then reaches one vertex further; between two rows of fixed vertices that is the only
    /// way to keep the angles). With `partway`, the new vertex goes part of the way instead
    /// (three quarters or half of the way from the edge's middle to `p`, projected onto the
    /// input; on a chain edge, the crease's point farthest from the edge, then its middle),
    /// where that brings `p` within the limit, and the split makes no trade (as for
    /// [`State::pull_partway`]). Returns the new vertex.
    fn split_toward(
        &mut self,
        f: u32,
        blocked: &[bool],
        pull: &mut FarPull<'_>,
        partway: bool,
    ) -> Option<u32> {
        let far = pull.p;
        // Edges of inner feature chains after the others.
        let mut edges: Vec<(bool, f64, u32)> = (0..3)
            .map(|k| 3 * f + k)
            .filter(|&h| {
                let t = self.he.tag(h);
                !self.he.is_boundary_edge(h) && (t == NONE || !self.boundary_chain[t as usize])
            })
            .map(|h| {
                let mid = vec3::lerp(
                    self.he.position(self.he.from(h)),
                    self.he.position(self.he.to(h)),
                    0.5,
                );
                (self.he.tag(h) != NONE, vec3::dist(mid, far), h)
            })
            .collect();
        edges.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
        // Where the new vertex goes (and its chain parameter): on the far point; part of the
        // way, three quarters or half of the way there from the edge's middle, on the input,
        // or on a chain the point of its crease farthest from the edge, then the crease's
        // middle (a chain vertex stays on its crease).
        let mut tries: Vec<(u32, V3, Option<f64>)> = Vec::new();
        for &(_, _, h) in &edges {
            let (a, b) = (self.he.from(h), self.he.to(h));
            let c = self.he.tag(h);
            if !partway {
                // A chain edge's new vertex takes the stretch's middle, found once it splits.
                tries.push((h, far, None));
            } else if c != NONE {
                let chain = &self.chains[c as usize];
                let (lo, hi) = self.stretch(c, a, b);
                let s_mid = chain.wrap(0.5 * (lo + hi));
                let (pa, pb) = (self.he.position(a), self.he.position(b));
                if let Some((_, s)) = chain.farthest_over(lo, hi, pa, pb) {
                    tries.push((h, chain.point_at(s), Some(s)));
                }
                tries.push((h, chain.point_at(s_mid), Some(s_mid)));
            } else {
                let mid = vec3::lerp(self.he.position(a), self.he.position(b), 0.5);
                for t in [0.75, 0.5] {
                    tries.push((h, vec3::lerp(mid, far, t), None));
                }
            }
        }
        for (h, at, s) in tries {
            let (p, p_face) = if partway {
                let r = self
                    .proj
                    .project(at, self.hint[self.he.from(h) as usize], self.l);
                (if s.is_some() { at } else { r.hit.point }, r.hit.face)
            } else {
                (far, pull.p_face)
            };
            let Some(plan) = self.plan_split(h, p, blocked) else {
                continue;
            };
            let hint = |u: u32| self.hint[u as usize];
            let hints_of = |t: &[u32; 3]| t.map(|u| if u == NONE { p_face } else { hint(u) });
            let x = |u: u32| if u == NONE { p } else { self.he.position(u) };
            let (a, b) = (self.he.from(h), self.he.to(h));
            let mid = vec3::lerp(x(a), x(b), 0.5);
            // Before: the two faces (as split at the middle of the edge, the same surface)
            // and the flipped neighbours; after: the planned triangles.
            let before: Vec<[V3; 3]> = plan
                .before
                .iter()
                .map(|t| t.map(|u| if u == NONE { mid } else { x(u) }))
                .collect();
            let hints_before: Vec<[u32; 3]> = plan
                .before
                .iter()
                .map(|t| t.map(|u| if u == NONE { hint(a) } else { hint(u) }))
                .collect();
            let after: Vec<[V3; 3]> = plan.after.iter().map(|t| t.map(x)).collect();
            let hints_after: Vec<[u32; 3]> = plan.after.iter().map(hints_of).collect();
            if partway && !pull.within_limit_of(after.iter().copied()) {
                continue;
            }
            let corners: Vec<u32> = plan
                .after
                .iter()
                .flatten()
                .copied()
                .filter(|&u| u != NONE)
                .collect();
            if !self.replacement_keeps_distances(
                mid,
                &corners,
                hint(a),
                [&before, &after],
                [&hints_before, &hints_after],
                &plan.faces,
                pull,
                !partway,
            ) {
                continue;
            }
            let t = self.he.tag(h);
            // On a chain the new vertex takes the middle of the edge's stretch as its
            // parameter (or that of its place on the crease, part of the way); it sits on the
            // input, off the chain's chord, and no later step slides it.
            let s = match s {
                Some(s) => s,
                None if t != NONE => self.stretch_middle(t, a, b),
                None => 0.0,
            };
            let m = self.he.split_edge(h, p);
            self.role.push(if t != NONE {
                Role::Chain(t)
            } else {
                Role::Free
            });
            self.param.push(s);
            self.hint.push(p_face);
            self.size
                .push(0.5 * (self.size[a as usize] + self.size[b as usize]));
            self.origin
                .push(self.origin[a as usize].min(self.origin[b as usize]));
            self.splits += 1;
            self.far_splits_partway += partway as usize;
            for (u, w) in plan.flips {
                let e = self.he.find_edge(u, w);
                if e != NONE && self.he.flip_ok(e) {
                    self.he.flip(e);
                    self.flips += 1;
                }
            }
            return Some(m);
        }
        None
    }

    /// The triangles that splitting the edge of `h` at `p` would make (the new vertex written
    /// `NONE`), with the outer sides of those below 30° flipped (see [`State::split_toward`]);
    /// `None` when they cannot all keep 30° and turn by at most 60°.
    fn plan_split(&self, h: u32, p: V3, blocked: &[bool]) -> Option<SplitPlan> {
        let g = self.he.opp(h);
        let (a, b) = (self.he.from(h), self.he.to(h));
        let c = self.he.from(halfedge::prev(h));
        let d = self.he.from(halfedge::prev(g));
        if [a, b, c, d].iter().any(|&u| blocked[u as usize]) {
            return None;
        }
        let x = |u: u32| if u == NONE { p } else { self.he.position(u) };
        let (nf, ng) = (
            self.he.face_normal_raw(h / 3),
            self.he.face_normal_raw(g / 3),
        );
        let mut plan = SplitPlan {
            before: vec![[a, b, c], [b, a, d]],
            after: Vec::new(),
            faces: vec![h / 3, g / 3],
            flips: Vec::new(),
        };
        // (m, u, w) with the side u → w opposite the new vertex m, and that side's half-edge
        // in the faces being split: (a, m, c), (m, b, c), (b, m, d), (m, a, d).
        let sides = [
            (c, a, halfedge::prev(h), nf),
            (b, c, halfedge::next(h), nf),
            (d, b, halfedge::prev(g), ng),
            (a, d, halfedge::next(g), ng),
        ];
        // Keeps the orientation of the face of normal `n` and the 30° of the rule.
        let shape = |t: [u32; 3], n: V3| {
            let q = t.map(x);
            keeps_orientation(n, q, self.cos_turn)
                && min_angle_cos(q[0], q[1], q[2]) <= COS_FAR_MOVE_MIN_ANGLE
        };
        for (u, w, o, n_old) in sides {
            let t = [NONE, u, w];
            if shape(t, n_old) {
                plan.after.push(t);
                continue;
            }
            // Flip u–w: (m, u, w) and (w, u, e) become (m, u, e) and (m, e, w).
            let o2 = self.he.opp(o);
            if self.he.tag(o) != NONE || o2 == NONE || self.he.tag(o2) != NONE {
                return None;
            }
            let e = self.he.from(halfedge::prev(o2));
            // A vertex the new one already reaches, or reaches through another flip (two
            // sides of a valence-4 corner), would get a second edge to it.
            if [a, b, c, d].contains(&e)
                || blocked[e as usize]
                || plan.after.iter().any(|t| t[1] == e || t[2] == e)
            {
                return None;
            }
            let n_e = self.he.face_normal_raw(o2 / 3);
            let (t1, t2) = ([NONE, u, e], [NONE, e, w]);
            if !(shape(t1, n_old) && shape(t1, n_e) && shape(t2, n_old) && shape(t2, n_e)) {
                return None;
            }
            plan.before.push([w, u, e]);
            plan.faces.push(o2 / 3);
            plan.after.extend([t1, t2]);
            plan.flips.push((u, w));
        }
        Some(plan)
    }

    /// The triangles around `v`, each corner mapped by `value`, `v` itself to `at`.
    fn fan_corners<T: Copy>(&self, v: u32, at: T, value: impl Fn(u32) -> T) -> Vec<[T; 3]> {
        self.he
            .outgoing(v)
            .map(|k| {
                self.he
                    .face_vertices(halfedge::face_of(k))
                    .map(|u| if u == v { at } else { value(u) })
            })
            .collect()
    }

    /// Whether the triangles `tris[0]` (around `q`, projected from input face `q_hint`, with
    /// corners `corners`) may become `tris[1]` on the way to the far point of `pull`:
    /// [`State::move_keeps_distances`] over the input vertices [`State::input_near`] them,
    /// with a `trade` or without ([`FarPull::uncover_bound2`]).
    #[allow(clippy::too_many_arguments)]
    fn replacement_keeps_distances(
        &self,
        q: V3,
        corners: &[u32],
        q_hint: u32,
        tris: [&[[V3; 3]]; 2],
        hints: [&[[u32; 3]]; 2],
        faces: &[u32],
        pull: &mut FarPull<'_>,
        trade: bool,
    ) -> bool {
        *pull.generation += 1;
        let near = self.input_near(
            q,
            pull.p,
            corners,
            q_hint,
            pull.i,
            pull.limit,
            pull.input,
            pull.stamp,
            *pull.generation,
        );
        self.move_keeps_distances(
            tris,
            hints,
            faces,
            &near,
            pull.far_face,
            pull.limit,
            pull.uncover_bound2(trade),
            pull.input,
        )
    }

    /// The input vertices whose distance from a fan of triangles may change when its centre
    /// moves from `q` to `p` (the fan's other corners: `ring`): those within the reach of the
    /// fan at either position (its longest spoke plus `limit`) of either position, found by a
    /// breadth-first search over the input's edges from input vertex `i`, the input face the
    /// centre was projected onto (`q_hint`) and those of the ring's vertices.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn input_near(
        &self,
        q: V3,
        p: V3,
        ring: &[u32],
        q_hint: u32,
        i: u32,
        limit: f64,
        input: &TriMesh,
        stamp: &mut [u32],
        generation: u32,
    ) -> Vec<u32> {
        let mut reach: f64 = 0.0;
        let mut seeds = vec![i];
        for &u in ring {
            let x = self.he.position(u);
            reach = reach.max(vec3::dist(x, q)).max(vec3::dist(x, p));
            if let Some(t) = input.triangles.get(self.hint[u as usize] as usize) {
                seeds.extend_from_slice(t);
            }
        }
        if let Some(t) = input.triangles.get(q_hint as usize) {
            seeds.extend_from_slice(t);
        }
        let r = reach + limit;
        let inside = |x: V3| vec3::dist(x, q) <= r || vec3::dist(x, p) <= r;
        let mut found = Vec::new();
        for s in seeds {
            if stamp[s as usize] != generation && inside(input.positions[s as usize]) {
                stamp[s as usize] = generation;
                found.push(s);
            }
        }
        grow_over_input(input, found, stamp, generation, inside)
    }

    /// The triangles of `v` before and after it moves to `p` (projected onto input face
    /// `p_face`), the input faces their corners were projected onto, and their faces: the
    /// arguments of [`State::move_keeps_distances`].
    #[allow(clippy::type_complexity)]
    fn fan_move(
        &self,
        v: u32,
        p: V3,
        p_face: u32,
    ) -> ([Vec<[V3; 3]>; 2], [Vec<[u32; 3]>; 2], Vec<u32>) {
        let position = |u: u32| self.he.position(u);
        let hint = |u: u32| self.hint[u as usize];
        (
            [
                self.fan_corners(v, position(v), position),
                self.fan_corners(v, p, position),
            ],
            [
                self.fan_corners(v, hint(v), hint),
                self.fan_corners(v, p_face, hint),
            ],
            self.he.outgoing(v).map(halfedge::face_of).collect(),
        )
    }

    /// Whether the triangles `tris[0]` becoming `tris[1]` (the input faces their corners were
    /// projected onto in `hints`; they replace the faces `fan_faces`) leave every input vertex
    /// of `near` within the larger of its old distance from them and `limit` (or within
    /// [`FAR_TRADE`] times the distance `√far_d2` of the point pulled in), and seven points of
    /// each new triangle (centroid, thirds of the sides) within the larger of their old
    /// distance from the input surface and `limit`.
    #[allow(clippy::too_many_arguments)]
    fn move_keeps_distances(
        &self,
        tris: [&[[V3; 3]]; 2],
        hints: [&[[u32; 3]]; 2],
        fan_faces: &[u32],
        near: &[u32],
        far_face: &[u32],
        limit: f64,
        far_d2: f64,
        input: &TriMesh,
    ) -> bool {
        let [before, after] = tris;
        let limit2 = limit * limit;
        let mut uncovered: f64 = 0.0;
        // Most near points lie beyond the limit of both fans (the points are gathered in
        // balls around the fan's centre, the fans cover less): a triangle whose box is
        // beyond the limit (with a margin for rounding) cannot hold a point within it, and
        // its exact distance is computed only where the answer needs it.
        let boxes =
            |tris: &[[V3; 3]]| -> Vec<Aabb> { tris.iter().map(|t| Aabb::around(t)).collect() };
        let (boxes_before, boxes_after) = (boxes(before), boxes(after));
        let beyond2 = limit2 * (1.0 + 1e-9);
        let within = |tris: &[[V3; 3]], boxes: &[Aabb], x: V3| {
            tris.iter().zip(boxes).any(|(t, b)| {
                b.dist2(x) <= beyond2
                    && crestflow_geom::bvh::closest_point_on_triangle(x, t[0], t[1], t[2]).0
                        <= limit2
            })
        };
        let dist2 = |tris: &[[V3; 3]], x: V3| dist2_to_triangles(x, tris.iter().copied());
        for &k in near {
            let x = input.positions[k as usize];
            if within(after, &boxes_after, x) {
                continue;
            }
            // Farther than the limit from the fan before: either a far point, whose own face
            // may be in the fan, or closer to some other (unmoved) face, which the move does
            // not change.
            let own_face_moves =
                far_face[k as usize] != NONE && fan_faces.contains(&far_face[k as usize]);
            if own_face_moves {
                let (d_new, d_old) = (dist2(after, x), dist2(before, x));
                if d_old <= limit2 || d_new > d_old {
                    uncovered = uncovered.max(d_new);
                }
            } else if within(before, &boxes_before, x) {
                uncovered = uncovered.max(dist2(after, x));
            }
        }
        // A point the move leaves farther than the limit (or farther than before) is
        // accepted only well below the distance of the point pulled in, so the largest
        // distance around the fan drops.
        if uncovered > FAR_TRADE * FAR_TRADE * far_d2 {
            return false;
        }
        const SAMPLES: [[f64; 3]; 7] = [
            [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
            [2.0 / 3.0, 1.0 / 3.0, 0.0],
            [1.0 / 3.0, 2.0 / 3.0, 0.0],
            [0.0, 2.0 / 3.0, 1.0 / 3.0],
            [0.0, 1.0 / 3.0, 2.0 / 3.0],
            [1.0 / 3.0, 0.0, 2.0 / 3.0],
            [2.0 / 3.0, 0.0, 1.0 / 3.0],
        ];
        // To the input by a walk from the face the nearest corner was projected onto (the
        // moved vertex: the far point's face); the BVH answers where the walk gets lost.
        let off_surface = |tris: &[[V3; 3]], hints: &[[u32; 3]]| {
            let mut worst: f64 = 0.0;
            for (t, h) in tris.iter().zip(hints) {
                for w in SAMPLES {
                    let x = vec3::add(
                        vec3::add(vec3::scale(t[0], w[0]), vec3::scale(t[1], w[1])),
                        vec3::scale(t[2], w[2]),
                    );
                    let k = if w[0] >= w[1] && w[0] >= w[2] {
                        0
                    } else if w[1] >= w[2] {
                        1
                    } else {
                        2
                    };
                    worst = worst.max(self.proj.project(x, h[k], self.l).hit.dist2);
                }
            }
            worst
        };
        let new_off = off_surface(after, hints[1]);
        new_off <= limit2 || new_off <= off_surface(before, hints[0])
    }

    /// Whether moving `v` to `p` makes an edge at `v` a chord off the surface
    /// ([`Self::chord_leaves_surface`]): the far-point pull runs after the last splits, like
    /// the final flips ([`Self::long_flip_leaves_surface`]).
    pub(super) fn move_leaves_surface(&self, v: u32, p: V3) -> bool {
        let q = self.he.position(v);
        self.neighbor_iter(v).any(|u| {
            let x = self.he.position(u);
            let split2 = Self::split_len2(self.size[u as usize], self.size[v as usize]);
            self.chord_leaves_surface([x, p], [x, q], [u, u], split2)
        })
    }
}

/// The far input point being pulled in ([`State::pull_to_far_points`]): input vertex `i` at
/// `p` on input face `p_face`, its squared distance `far_d2` from the output, the distance
/// limit, the faces the far points are closest to, and the stamps of [`State::input_near`].
struct FarPull<'a> {
    p: V3,
    i: u32,
    p_face: u32,
    far_d2: f64,
    limit: f64,
    far_face: &'a [u32],
    input: &'a TriMesh,
    stamp: &'a mut [u32],
    generation: &'a mut u32,
}

impl FarPull<'_> {
    /// Whether the far point lies within the limit of `tris` (what a partial pull must reach).
    fn within_limit_of(&self, tris: impl IntoIterator<Item = [V3; 3]>) -> bool {
        let limit2 = self.limit * self.limit;
        dist2_within(self.p, tris, limit2) <= limit2
    }

    /// The squared distance that [`State::move_keeps_distances`] divides by [`FAR_TRADE`]²
    /// to bound what a change may uncover: the far point's own with a `trade`; without one
    /// (a partial pull or split), at most what makes that bound the limit itself.
    fn uncover_bound2(&self, trade: bool) -> f64 {
        if trade {
            self.far_d2
        } else {
            self.far_d2
                .min(self.limit * self.limit / (FAR_TRADE * FAR_TRADE))
        }
    }
}

/// What [`State::split_toward`] would do to one edge: the triangles it replaces (`NONE` for
/// the middle of the split edge) and makes (`NONE` for the new vertex), the faces it
/// replaces, and the sides (vertex pairs) it flips after the split.
struct SplitPlan {
    before: Vec<[u32; 3]>,
    after: Vec<[u32; 3]>,
    faces: Vec<u32>,
    flips: Vec<(u32, u32)>,
}

/// A share of the squared far-point limit within which an output vertex alone shows that an
/// input vertex is not far: below 1, so that rounding in the triangle distances cannot undo
/// what the vertex shows.
const NEAR_CORNER: f64 = 0.99;

/// How far, relative to the far point pulled in, a point the pull uncovers may end up from
/// the output ([`State::move_keeps_distances`]).
const FAR_TRADE: f64 = 0.7;
