//! Loads every file under ../shared/data/meshes (relative to the repository root) and checks
//! it against the table in its SOURCES.md: meshes load with the listed vertex, face, boundary
//! edge and component counts; the bad-input meshes named under "Formats to know" fail with a
//! non-manifold error naming the listed number of non-manifold edges, and with `repair: true`
//! load with the listed faces, every vertex accounted for, and manifold connectivity; files
//! that are not meshes are refused by extension.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crestflow_geom::io::{find_nonmanifold, load_mesh, LoadOptions, MeshError};

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/meshes");

/// One row of the SOURCES.md table.
#[derive(Debug)]
struct Row {
    v: usize,
    f: usize,
    boundary: usize,
    nonmanifold: usize,
    components: usize,
}

fn table(sources: &str) -> BTreeMap<String, Row> {
    let mut rows = BTreeMap::new();
    for line in sources.lines().filter(|l| l.starts_with("| ")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        // | file | V | F | boundary | non-manifold | components | watertight | source | license |
        let num = |i: usize| cells.get(i).and_then(|c| c.parse::<usize>().ok());
        if let (Some(v), Some(f), Some(b), Some(n), Some(c)) =
            (num(2), num(3), num(4), num(5), num(6))
        {
            rows.insert(
                cells[1].to_string(),
                Row {
                    v,
                    f,
                    boundary: b,
                    nonmanifold: n,
                    components: c,
                },
            );
        }
    }
    rows
}

/// The files named in backticks in the "Formats to know" section.
fn bad_inputs(sources: &str) -> Vec<String> {
    let Some(start) = sources.find("## Formats to know") else {
        return Vec::new();
    };
    let section = &sources[start..];
    let section = &section[..section[3..].find("\n## ").map_or(section.len(), |e| e + 3)];
    section
        .split('`')
        .skip(1)
        .step_by(2)
        .filter(|s| s.contains('/') && !s.starts_with('.'))
        .map(str::to_string)
        .collect()
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            walk(&p, out);
        } else {
            out.push(p);
        }
    }
}

#[test]
fn every_shared_mesh_loads_or_fails_as_documented() {
    let root = Path::new(ROOT);
    if !root.is_dir() {
        eprintln!("skipped: {ROOT} not found");
        return;
    }
    let sources = std::fs::read_to_string(root.join("SOURCES.md")).unwrap();
    let rows = table(&sources);
    let bad = bad_inputs(&sources);
    assert!(
        rows.len() >= 40,
        "SOURCES.md table not understood: {} rows",
        rows.len()
    );
    assert_eq!(bad.len(), 3, "bad-input meshes not understood: {bad:?}");

    let mut files = Vec::new();
    walk(root, &mut files);
    let (mut loaded, mut repaired, mut refused) = (0, 0, 0);
    for path in &files {
        let name = path
            .strip_prefix(root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let result = load_mesh(path, &LoadOptions::default());
        let Some(row) = rows.get(&name) else {
            // Not in the table: ground-truth files and READMEs, refused by extension.
            match result {
                Err(MeshError::UnsupportedFormat { .. }) => refused += 1,
                other => panic!("{name}: not in SOURCES.md, expected a refusal, got {other:?}"),
            }
            continue;
        };
        match result {
            Ok(m) => {
                let r = &m.report;
                assert_eq!(
                    (r.vertices, r.faces, r.boundary_edges, r.components),
                    (row.v, row.f, row.boundary, row.components),
                    "{name}: (V, F, boundary edges, components) against SOURCES.md; {r:?}"
                );
                assert_eq!(
                    row.nonmanifold, 0,
                    "{name}: loaded but SOURCES.md lists non-manifold edges"
                );
                assert!(
                    !bad.contains(&name),
                    "{name} is a documented bad input but loaded"
                );
                loaded += 1;
            }
            Err(MeshError::NonManifold {
                edges, vertices, ..
            }) => {
                assert!(
                    bad.contains(&name),
                    "{name}: non-manifold but not a documented bad input"
                );
                assert_eq!(
                    edges, row.nonmanifold,
                    "{name}: non-manifold edges against SOURCES.md"
                );
                let m = load_mesh(
                    path,
                    &LoadOptions {
                        repair: true,
                        ..Default::default()
                    },
                )
                .unwrap_or_else(|e| panic!("{name}: repair failed: {e}"));
                let r = &m.report;
                assert_eq!((r.file_vertices, r.faces), (row.v, row.f), "{name}: {r:?}");
                assert_eq!(
                    (r.nonmanifold_edges, r.nonmanifold_vertices),
                    (edges, vertices)
                );
                assert_eq!(
                    r.vertices,
                    row.v - r.unreferenced_vertices_dropped + r.vertices_split,
                    "{name}: every vertex accounted for"
                );
                assert!(
                    r.vertices_split >= vertices,
                    "{name}: each non-manifold vertex split"
                );
                assert!(find_nonmanifold(m.mesh.n_vertices(), &m.mesh.triangles).is_manifold());
                assert!(m.mesh.topology().nonmanifold_edges.is_empty());
                // Splitting only adds boundary (cut non-manifold edges), never removes it.
                assert!(r.boundary_edges >= row.boundary, "{name}: {r:?}");
                if edges == 0 {
                    assert_eq!(
                        r.boundary_edges, row.boundary,
                        "{name}: vertex splits keep edges"
                    );
                }
                repaired += 1;
            }
            Err(e) => panic!("{name}: unexpected error {e}"),
        }
    }
    assert_eq!(loaded + repaired, rows.len(), "every table row has a file");
    assert_eq!(
        repaired,
        bad.len(),
        "every documented bad input needed the repair"
    );
    eprintln!("{loaded} loaded, {repaired} repaired, {refused} non-mesh files refused");
}
