//! Steps 4 and 5 of each round of [`super`]: tangential relaxation of the free vertices (to
//! the area-weighted centroid of their triangles' centroids, or with Lloyd steps to their
//! Voronoi cells' centroids), chain vertices sliding along their chain, and projection onto
//! the input surface.

use super::*;

impl State<'_> {
    /// Whether boundary vertex `v` may slide to `p`: its triangles keep their orientation and
    /// none gets an angle below both 30° and the smallest angle of the fan before. A boundary
    /// vertex may slide far (its tolerance lets bends go), over an inner neighbour or onto
    /// the chord between its chain neighbours (a small part whose boundary loop is down to
    /// one triangle).
    fn boundary_slide_ok(&self, v: u32, p: V3) -> bool {
        let (mut new, mut old) = (-1.0f64, -1.0f64);
        self.fan_ok_with_old(v, NONE, p, &mut new, Some(&mut old), f64::INFINITY)
            && new <= old.max(COS_FAR_MOVE_MIN_ANGLE)
    }

    pub(super) fn relax_and_project(&mut self, par: Par, project: bool) {
        let nv = self.he.n_vertex_slots();
        let he = &self.he;
        let role = &self.role;
        let proj = self.proj;
        let far = self.l;
        let lloyd = self.lloyd;
        // Per face: its unnormalised normal (2 × area along the normal), its corner sum
        // weighted by a third of that length, and the length itself. Computed by each of its
        // corners (three times over): one parallel loop per sweep instead of two, which on
        // meshes of a few thousand vertices costs less than the second loop's start.
        let face_value = |f: u32| {
            let [x, y, z] = he.face_vertices(f).map(|u| he.position(u));
            let nf = vec3::cross(vec3::sub(y, x), vec3::sub(z, x));
            let a = vec3::norm(nf);
            (nf, vec3::scale(vec3::add(vec3::add(x, y), z), a / 3.0), a)
        };
        // Chain vertices slide along their chains meanwhile: that reads their parameters and
        // fixed corners only, and their new positions are written after the free vertices'
        // moves, which see the old ones (as when the slide ran after them).
        let mut param = std::mem::take(&mut self.param);
        let mut slides = std::mem::take(&mut self.slides);
        // Each vertex's new place goes into a second buffer (its neighbours read the old
        // ones), swapped in afterwards; its projection hint, which no other vertex reads, is
        // updated in place. One parallel loop writes both, with no list of moves between
        // (written back after the loop, on the calling thread or on the pool, the moves cost
        // a few milliseconds of fandisk_large's run at 2 %).
        let mut hint = std::mem::take(&mut self.hint);
        let mut next = std::mem::take(&mut self.spare_positions);
        next.resize(nv, [0.0; 3]);
        let st = &*self;
        // The new place of `v` from its projection hint `h`: the place, its input face
        // (`NONE`: the old place, kept) and how it was projected (0: not, 1: by a walk, 2: by
        // the BVH).
        let relax = |v: u32, h: u32| -> (V3, u32, u8) {
            let p = he.position(v);
            if !he.is_vertex_alive(v) {
                return (p, NONE, 0);
            }
            match role[v as usize] {
                Role::Corner => (p, h, 0),
                // Slid by the other side of the join.
                Role::Chain(_) => (p, NONE, 0),
                Role::Free => {
                    // Centroid of the incident triangles' centroids weighted by their
                    // areas, moved within the tangent plane of the area-weighted
                    // vertex normal.
                    let mut s = [0.0; 3];
                    let mut nsum = [0.0; 3];
                    let mut w = 0.0;
                    let mut degree = 0;
                    if lloyd {
                        for k in he.outgoing(v) {
                            degree += 1;
                            // The corners after v, in the face's order.
                            let a = he.position(he.to(k));
                            let b = he.position(he.to(halfedge::next(k)));
                            let n = vec3::cross(vec3::sub(a, p), vec3::sub(b, p));
                            nsum = vec3::add(nsum, n);
                            let (g, area) = voronoi_part(p, a, b);
                            s = vec3::add(s, vec3::scale(g, area));
                            w += area;
                        }
                    } else {
                        for k in he.outgoing(v) {
                            degree += 1;
                            let (nf, c, a) = face_value(halfedge::face_of(k));
                            nsum = vec3::add(nsum, nf);
                            s = vec3::add(s, c);
                            w += a;
                        }
                    }
                    let q = if w > 0.0 {
                        let u = vec3::sub(vec3::scale(s, 1.0 / w), p);
                        let n = vec3::normalize(nsum);
                        vec3::add(p, vec3::sub(u, vec3::scale(n, vec3::dot(n, u))))
                    } else {
                        p
                    };
                    if degree == 3 && shrinks_tetrahedron(he, v, q, 0.5 * far) {
                        return (p, h, 0);
                    }
                    if project {
                        let r = proj.project(q, h, far);
                        (r.hit.point, r.hit.face, 1 + r.fallback as u8)
                    } else {
                        (q, h, 0)
                    }
                }
            }
        };
        const CHUNK: usize = 512;
        let (counts, slid) = par.join(
            || {
                par.map_chunk_pairs_mut(&mut next, &mut hint[..nv], CHUNK, |start, ps, hs| {
                    let (mut projections, mut fallbacks) = (0, 0);
                    for (i, (p, h)) in ps.iter_mut().zip(hs.iter_mut()).enumerate() {
                        let (q, f, k) = relax((start + i) as u32, *h);
                        *p = q;
                        if f != NONE {
                            *h = f;
                        }
                        projections += (k > 0) as usize;
                        fallbacks += (k > 1) as usize;
                    }
                    (projections, fallbacks)
                })
            },
            || st.slide_chain_params(&mut param, &mut slides),
        );
        for (p, f) in counts {
            self.projections += p;
            self.fallbacks += f;
        }
        self.he.swap_positions(&mut next);
        self.spare_positions = next;
        self.hint = hint;
        self.param = param;
        self.slides = slides;
        for (v, p) in slid {
            self.he.set_position(v, p);
        }
    }

    /// Every vertex inside a chain moves to the middle (in arc length) of its two chain
    /// neighbours, on the chain, unless that would make one of its two feature edges stray
    /// from the chain by more than the tolerance (so bends stay in place). Gauss–Seidel in
    /// vertex order: few vertices, and each move is checked against its neighbours' current
    /// places. Updates `param` and returns the new positions (the mesh is not touched, so
    /// that it can run beside the free vertices' relaxation). `slides` keeps each vertex's
    /// last slide ([`Slide`]).
    fn slide_chain_params(&self, param: &mut [f64], slides: &mut Vec<Slide>) -> Vec<(u32, V3)> {
        slides.resize(self.he.n_vertex_slots(), Slide::NONE);
        let mut slid = Vec::new();
        for v in 0..self.he.n_vertex_slots() as u32 {
            let Role::Chain(c) = self.role[v as usize] else {
                continue;
            };
            if !self.he.is_vertex_alive(v) {
                continue;
            }
            let x = self.chain_neighbor(v, c, NONE);
            let y = if x == NONE {
                NONE
            } else {
                self.chain_neighbor(v, c, x)
            };
            if y == NONE {
                continue;
            }
            let s = param[v as usize];
            let (sx, sy) = self.stretch_params(param, c, x, y, s);
            // A boundary chain's slide also depends on the neighbours' places.
            let key = [sx.to_bits(), sy.to_bits(), s.to_bits()];
            let known = slides[v as usize];
            let same = known.chain == c && known.key == key && !self.boundary_chain[c as usize];
            // Debug builds compute the slide anyway and compare.
            if same && !cfg!(debug_assertions) {
                slid.push((v, known.p));
                param[v as usize] = known.to;
                continue;
            }
            let ch = &self.chains[c as usize];
            // The neighbours' places on the chain (where they are, or will be once slid onto
            // it: a curve chain starts at the edge path, off the network's polyline).
            let (px, py) = (ch.point_at(sx), ch.point_at(sy));
            // The stretch from x through v to y (on a short loop, maybe the longer way round),
            // and the ends of its two halves at a parameter t inside it.
            let (lo, hi) = ch.interval_through(sx, sy, s);
            // Both neighbours at one parameter (a corner that is not an end of this chain
            // stands for the nearer end): the middle would put the vertex on top of one.
            if !(hi > lo) {
                continue;
            }
            let (plo, phi) = if lo == sx { (px, py) } else { (py, px) };
            let unwrap = |t: f64| if t < lo { t + ch.total() } else { t };
            let ok = |t: f64| {
                let t = unwrap(t);
                let p = ch.point_at(t);
                self.replaces(c, lo, t, plo, p)
                    && self.replaces(c, t, hi, p, phi)
                    && (!self.boundary_chain[c as usize] || self.boundary_slide_ok(v, p))
            };
            let t = ch.wrap(0.5 * (lo + hi));
            // Else onto the bend between the neighbours: two vertices that straddle a bend
            // cannot merge (their edge cannot cut it), and they would stay a short edge
            // with a needle triangle on each side.
            let to = if ok(t) {
                Some(t)
            } else {
                ch.sharpest_over(lo, hi).filter(|&k| ok(k))
            };
            // Onto the chain at its own parameter when it stays: a no-op on a chain of input
            // edges, and on a curve chain never farther from the network's polyline than
            // before.
            let t = to.unwrap_or(s);
            let p = ch.point_at(t);
            debug_assert!(
                !same
                    || (known.to.to_bits() == t.to_bits()
                        && known.p.map(f64::to_bits) == p.map(f64::to_bits)),
                "a chain vertex's slide differs from the one computed before"
            );
            slid.push((v, p));
            param[v as usize] = t;
            slides[v as usize] = Slide {
                chain: c,
                key,
                to: t,
                p,
            };
        }
        slid
    }
}

/// One chain vertex's slide: where a vertex at parameter `s` of chain `chain`, between
/// neighbours at `sx` and `sy`, goes (parameter `to`, point `p`). Away from boundaries the
/// slide depends on nothing else, so a vertex whose three parameters did not change since
/// (bit for bit) takes the same slide without computing it: once a stretch has settled, most
/// of the 50 relaxation steps of a run find it so.
#[derive(Clone, Copy)]
pub(super) struct Slide {
    chain: u32,
    key: [u64; 3],
    to: f64,
    p: V3,
}

impl Slide {
    pub(super) const NONE: Slide = Slide {
        chain: NONE,
        key: [0; 3],
        to: 0.0,
        p: [0.0; 3],
    };
}

/// The part of triangle (p, a, b) nearer to p than to a and b (its Voronoi part; where the
/// triangle is obtuse, the circumcentre is replaced by the middle of the longest side, as in
/// Meyer et al.'s mixed area): centroid and area.
fn voronoi_part(p: V3, a: V3, b: V3) -> (V3, f64) {
    let (u, w) = (vec3::sub(a, p), vec3::sub(b, p));
    let n = vec3::cross(u, w);
    let nn = vec3::dot(n, n);
    if nn <= 0.0 {
        return (p, 0.0);
    }
    let (ma, mb) = (vec3::lerp(p, a, 0.5), vec3::lerp(p, b, 0.5));
    let (da, db, dab) = (vec3::dot(u, u), vec3::dot(w, w), vec3::dist(a, b).powi(2));
    let c = if dab >= da + db {
        vec3::lerp(a, b, 0.5)
    } else if da >= db + dab {
        ma
    } else if db >= da + dab {
        mb
    } else {
        // circumcentre p + (|u|² (w × n) + |w|² (n × u)) / (2 |n|²)
        let t = vec3::add(
            vec3::scale(vec3::cross(w, n), da),
            vec3::scale(vec3::cross(n, u), db),
        );
        vec3::add(p, vec3::scale(t, 0.5 / nn))
    };
    let tri = |x: V3, y: V3, z: V3| {
        let a = 0.5 * vec3::norm(vec3::cross(vec3::sub(y, x), vec3::sub(z, x)));
        (vec3::scale(vec3::add(vec3::add(x, y), z), a / 3.0), a)
    };
    let (g1, a1) = tri(p, ma, c);
    let (g2, a2) = tri(p, c, mb);
    let a = a1 + a2;
    if a <= 0.0 {
        return (p, 0.0);
    }
    (vec3::scale(vec3::add(g1, g2), 1.0 / a), a)
}

/// Whether `v` is a vertex of a tetrahedron (a closed part collapsed to four vertices of
/// valence 3, which no collapse can reduce further) whose move to `q` would bring it within
/// `floor` of a neighbour, and closer than it is. Tangential relaxation pulls each vertex of
/// such a part toward the other three: on a smooth sphere that settles into a regular
/// tetrahedron, but on a coarse small part, or with one vertex fixed, it draws all four to one
/// point (small closed parts of a CAD assembly remeshed at a target about their size ended
/// so). Below the floor no move may shorten a vertex's shortest edge.
fn shrinks_tetrahedron(he: &HalfEdgeMesh, v: u32, q: V3, floor: f64) -> bool {
    let valence3 = |u: u32| !he.is_boundary_vertex(u) && he.valence(u) == 3;
    if !(valence3(v) && he.outgoing(v).all(|k| valence3(he.to(k)))) {
        return false;
    }
    let nearest = |x: V3| {
        he.outgoing(v)
            .map(|k| vec3::dist(x, he.position(he.to(k))))
            .fold(f64::INFINITY, f64::min)
    };
    let near_q = nearest(q);
    near_q < floor && near_q < nearest(he.position(v))
}
