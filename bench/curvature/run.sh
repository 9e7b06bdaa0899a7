#!/usr/bin/env bash
# Curvature speed against libigl on the same files in the same run, and accuracy on an
# irregular torus. Run from the repository root:
#
#   python3 -m venv ../venv-peers && ../venv-peers/bin/pip install numpy scipy libigl
#   PYTHON=../venv-peers/bin/python bench/curvature/run.sh
#
# Meshes: ../shared/data/meshes/organic/cgal_bunny00.off (37,706 vertices) and an irregular
# torus of ~115k vertices (R = 1, r = 0.35, (u, v) jitter 0.35, random diagonals) written by
# the Rust bench. Prints JSON lines, then a table of µs/vertex and ratios (libigl / ours).
set -euo pipefail

PYTHON=${PYTHON:-python3}
OUT=${OUT:-target/bench-curvature}
BUNNY=$(realpath ../shared/data/meshes/organic/cgal_bunny00.off)
TORUS_N=${TORUS_N:-115000}
ACC_N=${ACC_N:-80000}
mkdir -p "$OUT"
OUT=$(realpath "$OUT")  # cargo bench runs in the crate folder: pass absolute paths
TORUS="$OUT/torus_irregular_${TORUS_N}.off"
ACC_TORUS="$OUT/torus_irregular_${ACC_N}.off"

bench() { cargo bench -q -p crestflow-nodes-curvature --bench curvature -- "$@"; }

bench --make-torus "$TORUS" "$TORUS_N"
bench --make-torus "$ACC_TORUS" "$ACC_N"

: > "$OUT/results.jsonl"
bench "$BUNNY" "$TORUS" | tee -a "$OUT/results.jsonl"
bench --accuracy "$ACC_N" | tee -a "$OUT/results.jsonl"
for threads in 1 2; do
    OMP_NUM_THREADS=$threads IGL_NUM_THREADS=$threads taskset -c "0-$((threads - 1))" \
        "$PYTHON" bench/curvature/peer_igl.py "$BUNNY" "$TORUS" \
        | sed "s/^{/{\"threads\": $threads, /" | tee -a "$OUT/results.jsonl"
done
OMP_NUM_THREADS=1 IGL_NUM_THREADS=1 "$PYTHON" bench/curvature/peer_igl.py "$ACC_TORUS" --torus 1.0 0.35 \
    | sed 's/^{/{"threads": 1, "accuracy": "igl.principal_curvature", /' | tee -a "$OUT/results.jsonl"

"$PYTHON" - "$OUT/results.jsonl" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
speed = [r for r in rows if "us_per_vertex" in r and "accuracy" not in r]
igl = {(r["mesh"], r["threads"]): r["us_per_vertex"] for r in speed if r["method"].startswith("igl")}
print()
print("| mesh | V | method | threads | µs/vertex | libigl µs/vertex (same threads) | libigl / ours | libigl 1 thread / ours |")
print("|---|---|---|---|---|---|---|---|")
for r in speed:
    if r["method"].startswith("igl"):
        continue
    ref = igl.get((r["mesh"], r["threads"]))
    ref1 = igl.get((r["mesh"], 1))
    ratio = f"{ref / r['us_per_vertex']:.1f}x" if ref else "-"
    ratio1 = f"{ref1 / r['us_per_vertex']:.1f}x" if ref1 else "-"
    print(f"| {r['mesh'].split('/')[-1]} | {r['n_vertices']} | {r['method']} | {r['threads']} | "
          f"{r['us_per_vertex']:.3f} | {ref if ref else float('nan'):.3f} | {ratio} | {ratio1} |")
print()
for r in rows:
    if "accuracy" in r:
        print(f"accuracy on the irregular torus ({r['n_vertices']} V): {r['accuracy']}: "
              f"mean rel k_max error {100 * r['k_max_mean_rel']:.4f} %, k_min {100 * r['k_min_mean_rel']:.4f} %")
PY
