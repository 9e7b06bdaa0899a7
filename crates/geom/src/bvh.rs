//! Exact closest-point queries on a triangle mesh: a bounding volume hierarchy over the
//! triangles (median split on the longest centroid axis, leaves of up to 4 triangles) and the
//! point-triangle case analysis. Used by mesh distances (Hausdorff) and by remeshing's
//! projection back onto the input surface (Botsch & Kobbelt 2004).

use rayon::prelude::*;

use crate::vec3::{self, V3};
use crate::TriMesh;

/// The closest point of triangle (a, b, c) to `p`: its squared distance and barycentric
/// coordinates. Exact case analysis over the Voronoi regions of the corners, sides and
/// interior (each region is tested with the signs of a few dot products).
pub fn closest_point_on_triangle(p: V3, a: V3, b: V3, c: V3) -> (f64, [f64; 3]) {
    let ab = vec3::sub(b, a);
    let ac = vec3::sub(c, a);
    let ap = vec3::sub(p, a);
    let d1 = vec3::dot(ab, ap);
    let d2 = vec3::dot(ac, ap);
    let bary = if d1 <= 0.0 && d2 <= 0.0 {
        [1.0, 0.0, 0.0]
    } else {
        let bp = vec3::sub(p, b);
        let d3 = vec3::dot(ab, bp);
        let d4 = vec3::dot(ac, bp);
        let cp = vec3::sub(p, c);
        let d5 = vec3::dot(ab, cp);
        let d6 = vec3::dot(ac, cp);
        let vc = d1 * d4 - d3 * d2;
        let vb = d5 * d2 - d1 * d6;
        let va = d3 * d6 - d5 * d4;
        if d3 >= 0.0 && d4 <= d3 {
            [0.0, 1.0, 0.0]
        } else if d6 >= 0.0 && d5 <= d6 {
            [0.0, 0.0, 1.0]
        } else if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            // Side ab.
            let v = d1 / (d1 - d3);
            [1.0 - v, v, 0.0]
        } else if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            // Side ac.
            let w = d2 / (d2 - d6);
            [1.0 - w, 0.0, w]
        } else if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            // Side bc.
            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            [0.0, 1.0 - w, w]
        } else {
            let s = va + vb + vc;
            if s > 0.0 && s.is_finite() {
                let v = vb / s;
                let w = vc / s;
                [1.0 - v - w, v, w]
            } else {
                // Degenerate (zero-area) triangle that slipped through: fall back to its
                // corners, which is where such a triangle's points are anyway.
                let da = vec3::dot(ap, ap);
                let db = vec3::dot(bp, bp);
                let dc = vec3::dot(cp, cp);
                if da <= db && da <= dc {
                    [1.0, 0.0, 0.0]
                } else if db <= dc {
                    [0.0, 1.0, 0.0]
                } else {
                    [0.0, 0.0, 1.0]
                }
            }
        }
    };
    let q = [
        bary[0] * a[0] + bary[1] * b[0] + bary[2] * c[0],
        bary[0] * a[1] + bary[1] * b[1] + bary[2] * c[1],
        bary[0] * a[2] + bary[1] * b[2] + bary[2] * c[2],
    ];
    let d = vec3::sub(p, q);
    (vec3::dot(d, d), bary)
}

/// An axis-aligned box.
#[derive(Clone, Copy, Debug)]
pub struct Aabb {
    lo: V3,
    hi: V3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
    };
    /// The smallest box holding `points` (NaN coordinates left out).
    pub fn around(points: &[V3]) -> Aabb {
        let mut b = Aabb::EMPTY;
        for &p in points {
            b.grow(p);
        }
        b
    }
    /// Grows the box to hold `p`; NaN coordinates are left out (as by `f64::min`), in
    /// comparisons that compile to plain min/max instructions.
    fn grow(&mut self, p: V3) {
        for (k, &c) in p.iter().enumerate() {
            self.lo[k] = if c < self.lo[k] { c } else { self.lo[k] };
            self.hi[k] = if c > self.hi[k] { c } else { self.hi[k] };
        }
    }
    fn merge(&mut self, o: &Aabb) {
        self.grow(o.lo);
        self.grow(o.hi);
    }
    /// Squared distance from `p` to the box (0 inside).
    pub fn dist2(&self, p: V3) -> f64 {
        let mut s = 0.0;
        for (k, &c) in p.iter().enumerate() {
            let d = (self.lo[k] - c).max(c - self.hi[k]).max(0.0);
            s += d * d;
        }
        s
    }
}

#[derive(Clone, Copy, Debug)]
struct BvhNode {
    bounds: Aabb,
    /// Leaf: first index into `order`; inner: index of the left child (right = left + 1).
    first: u32,
    /// Leaf: number of triangles (> 0); inner: 0.
    count: u32,
}

/// The closest point of a mesh to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    pub distance: f64,
    /// `distance` squared (what the search compares).
    pub dist2: f64,
    pub face: u32,
    pub bary: [f64; 3],
    /// The point itself: `bary` applied to the face's corners.
    pub point: V3,
}

impl ClosestPoint {
    const NONE: ClosestPoint = ClosestPoint {
        distance: f64::INFINITY,
        dist2: f64::INFINITY,
        face: u32::MAX,
        bary: [0.0; 3],
        point: [f64::NAN; 3],
    };
}

/// A bounding volume hierarchy over the triangles of a mesh, for exact closest-point queries.
/// Built by median splits on the longest axis of the triangle centroids (leaves of up to 4
/// triangles); a query descends the nearer child first and prunes boxes farther than the best
/// distance found, so it returns the exact minimum over all triangles.
pub struct TriangleBvh {
    /// The triangles in leaf order: a leaf's triangles lie side by side.
    tris: Vec<[V3; 3]>,
    nodes: Vec<BvhNode>,
    /// Face index of each triangle in `tris`.
    order: Vec<u32>,
    /// Where each face's triangle is in `tris`.
    slot: Vec<u32>,
}

const LEAF_SIZE: usize = 4;

/// Each triangle's centroid with its face index. The splits move these records themselves
/// rather than indices into them, so that the scans over a node's range read memory in order
/// (on a 208k-face mesh the build took 81 ms with indices, most of it in cache misses).
type Item = (V3, u32);

/// Splits `items` at its middle along the longest axis of its centroids: afterwards the first
/// half holds the smaller centroids on that axis (ties broken by face index, so that the tree
/// does not depend on the selection algorithm). Returns the middle.
fn split(items: &mut [Item]) -> usize {
    let mut cbounds = Aabb::EMPTY;
    for &(c, _) in items.iter() {
        cbounds.grow(c);
    }
    let ext = vec3::sub(cbounds.hi, cbounds.lo);
    let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |x, y| {
        x.0[axis].total_cmp(&y.0[axis]).then(x.1.cmp(&y.1))
    });
    mid
}

/// The nodes of the tree over `items` (node 0 its root; a leaf's `first` is `offset` plus its
/// start in `items`, an inner node's the index of its left child here), boxes left empty.
fn build_range(items: &mut [Item], offset: usize) -> Vec<BvhNode> {
    let mut nodes = Vec::with_capacity(2 * items.len() / LEAF_SIZE + 1);
    nodes.push(BvhNode {
        bounds: Aabb::EMPTY,
        first: offset as u32,
        count: 0,
    });
    // Explicit stack of (node, start, end) so deep meshes cannot overflow the call stack.
    let mut stack = vec![(0usize, 0usize, items.len())];
    while let Some((node, start, end)) = stack.pop() {
        if end - start <= LEAF_SIZE {
            nodes[node].first = (offset + start) as u32;
            nodes[node].count = (end - start) as u32;
            continue;
        }
        let mid = start + split(&mut items[start..end]);
        let left = nodes.len();
        for _ in 0..2 {
            nodes.push(BvhNode {
                bounds: Aabb::EMPTY,
                first: 0,
                count: 0,
            });
        }
        nodes[node].first = left as u32;
        nodes[node].count = 0;
        stack.push((left + 1, mid, end));
        stack.push((left, start, mid));
    }
    nodes
}

/// Ranges at least this long split with their two halves built on the rayon pool.
const PARALLEL_MIN: usize = 16_384;

/// [`build_range`] with the halves of long ranges built in parallel. The nodes are laid out
/// as root, its two children, the left subtree's other nodes, the right's: the depth-first
/// numbering of [`build_range`], so the tree is the same node for node.
fn build_range_parallel(items: &mut [Item], offset: usize) -> Vec<BvhNode> {
    if items.len() < PARALLEL_MIN {
        return build_range(items, offset);
    }
    let mid = split(items);
    let (lo, hi) = items.split_at_mut(mid);
    let (left, right) = rayon::join(
        || build_range_parallel(lo, offset),
        || build_range_parallel(hi, offset + mid),
    );
    let n_left = left.len() as u32;
    // Node i of a half moves to: its root next to the other's, the rest after both roots.
    let at_left = |i: u32| if i == 0 { 1 } else { i + 2 };
    let at_right = |i: u32| if i == 0 { 2 } else { i + 1 + n_left };
    let moved = |node: &BvhNode, at: &dyn Fn(u32) -> u32| BvhNode {
        first: if node.count == 0 {
            at(node.first)
        } else {
            node.first
        },
        ..*node
    };
    let mut nodes = Vec::with_capacity(1 + left.len() + right.len());
    nodes.push(BvhNode {
        bounds: Aabb::EMPTY,
        first: 1,
        count: 0,
    });
    nodes.push(moved(&left[0], &at_left));
    nodes.push(moved(&right[0], &at_right));
    nodes.extend(left[1..].iter().map(|n| moved(n, &at_left)));
    nodes.extend(right[1..].iter().map(|n| moved(n, &at_right)));
    nodes
}

impl TriangleBvh {
    /// Builds the hierarchy over a copy of the triangles (the mesh's indices must be valid),
    /// on the calling thread.
    pub fn new(mesh: &TriMesh) -> Self {
        Self::new_with(mesh, false)
    }

    /// [`TriangleBvh::new`] with the subtrees of large meshes built on the rayon pool: the
    /// same tree (the same answers to every query), at any thread count.
    pub fn new_in_parallel(mesh: &TriMesh) -> Self {
        Self::new_with(mesh, true)
    }

    /// [`TriangleBvh::new_in_parallel`] when `parallel`, else [`TriangleBvh::new`] (for
    /// callers that pass their thread policy on).
    pub fn new_with(mesh: &TriMesh, parallel: bool) -> Self {
        let nf = mesh.n_faces();
        let item = |f: usize| -> Item {
            let [a, b, c] = mesh.face_points(f);
            (
                vec3::scale(vec3::add(vec3::add(a, b), c), 1.0 / 3.0),
                f as u32,
            )
        };
        // (Collected in order either way: the same vectors.)
        let mut items: Vec<Item> = if parallel {
            (0..nf).into_par_iter().map(item).collect()
        } else {
            (0..nf).map(item).collect()
        };
        let mut nodes = if parallel {
            build_range_parallel(&mut items, 0)
        } else {
            build_range(&mut items, 0)
        };
        let order: Vec<u32> = items.iter().map(|&(_, f)| f).collect();
        drop(items);
        let tri = |&f: &u32| mesh.face_points(f as usize);
        let tris: Vec<[V3; 3]> = if parallel {
            order.par_iter().map(tri).collect()
        } else {
            order.iter().map(tri).collect()
        };
        let mut slot = vec![0u32; nf];
        for (i, &f) in order.iter().enumerate() {
            slot[f as usize] = i as u32;
        }
        // Boxes bottom-up: a leaf's from its triangles, an inner node's as the union of its
        // children's, which come after it (min and max are exact, so that is the box of its
        // triangles). Only the root of an empty mesh is a leaf without triangles (first 0);
        // an inner node's left child is never node 0.
        for node in (0..nodes.len()).rev() {
            let BvhNode { first, count, .. } = nodes[node];
            let mut bounds = Aabb::EMPTY;
            if count > 0 {
                for t in &tris[first as usize..(first + count) as usize] {
                    for &p in t {
                        bounds.grow(p);
                    }
                }
            } else if first > 0 {
                bounds = nodes[first as usize].bounds;
                bounds.merge(&nodes[first as usize + 1].bounds);
            }
            nodes[node].bounds = bounds;
        }
        TriangleBvh {
            tris,
            nodes,
            order,
            slot,
        }
    }

    /// The tree's nodes as (box, first, count), for tests that compare two builds.
    #[cfg(test)]
    fn layout(&self) -> Vec<([V3; 2], u32, u32)> {
        self.nodes
            .iter()
            .map(|n| ([n.bounds.lo, n.bounds.hi], n.first, n.count))
            .collect()
    }

    /// Number of triangles.
    pub fn n_faces(&self) -> usize {
        self.tris.len()
    }

    /// The closest point of triangle `f` to `p`.
    pub fn on_face(&self, f: u32, p: V3) -> ClosestPoint {
        let [a, b, c] = self.tris[self.slot[f as usize] as usize];
        let (dist2, bary) = closest_point_on_triangle(p, a, b, c);
        ClosestPoint {
            distance: dist2.sqrt(),
            dist2,
            face: f,
            bary,
            point: barycentric_point(bary, a, b, c),
        }
    }

    /// The closest point of the mesh to `p` (exact). Among equally close triangles the one
    /// with the smallest face index wins.
    pub fn closest(&self, p: V3) -> ClosestPoint {
        self.closest_with_hint(p, u32::MAX)
    }

    /// Like [`TriangleBvh::closest`]; `hint` (a face index, or anything out of range for none),
    /// usually the previous answer for a point that moved a little, only speeds the search up:
    /// its distance is the first bound, so the descent prunes almost everything.
    pub fn closest_with_hint(&self, p: V3, hint: u32) -> ClosestPoint {
        let mut best = if (hint as usize) < self.tris.len() {
            self.on_face(hint, p)
        } else {
            ClosestPoint::NONE
        };
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        if !self.nodes.is_empty() {
            stack.push(0);
        }
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            if node.bounds.dist2(p) > best.dist2 {
                continue;
            }
            if node.count > 0 {
                let s = node.first as usize..(node.first + node.count) as usize;
                for (&f, &[a, b, c]) in self.order[s.clone()].iter().zip(&self.tris[s]) {
                    let (d2, bary) = closest_point_on_triangle(p, a, b, c);
                    if d2 < best.dist2 || (d2 == best.dist2 && f < best.face) {
                        best = ClosestPoint {
                            distance: 0.0,
                            dist2: d2,
                            face: f,
                            bary,
                            point: [0.0; 3],
                        };
                    }
                }
            } else if node.first > 0 {
                self.push_children(node.first, p, &mut stack);
            }
        }
        if best.face != u32::MAX {
            let [a, b, c] = self.tris[self.slot[best.face as usize] as usize];
            best.distance = best.dist2.sqrt();
            best.point = barycentric_point(best.bary, a, b, c);
        }
        best
    }
}

impl TriangleBvh {
    /// Whether some triangle lies within distance `r` of `p` (at most `r`): stops at the
    /// first one found, so it is cheaper than [`TriangleBvh::closest`] when the answer is yes.
    pub fn any_within(&self, p: V3, r: f64) -> bool {
        let r2 = r * r;
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        if !self.nodes.is_empty() {
            stack.push(0);
        }
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            if node.bounds.dist2(p) > r2 {
                continue;
            }
            if node.count > 0 {
                let s = node.first as usize..(node.first + node.count) as usize;
                for &[a, b, c] in &self.tris[s] {
                    if closest_point_on_triangle(p, a, b, c).0 <= r2 {
                        return true;
                    }
                }
            } else if node.first > 0 {
                self.push_children(node.first, p, &mut stack);
            }
        }
        false
    }

    /// Pushes the children `l` and `l + 1` of an inner node, the farther from `p` first so
    /// that the nearer one is searched first.
    fn push_children(&self, l: u32, p: V3, stack: &mut Vec<u32>) {
        let (dl, dr) = (
            self.nodes[l as usize].bounds.dist2(p),
            self.nodes[l as usize + 1].bounds.dist2(p),
        );
        if dl <= dr {
            stack.push(l + 1);
            stack.push(l);
        } else {
            stack.push(l);
            stack.push(l + 1);
        }
    }
}

fn barycentric_point(bary: [f64; 3], a: V3, b: V3, c: V3) -> V3 {
    [
        bary[0] * a[0] + bary[1] * b[0] + bary[2] * c[0],
        bary[0] * a[1] + bary[1] * b[1] + bary[2] * c[1],
        bary[0] * a[2] + bary[1] * b[2] + bary[2] * c[2],
    ]
}

#[cfg(test)]
#[path = "bvh_test.rs"]
mod tests;
