//! The feature constraints of thesis §5.1.1 as [`super`] applies them: where a chain vertex
//! lies on its chain (arc-length parameters), which stretch of chain an output edge
//! replaces, and into which vertex a feature vertex may be removed without cutting a bend
//! of its chain or merging two chains.

use super::*;

impl State<'_> {
    /// The parameter halfway along the stretch of chain `t` that its edge a → b stands for.
    pub(super) fn stretch_middle(&self, t: u32, a: u32, b: u32) -> f64 {
        let (lo, hi) = self.stretch(t, a, b);
        self.chains[t as usize].wrap(0.5 * (lo + hi))
    }

    /// The stretch of chain `t` that its edge from `a` to `b` stands for, as `(lo, hi)`.
    pub(super) fn stretch(&self, t: u32, a: u32, b: u32) -> (f64, f64) {
        let c = &self.chains[t as usize];
        let (sa, sb) = self.edge_params(t, a, b);
        // On a loop the edge stands for the stretch away from a's other chain neighbour (the
        // longer way round on a loop of few vertices).
        let x = if c.is_closed() {
            self.chain_neighbor(a, t, b)
        } else {
            NONE
        };
        if x != NONE && x != b {
            c.interval_avoiding(sa, sb, self.param[x as usize])
        } else {
            c.interval(sa, sb)
        }
    }

    /// Arc-length parameter of vertex `u` on chain `c` (an edge of `u` is tagged `c`): its own
    /// for a vertex inside the chain; for a corner, the end of the chain it sits at (on a
    /// chain from a corner back to itself, the end nearer to `near`).
    pub(super) fn param_on(&self, u: u32, c: u32, near: f64) -> f64 {
        self.param_on_in(&self.param, u, c, near)
    }

    /// [`Self::param_on`] with the chain vertices' parameters taken from `param`.
    fn param_on_in(&self, param: &[f64], u: u32, c: u32, near: f64) -> f64 {
        if self.role[u as usize] == Role::Chain(c) {
            return param[u as usize];
        }
        let ch = &self.chains[c as usize];
        let (first, last) = ch.ends();
        let p = self.he.position(u);
        let (d0, d1) = (vec3::dist(p, first), vec3::dist(p, last));
        if d0 < d1 || (d0 == d1 && !(near > 0.5 * ch.total())) {
            0.0
        } else {
            ch.total()
        }
    }

    /// Parameters of `x` and `y` on chain `c`, the ends of a stretch that holds the parameter
    /// `inner` (of the chain vertex between them). A corner at both ends of its chain (a loop
    /// through one corner) stands at the end beyond `inner` as seen from the other vertex:
    /// which end is nearer to `inner` does not tell on a loop of few vertices.
    pub(super) fn stretch_params(
        &self,
        param: &[f64],
        c: u32,
        x: u32,
        y: u32,
        inner: f64,
    ) -> (f64, f64) {
        let total = self.chains[c as usize].total();
        let beyond = |other: u32| {
            let so = param[other as usize];
            if self.role[other as usize] != Role::Chain(c) || inner == so {
                inner
            } else if inner > so {
                total
            } else {
                0.0
            }
        };
        (
            self.param_on_in(param, x, c, beyond(y)),
            self.param_on_in(param, y, c, beyond(x)),
        )
    }

    /// Parameters of the ends of edge a–b of chain `c`: a corner at both ends of its chain
    /// stands at the end away from the chain vertex's other chain neighbour.
    fn edge_params(&self, c: u32, a: u32, b: u32) -> (f64, f64) {
        let total = self.chains[c as usize].total();
        // Where the corner `u` stands, seen from its chain neighbour `v`.
        let side = |u: u32, v: u32| {
            if self.role[v as usize] != Role::Chain(c) {
                return f64::NAN;
            }
            let w = self.chain_neighbor(v, c, u);
            if w == NONE || self.role[w as usize] != Role::Chain(c) {
                return f64::NAN;
            }
            let (sw, sv) = (self.param[w as usize], self.param[v as usize]);
            if sw > sv {
                0.0
            } else if sw < sv {
                total
            } else {
                f64::NAN
            }
        };
        let sa = self.param_on(a, c, side(a, b));
        let sb = self.param_on(b, c, side(b, a));
        if side(a, b).is_nan() && side(b, a).is_nan() {
            // Neither end tells (two corners, or a chain of two edges): the nearer end.
            let sb = self.param_on(b, c, sa);
            return (self.param_on(a, c, sb), sb);
        }
        (sa, sb)
    }

    /// The neighbour of chain vertex `v` across its chain-`c` edge other than to `not`.
    pub(super) fn chain_neighbor(&self, v: u32, c: u32, not: u32) -> u32 {
        for k in self.he.outgoing(v) {
            let x = self.he.to(k);
            if x != not && self.he.tag(k) == c {
                return x;
            }
        }
        // The boundary edge ending at `v` (not in the outgoing sweep).
        let last = self.he.outgoing(v).last().unwrap_or(NONE);
        if last != NONE {
            let p = halfedge::prev(last);
            if self.he.opp(p) == NONE && self.he.tag(p) == c && self.he.from(p) != not {
                return self.he.from(p);
            }
        }
        NONE
    }

    /// Whether the chain between `x` and `y` (both on chain `c`, `near` a parameter between
    /// them) stays within the tolerance of the segment joining their places on the chain.
    fn chain_straight(&self, c: u32, x: u32, y: u32, near: f64) -> bool {
        let (sx, sy) = self.stretch_params(&self.param, c, x, y, near);
        let ch = &self.chains[c as usize];
        let (lo, hi) = ch.interval_through(sx, sy, near);
        self.replaces(c, lo, hi, ch.point_at(sx), ch.point_at(sy))
    }

    /// Whether the output edge `pa`–`pb` may replace the stretch `(lo, hi)` of chain `c`: no
    /// point of the stretch farther from it than the chain's tolerance.
    pub(super) fn replaces(&self, c: u32, lo: f64, hi: f64, pa: V3, pb: V3) -> bool {
        self.chains[c as usize].deviation_over(lo, hi, pa, pb) <= self.tol[c as usize]
    }

    /// Whether vertex `a` may disappear into `b` along the edge of `h` (feature rules only):
    /// a chain vertex only along its chain, into the next vertex of the chain, and only where
    /// the chain is straight between its other neighbour and `b`.
    pub(super) fn removable_into(&self, h: u32, a: u32, b: u32) -> bool {
        match self.role[a as usize] {
            // Two corners at the ends of a short curve chain are one network vertex whose
            // curves reach the input's edges at different vertices (their edge paths share
            // their first edge): kept apart, they pin triangles of a few degrees.
            Role::Corner => {
                let c = self.he.tag(h);
                c != NONE
                    && self.mergeable[c as usize]
                    && self.role[b as usize] == Role::Corner
                    && self.merged_chains_apart(a, b)
            }
            Role::Free => true,
            Role::Chain(c) => {
                if self.he.tag(h) != c
                    || !(matches!(self.role[b as usize], Role::Corner)
                        || self.role[b as usize] == Role::Chain(c))
                {
                    return false;
                }
                let x = self.chain_neighbor(a, c, b);
                if x == NONE || x == b {
                    return false;
                }
                let s = self.param[a as usize];
                self.chain_straight(c, x, b, s)
            }
        }
    }

    /// Whether the feature edges of corner `a`, moved onto corner `b`, belong to other chains
    /// than those of `b` and keep 30° from them. A chain joining both would become a loop
    /// through one vertex, and two chains leaving in (nearly) the same direction would keep
    /// only a sliver between them that no flip may remove.
    fn merged_chains_apart(&self, a: u32, b: u32) -> bool {
        let pb = self.he.position(b);
        // (far end, chain) of the feature edges at `v`, but the one joining a and b.
        let chain_ends = |v: u32| {
            self.incident_halfedges(v).filter_map(move |k| {
                let (x, y) = (self.he.from(k), self.he.to(k));
                let far = if x == v { y } else { x };
                (self.he.tag(k) != NONE && far != a && far != b).then(|| (far, self.he.tag(k)))
            })
        };
        chain_ends(a).all(|(x, ca)| {
            let u = vec3::sub(self.he.position(x), pb);
            chain_ends(b).all(|(y, cb)| {
                if ca == cb {
                    return false;
                }
                let w = vec3::sub(self.he.position(y), pb);
                let d = vec3::dot(u, w);
                d <= 0.0
                    || d * d
                        <= COS_FLIP_MIN_ANGLE
                            * COS_FLIP_MIN_ANGLE
                            * vec3::dot(u, u)
                            * vec3::dot(w, w)
            })
        })
    }
}
