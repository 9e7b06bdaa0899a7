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
# Per k, crestflow and then scipy (each the median of its repeats): the two alternate, so a
# host that slows down for a few minutes weighs on both sides of a ratio, not on one.
merge() { # out, inputs...: the JSON objects merged (the per-k entries side by side)
  "$PYTHON" - "$@" <<'PY'
import json, sys
out = {}
for f in sys.argv[2:]:
    out.update(json.load(open(f)))
json.dump(out, open(sys.argv[1], "w"))
PY
}
run_one() { # name, then the crestflow bench arguments
  local name="$1"; shift
  local mesh="" k ours=() theirs=()
  for k in ${KS//,/ }; do
    cargo bench -q -p crestflow-nodes-spectral --bench eigen -- "$@" --ks "$k" > "$OUT/$name.k$k.crestflow.json"
    # The torus is written by the first call; later calls read the file it wrote.
    mesh=$("$PYTHON" -c 'import json,sys; print(json.load(open(sys.argv[1]))["mesh"])' "$OUT/$name.k$k.crestflow.json")
    if [ "$1" = "--torus" ]; then set -- "$mesh"; fi
    "$PYTHON" bench/spectral/peer_scipy.py "$mesh" --ks "$k" > "$OUT/$name.k$k.scipy.json"
    ours+=("$OUT/$name.k$k.crestflow.json"); theirs+=("$OUT/$name.k$k.scipy.json")
  done
  merge "$OUT/$name.crestflow.json" "${ours[@]}"
  merge "$OUT/$name.scipy.json" "${theirs[@]}"
  "$PYTHON" bench/spectral/compare.py "$OUT/$name.crestflow.json" "$OUT/$name.scipy.json"
}
run_one bunny "$ROOT/../shared/data/meshes/organic/cgal_bunny00.off"
run_one elephant "$ROOT/../shared/data/meshes/organic/cgal_refined_elephant.off"
# ~115k vertices: a jittered torus (major 1, minor 0.35) from crestflow_geom::shapes.
run_one torus115k --torus 115000 "$OUT/torus115k.off"
