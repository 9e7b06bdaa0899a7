//! Closest points on the input surface, the "projection back onto the original surface" step
//! of Botsch & Kobbelt 2004 (thesis §5.1.1).
//!
//! A bounding volume hierarchy over the input triangles (median split on the longest centroid
//! axis, leaves of up to 4 triangles). Queries take a hint face, usually the face the vertex
//! was projected onto in the previous iteration: its distance is the starting bound, so the
//! descent prunes almost everything when the vertex moved little. The result is still the
//! exact closest point (ties to the smallest face index), whatever the hint.

use crestflow_geom::vec3::{self, V3};
use crestflow_geom::TriMesh;

#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: V3,
    hi: V3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
    };
    fn grow(&mut self, p: V3) {
        for ((lo, hi), c) in self.lo.iter_mut().zip(self.hi.iter_mut()).zip(p) {
            *lo = lo.min(c);
            *hi = hi.max(c);
        }
    }
    fn merge(&mut self, o: &Aabb) {
        self.grow(o.lo);
        self.grow(o.hi);
    }
    fn dist2(&self, p: V3) -> f64 {
        let mut d = 0.0;
        for ((lo, hi), c) in self.lo.iter().zip(&self.hi).zip(p) {
            let e = (lo - c).max(c - hi).max(0.0);
            d += e * e;
        }
        d
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    /// Leaf: first index into `order`; inner: index of the left child (right = left + 1).
    first: u32,
    /// Leaf: triangle count (> 0); inner: 0.
    count: u32,
}

const LEAF: usize = 4;

/// Closest-point queries on a triangle mesh.
pub struct Bvh {
    tris: Vec<[V3; 3]>,
    nodes: Vec<Node>,
    order: Vec<u32>,
}

/// The closest point of a mesh to a query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub face: u32,
    pub point: V3,
    pub dist2: f64,
}

impl Bvh {
    /// Builds the hierarchy (the mesh's indices must be valid).
    pub fn new(mesh: &TriMesh) -> Self {
        let tris: Vec<[V3; 3]> = (0..mesh.n_faces()).map(|f| mesh.face_points(f)).collect();
        let n = tris.len();
        let cent: Vec<V3> = tris
            .iter()
            .map(|t| vec3::scale(vec3::add(vec3::add(t[0], t[1]), t[2]), 1.0 / 3.0))
            .collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut nodes = vec![Node {
            bounds: Aabb::EMPTY,
            first: 0,
            count: 0,
        }];
        let mut stack = vec![(0usize, 0usize, n)];
        while let Some((node, s, e)) = stack.pop() {
            let mut b = Aabb::EMPTY;
            let mut cb = Aabb::EMPTY;
            for &f in &order[s..e] {
                let t = &tris[f as usize];
                let mut tb = Aabb::EMPTY;
                t.iter().for_each(|&p| tb.grow(p));
                b.merge(&tb);
                cb.grow(cent[f as usize]);
            }
            nodes[node].bounds = b;
            if e - s <= LEAF {
                nodes[node].first = s as u32;
                nodes[node].count = (e - s) as u32;
                continue;
            }
            let ext = vec3::sub(cb.hi, cb.lo);
            let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
                0
            } else if ext[1] >= ext[2] {
                1
            } else {
                2
            };
            let mid = (s + e) / 2;
            order[s..e].select_nth_unstable_by(mid - s, |&x, &y| {
                cent[x as usize][axis]
                    .total_cmp(&cent[y as usize][axis])
                    .then(x.cmp(&y))
            });
            let left = nodes.len();
            nodes.push(nodes[node]);
            nodes.push(nodes[node]);
            nodes[node].first = left as u32;
            nodes[node].count = 0;
            stack.push((left + 1, mid, e));
            stack.push((left, s, mid));
        }
        Bvh { tris, nodes, order }
    }

    /// Closest point of triangle `f` to `p`.
    pub fn on_face(&self, f: u32, p: V3) -> Hit {
        let [a, b, c] = self.tris[f as usize];
        let q = closest_on_triangle(p, a, b, c);
        Hit {
            face: f,
            point: q,
            dist2: vec3::dot(vec3::sub(p, q), vec3::sub(p, q)),
        }
    }

    /// The exact closest point of the mesh to `p`; `hint` (a face index, or anything out of
    /// range for none) only speeds the search up.
    pub fn closest(&self, p: V3, hint: u32) -> Hit {
        let mut best = if (hint as usize) < self.tris.len() {
            self.on_face(hint, p)
        } else {
            Hit {
                face: u32::MAX,
                point: p,
                dist2: f64::INFINITY,
            }
        };
        let mut stack = [0u32; 96];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top] as usize];
            if node.bounds.dist2(p) > best.dist2 {
                continue;
            }
            if node.count > 0 {
                let s = node.first as usize;
                for &f in &self.order[s..s + node.count as usize] {
                    let h = self.on_face(f, p);
                    if h.dist2 < best.dist2 || (h.dist2 == best.dist2 && f < best.face) {
                        best = h;
                    }
                }
            } else if node.first > 0 && top + 2 <= stack.len() {
                let l = node.first;
                let dl = self.nodes[l as usize].bounds.dist2(p);
                let dr = self.nodes[l as usize + 1].bounds.dist2(p);
                // Nearer child on top of the stack.
                if dl <= dr {
                    stack[top] = l + 1;
                    stack[top + 1] = l;
                } else {
                    stack[top] = l;
                    stack[top + 1] = l + 1;
                }
                top += 2;
            }
        }
        best
    }
}

/// Closest point of triangle (a, b, c) to `p` (Voronoi-region case analysis).
pub fn closest_on_triangle(p: V3, a: V3, b: V3, c: V3) -> V3 {
    let ab = vec3::sub(b, a);
    let ac = vec3::sub(c, a);
    let ap = vec3::sub(p, a);
    let d1 = vec3::dot(ab, ap);
    let d2 = vec3::dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = vec3::sub(p, b);
    let d3 = vec3::dot(ab, bp);
    let d4 = vec3::dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return vec3::add(a, vec3::scale(ab, d1 / (d1 - d3)));
    }
    let cp = vec3::sub(p, c);
    let d5 = vec3::dot(ab, cp);
    let d6 = vec3::dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return vec3::add(a, vec3::scale(ac, d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return vec3::add(b, vec3::scale(vec3::sub(c, b), w));
    }
    let den = va + vb + vc;
    if !(den.abs() > 0.0) {
        return a; // zero-area triangle: its corners were handled above
    }
    let v = vb / den;
    let w = vc / den;
    vec3::add(a, vec3::add(vec3::scale(ab, v), vec3::scale(ac, w)))
}

/// Closest point of segment [a, b] to `p` and its parameter in [0, 1].
pub fn closest_on_segment(p: V3, a: V3, b: V3) -> (V3, f64) {
    let d = vec3::sub(b, a);
    let l2 = vec3::dot(d, d);
    if !(l2 > 0.0) {
        return (a, 0.0);
    }
    let t = (vec3::dot(vec3::sub(p, a), d) / l2).clamp(0.0, 1.0);
    (vec3::add(a, vec3::scale(d, t)), t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crestflow_geom::shapes;

    #[test]
    fn matches_brute_force_with_any_hint() {
        let m = shapes::sphere(1.0, 3).unwrap();
        let bvh = Bvh::new(&m);
        let mut s = 12345u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 * 3.0 - 1.5
        };
        for i in 0..300 {
            let p = [rnd(), rnd(), rnd()];
            let brute = (0..m.n_faces() as u32)
                .map(|f| bvh.on_face(f, p))
                .min_by(|x, y| x.dist2.total_cmp(&y.dist2).then(x.face.cmp(&y.face)))
                .unwrap();
            let hint = if i % 2 == 0 {
                u32::MAX
            } else {
                (i * 7) as u32 % 1280
            };
            let h = bvh.closest(p, hint);
            assert_eq!(h.dist2, brute.dist2, "query {i}");
        }
    }

    #[test]
    fn segment_and_triangle_points() {
        let (q, t) = closest_on_segment([0.5, 1.0, 0.0], [0.0; 3], [1.0, 0.0, 0.0]);
        assert_eq!((q, t), ([0.5, 0.0, 0.0], 0.5));
        let q = closest_on_triangle(
            [0.25, 0.25, 2.0],
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        );
        assert!(vec3::dist(q, [0.25, 0.25, 0.0]) < 1e-15);
        let q = closest_on_triangle([2.0, 2.0, 0.0], [0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        assert!(vec3::dist(q, [0.5, 0.5, 0.0]) < 1e-15);
    }
}
