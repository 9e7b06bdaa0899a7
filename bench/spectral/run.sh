#!/usr/bin/env bash
# Eigenbasis benchmark against scipy eigsh (shift-invert) on the same meshes in the same run.
# Run from the repository root: bench/spectral/run.sh [KS]   (default KS=20,60,120)
# Needs python3 with numpy, scipy and libigl (PYTHON=... to choose the interpreter).
set -euo pipefail
KS="${1:-20,60,120}"
PYTHON="${PYTHON:-python3}"
ROOT="$PWD"
# cargo runs benches from the crate folder: hand them absolute paths built from ROOT.
OUT="$ROOT/target/bench-spectral"
mkdir -p "$OUT"
cargo bench -p crestflow-nodes-spectral --bench eigen --no-run
run_one() { # name, then the crestflow bench arguments
  local name="$1"; shift
  cargo bench -q -p crestflow-nodes-spectral --bench eigen -- "$@" --ks "$KS" > "$OUT/$name.crestflow.json"
  local mesh
  mesh=$("$PYTHON" -c 'import json,sys; print(json.load(open(sys.argv[1]))["mesh"])' "$OUT/$name.crestflow.json")
  "$PYTHON" bench/spectral/peer_scipy.py "$mesh" --ks "$KS" > "$OUT/$name.scipy.json"
  "$PYTHON" bench/spectral/compare.py "$OUT/$name.crestflow.json" "$OUT/$name.scipy.json"
}
run_one bunny "$ROOT/../shared/data/meshes/organic/cgal_bunny00.off"
run_one elephant "$ROOT/../shared/data/meshes/organic/cgal_refined_elephant.off"
# ~115k vertices: a jittered torus (major 1, minor 0.35) from crestflow_geom::shapes.
run_one torus115k --torus 115000 "$OUT/torus115k.off"
