//! Closest-point hierarchy speed: building [`TriangleBvh`] over a mesh, and exact closest-point
//! queries from points scattered around its surface.
//!
//!   cargo bench -p crestflow-geom --bench bvh -- MESH... [--repeats 15]
//!
//! Per mesh one line: faces, the fastest and the median time of [`TriangleBvh::new`] (one
//! thread) and of [`TriangleBvh::new_in_parallel`] (the rayon pool), and the median time of
//! 100 000 queries (points at face centroids pushed off along the face normal by up to 2 %
//! of the bounding-box diagonal, in face order).

use std::time::Instant;

use crestflow_geom::bvh::TriangleBvh;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_geom::vec3;

fn main() {
    let mut args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut repeats = 15usize;
    if let Some(i) = args.iter().position(|a| a == "--repeats") {
        if let Some(r) = args.get(i + 1).and_then(|r| r.parse().ok()) {
            repeats = r;
        }
        args.drain(i..(i + 2).min(args.len()));
    }
    for path in &args {
        let mesh = match load_mesh(path, &LoadOptions::default()) {
            Ok(m) => m.mesh,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        let nf = mesh.n_faces();
        if nf == 0 {
            eprintln!("{path}: no faces");
            continue;
        }
        let off = 0.02 * mesh.bbox_diagonal();
        let normals = mesh.face_normals();
        let queries: Vec<_> = (0..100_000usize)
            .map(|i| {
                let f = (i * 7919) % nf;
                let [a, b, c] = mesh.face_points(f);
                let centroid = vec3::scale(vec3::add(vec3::add(a, b), c), 1.0 / 3.0);
                // A fixed spread of offsets in [-1, 1) times `off`.
                let s = ((i * 2654435761) % 1000) as f64 / 500.0 - 1.0;
                vec3::add(centroid, vec3::scale(normals[f], s * off))
            })
            .collect();
        let mut build = Vec::new();
        let mut build_par = Vec::new();
        let mut query = Vec::new();
        let mut check = 0.0;
        for _ in 0..repeats {
            let t = Instant::now();
            let bvh = TriangleBvh::new(&mesh);
            build.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            std::hint::black_box(TriangleBvh::new_in_parallel(&mesh));
            build_par.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            check += queries.iter().map(|&p| bvh.closest(p).dist2).sum::<f64>();
            query.push(t.elapsed().as_secs_f64());
        }
        for v in [&mut build, &mut build_par, &mut query] {
            v.sort_by(f64::total_cmp);
        }
        println!(
            "{path}: {nf} faces, build {:.2} / {:.2} ms (fastest / median), in parallel {:.2} / {:.2} ms, 100k queries {:.1} ms median (checksum {check:.6e})",
            build[0] * 1e3,
            build[repeats / 2] * 1e3,
            build_par[0] * 1e3,
            build_par[repeats / 2] * 1e3,
            query[repeats / 2] * 1e3
        );
    }
}
