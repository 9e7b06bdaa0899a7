#!/usr/bin/env bash
# Smoothing speed against pymeshlab and libigl on the same noisy files in the same run.
# Run from the repository root:
#
#   python3 -m venv ../venv-peers && ../venv-peers/bin/pip install numpy scipy libigl pymeshlab
#   PYTHON=../venv-peers/bin/python bench/smooth/run.sh
#
# Meshes: ../shared/data/meshes/organic/cgal_bunny00.off (37,706 vertices) and an irregular
# torus of ~115k vertices written by the Rust bench, both with 0.1 % Gaussian noise added by
# peer.py (the Rust bench reads the noisy files it writes). Prints JSON lines, then seconds per
# iteration and the ratios peer / ours (peers single-threaded; ours at 1 and 2 threads).
set -euo pipefail

PYTHON=${PYTHON:-python3}
OUT=${OUT:-target/bench-smooth}
BUNNY=$(realpath ../shared/data/meshes/organic/cgal_bunny00.off)
TORUS_N=${TORUS_N:-115000}
mkdir -p "$OUT"
OUT=$(realpath "$OUT")  # cargo bench runs in the crate folder: pass absolute paths
TORUS="$OUT/torus_irregular_${TORUS_N}.off"

bench() { cargo bench -q -p crestflow-nodes-smooth --bench smooth -- "$@"; }

bench --make-torus "$TORUS" "$TORUS_N"
: > "$OUT/results.jsonl"
OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 "$PYTHON" bench/smooth/peer.py "$OUT" "$BUNNY" "$TORUS" \
    | tee -a "$OUT/results.jsonl"
bench "$OUT/cgal_bunny00_noisy.off" "$OUT/torus_irregular_${TORUS_N}_noisy.off" \
    | tee -a "$OUT/results.jsonl"

"$PYTHON" - "$OUT/results.jsonl" <<'PY'
import json, sys
# libigl's OFF reader prints diagnostics on stdout: keep the JSON lines only.
rows = [json.loads(l) for l in open(sys.argv[1]) if l.startswith("{")]
peer = {(r["mesh"], r["method"]): r["s_per_iter"] for r in rows if r["impl"] == "peer"}
pairs = {"uniform_explicit": "pymeshlab_uniform_10", "cotan_explicit": "pymeshlab_cotan_10",
         "cotan_implicit_1": "igl_implicit_1", "cotan_implicit_10": "igl_implicit_1",
         "cotan_implicit_frozen_10": "igl_implicit_1"}
print()
print("| mesh | V | ours | threads | ours s/iter | peer | peer s/iter | peer / ours |")
print("|---|---|---|---|---|---|---|---|")
for r in rows:
    if r["impl"] != "crestflow":
        continue
    p = pairs[r["method"]]
    ref = peer.get((r["mesh"], p))
    ratio = f"{ref / r['s_per_iter']:.2f}x" if ref else "-"
    print(f"| {r['mesh']} | {r['n_vertices']} | {r['method']} | {r['threads']} | "
          f"{r['s_per_iter']:.3e} | {p} | {ref if ref else float('nan'):.3e} | {ratio} |")
PY
