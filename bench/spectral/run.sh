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
# Per k, ROUNDS rounds (default 3) of crestflow and then scipy, three runs each in one process;
# each tool's time is the median of all its runs. The two alternate every few seconds, so a
# host that slows down for a while weighs on both sides of a ratio, not on one.
ROUNDS="${ROUNDS:-3}"
merge() { # out, inputs...: the JSON objects merged; an entry k<K> met in several inputs (one
  # per round) gets all their times and their median as its time
  "$PYTHON" - "$@" <<'PY'
import json, statistics, sys
out = {}
for f in sys.argv[2:]:
    for key, val in json.load(open(f)).items():
        if key.startswith("k") and key in out:
            out[key]["times"] += val["times"]
            out[key]["time"] = statistics.median(out[key]["times"])
        else:
            out[key] = val
json.dump(out, open(sys.argv[1], "w"))
PY
}
run_one() { # name, then the crestflow bench arguments
  local name="$1"; shift
  local mesh="" k ours=() theirs=()
  for k in ${KS//,/ }; do
    for r in $(seq "$ROUNDS"); do
      cargo bench -q -p crestflow-nodes-spectral --bench eigen -- "$@" --ks "$k" > "$OUT/$name.k$k.r$r.crestflow.json"
      # The torus is written by the first call; later calls read the file it wrote.
      mesh=$("$PYTHON" -c 'import json,sys; print(json.load(open(sys.argv[1]))["mesh"])' "$OUT/$name.k$k.r$r.crestflow.json")
      if [ "$1" = "--torus" ]; then set -- "$mesh"; fi
      "$PYTHON" bench/spectral/peer_scipy.py "$mesh" --ks "$k" > "$OUT/$name.k$k.r$r.scipy.json"
      ours+=("$OUT/$name.k$k.r$r.crestflow.json"); theirs+=("$OUT/$name.k$k.r$r.scipy.json")
    done
  done
  merge "$OUT/$name.crestflow.json" "${ours[@]}"
  merge "$OUT/$name.scipy.json" "${theirs[@]}"
  "$PYTHON" bench/spectral/compare.py "$OUT/$name.crestflow.json" "$OUT/$name.scipy.json"
}
run_one bunny "$ROOT/../shared/data/meshes/organic/cgal_bunny00.off"
run_one elephant "$ROOT/../shared/data/meshes/organic/cgal_refined_elephant.off"
# ~115k vertices: a jittered torus (major 1, minor 0.35) from crestflow_geom::shapes.
run_one torus115k --torus 115000 "$OUT/torus115k.off"
