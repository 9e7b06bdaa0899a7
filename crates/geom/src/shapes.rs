//! Analytic test shapes: meshes of spheres, open cylinders, tori and ellipsoids, and their
//! closed-form principal curvatures, directions and extremality coefficients (thesis §2.1.2).
//!
//! These are the ground truth of the curvature estimators (YBS05 polynomial fitting and the
//! HPW05 discrete shape operator, thesis §2.4) and of ridge tracing (§2.5): an estimator is
//! tested by comparing its [`CurvatureField`] with [`analytic_curvature_field`] on the same mesh.
//!
//! Conventions follow [`CurvatureField`]: outward normals, `k_max >= k_min`, convex surfaces
//! have positive curvature (a sphere of radius r has k = +1/r). All shapes are centred at the
//! origin; the cylinder and the torus have the z axis as their axis.
//!
//! Meshes are deterministic: irregular sampling uses a seeded SplitMix64 generator, so the same
//! `(shape, vertices, jitter, seed)` always gives the same mesh, bit for bit.

use std::collections::HashMap;
use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::curvature::CurvatureField;
use crate::mesh::TriMesh;
use crate::vec3::{self, V3};

/// The largest vertex count a generator accepts (keeps a typo from exhausting memory).
pub const MAX_VERTICES: usize = 20_000_000;
/// The largest allowed jitter, as a fraction of the grid spacing (beyond ~0.5 triangles fold).
pub const MAX_JITTER: f64 = 0.45;

/// Why a shape or a sampling request was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeError {
    #[error("{shape}: parameter `{name}` = {value} is invalid: {reason}")]
    InvalidParameter {
        shape: &'static str,
        name: &'static str,
        value: f64,
        reason: &'static str,
    },
    #[error("requested {requested} vertices; a generator accepts between {min} and {max}")]
    VertexCount {
        requested: usize,
        min: usize,
        max: usize,
    },
}

/// A surface with closed-form curvature. Serialises as e.g. `Torus(major: 2.0, minor: 0.5)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum AnalyticShape {
    /// Sphere of the given radius (every point is umbilic).
    Sphere { radius: f64 },
    /// Open cylinder around the z axis, z in [-height/2, height/2]. The analytic values are those
    /// of the infinite cylinder (the mesh has no caps, so its rim vertices are boundary vertices).
    Cylinder { radius: f64, height: f64 },
    /// Ring torus around the z axis: `major` is the distance from the axis to the tube centre,
    /// `minor` the tube radius (`major > minor > 0`).
    Torus { major: f64, minor: f64 },
    /// Ellipsoid x²/a² + y²/b² + z²/c² = 1.
    Ellipsoid { a: f64, b: f64, c: f64 },
}

impl Default for AnalyticShape {
    fn default() -> Self {
        AnalyticShape::Sphere { radius: 1.0 }
    }
}

/// Principal curvatures, directions and normal at a surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principal {
    /// The point on the surface the values belong to.
    pub point: V3,
    pub k_max: f64,
    pub k_min: f64,
    pub t_max: V3,
    pub t_min: V3,
    /// Outward unit normal.
    pub normal: V3,
}

fn positive(shape: &'static str, name: &'static str, value: f64) -> Result<(), ShapeError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ShapeError::InvalidParameter {
            shape,
            name,
            value,
            reason: "must be finite and > 0",
        })
    }
}

impl AnalyticShape {
    /// The variant's name (`"torus"`), for reports.
    pub fn name(&self) -> &'static str {
        match self {
            AnalyticShape::Sphere { .. } => "sphere",
            AnalyticShape::Cylinder { .. } => "cylinder",
            AnalyticShape::Torus { .. } => "torus",
            AnalyticShape::Ellipsoid { .. } => "ellipsoid",
        }
    }

    /// Checks the dimensions: positive and finite, `major > minor` for the torus.
    pub fn check(&self) -> Result<(), ShapeError> {
        match *self {
            AnalyticShape::Sphere { radius } => positive("sphere", "radius", radius),
            AnalyticShape::Cylinder { radius, height } => {
                positive("cylinder", "radius", radius)?;
                positive("cylinder", "height", height)
            }
            AnalyticShape::Torus { major, minor } => {
                positive("torus", "major", major)?;
                positive("torus", "minor", minor)?;
                if major <= minor {
                    return Err(ShapeError::InvalidParameter {
                        shape: "torus",
                        name: "major",
                        value: major,
                        reason: "must exceed `minor` (ring torus)",
                    });
                }
                Ok(())
            }
            AnalyticShape::Ellipsoid { a, b, c } => {
                positive("ellipsoid", "a", a)?;
                positive("ellipsoid", "b", b)?;
                positive("ellipsoid", "c", c)
            }
        }
    }

    /// The smallest radius of curvature scale of the shape (used for finite-difference steps).
    fn length_scale(&self) -> f64 {
        match *self {
            AnalyticShape::Sphere { radius } => radius,
            AnalyticShape::Cylinder { radius, .. } => radius,
            AnalyticShape::Torus { minor, .. } => minor,
            AnalyticShape::Ellipsoid { a, b, c } => a.min(b).min(c),
        }
    }

    /// The point of the surface closest to `p` (for the ellipsoid: Newton on the Lagrange
    /// multiplier, exact to rounding). Points on the axis of a cylinder/torus or at the centre
    /// of a sphere have no unique projection; a fixed choice is made.
    pub fn project(&self, p: V3) -> V3 {
        match *self {
            AnalyticShape::Sphere { radius } => {
                let d = vec3::normalize(p);
                let d = if d == [0.0; 3] { [0.0, 0.0, 1.0] } else { d };
                vec3::scale(d, radius)
            }
            AnalyticShape::Cylinder { radius, .. } => {
                let rho = p[0].hypot(p[1]);
                let (c, s) = if rho > 0.0 {
                    (p[0] / rho, p[1] / rho)
                } else {
                    (1.0, 0.0)
                };
                [radius * c, radius * s, p[2]]
            }
            AnalyticShape::Torus { major, minor } => {
                let (u, v) = torus_angles(major, p);
                torus_point(major, minor, u, v)
            }
            AnalyticShape::Ellipsoid { a, b, c } => ellipsoid_closest_point([a, b, c], p),
        }
    }

    /// Principal curvatures and directions at the projection of `p` onto the surface.
    ///
    /// At umbilics (everywhere on the sphere; four points of a triaxial ellipsoid) the directions
    /// are an arbitrary orthonormal tangent pair. `t_min = normal × t_max` everywhere.
    pub fn principal(&self, p: V3) -> Principal {
        match *self {
            AnalyticShape::Sphere { radius } => {
                let q = self.project(p);
                let n = vec3::scale(q, 1.0 / radius);
                let t_max = any_tangent(n);
                Principal {
                    point: q,
                    k_max: 1.0 / radius,
                    k_min: 1.0 / radius,
                    t_max,
                    t_min: vec3::cross(n, t_max),
                    normal: n,
                }
            }
            AnalyticShape::Cylinder { radius, .. } => {
                let q = self.project(p);
                let n = [q[0] / radius, q[1] / radius, 0.0];
                // Around the axis (curvature 1/r) and along it (curvature 0).
                let t_max = [-n[1], n[0], 0.0];
                Principal {
                    point: q,
                    k_max: 1.0 / radius,
                    k_min: 0.0,
                    t_max,
                    t_min: vec3::cross(n, t_max),
                    normal: n,
                }
            }
            AnalyticShape::Torus { major, minor } => {
                let (u, v) = torus_angles(major, p);
                let (su, cu) = u.sin_cos();
                let (sv, cv) = v.sin_cos();
                let n = [cv * cu, cv * su, sv];
                // Meridian circles (radius `minor`) carry k_max = 1/r; parallels carry
                // k_min = cos v / (R + r cos v), which is below 1/r whenever R > 0.
                let t_max = [-sv * cu, -sv * su, cv];
                Principal {
                    point: torus_point(major, minor, u, v),
                    k_max: 1.0 / minor,
                    k_min: cv / (major + minor * cv),
                    t_max,
                    t_min: vec3::cross(n, t_max),
                    normal: n,
                }
            }
            AnalyticShape::Ellipsoid { a, b, c } => ellipsoid_principal([a, b, c], self.project(p)),
        }
    }

    /// Whether the principal curvatures at (the projection of) `p` differ by less than
    /// `rel_tol` times their magnitude, i.e. the point is (nearly) umbilic and its principal
    /// directions are not defined.
    pub fn is_umbilic(&self, p: V3, rel_tol: f64) -> bool {
        let pr = self.principal(p);
        (pr.k_max - pr.k_min) <= rel_tol * pr.k_max.abs().max(pr.k_min.abs())
    }

    /// Extremality coefficients (e_max, e_min) = (∇k_max·t_max, ∇k_min·t_min) at the projection
    /// of `p`, for the directions `principal(p)` returns, by central finite differences of the
    /// closed-form curvature along the principal direction (step 1e-4 of the shape's smallest
    /// length, points projected back onto the surface; error O(step²)).
    pub fn extremality(&self, p: V3) -> (f64, f64) {
        let pr = self.principal(p);
        let h = 1e-4 * self.length_scale();
        let diff = |t: V3, pick: fn(&Principal) -> f64| {
            let fwd = self.principal(vec3::add(pr.point, vec3::scale(t, h)));
            let bwd = self.principal(vec3::sub(pr.point, vec3::scale(t, h)));
            // Divide by the true distance of the projected points (not 2h) to stay O(h²).
            let d = vec3::dist(fwd.point, bwd.point);
            if d > 0.0 {
                (pick(&fwd) - pick(&bwd)) / d
            } else {
                0.0
            }
        };
        (diff(pr.t_max, |q| q.k_max), diff(pr.t_min, |q| q.k_min))
    }

    /// A mesh of the shape with about `vertices` vertices (see the generators for how the count
    /// is matched). `jitter` in [0, 0.45] moves every sample randomly by up to that fraction of
    /// the local grid spacing (irregular sampling, seeded by `seed`); 0 gives the regular mesh.
    pub fn mesh(&self, vertices: usize, jitter: f64, seed: u64) -> Result<TriMesh, ShapeError> {
        self.check()?;
        match *self {
            AnalyticShape::Sphere { radius } => ellipsoid(
                radius,
                radius,
                radius,
                icosphere_level_for(vertices)?,
                jitter,
                seed,
            ),
            AnalyticShape::Ellipsoid { a, b, c } => {
                ellipsoid(a, b, c, icosphere_level_for(vertices)?, jitter, seed)
            }
            AnalyticShape::Cylinder { radius, height } => {
                check_count(vertices)?;
                // Square cells: n_around / n_along ≈ 2πr / h, n_around · (n_along + 1) ≈ N.
                let aspect = 2.0 * PI * radius / height;
                let n_around = ((vertices as f64 * aspect).sqrt().round() as usize).max(3);
                let n_along = (vertices / n_around).saturating_sub(1).max(1);
                cylinder(radius, height, n_around, n_along, jitter, seed)
            }
            AnalyticShape::Torus { major, minor } => {
                check_count(vertices)?;
                let n_v = ((vertices as f64 * minor / major).sqrt().round() as usize).max(3);
                let n_u = (vertices / n_v).max(3);
                torus(major, minor, n_u, n_v, jitter, seed)
            }
        }
    }
}

fn check_count(vertices: usize) -> Result<(), ShapeError> {
    if (12..=MAX_VERTICES).contains(&vertices) {
        Ok(())
    } else {
        Err(ShapeError::VertexCount {
            requested: vertices,
            min: 12,
            max: MAX_VERTICES,
        })
    }
}

fn check_jitter(shape: &'static str, jitter: f64) -> Result<(), ShapeError> {
    if (0.0..=MAX_JITTER).contains(&jitter) {
        Ok(())
    } else {
        Err(ShapeError::InvalidParameter {
            shape,
            name: "jitter",
            value: jitter,
            reason: "must be in [0, 0.45] (a fraction of the grid spacing)",
        })
    }
}

/// The icosphere subdivision level whose vertex count 10·4^L + 2 is closest (in ratio) to `n`.
pub fn icosphere_level_for(n: usize) -> Result<u32, ShapeError> {
    check_count(n)?;
    let mut best = 0;
    let mut best_err = f64::INFINITY;
    for level in 0..=11u32 {
        let count = icosphere_vertex_count(level);
        if count > MAX_VERTICES {
            break;
        }
        let err = (count as f64 / n as f64).ln().abs();
        if err < best_err {
            best_err = err;
            best = level;
        }
    }
    Ok(best)
}

/// Vertices of the icosphere of subdivision `level`: 10·4^level + 2.
pub fn icosphere_vertex_count(level: u32) -> usize {
    10 * 4usize.pow(level) + 2
}

/// Deterministic SplitMix64 stream: uniform numbers for jitter without a dependency.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [-1, 1).
    fn symmetric(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (2.0 / (1u64 << 53) as f64) - 1.0
    }
}

/// Icosphere of radius `radius`: the icosahedron subdivided `level` times (10·4^level + 2
/// vertices), triangles counter-clockwise seen from outside.
pub fn sphere(radius: f64, level: u32) -> Result<TriMesh, ShapeError> {
    ellipsoid(radius, radius, radius, level, 0.0, 0)
}

/// Ellipsoid with semi-axes a, b, c along x, y, z: an icosphere of `level` whose vertices are
/// jittered on the unit sphere (tangentially, by up to `jitter` × the mean edge length, then
/// renormalised) and mapped by (x, y, z) ↦ (a x, b y, c z), which keeps them on the ellipsoid.
pub fn ellipsoid(
    a: f64,
    b: f64,
    c: f64,
    level: u32,
    jitter: f64,
    seed: u64,
) -> Result<TriMesh, ShapeError> {
    AnalyticShape::Ellipsoid { a, b, c }.check()?;
    check_jitter("ellipsoid", jitter)?;
    let count = icosphere_vertex_count(level.min(12));
    if level > 12 || count > MAX_VERTICES {
        return Err(ShapeError::VertexCount {
            requested: count,
            min: 12,
            max: MAX_VERTICES,
        });
    }
    let (mut pos, tris) = unit_icosphere(level);
    if jitter > 0.0 {
        // Icosahedron edge on the unit sphere ≈ 1.0515, halved per level.
        let spacing = 1.0515 / f64::from(1u32 << level);
        let mut rng = SplitMix64(seed);
        for p in &mut pos {
            let t1 = any_tangent(*p);
            let t2 = vec3::cross(*p, t1);
            let (d1, d2) = (rng.symmetric(), rng.symmetric());
            let moved = vec3::add(
                *p,
                vec3::add(
                    vec3::scale(t1, d1 * jitter * spacing),
                    vec3::scale(t2, d2 * jitter * spacing),
                ),
            );
            *p = vec3::normalize(moved);
        }
    }
    let positions = pos
        .into_iter()
        .map(|p| [a * p[0], b * p[1], c * p[2]])
        .collect();
    Ok(TriMesh::new(positions, tris))
}

/// The unit icosphere: positions and triangles. Midpoints are shared through an edge map filled
/// in face order, so vertex numbering is deterministic.
fn unit_icosphere(level: u32) -> (Vec<V3>, Vec<[u32; 3]>) {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut pos: Vec<V3> = [
        [-1.0, g, 0.0],
        [1.0, g, 0.0],
        [-1.0, -g, 0.0],
        [1.0, -g, 0.0],
        [0.0, -1.0, g],
        [0.0, 1.0, g],
        [0.0, -1.0, -g],
        [0.0, 1.0, -g],
        [g, 0.0, -1.0],
        [g, 0.0, 1.0],
        [-g, 0.0, -1.0],
        [-g, 0.0, 1.0],
    ]
    .iter()
    .map(|&p| vec3::normalize(p))
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(tris.len() * 2);
        let mut next = Vec::with_capacity(tris.len() * 4);
        let mut midpoint = |i: u32, j: u32, pos: &mut Vec<V3>| -> u32 {
            let key = (i.min(j), i.max(j));
            *mid.entry(key).or_insert_with(|| {
                let m = vec3::normalize(vec3::add(pos[i as usize], pos[j as usize]));
                pos.push(m);
                (pos.len() - 1) as u32
            })
        };
        for t in &tris {
            let ab = midpoint(t[0], t[1], &mut pos);
            let bc = midpoint(t[1], t[2], &mut pos);
            let ca = midpoint(t[2], t[0], &mut pos);
            next.push([t[0], ab, ca]);
            next.push([t[1], bc, ab]);
            next.push([t[2], ca, bc]);
            next.push([ab, bc, ca]);
        }
        tris = next;
    }
    (pos, tris)
}

/// Open cylinder of radius `radius` around the z axis, z in [-height/2, height/2]:
/// `n_around` samples per ring, `n_along + 1` rings. `jitter` moves samples by up to that
/// fraction of the grid spacing (angle on every ring, height on interior rings only, so the
/// rims stay planar); each quad is split along a random diagonal when `jitter > 0`.
pub fn cylinder(
    radius: f64,
    height: f64,
    n_around: usize,
    n_along: usize,
    jitter: f64,
    seed: u64,
) -> Result<TriMesh, ShapeError> {
    AnalyticShape::Cylinder { radius, height }.check()?;
    check_jitter("cylinder", jitter)?;
    grid_size_ok(n_around, n_along + 1)?;
    let mut rng = SplitMix64(seed);
    let mut positions = Vec::with_capacity(n_around * (n_along + 1));
    for j in 0..=n_along {
        for i in 0..n_around {
            let du = jitter * rng.symmetric();
            let dv = jitter * rng.symmetric();
            let theta = 2.0 * PI * (i as f64 + du) / n_around as f64;
            let dz = if j == 0 || j == n_along { 0.0 } else { dv };
            let z = height * ((j as f64 + dz) / n_along as f64 - 0.5);
            positions.push([radius * theta.cos(), radius * theta.sin(), z]);
        }
    }
    let idx = |i: usize, j: usize| (j * n_around + i % n_around) as u32;
    let tris = grid_triangles(n_around, n_along, idx, jitter > 0.0, &mut rng);
    Ok(TriMesh::new(positions, tris))
}

/// Ring torus around the z axis (tube centre at distance `major`, tube radius `minor`), sampled
/// on an `n_u` × `n_v` grid of the angles (u around the axis, v around the tube). With
/// `jitter > 0` every (u, v) sample moves by up to `jitter` grid cells and each quad is split
/// along a random diagonal (irregular sampling and valences); points stay exactly on the torus.
pub fn torus(
    major: f64,
    minor: f64,
    n_u: usize,
    n_v: usize,
    jitter: f64,
    seed: u64,
) -> Result<TriMesh, ShapeError> {
    AnalyticShape::Torus { major, minor }.check()?;
    check_jitter("torus", jitter)?;
    grid_size_ok(n_u, n_v)?;
    let mut rng = SplitMix64(seed);
    let mut positions = Vec::with_capacity(n_u * n_v);
    for j in 0..n_v {
        for i in 0..n_u {
            let u = 2.0 * PI * (i as f64 + jitter * rng.symmetric()) / n_u as f64;
            let v = 2.0 * PI * (j as f64 + jitter * rng.symmetric()) / n_v as f64;
            positions.push(torus_point(major, minor, u, v));
        }
    }
    let idx = |i: usize, j: usize| ((j % n_v) * n_u + i % n_u) as u32;
    let tris = grid_triangles(n_u, n_v, idx, jitter > 0.0, &mut rng);
    Ok(TriMesh::new(positions, tris))
}

fn grid_size_ok(n_u: usize, n_v: usize) -> Result<(), ShapeError> {
    if n_u < 3 || n_v < 2 {
        return Err(ShapeError::VertexCount {
            requested: n_u * n_v,
            min: 12,
            max: MAX_VERTICES,
        });
    }
    match n_u.checked_mul(n_v) {
        Some(n) if n <= MAX_VERTICES => Ok(()),
        _ => Err(ShapeError::VertexCount {
            requested: n_u.saturating_mul(n_v),
            min: 12,
            max: MAX_VERTICES,
        }),
    }
}

/// Two triangles per grid cell (i, j), counter-clockwise in (u, v) (outward for both the
/// cylinder and the torus parametrisations). `rows` cells along v.
fn grid_triangles(
    n_u: usize,
    rows: usize,
    idx: impl Fn(usize, usize) -> u32,
    random_diagonal: bool,
    rng: &mut SplitMix64,
) -> Vec<[u32; 3]> {
    let mut tris = Vec::with_capacity(2 * n_u * rows);
    for j in 0..rows {
        for i in 0..n_u {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            let flip = random_diagonal && rng.next_u64() & 1 == 1;
            if flip {
                tris.push([a, b, d]);
                tris.push([b, c, d]);
            } else {
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            }
        }
    }
    tris
}

fn torus_point(major: f64, minor: f64, u: f64, v: f64) -> V3 {
    let (su, cu) = u.sin_cos();
    let (sv, cv) = v.sin_cos();
    let rho = major + minor * cv;
    [rho * cu, rho * su, minor * sv]
}

/// Angles (u, v) of the torus point closest to `p`.
fn torus_angles(major: f64, p: V3) -> (f64, f64) {
    let u = p[1].atan2(p[0]);
    let rho = p[0].hypot(p[1]);
    let v = p[2].atan2(rho - major);
    (u, v)
}

/// A unit vector orthogonal to unit `n`, chosen by a fixed rule (cross with the axis least
/// aligned with `n`).
fn any_tangent(n: V3) -> V3 {
    let axis = if n[0].abs() <= n[1].abs() && n[0].abs() <= n[2].abs() {
        [1.0, 0.0, 0.0]
    } else if n[1].abs() <= n[2].abs() {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    vec3::normalize(vec3::cross(n, axis))
}

/// Closest point on the ellipsoid with semi-axes `s` to `p`: q_i = s_i² p_i / (s_i² + t) where
/// t solves f(t) = Σ s_i² p_i² / (s_i² + t)² − 1 = 0. f is convex and decreasing; Newton
/// started left of the root (f ≥ 0) converges monotonically.
fn ellipsoid_closest_point(s: V3, p: V3) -> V3 {
    let s2 = [s[0] * s[0], s[1] * s[1], s[2] * s[2]];
    if p.iter().all(|&x| x == 0.0) {
        return [0.0, 0.0, s[2]];
    }
    // For any i with p_i ≠ 0, t = s_i|p_i| − s_i² makes that term 1, hence f(t) ≥ 0.
    let mut t = (0..3)
        .filter(|&i| p[i] != 0.0)
        .map(|i| s[i] * p[i].abs() - s2[i])
        .fold(f64::NEG_INFINITY, f64::max);
    for _ in 0..200 {
        let mut f = -1.0;
        let mut df = 0.0;
        for i in 0..3 {
            let d = s2[i] + t;
            if d <= 0.0 {
                continue;
            }
            let r = s[i] * p[i] / d;
            f += r * r;
            df += -2.0 * r * r / d;
        }
        if df >= 0.0 || !f.is_finite() {
            break;
        }
        let step = f / df;
        t -= step;
        if step.abs() <= 1e-15 * (1.0 + t.abs()) {
            break;
        }
    }
    let q = [0, 1, 2].map(|i| {
        let d = s2[i] + t;
        if d > 0.0 {
            s2[i] * p[i] / d
        } else {
            0.0
        }
    });
    // Polish: scale radially onto the surface so rounding leaves no residual.
    let g = (q[0] / s[0]).powi(2) + (q[1] / s[1]).powi(2) + (q[2] / s[2]).powi(2);
    if g > 0.0 {
        vec3::scale(q, 1.0 / g.sqrt())
    } else {
        q
    }
}

/// Principal curvatures of the ellipsoid at surface point q. With F = Σ x_i²/s_i² − 1,
/// D = diag(1/s_i²), the outward normal is n = D q / |D q| and the shape operator (positive on
/// convex surfaces) is P D P / |D q| with P = I − n nᵀ; its 2×2 restriction to a tangent basis
/// is diagonalised in closed form.
fn ellipsoid_principal(s: V3, q: V3) -> Principal {
    let d = [
        1.0 / (s[0] * s[0]),
        1.0 / (s[1] * s[1]),
        1.0 / (s[2] * s[2]),
    ];
    let g = [d[0] * q[0], d[1] * q[1], d[2] * q[2]];
    let h = vec3::norm(g);
    let n = vec3::scale(g, 1.0 / h);
    let e1 = any_tangent(n);
    let e2 = vec3::cross(n, e1);
    let form = |x: V3, y: V3| (d[0] * x[0] * y[0] + d[1] * x[1] * y[1] + d[2] * x[2] * y[2]) / h;
    let (m11, m12, m22) = (form(e1, e1), form(e1, e2), form(e2, e2));
    let (k_max, k_min, c, s_) = sym2_eigen(m11, m12, m22);
    let t_max = vec3::normalize(vec3::add(vec3::scale(e1, c), vec3::scale(e2, s_)));
    Principal {
        point: q,
        k_max,
        k_min,
        t_max,
        t_min: vec3::cross(n, t_max),
        normal: n,
    }
}

/// Eigen-decomposition of the symmetric 2×2 matrix [[a, b], [b, c]]: (λ_max, λ_min, cos θ,
/// sin θ) with (cos θ, sin θ) the unit eigenvector of λ_max. Stable for b ≈ 0.
pub fn sym2_eigen(a: f64, b: f64, c: f64) -> (f64, f64, f64, f64) {
    let mean = 0.5 * (a + c);
    let half_diff = 0.5 * (a - c);
    let r = half_diff.hypot(b);
    let (l_max, l_min) = (mean + r, mean - r);
    // θ = ½ atan2(2b, a − c) is the angle of the λ_max eigenvector.
    let theta = 0.5 * (2.0 * b).atan2(a - c);
    let (sn, cs) = theta.sin_cos();
    (l_max, l_min, cs, sn)
}

/// The exact [`CurvatureField`] of `shape` at the vertices of `mesh` (each vertex projected onto
/// the surface): closed-form k_max, k_min, directions and outward normals, and extremality
/// coefficients by central finite differences of the closed-form curvature along the principal
/// directions ([`AnalyticShape::extremality`]).
///
/// Directions are then oriented consistently (§2.5.1.1 step 2): a breadth-first walk over the
/// mesh edges, in vertex index order, flips a neighbour's direction (and its extremality
/// coefficient with it) when it makes an obtuse angle with the direction it was reached from.
/// On the cylinder and the torus the closed-form directions are already smooth and stay as they
/// are; on the ellipsoid, line fields that cannot be oriented around umbilics leave seams.
///
/// The shape is not validated here (see [`AnalyticShape::check`]); invalid dimensions give
/// non-finite values.
pub fn analytic_curvature_field(mesh: &TriMesh, shape: &AnalyticShape) -> CurvatureField {
    let n = mesh.n_vertices();
    let mut f = CurvatureField {
        k_max: Vec::with_capacity(n),
        k_min: Vec::with_capacity(n),
        t_max: Vec::with_capacity(n),
        t_min: Vec::with_capacity(n),
        normal: Vec::with_capacity(n),
        e_max: Vec::with_capacity(n),
        e_min: Vec::with_capacity(n),
        method: format!("analytic.{}", shape.name()),
    };
    for &p in &mesh.positions {
        let pr = shape.principal(p);
        let (e_max, e_min) = shape.extremality(p);
        f.k_max.push(pr.k_max);
        f.k_min.push(pr.k_min);
        f.t_max.push(pr.t_max);
        f.t_min.push(pr.t_min);
        f.normal.push(pr.normal);
        f.e_max.push(e_max);
        f.e_min.push(e_min);
    }
    orient_bfs(mesh, &mut f.t_max, &mut f.e_max);
    orient_bfs(mesh, &mut f.t_min, &mut f.e_min);
    f
}

fn orient_bfs(mesh: &TriMesh, t: &mut [V3], e: &mut [f64]) {
    let topo = mesh.topology();
    let n = mesh.n_vertices();
    let mut seen = vec![false; n];
    let mut queue = std::collections::VecDeque::new();
    for root in 0..n {
        if seen[root] {
            continue;
        }
        seen[root] = true;
        queue.push_back(root as u32);
        while let Some(v) = queue.pop_front() {
            for &w in topo.neighbors(v) {
                let w = w as usize;
                if seen[w] {
                    continue;
                }
                seen[w] = true;
                if vec3::dot(t[v as usize], t[w]) < 0.0 {
                    t[w] = vec3::scale(t[w], -1.0);
                    e[w] = -e[w];
                }
                queue.push_back(w as u32);
            }
        }
    }
}

#[cfg(test)]
#[path = "shapes_test.rs"]
mod tests;
