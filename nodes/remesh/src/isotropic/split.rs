//! Step 1 of each round of [`super`] (Botsch & Kobbelt 2004): edges longer than 4/3 of the
//! local target are split at their middle (a feature edge at the middle of its stretch of
//! chain), in sweeps (at most 64 per round) until none is left or the vertex cap is reached.

use super::*;

impl State<'_> {
    pub(super) fn split_long(&mut self, max_vertices: usize, par: Par) -> Result<(), RemeshError> {
        // The vertices the last pass made: after a pass, only edges of their faces (either
        // half-edge: a split moves the far side of its triangles to new half-edges, which can
        // make the half-edge across it canonical) can be long. Elsewhere no end moved, no
        // size changed, and an edge long before the pass was split.
        let mut made: Option<Vec<u32>> = None;
        for _ in 0..64 {
            let mut any = false;
            // Longest edges first (ties by slot): longest-edge bisection never makes a
            // triangle thinner than half its smallest angle, while splitting in slot order
            // can bisect the short sides of a triangle again and again, making needles whose
            // long sides never get shorter (the sweep then only stops at the vertex cap).
            let st = &*self;
            let long_edge = |h: u32| {
                if !(st.he.is_halfedge_alive(h) && st.he.is_canonical(h)) {
                    return None;
                }
                let (a, b) = (st.he.from(h), st.he.to(h));
                let l2 = st.len2(a, b);
                let hi2 = Self::split_len2(st.size[a as usize], st.size[b as usize]);
                (l2 > hi2).then_some((l2, h))
            };
            // All of them, found in parallel over fixed slot chunks (the sort fixes the order
            // anyway).
            let all =
                || par.filter_map_collect(st.he.n_halfedge_slots(), 8192, |h| long_edge(h as u32));
            let mut long: Vec<(f64, u32)> = match &made {
                None => all(),
                Some(made) => {
                    let mut long: Vec<(f64, u32)> = made
                        .iter()
                        .flat_map(|&m| st.he.outgoing(m))
                        .flat_map(|k| {
                            let f = halfedge::face_of(k);
                            [3 * f, 3 * f + 1, 3 * f + 2]
                        })
                        .flat_map(|k| [k, st.he.opp(k)])
                        .filter(|&k| k != NONE)
                        .filter_map(long_edge)
                        .collect();
                    long.sort_by_key(|&(_, h)| h);
                    long.dedup_by_key(|&mut (_, h)| h);
                    debug_assert_eq!(
                        {
                            let mut a = all();
                            a.sort_by_key(|&(_, h)| h);
                            a
                        },
                        long,
                        "a long edge away from the last pass's splits"
                    );
                    long
                }
            };
            long.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
            let mut new_vertices = Vec::new();
            for (_, h) in long {
                if !self.he.is_halfedge_alive(h) || !self.he.is_canonical(h) {
                    continue;
                }
                let (a, b) = (self.he.from(h), self.he.to(h));
                let (ha, hb) = (self.size[a as usize], self.size[b as usize]);
                if self.len2(a, b) <= Self::split_len2(ha, hb) {
                    continue;
                }
                if self.he.n_live_vertices() >= max_vertices {
                    return Err(RemeshError::TooManyVertices {
                        target: self.l,
                        estimate: self.he.n_live_vertices(),
                        max: max_vertices,
                    });
                }
                let t = self.he.tag(h);
                // A feature edge is split at the middle of its stretch of chain.
                let (mid, s) = if t != NONE {
                    let s = self.stretch_middle(t, a, b);
                    (self.chains[t as usize].point_at(s), s)
                } else {
                    (
                        vec3::lerp(self.he.position(a), self.he.position(b), 0.5),
                        0.0,
                    )
                };
                let m = self.he.split_edge(h, mid);
                self.role.push(if t != NONE {
                    Role::Chain(t)
                } else {
                    Role::Free
                });
                self.param.push(s);
                self.hint.push(self.hint[a as usize]);
                self.size.push(0.5 * (ha + hb));
                self.origin
                    .push(self.origin[a as usize].min(self.origin[b as usize]));
                self.splits += 1;
                any = true;
                new_vertices.push(m);
                debug_assert_eq!(m as usize + 1, self.role.len());
            }
            if !any {
                break;
            }
            made = Some(new_vertices);
        }
        Ok(())
    }
}
