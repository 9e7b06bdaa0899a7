#!/usr/bin/env bash
# scale.conform on CAD and organic meshes at three scales (0.5 %, 1 %, 2 % of the bounding-box
# diagonal): input vs kept edges, the exact selection's objective against the greedy baseline
# (heaviest edge first, kept if it conflicts with nothing kept) on the same first problem,
# scale.check on every output, and run times (release, median of 3). Run from the repository
# root:
#
#   bench/scale/run.sh
#   MESHES="path/a.off path/b.off" SCALES=1,2 bench/scale/run.sh
#   SOLVERS="microlp highs" bench/scale/run.sh   # both solvers, in one run
#
# HiGHS is built only with the `highs` feature (cmake, libclang and a C++ compiler: on Debian
# `apt-get install cmake libclang-dev g++`).
# Prints one JSON line per mesh and scale, then a Markdown table.
set -euo pipefail

OUT=${OUT:-target/bench-scale}
SCALES=${SCALES:-0.5,1,2}
MESHES=${MESHES:-"../shared/data/meshes/cad/cgal_fandisk.off ../shared/data/meshes/cad/cgal_blade.off ../shared/data/meshes/cad/cgal_anchor_dense.off ../shared/data/meshes/organic/cgal_bunny00.off"}
mkdir -p "$OUT"
ABS=()
for m in $MESHES; do ABS+=("$(realpath "$m")"); done

SOLVERS=${SOLVERS:-microlp}
: > "$OUT/results.jsonl"
for solver in $SOLVERS; do
    case "$solver" in
        microlp) cargo bench -q -p crestflow-nodes-scale --bench scale -- "${ABS[@]}" --scales "$SCALES" ;;
        highs) cargo bench -q -p crestflow-nodes-scale --features highs --bench scale -- "${ABS[@]}" --scales "$SCALES" --highs ;;
        *) echo "unknown solver $solver (microlp or highs)" >&2; exit 2 ;;
    esac | tee -a "$OUT/results.jsonl"
done

python3 - "$OUT/results.jsonl" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.startswith("{")]
print()
print("| mesh | solver | scale % | input edges | input violations | resampled | conflicts (e/v) | components (largest) | kept ILP | kept greedy | objective ILP | objective greedy | on components ILP / greedy | output edges | check violations (ILP, greedy) | iterations | repaired | unproven (out of time) | conform s | greedy s |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for r in rows:
    print(f"| {r['mesh']} | {r['solver']} | {r['scale_pct']} | {r['input_edges']} | {r['input_violations']} | {r['resampled_edges']} | "
          f"{r['conflicts']}/{r['vertex_conflicts']} | {r['components']} ({r['largest_component']}) | {r['kept_ilp']} | {r['kept_greedy']} | "
          f"{r['objective_ilp']:.1f} | {r['objective_greedy']:.1f} | "
          f"{r['objective_components_ilp']:.1f} / {r['objective_components_greedy']:.1f} | "
          f"{r['output_edges']} | {r['violations']}, {r['violations_greedy']} | "
          f"{r['iterations']} | {r['repaired']} | {r['unproven']} ({r.get('out_of_time', 0)}) | {r['conform_s']:.3f} | {r['conform_greedy_s']:.3f} |")
PY
