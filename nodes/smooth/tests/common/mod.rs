//! Test shapes and seeded noise shared by the smoothing tests.
#![allow(dead_code)]

use std::collections::HashMap;

use crestflow_geom::vec3::V3;
use crestflow_geom::TriMesh;

/// SplitMix64: a small seeded generator.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in (0, 1].
    pub fn unit(&mut self) -> f64 {
        ((self.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let (u, v) = (self.unit(), self.unit());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// Adds i.i.d. N(0, σ²) to every coordinate.
pub fn add_noise(mesh: &TriMesh, sigma: f64, seed: u64) -> TriMesh {
    let mut rng = Rng(seed);
    let pos = mesh
        .positions
        .iter()
        .map(|p| {
            [
                p[0] + sigma * rng.normal(),
                p[1] + sigma * rng.normal(),
                p[2] + sigma * rng.normal(),
            ]
        })
        .collect();
    mesh.with_positions(pos)
}

/// The surface of the cube [0, 1]³ with an n × n grid on every face (shared vertices).
pub fn cube(n: usize) -> TriMesh {
    let mut index: HashMap<[usize; 3], u32> = HashMap::new();
    let mut positions: Vec<V3> = Vec::new();
    let mut triangles = Vec::new();
    let mut vid = |c: [usize; 3], positions: &mut Vec<V3>| -> u32 {
        *index.entry(c).or_insert_with(|| {
            positions.push([
                c[0] as f64 / n as f64,
                c[1] as f64 / n as f64,
                c[2] as f64 / n as f64,
            ]);
            (positions.len() - 1) as u32
        })
    };
    // (normal axis, side, u axis, v axis) with u × v pointing outwards.
    let faces = [
        (0, n, 1, 2),
        (0, 0, 2, 1),
        (1, n, 2, 0),
        (1, 0, 0, 2),
        (2, n, 0, 1),
        (2, 0, 1, 0),
    ];
    for (axis, side, ua, va) in faces {
        for j in 0..n {
            for i in 0..n {
                let at = |i: usize, j: usize| {
                    let mut c = [0; 3];
                    c[axis] = side;
                    c[ua] = i;
                    c[va] = j;
                    c
                };
                let a = vid(at(i, j), &mut positions);
                let b = vid(at(i + 1, j), &mut positions);
                let c = vid(at(i + 1, j + 1), &mut positions);
                let d = vid(at(i, j + 1), &mut positions);
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
    }
    TriMesh::new(positions, triangles)
}

/// Distance from `p` to the surface of the unit cube [0, 1]³.
pub fn cube_distance(p: V3) -> f64 {
    let inside = p.iter().all(|&c| (0.0..=1.0).contains(&c));
    if inside {
        p.iter()
            .map(|&c| c.min(1.0 - c))
            .fold(f64::INFINITY, f64::min)
    } else {
        p.iter()
            .map(|&c| (-c).max(c - 1.0).max(0.0))
            .map(|d| d * d)
            .sum::<f64>()
            .sqrt()
    }
}

/// A flat, irregular grid of (n + 1)² vertices on the tilted plane z = 0.3 x + 0.2 y.
pub fn tilted_plane(n: usize, jitter: f64, seed: u64) -> TriMesh {
    let mut rng = Rng(seed);
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let interior = i > 0 && j > 0 && i < n && j < n;
            let (mut x, mut y) = (i as f64 / n as f64, j as f64 / n as f64);
            if interior {
                x += jitter / n as f64 * (rng.unit() - 0.5);
                y += jitter / n as f64 * (rng.unit() - 0.5);
            }
            positions.push([x, y, 0.3 * x + 0.2 * y]);
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            // Alternate diagonals so that the mesh is irregular.
            if (i + j) % 2 == 0 {
                triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            } else {
                triangles.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
                triangles.push([id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    TriMesh::new(positions, triangles)
}

/// A gear-like closed surface with `teeth` repeated features: the unit icosphere of `level`
/// with every vertex pushed out radially by `height` · g(k φ) · sin² θ, where φ is the
/// longitude, θ the colatitude and g a trapezoid wave (flat tooth tops and gaps joined by
/// steep flanks). Each tooth has two convex creases (tooth top edges) and two concave ones
/// (gap edges) running along meridians, fading towards the poles: the same feature repeated
/// `teeth` times by rotation, like the petals of the thesis' lotus (Table 5.1).
pub fn gear(level: u32, teeth: usize, height: f64) -> TriMesh {
    let base = crestflow_geom::shapes::sphere(1.0, level).expect("valid sphere level");
    let pos = base
        .positions
        .iter()
        .map(|&p| {
            let phi = p[1].atan2(p[0]);
            let sin2 = 1.0 - p[2] * p[2];
            let u = phi / (2.0 * std::f64::consts::PI) * teeth as f64;
            // Triangle wave in [0, 1], then a trapezoid: flat below 0.3 and above 0.7.
            let tri = 2.0 * (u - u.floor() - 0.5).abs();
            let g = ((tri - 0.3) / 0.4).clamp(0.0, 1.0);
            let r = 1.0 + height * g * sin2;
            [p[0] * r, p[1] * r, p[2] * r]
        })
        .collect();
    base.with_positions(pos)
}
