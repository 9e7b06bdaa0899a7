//! Tips at the scale of the target length: places where the surface comes to a point within
//! a disk smaller than one output triangle (the end of a finger, a horn, the ends of a
//! cigar).
//!
//! A remesher at target length L represents a cap narrower than L only if one of its
//! vertices lands on the apex; otherwise the cap is cut off, by up to its height, and
//! whether a vertex lands there depends on the order in which edges happen to be visited
//! (on a cigar remeshed at ten times its tip radius, five of seven random orders of the
//! same faces left an apex 0.23–0.45 L from the output). The total Gaussian curvature of the
//! disk of radius L/2 around a vertex (the sum of the angle deficits `2π − Σθ` of the
//! vertices in it, discrete Gauss–Bonnet) measures how much the surface closes up there: 0 on
//! a plane or a cylinder, 2π on a whole cap, π on a cone whose sides meet at 60°. Where it
//! reaches π (largest first, one tip per distance L) the vertex of that disk that sticks out
//! farthest along the disk's mean normal (or, in a pit, lies deepest) is kept as a fixed
//! vertex of the output, like a feature corner.
//!
//! A corner of a part (three or more creases meeting where the surface turns by a quarter
//! turn or more at a single vertex: a box corner closes it by π/2) is cut off the same way
//! when the creases are not features of the output (sharp-edge detection off, only curves
//! followed): [`part_corners`] keeps those vertices too.
//!
//! Sums run over the vertices reached from the centre through edges without leaving the
//! ball, in breadth-first order, so values do not depend on the thread count. Only disks in
//! blocks of cells with enough positive curvature are summed, a few hundred vertices of a
//! 100k-vertex mesh; the angle deficits themselves are one pass over the faces.

use std::collections::HashMap;

use crestflow_flow::Par;
use crestflow_geom::mesh::{corner_angle, TriMesh, NO_FACE};
use crestflow_geom::vec3::{self, V3};

/// Total angle deficit (radians) a disk of radius L/2 must hold for its centre to be a tip.
pub const TIP_DEFICIT: f64 = std::f64::consts::PI;

/// The angle of triangle `p` at its corner `k`.
fn angle_at(p: &[V3; 3], k: usize) -> f64 {
    let (a, b, c) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
    corner_angle(vec3::sub(b, a), vec3::sub(c, a))
}

/// Cells of side `side` over a mesh's bounding box: coordinates offset by one so that a
/// cell's neighbours stay non-negative, packed 21 bits each into a key (clamped: a grid that
/// fine comes only with a target the remesher rejects).
struct Grid {
    lo: V3,
    side: f64,
}

impl Grid {
    fn new(mesh: &TriMesh, side: f64) -> Grid {
        let mut lo = [f64::INFINITY; 3];
        for p in &mesh.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
            }
        }
        Grid { lo, side }
    }

    fn cell(&self, p: V3) -> [u64; 3] {
        // (Clamped before the offset: the field is built beside the remesher's set-up, before
        // a target far below the input's edges is rejected.)
        [0, 1, 2].map(|k| {
            ((p[k] - self.lo[k]) / self.side)
                .floor()
                .clamp(0.0, 0x1f_fffd as f64) as u64
                + 1
        })
    }

    /// Key of the cell at offset `d - 1` (each of `d` in 0..3) from `c`.
    fn key(c: [u64; 3], d: [u64; 3]) -> u64 {
        (c[0] + d[0] - 1) | ((c[1] + d[1] - 1) << 21) | ((c[2] + d[2] - 1) << 42)
    }

    /// Keys of the 3×3×3 cells around `c`, itself included.
    fn block(c: [u64; 3]) -> impl Iterator<Item = u64> {
        (0..27u64).map(move |i| Grid::key(c, [i % 3, (i / 3) % 3, i / 9]))
    }
}

/// Angle deficit `2π − Σθ` of each interior vertex (0 on the boundary and for unreferenced
/// vertices). The corner angles are computed in parallel and added in face order.
pub fn angle_deficits(mesh: &TriMesh, par: Par) -> Vec<f64> {
    let n = mesh.n_vertices();
    const FACES: usize = 8192;
    let nf = mesh.triangles.len();
    let angles: Vec<Vec<[f64; 3]>> = par.map_collect(nf.div_ceil(FACES), |c| {
        mesh.triangles[c * FACES..((c + 1) * FACES).min(nf)]
            .iter()
            .map(|t| {
                let p = t.map(|v| mesh.positions[v as usize]);
                [0, 1, 2].map(|k| angle_at(&p, k))
            })
            .collect()
    });
    let mut sum = vec![0.0; n];
    let mut used = vec![false; n];
    for (t, a) in mesh.triangles.iter().zip(angles.iter().flatten()) {
        for k in 0..3 {
            sum[t[k] as usize] += a[k];
            used[t[k] as usize] = true;
        }
    }
    let boundary = &mesh.topology().is_boundary_vertex;
    (0..n)
        .map(|v| {
            if used[v] && !boundary[v] && sum[v].is_finite() {
                2.0 * std::f64::consts::PI - sum[v]
            } else {
                0.0
            }
        })
        .collect()
}

/// A multiplicative hash for the packed cell keys (the default hasher is built to resist
/// adversarial keys, which costs more than the rest of this search).
#[derive(Default)]
struct CellHasher(u64);

impl std::hash::Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ b as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0 ^ x).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        self.0 ^= self.0 >> 29;
    }
}

type CellMap<T> = HashMap<u64, T, std::hash::BuildHasherDefault<CellHasher>>;

/// Sum of `deficit` over the vertices within `radius` of `v` reached through edges that stay
/// in the ball (`stamp` is scratch, all entries different from `mark` on entry).
fn ball_sum(
    mesh: &TriMesh,
    deficit: &[f64],
    v: u32,
    radius: f64,
    stamp: &mut [u32],
    mark: u32,
    queue: &mut Vec<u32>,
) -> f64 {
    let topo = mesh.topology();
    let centre: V3 = mesh.positions[v as usize];
    let r2 = radius * radius;
    queue.clear();
    queue.push(v);
    stamp[v as usize] = mark;
    let mut total = 0.0;
    let mut k = 0;
    while k < queue.len() {
        let u = queue[k];
        k += 1;
        total += deficit[u as usize];
        for &w in topo.neighbors(u) {
            if stamp[w as usize] != mark {
                stamp[w as usize] = mark;
                let d = vec3::sub(mesh.positions[w as usize], centre);
                if vec3::dot(d, d) <= r2 {
                    queue.push(w);
                }
            }
        }
    }
    total
}

/// The tips of `mesh` at target length `l`, ascending: vertices (not `excluded`) whose disk
/// of radius `l / 2` holds an angle deficit of at least [`TIP_DEFICIT`], the largest first,
/// none within `l` of a tip already taken.
pub fn tip_vertices(mesh: &TriMesh, l: f64, excluded: &[bool], par: Par) -> Vec<u32> {
    TipField::new(mesh, l, par).tips(mesh, excluded, par)
}

/// What the tip search needs of a mesh at target length `l` before it knows which vertices
/// are excluded: the angle deficits, and which vertices lie in a cell of side `l / 2` whose
/// 3×3×3 block may hold a tip. [`crate::isotropic()`] builds it on the pool beside the
/// half-edge structure, then asks for the tips once the features are known
/// ([`TipField::tips`]).
pub struct TipField {
    l: f64,
    deficit: Vec<f64>,
    /// Per vertex: a positive deficit, in a cell whose block's positive sums reach
    /// [`TIP_DEFICIT`].
    may_be_centre: Vec<bool>,
}

impl TipField {
    /// The field of `mesh` at target length `l` (empty when `l` is not a positive length).
    pub fn new(mesh: &TriMesh, l: f64, par: Par) -> TipField {
        let n = mesh.n_vertices();
        if !(l > 0.0 && l.is_finite()) || n == 0 {
            return TipField {
                l,
                deficit: Vec::new(),
                may_be_centre: Vec::new(),
            };
        }
        let deficit = angle_deficits(mesh, par);
        // A ball of radius l/2 around a vertex lies in the 3×3×3 block of cells of side l/2
        // around the vertex's cell. Blocks whose cells' positive sums stay below the
        // threshold hold no tip (within a cell, the deficits of a noisy but smooth surface
        // cancel), so the ball sums run only in the other blocks' centre cells: a few
        // vertices of a large mesh.
        let grid = Grid::new(mesh, 0.5 * l);
        let key = |c: [u64; 3]| Grid::key(c, [1, 1, 1]);
        let cell: Vec<[u64; 3]> = mesh.positions.iter().map(|&p| grid.cell(p)).collect();
        let mut cells: CellMap<f64> = CellMap::default();
        for (c, &d) in cell.iter().zip(&deficit) {
            if d != 0.0 {
                *cells.entry(key(*c)).or_insert(0.0) += d;
            }
        }
        // The block around each cell of a positive vertex, each on its own.
        let mut centres: Vec<[u64; 3]> = cell
            .iter()
            .zip(&deficit)
            .filter(|(_, &d)| d > 0.0)
            .map(|(&c, _)| c)
            .collect();
        centres.sort_unstable_by_key(|&c| key(c));
        centres.dedup();
        let block_may_hold_a_tip = |c: [u64; 3]| {
            let sum: f64 = Grid::block(c)
                .map(|k| cells.get(&k).copied().unwrap_or(0.0).max(0.0))
                .sum();
            sum >= TIP_DEFICIT
        };
        let flags = par.map_collect(centres.len(), |i| block_may_hold_a_tip(centres[i]));
        let hot: CellMap<bool> = centres.iter().map(|&c| key(c)).zip(flags).collect();
        let may_be_centre = cell
            .iter()
            .zip(&deficit)
            .map(|(&c, &d)| d > 0.0 && hot[&key(c)])
            .collect();
        TipField {
            l,
            deficit,
            may_be_centre,
        }
    }

    /// The tips of the field's mesh (not `excluded`), as [`tip_vertices`].
    pub fn tips(&self, mesh: &TriMesh, excluded: &[bool], par: Par) -> Vec<u32> {
        let (l, n) = (self.l, self.may_be_centre.len());
        if n != mesh.n_vertices() {
            return Vec::new();
        }
        let deficit = &self.deficit;
        // Only a vertex that closes the surface itself can be the centre of a tip; the ball
        // sums are computed for those, in fixed chunks each with its own scratch.
        let candidates: Vec<u32> = (0..n as u32)
            .filter(|&v| {
                self.may_be_centre[v as usize]
                    && !excluded.get(v as usize).copied().unwrap_or(false)
            })
            .collect();
        const CHUNK: usize = 4096;
        let sums: Vec<Vec<(f64, u32)>> = par.map_collect(candidates.len().div_ceil(CHUNK), |c| {
            let mut stamp = vec![0u32; n];
            let mut queue = Vec::new();
            let part = &candidates[c * CHUNK..((c + 1) * CHUNK).min(candidates.len())];
            part.iter()
                .enumerate()
                .filter_map(|(i, &v)| {
                    let s = ball_sum(
                        mesh,
                        deficit,
                        v,
                        0.5 * l,
                        &mut stamp,
                        i as u32 + 1,
                        &mut queue,
                    );
                    (s >= TIP_DEFICIT).then_some((s, v))
                })
                .collect()
        });
        let mut found: Vec<(f64, u32)> = sums.into_iter().flatten().collect();
        found.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut tips: Vec<u32> = Vec::new();
        let mut stamp = vec![0u32; n];
        let mut queue = Vec::new();
        for (k, (_, v)) in found.into_iter().enumerate() {
            let p = mesh.positions[v as usize];
            // Balls whose centre is within L of a tip taken already hold the same tip.
            if tips
                .iter()
                .any(|&t| vec3::dist(mesh.positions[t as usize], p) <= l)
            {
                continue;
            }
            ball_sum(
                mesh,
                deficit,
                v,
                0.5 * l,
                &mut stamp,
                u32::MAX - k as u32,
                &mut queue,
            );
            let apex = apex_of(mesh, &queue);
            if !excluded.get(apex as usize).copied().unwrap_or(false) && !tips.contains(&apex) {
                tips.push(apex);
            }
        }
        tips.sort_unstable();
        tips
    }
}

/// `vertices` without those within 4/5 `l` of a `fixed` vertex (see [`part_corners`]).
pub fn clear_of_fixed(mesh: &TriMesh, vertices: &[u32], fixed: &[bool], l: f64) -> Vec<u32> {
    if vertices.is_empty() {
        return Vec::new();
    }
    let fixed = Clearance::new(mesh, fixed, l);
    vertices
        .iter()
        .copied()
        .filter(|&v| fixed.clear(mesh.positions[v as usize]))
        .collect()
}

/// The marked vertices of a mesh in cells of side 4/5 `l`, to tell whether a new fixed vertex
/// keeps 4/5 `l` from all of them: two closer could only be joined by an edge shorter than
/// the collapse length that no collapse may remove (a curve ending beside a tip: triangles
/// of 8°). A point's neighbours within that distance lie in the 3×3×3 cells around its own.
struct Clearance {
    cells: CellMap<Vec<V3>>,
    grid: Grid,
}

impl Clearance {
    fn new(mesh: &TriMesh, marked: &[bool], l: f64) -> Clearance {
        let grid = Grid::new(mesh, 0.8 * l);
        let mut cells: CellMap<Vec<V3>> = CellMap::default();
        for (u, &p) in mesh.positions.iter().enumerate() {
            if marked.get(u).copied().unwrap_or(false) {
                cells
                    .entry(Grid::key(grid.cell(p), [1, 1, 1]))
                    .or_default()
                    .push(p);
            }
        }
        Clearance { cells, grid }
    }

    fn clear(&self, p: V3) -> bool {
        Grid::block(self.grid.cell(p)).all(|k| {
            self.cells
                .get(&k)
                .is_none_or(|pts| pts.iter().all(|&q| vec3::dist(p, q) > self.grid.side))
        })
    }
}

/// Angle deficit (radians, either sign) from which a vertex where three or more creases meet
/// is a corner of the part: a box corner has π/2, a corner of a regular octahedron 2π/3,
/// the concave corner of an L-shaped block −π/2.
pub const CORNER_DEFICIT: f64 = 0.4 * std::f64::consts::PI;

/// Corners of the part at target length `l`, ascending: vertices where at least three edges
/// with a dihedral angle above `sharp_angle_deg` meet and the angle deficit is at least
/// [`CORNER_DEFICIT`] in magnitude (not `excluded`); the largest first, none within `l` of
/// another or of a vertex in `taken`, and none within 4/5 `l` of a `fixed` vertex.
pub fn part_corners(
    mesh: &TriMesh,
    l: f64,
    sharp_angle_deg: f64,
    excluded: &[bool],
    fixed: &[bool],
    taken: &[u32],
) -> Vec<u32> {
    let n = mesh.n_vertices();
    if !(l > 0.0 && l.is_finite()) || n == 0 {
        return Vec::new();
    }
    // Creases first (one pass over the edges), then the angle deficits of the few vertices
    // with three or more, summed over their faces in face order as `angle_deficits` does.
    let topo = mesh.topology();
    let cos_sharp = sharp_angle_deg.to_radians().cos();
    let normals = mesh.face_normals();
    let mut creases = vec![0u8; n];
    for (e, &[f0, f1]) in topo.edge_faces.iter().enumerate() {
        if f1 != NO_FACE && vec3::dot(normals[f0 as usize], normals[f1 as usize]) < cos_sharp {
            for v in topo.edges[e] {
                creases[v as usize] = creases[v as usize].saturating_add(1);
            }
        }
    }
    let boundary = &topo.is_boundary_vertex;
    let deficit = |v: u32| {
        let sum: f64 = topo
            .vertex_faces(v)
            .iter()
            .map(|&f| {
                let t = mesh.triangles[f as usize];
                let k = t.iter().position(|&c| c == v).unwrap_or(0);
                angle_at(&t.map(|c| mesh.positions[c as usize]), k)
            })
            .sum();
        2.0 * std::f64::consts::PI - sum
    };
    let mut found: Vec<(f64, u32)> = (0..n as u32)
        .filter(|&v| {
            creases[v as usize] >= 3
                && !boundary[v as usize]
                && !excluded.get(v as usize).copied().unwrap_or(false)
        })
        .map(|v| (deficit(v).abs(), v))
        .filter(|&(d, _)| d >= CORNER_DEFICIT)
        .collect();
    if !found.is_empty() {
        let fixed = Clearance::new(mesh, fixed, l);
        found.retain(|&(_, v)| fixed.clear(mesh.positions[v as usize]));
    }
    found.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut corners: Vec<u32> = Vec::new();
    for (_, v) in found {
        let p = mesh.positions[v as usize];
        let near = |t: &u32| vec3::dist(mesh.positions[*t as usize], p) <= l;
        if !taken.iter().any(near) && !corners.iter().any(near) {
            corners.push(v);
        }
    }
    corners.sort_unstable();
    corners
}

/// The vertex of `ball` where the surface comes to its point: the one farthest out along
/// the ball's mean normal where the surface bends away from that normal (a tip), the one
/// deepest in where it bends towards it (a pit). The ball sum peaks on a plateau around the
/// apex, so its centre need not be the apex itself.
fn apex_of(mesh: &TriMesh, ball: &[u32]) -> u32 {
    let topo = mesh.topology();
    let n_ball = ball.len() as f64;
    let mut centre = [0.0; 3];
    for &u in ball {
        centre = vec3::add(centre, mesh.positions[u as usize]);
    }
    centre = vec3::scale(centre, 1.0 / n_ball);
    // Area-weighted vertex normals (face normals unnormalised, so weighted by area).
    let normal_at = |u: u32| {
        topo.vertex_faces(u).iter().fold([0.0; 3], |acc, &f| {
            let [a, b, c] = mesh.triangles[f as usize].map(|x| mesh.positions[x as usize]);
            vec3::add(acc, vec3::cross(vec3::sub(b, a), vec3::sub(c, a)))
        })
    };
    let normals: Vec<V3> = ball.iter().map(|&u| normal_at(u)).collect();
    let mean = normals.iter().fold([0.0; 3], |acc, &m| vec3::add(acc, m));
    // Convex where the normals point away from the centre.
    let bulge: f64 = ball
        .iter()
        .zip(&normals)
        .map(|(&u, &m)| vec3::dot(vec3::sub(mesh.positions[u as usize], centre), m))
        .sum();
    let sign = if bulge >= 0.0 { 1.0 } else { -1.0 };
    let height = |u: u32| sign * vec3::dot(mesh.positions[u as usize], mean);
    let mut best = ball[0];
    for &u in &ball[1..] {
        if height(u) > height(best) || (height(u) == height(best) && u < best) {
            best = u;
        }
    }
    best
}

#[cfg(test)]
#[path = "tips_test.rs"]
mod tests;
