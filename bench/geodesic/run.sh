#!/usr/bin/env bash
# Heat-method geodesics against potpourri3d on the same meshes in the same run.
# Run from the repository root: bench/geodesic/run.sh
# Needs python3 with numpy, scipy, potpourri3d (PYTHON=... to choose the interpreter).
set -euo pipefail
PYTHON="${PYTHON:-python3}"
# Repeats per timing on both sides (the steady one-source figure is the median of this many
# back-to-back calls after fifty): this host's call times spread by 2-3x.
REPEATS="${REPEATS:-15}"
ROOT="$PWD"
OUT="$ROOT/target/bench-geodesic"
mkdir -p "$OUT"
cargo bench -p crestflow-nodes-geodesic --bench heat --no-run
ratio() { # name, crestflow json, peer json
  "$PYTHON" - "$@" <<'PY'
import json, sys
name, a, b = sys.argv[1], json.load(open(sys.argv[2])), json.load(open(sys.argv[3]))
print("%s  n=%d  threads=%s" % (name, a["n"], a["threads"]))
for k in ("precompute", "solve_one", "solve_one_cold"):
    print("  %-26s crestflow %9.4f s  potpourri3d %9.4f s  ratio %5.2fx" % (k, a[k], b[k], b[k] / a[k]))
print("  %-26s crestflow %9.4f s  (potpourri3d %9.4f s one at a time: %5.2fx)" % (
    "solve_batched_per_source", a["solve_batched_per_source"], b["solve_one"],
    b["solve_one"] / a["solve_batched_per_source"]))
if a["error"] and b["error"]:
    for k in ("mean_rel_err", "mean_abs_err_rel", "max_abs_err_rel"):
        print("  %-26s crestflow %.4e  potpourri3d %.4e" % (k, a["error"][k], b["error"][k]))
PY
}
run_one() { # name, sphere flag, then the crestflow bench arguments
  local name="$1" sphere="$2"; shift 2
  cargo bench -q -p crestflow-nodes-geodesic --bench heat -- "$@" --repeats "$REPEATS" > "$OUT/$name.crestflow.json"
  local mesh src
  mesh=$("$PYTHON" -c 'import json,sys; print(json.load(open(sys.argv[1]))["mesh"])' "$OUT/$name.crestflow.json")
  src=$("$PYTHON" -c 'import json,sys; print(json.load(open(sys.argv[1]))["source"])' "$OUT/$name.crestflow.json")
  "$PYTHON" bench/geodesic/peer.py "$mesh" "$src" $sphere --repeats "$REPEATS" > "$OUT/$name.pp3d.json"
  ratio "$name" "$OUT/$name.crestflow.json" "$OUT/$name.pp3d.json"
}
run_one bunny "" "$ROOT/../shared/data/meshes/organic/cgal_bunny00.off"
# Unit icosphere, level 6 (40962 vertices), from crestflow_geom::shapes::sphere.
run_one sphere --sphere --sphere 6 "$OUT/sphere6.off"
# GICS of all ridge/ravine curves of the armadillo (26k vertices) at 1 and 2 threads.
cargo bench -q -p crestflow-nodes-descriptors --bench gics -- "$ROOT/../shared/data/meshes/organic/cgal_armadillo.off"
