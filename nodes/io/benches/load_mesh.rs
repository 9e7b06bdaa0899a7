//! Mesh loading speed (not a test): `cargo bench -p crestflow-nodes-io --bench load_mesh`.
//!
//! Loads the largest shared mesh of each format (parse + validation + connectivity) several
//! times and prints the median wall time and throughput. Skips files that are missing.

use std::path::Path;
use std::time::Instant;

use crestflow_geom::io::{load_mesh, LoadOptions};

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/meshes");

fn main() {
    let files = [
        ("scans/pymeshlab_face000_rangemap.ply", true),
        ("scans/pymeshfix_StanfordBunny_scan.ply", true),
        ("organic/cgal_refined_elephant.off", false),
        ("organic/cgal_bunny00.off", false),
        ("organic/oded_koala.obj", false),
        ("cad/trimesh_featuretype.STL", false),
    ];
    println!(
        "{:<42} {:>8} {:>8} {:>10} {:>8}",
        "file", "V", "F", "median ms", "MB/s"
    );
    for (name, repair) in files {
        let path = Path::new(ROOT).join(name);
        let Ok(meta) = std::fs::metadata(&path) else {
            println!("{name}: missing, skipped");
            continue;
        };
        let options = LoadOptions {
            repair,
            ..Default::default()
        };
        let mut times = Vec::new();
        let mut counts = (0, 0);
        for _ in 0..7 {
            let t = Instant::now();
            let m = match load_mesh(&path, &options) {
                Ok(m) => m,
                Err(e) => {
                    println!("{name}: {e}");
                    break;
                }
            };
            times.push(t.elapsed().as_secs_f64() * 1e3);
            counts = (m.mesh.n_vertices(), m.mesh.n_faces());
        }
        if times.is_empty() {
            continue;
        }
        times.sort_by(f64::total_cmp);
        let ms = times[times.len() / 2];
        let mbs = meta.len() as f64 / 1e6 / (ms / 1e3);
        println!(
            "{name:<42} {:>8} {:>8} {ms:>10.1} {mbs:>8.1}",
            counts.0, counts.1
        );
    }
}
