//! After the rounds of [`super`]: the last triangles below 30° lose their shortest edge
//! (or a cap its middle vertex), their free corners move to better nearby places on the
//! input, and, where that is not enough, onto input vertices up to 0.8 L away.

use super::*;

impl State<'_> {
    /// After the rounds: a triangle with an angle below 30° loses its shortest edge when the
    /// collapse raises the smallest angle around it, even if that leaves an edge up to 2 L.
    /// Such slivers remain where a vertex sits close to a corner or a feature and every
    /// collapse would have made an edge just over 4/3 L. A cap whose shortest side fails the
    /// link condition loses its middle vertex instead ([`Self::cap_apex_collapse`]).
    pub(super) fn collapse_slivers(&mut self, par: Par) {
        const STRETCH2: f64 = 1.5 * 1.5;
        // A vertex takes part in one collapse per sweep; a few sweeps reach neighbouring
        // slivers.
        for _ in 0..3 {
            if !self.collapse_slivers_sweep(STRETCH2, par) {
                break;
            }
        }
    }

    /// After the last flips: a free vertex of a triangle still below 30° moves to the best of
    /// a few nearby positions (towards the centroid of its neighbours, and a ring of tangent
    /// steps; each projected onto the input surface) when that raises the smallest angle of
    /// its triangles and keeps them nearly flat, or on a curved fan lifts it to 30°. A few
    /// sweeps.
    pub(super) fn improve_sliver_vertices(&mut self, par: Par) {
        self.improve_sliver_vertices_among(None, par);
    }

    /// [`Self::improve_sliver_vertices`] for the vertices marked in `only` (all when `None`).
    fn improve_sliver_vertices_among(&mut self, only: Option<&[bool]>, par: Par) {
        // What `plan_vertex` finds depends only on the positions (and hints) of the vertex
        // and its neighbours (connectivity does not change here): a vertex that found no
        // better place is not tried again until one of them has moved. Moves are numbered
        // from 1; `failed[v]` is the number of moves made when v last found nothing (0:
        // never).
        let nv = self.he.n_vertex_slots();
        let mut moved_at = vec![0u32; nv];
        let mut failed = vec![0u32; nv];
        let mut moves = 1u32;
        // Class of each vertex in this sweep's colouring (u32::MAX: none yet).
        let mut class = vec![u32::MAX; nv];
        for _ in 0..3 {
            // The vertices to try, in face order, coloured greedily so that no two of a class
            // are neighbours: the moves of one class do not change what the others of it
            // find, so each class is planned on the pool and then moved, class by class.
            let mut tried: Vec<u32> = Vec::new();
            let mut classes = 0u32;
            for f in self.sliver_faces(par) {
                for v in self.he.face_vertices(f) {
                    if class[v as usize] != u32::MAX
                        || self.role[v as usize] != Role::Free
                        || self.he.is_boundary_vertex(v)
                        || only.is_some_and(|m| !m[v as usize])
                    {
                        continue;
                    }
                    let f = failed[v as usize];
                    if f > 0
                        && moved_at[v as usize] < f
                        && self.neighbor_iter(v).all(|u| moved_at[u as usize] < f)
                    {
                        continue;
                    }
                    let mut c = 0u32;
                    while self.neighbor_iter(v).any(|u| class[u as usize] == c) {
                        c += 1;
                    }
                    class[v as usize] = c;
                    classes = classes.max(c + 1);
                    tried.push(v);
                }
            }
            let mut any = false;
            for c in 0..classes {
                let members: Vec<u32> = tried
                    .iter()
                    .copied()
                    .filter(|&v| class[v as usize] == c)
                    .collect();
                let plans = {
                    let st = &*self;
                    par.map_collect(members.len(), |i| st.plan_vertex(members[i]))
                };
                for (&v, plan) in members.iter().zip(plans) {
                    if self.apply_plan(v, plan) {
                        moves += 1;
                        moved_at[v as usize] = moves;
                        any = true;
                    } else {
                        failed[v as usize] = moves + 1;
                    }
                }
            }
            for &v in &tried {
                class[v as usize] = u32::MAX;
            }
            if !any {
                break;
            }
        }
    }

    /// After [`Self::improve_sliver_vertices`], for the triangles still below 30°: up to three
    /// rounds of [`Self::move_sliver_vertices_onto_input`], each followed by the nearby moves
    /// again. Then the vertices moved are grouped by edges, and a group whose triangles do not
    /// all reach 30° goes back where it was: a thin part (a claw) may need two or three
    /// vertices to move round it, each by a partial gain, but beside fixed feature vertices
    /// such moves only bend the surface for a few degrees. Returns the number of vertices
    /// that kept a new place.
    pub(super) fn end_slivers_by_wider_moves(&mut self, input: &TriMesh, par: Par) -> usize {
        let nv = self.he.n_vertex_slots();
        let before: Vec<(V3, u32)> = (0..nv as u32)
            .map(|v| (self.he.position(v), self.hint[v as usize]))
            .collect();
        // Each round looks at what the last one moved and its neighbours only: elsewhere
        // nothing changed since a vertex found no gain.
        let mut only: Option<Vec<bool>> = None;
        let mut any = false;
        for _ in 0..3 {
            let moved = self.move_sliver_vertices_onto_input(input, only.as_deref());
            if moved.is_empty() {
                break;
            }
            any = true;
            let mut near = vec![false; nv];
            for &v in &moved {
                near[v as usize] = true;
                for u in self.neighbor_iter(v) {
                    near[u as usize] = true;
                }
            }
            let at: Vec<V3> = (0..nv as u32).map(|v| self.he.position(v)).collect();
            self.improve_sliver_vertices_among(Some(&near), par);
            for v in 0..nv as u32 {
                if self.he.position(v) != at[v as usize] {
                    near[v as usize] = true;
                    for u in self.neighbor_iter(v) {
                        near[u as usize] = true;
                    }
                }
            }
            only = Some(near);
        }
        if !any {
            return 0;
        }
        let moved: Vec<bool> = (0..nv as u32)
            .map(|v| self.he.is_vertex_alive(v) && self.he.position(v) != before[v as usize].0)
            .collect();
        let mut seen = vec![false; nv];
        let mut kept = 0;
        for s in 0..nv as u32 {
            if !moved[s as usize] || seen[s as usize] {
                continue;
            }
            seen[s as usize] = true;
            let mut group = vec![s];
            let mut k = 0;
            while k < group.len() {
                let v = group[k];
                k += 1;
                for u in self.neighbor_iter(v) {
                    if moved[u as usize] && !seen[u as usize] {
                        seen[u as usize] = true;
                        group.push(u);
                    }
                }
            }
            let ends = group
                .iter()
                .all(|&v| self.fan_min_angle_cos(v, NONE) <= COS_FLIP_MIN_ANGLE);
            if ends && !group.iter().any(|&v| self.next_to_chain(v)) {
                kept += group.len();
            } else {
                for &v in &group {
                    let (p, f) = before[v as usize];
                    self.he.set_position(v, p);
                    self.hint[v as usize] = f;
                }
            }
        }
        kept
    }

    /// Whether a neighbour of `v` lies on a feature chain: inside it, or a corner where two
    /// or more feature edges meet (a tip, a part corner or the free end of a curve is not).
    fn next_to_chain(&self, v: u32) -> bool {
        self.neighbor_iter(v).any(|u| match self.role[u as usize] {
            Role::Chain(_) => true,
            Role::Corner => {
                self.he
                    .outgoing(u)
                    .filter(|&k| self.he.tag(k) != NONE)
                    .count()
                    >= 2
            }
            Role::Free => false,
        })
    }

    /// A free vertex of a triangle below 30° moves onto the input vertex within
    /// [`SLIVER_MOVE_REACH`]·L of it that raises the smallest angle of its triangles most,
    /// when its triangles turn by at most 60° and no edge becomes a chord off the surface
    /// (not next to a feature chain; only the vertices marked in `only`, when given). One
    /// sweep in face order; returns the vertices moved.
    fn move_sliver_vertices_onto_input(
        &mut self,
        input: &TriMesh,
        only: Option<&[bool]>,
    ) -> Vec<u32> {
        let topo = input.topology();
        let mut stamp = vec![0u32; input.n_vertices()];
        let mut generation = 0u32;
        let mut moves = Vec::new();
        for f in 0..(self.he.n_halfedge_slots() / 3) as u32 {
            let Some(t) = self.sliver_corners(f) else {
                continue;
            };
            for v in t {
                if !self.movable(v) || only.is_some_and(|m| !m[v as usize]) || self.next_to_chain(v)
                {
                    continue;
                }
                let Some(seed) = input.triangles.get(self.hint[v as usize] as usize) else {
                    continue;
                };
                // The input vertices within reach, by a breadth-first search over the input's
                // edges from the face v was projected onto.
                let p = self.he.position(v);
                let reach = SLIVER_MOVE_REACH * self.size[v as usize];
                generation += 1;
                let mut seeds: Vec<u32> = Vec::new();
                for &i in seed {
                    if stamp[i as usize] != generation {
                        stamp[i as usize] = generation;
                        seeds.push(i);
                    }
                }
                let near = grow_over_input(input, seeds, &mut stamp, generation, |x| {
                    vec3::dist(x, p) <= reach
                });
                // The best gain; ties to the first found (the search's order is the input's).
                let mut best = (self.fan_min_angle_cos(v, NONE), NONE);
                for &i in &near {
                    let x = input.positions[i as usize];
                    if let Some(new) = self.fan_below(v, x, best.0) {
                        if !topo.vertex_faces(i).is_empty() && !self.move_leaves_surface(v, x) {
                            best = (new, i);
                        }
                    }
                }
                if best.1 != NONE {
                    let i = best.1;
                    self.he.set_position(v, input.positions[i as usize]);
                    self.hint[v as usize] = topo.vertex_faces(i)[0];
                    moves.push(v);
                }
            }
        }
        moves
    }

    /// The faces for which [`State::sliver_corners`] answers, in face order (found on the pool
    /// over fixed chunks).
    fn sliver_faces(&self, par: Par) -> Vec<u32> {
        par.filter_map_collect(self.he.n_halfedge_slots() / 3, 4096, |f| {
            let f = f as u32;
            self.sliver_corners(f).map(|_| f)
        })
    }

    /// The corners of face `f` when it is alive and has an angle below 30°.
    fn sliver_corners(&self, f: u32) -> Option<[u32; 3]> {
        if !self.he.is_face_alive(f) {
            return None;
        }
        let t = self.he.face_vertices(f);
        let [x, y, z] = t.map(|u| self.he.position(u));
        (min_angle_cos(x, y, z) > COS_FLIP_MIN_ANGLE).then_some(t)
    }

    /// Where free vertex `v` would move: the best of a few positions (towards its neighbours'
    /// centroid, or tangent steps of 0.05–0.3 of its target length, projected onto the input
    /// surface) when that raises the smallest angle of its triangles and keeps them nearly flat
    /// (or, on a fan that is not, lifts it to 30°). Reads only the positions, hints and sizes
    /// of `v` and its neighbours.
    fn plan_vertex(&self, v: u32) -> VertexPlan {
        let p = self.he.position(v);
        let mut c = [0.0; 3];
        let mut count = 0.0;
        for u in self.neighbor_iter(v) {
            c = vec3::add(c, self.he.position(u));
            count += 1.0;
        }
        let mut plan = VertexPlan {
            to: None,
            projections: 0,
            fallbacks: 0,
        };
        if count == 0.0 {
            return plan;
        }
        let c = vec3::scale(c, 1.0 / count);
        let mut normal = [0.0; 3];
        for k in self.he.outgoing(v) {
            normal = vec3::add(normal, self.he.face_normal_raw(halfedge::face_of(k)));
        }
        let n = vec3::normalize(normal);
        let seed = if n[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        // Any gain where the triangles around v are nearly flat (within 15° of their mean
        // normal, before and after); on a curved patch moving v changes the surface, so
        // only a move that ends the sliver (30°) is worth it there.
        let faces: Vec<[u32; 3]> = self
            .he
            .outgoing(v)
            .map(|k| self.he.face_vertices(halfedge::face_of(k)))
            .collect();
        let flat = |q: V3| {
            faces.iter().all(|t| {
                let [a, b, c] = t.map(|u| if u == v { q } else { self.he.position(u) });
                let m = vec3::cross(vec3::sub(b, a), vec3::sub(c, a));
                vec3::dot(m, n) >= COS_FLAT * vec3::norm(m)
            })
        };
        let flat_here = flat(p);
        let e1 = vec3::normalize(vec3::cross(n, seed));
        let e2 = vec3::cross(n, e1);
        let mut candidates: Vec<V3> = [0.25, 0.5, 1.0]
            .iter()
            .map(|&t| vec3::lerp(p, c, t))
            .collect();
        for r in [0.05, 0.15, 0.3] {
            for k in 0..8 {
                let a = k as f64 * std::f64::consts::FRAC_PI_4;
                let d = vec3::add(vec3::scale(e1, a.cos()), vec3::scale(e2, a.sin()));
                candidates.push(vec3::add(p, vec3::scale(d, r * self.size[v as usize])));
            }
        }
        let mut best = (self.fan_min_angle_cos(v, NONE), p, NONE);
        for q in candidates {
            let r = self.proj.project(q, self.hint[v as usize], self.l);
            plan.projections += 1;
            plan.fallbacks += r.fallback as u32;
            let Some(new) = self.fan_below(v, r.hit.point, best.0) else {
                continue;
            };
            let ok = if flat_here {
                flat(r.hit.point)
            } else {
                new <= COS_FLIP_MIN_ANGLE && !self.move_leaves_surface(v, r.hit.point)
            };
            if ok {
                best = (new, r.hit.point, r.hit.face);
            }
        }
        if best.2 != NONE {
            plan.to = Some((best.1, best.2));
        }
        plan
    }

    /// Counts the projections of `plan` and moves `v` where it says; returns whether it moved.
    fn apply_plan(&mut self, v: u32, plan: VertexPlan) -> bool {
        self.projections += plan.projections as usize;
        self.fallbacks += plan.fallbacks as usize;
        let Some((p, face)) = plan.to else {
            return false;
        };
        self.he.set_position(v, p);
        self.hint[v as usize] = face;
        true
    }

    fn collapse_slivers_sweep(&mut self, stretch2: f64, par: Par) -> bool {
        let mut any = false;
        let mut touched = vec![false; self.he.n_vertex_slots()];
        // The slivers at the sweep's start: a face that becomes one during the sweep has a
        // corner a collapse touched (only those move or change faces), and is skipped below
        // anyway. Those found are asked again (a collapse may have ended or removed them).
        for f in self.sliver_faces(par) {
            let Some(t) = self.sliver_corners(f) else {
                continue;
            };
            if t.iter().any(|&v| touched[v as usize]) {
                continue;
            }
            // The face's shortest side, either way along it.
            let h = (0..3u32)
                .map(|i| 3 * f + i)
                .min_by(|&p, &q| {
                    let lp = self.len2(self.he.from(p), self.he.to(p));
                    let lq = self.len2(self.he.from(q), self.he.to(q));
                    lp.total_cmp(&lq)
                })
                .expect("three sides");
            let g = self.he.opp(h);
            let mut pick = [h, g]
                .into_iter()
                .find(|&k| k != NONE && self.collapse_allowed_with(k, stretch2, true));
            if pick.is_none() && !self.collapse_topology_ok(h) {
                pick = self.cap_apex_collapse(f, stretch2);
            }
            let Some(pick) = pick else {
                // A boundary edge has one half-edge: its target can go into its origin only
                // this way (a boundary chain vertex beside a boundary corner).
                if g == NONE && self.merge_allowed(h, true, stretch2, true, COS_COLLAPSE_MIN_ANGLE)
                {
                    self.apply_merge(h, true, &mut touched);
                    any = true;
                }
                continue;
            };
            self.apply_collapse(pick, &mut touched);
            any = true;
        }
        any
    }

    /// For a cap `f` (an angle of 150° or more) whose shortest side fails the link condition,
    /// as where a tip of valence 3 has the cap's middle vertex beside it: a collapse of that
    /// middle vertex along one of its two sides (the shorter first) that
    /// [`Self::collapse_allowed_with`] allows and that leaves both vertices' old places within
    /// [`VALENCE_COLLAPSE_OFF`]·L of the triangles that replace them.
    fn cap_apex_collapse(&self, f: u32, stretch2: f64) -> Option<u32> {
        let t = self.he.face_vertices(f);
        let p = t.map(|u| self.he.position(u));
        let k = (0..3).find(|&k| {
            let u = vec3::normalize(vec3::sub(p[(k + 1) % 3], p[k]));
            let w = vec3::normalize(vec3::sub(p[(k + 2) % 3], p[k]));
            vec3::dot(u, w) <= -COS_CAP
        })?;
        // Half-edge 3f + k runs from corner k to k + 1; the twin of the one before it runs
        // from corner k to k + 2.
        let mut sides = [
            3 * f + k as u32,
            self.he.opp(halfedge::prev(3 * f + k as u32)),
        ];
        let len2 = |h: u32| {
            if h == NONE {
                f64::INFINITY
            } else {
                self.len2(self.he.from(h), self.he.to(h))
            }
        };
        if len2(sides[1]) < len2(sides[0]) {
            sides.swap(0, 1);
        }
        let off2 = (VALENCE_COLLAPSE_OFF * self.l).powi(2);
        sides.into_iter().find(|&h| {
            if h == NONE || !self.collapse_allowed_with(h, stretch2, true) {
                return false;
            }
            self.merge_stays_within(h, off2)
        })
    }
}

/// What [`State::plan_vertex`] found for a vertex: where to move it (position and input face),
/// if anywhere, and the projections it made.
#[derive(Clone, Copy)]
struct VertexPlan {
    to: Option<(V3, u32)>,
    projections: u32,
    fallbacks: u32,
}

/// How far, in target lengths, a vertex of a sliver may move onto an input vertex
/// ([`State::move_sliver_vertices_onto_input`]).
const SLIVER_MOVE_REACH: f64 = 0.8;

/// cos 15°: how far a triangle's normal may turn from its fan's mean for the final vertex
/// moves.
const COS_FLAT: f64 = 0.965_925_826_289_068_3;

/// Cosine of 30°: a triangle with an angle of 150° or more (the supplement) is a cap.
const COS_CAP: f64 = 0.866_025_403_784_438_6;
