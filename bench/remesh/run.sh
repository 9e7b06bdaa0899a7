#!/usr/bin/env bash
# Isotropic remeshing against pymeshlab, gpytoolbox and CGAL on the same meshes in the same run,
# at 1 % and 2 % of the bounding-box diagonal (10 rounds, edges sharper than 30° kept), ours with
# default parameters, with feature_grading = $GRADING (default 0.3), and constrained by the
# scale-conforming subset of the sharp edges instead of all of them. Run from
# the repository root:
#
#   python3 -m venv ../venv-peers && ../venv-peers/bin/pip install numpy scipy pymeshlab gpytoolbox cgal
#   PYTHON=../venv-peers/bin/python bench/remesh/run.sh
#
# The default meshes are cgal_fandisk_large (CAD, 15.8k vertices), cgal_bunny00 (organic, 37.7k)
# and cgal_armadillo subdivided once at edge midpoints (104k vertices; written to $OUT by
# bench/remesh/subdivide.py).
#
# The Rust bench (release) remeshes and writes its outputs; bench/remesh/peer.py runs the peers
# and grades every output with the same code (min angle, valence-6 share, pymeshlab Hausdorff
# and a dense deterministic one, sharp edges kept). Prints the JSON lines, then a table with
# the time ratios.
# PEERS (default pymeshlab,gpytoolbox,cgal) picks the peers; PEERS="" grades ours only.
# REPAIR=1 loads our inputs with `repair: true` (non-manifold meshes; bench/remesh/corpus.sh).
# BOUNDARY_TOLERANCE=F sets remesh.isotropic's boundary_tolerance (default 0.25) in our runs.
# SPECIAL_LONG=1 adds the conforming method with scale.conform's special_long_edges on.
# bench/remesh/orientations.sh runs all this on six axis orders of each mesh.
set -euo pipefail

PYTHON=${PYTHON:-python3}
OUT=${OUT:-target/bench-remesh}
TARGETS=${TARGETS:-1,2}
mkdir -p "$OUT"
if [ -z "${MESHES:-}" ]; then
    [ -f "$OUT/armadillo_sub1.off" ] || "$PYTHON" bench/remesh/subdivide.py \
        ../shared/data/meshes/organic/cgal_armadillo.off "$OUT/armadillo_sub1.off"
    MESHES="../shared/data/meshes/cad/cgal_fandisk_large.off ../shared/data/meshes/organic/cgal_bunny00.off $OUT/armadillo_sub1.off"
fi
OUT=$(realpath "$OUT")  # cargo bench runs in the crate folder: pass absolute paths
ABS=()
for m in $MESHES; do ABS+=("$(realpath "$m")"); done
EXTRA=()
if [ "${REPAIR:-0}" != "0" ]; then EXTRA+=(--repair); fi
if [ -n "${BOUNDARY_TOLERANCE:-}" ]; then EXTRA+=(--boundary-tolerance "$BOUNDARY_TOLERANCE"); fi

cargo bench -q -p crestflow-nodes-remesh --bench remesh -- "$OUT" "${ABS[@]}" --targets "$TARGETS" ${EXTRA[@]+"${EXTRA[@]}"} \
    | tee "$OUT/ours.jsonl"
# The same with local refinement along curved features (method crestflow_graded); GRADING=0
# skips it.
GRADING=${GRADING:-0.3}
if [ "$GRADING" != "0" ]; then
    cargo bench -q -p crestflow-nodes-remesh --bench remesh -- "$OUT" "${ABS[@]}" --targets "$TARGETS" ${EXTRA[@]+"${EXTRA[@]}"} \
        --feature-grading "$GRADING" | tee -a "$OUT/ours.jsonl"
fi
# The scale-conforming features instead of every sharp edge (method crestflow_conforming):
# sharp edges pruned at the target, scale.conform at r_min = target, then the remeshing.
# CONFORMING=0 skips it.
if [ "${CONFORMING:-1}" != "0" ]; then
    cargo bench -q -p crestflow-nodes-remesh --bench remesh -- "$OUT" "${ABS[@]}" --targets "$TARGETS" ${EXTRA[@]+"${EXTRA[@]}"} \
        --conforming | tee -a "$OUT/ours.jsonl"
    # SPECIAL_LONG=1 adds the conforming method with special long edges kept
    # (crestflow_conforming_long).
    if [ "${SPECIAL_LONG:-0}" != "0" ]; then
        cargo bench -q -p crestflow-nodes-remesh --bench remesh -- "$OUT" "${ABS[@]}" --targets "$TARGETS" ${EXTRA[@]+"${EXTRA[@]}"} \
            --conforming --special-long-edges | tee -a "$OUT/ours.jsonl"
    fi
fi
# Relaxation towards Voronoi-cell centroids (`relaxation: Lloyd`) for the plain and the
# conforming method (methods crestflow_lloyd, crestflow_conforming_lloyd); LLOYD=0 skips it.
if [ "${LLOYD:-1}" != "0" ]; then
    cargo bench -q -p crestflow-nodes-remesh --bench remesh -- "$OUT" "${ABS[@]}" --targets "$TARGETS" ${EXTRA[@]+"${EXTRA[@]}"} \
        --lloyd | tee -a "$OUT/ours.jsonl"
    if [ "${CONFORMING:-1}" != "0" ]; then
        cargo bench -q -p crestflow-nodes-remesh --bench remesh -- "$OUT" "${ABS[@]}" --targets "$TARGETS" ${EXTRA[@]+"${EXTRA[@]}"} \
            --conforming --lloyd | tee -a "$OUT/ours.jsonl"
    fi
fi
: > "$OUT/results.jsonl"
PEERS=${PEERS-pymeshlab,gpytoolbox,cgal}
for m in "${ABS[@]}"; do
    "$PYTHON" bench/remesh/peer.py "$m" --targets "$TARGETS" --ours "$OUT/ours.jsonl" \
        --methods "$PEERS" | tee -a "$OUT/results.jsonl"
done

"$PYTHON" - "$OUT/results.jsonl" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
print()
print("| mesh | target | method | time s | fastest peer / this | min angle | min angle off features | angles < 30° | valence 6 | Hausdorff (diag) | dense Hausdorff | sharp edges kept / in | V out |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for key in sorted({(r["mesh"], r["target_pct"]) for r in rows}):
    group = [r for r in rows if (r["mesh"], r["target_pct"]) == key and "time_s" in r]
    peers = [r["time_s"] for r in group if not r["method"].startswith("crestflow")]
    fastest = min(peers) if peers else float("nan")
    for r in group:
        print("| %s | %g %% | %s | %.3f | %.1f× | %.2f° | %.2f° | %.4f | %.3f | %.5f | %.5f | %d / %d | %d |" % (
            r["mesh"], r["target_pct"], r["method"], r["time_s"], fastest / r["time_s"],
            r["min_angle_deg"], r.get("min_angle_nonfeature_deg") or float("nan"),
            r["frac_angles_lt_30"], r["valence6_share"] or 0,
            r["hausdorff_rel"], r.get("hausdorff_dense_rel", float("nan")), r["sharp_edges_kept"], r["sharp_edges_in"], r["n_vertices"]))
    for r in rows:
        if (r["mesh"], r["target_pct"]) == key and "error" in r:
            print("| %s | %g %% | %s | failed: %s |" % (r["mesh"], r["target_pct"], r["method"], r["error"]))
# What keeping every sharp edge allows: a triangle corner lies in each sector between two
# sharp edges that follow each other around a vertex.
print()
for mesh in sorted({r["mesh"] for r in rows}):
    s = next((r.get("input_sharp_sector_min_deg") for r in rows if r["mesh"] == mesh), None)
    print("%s: narrowest sector between sharp edges of the input: %s (the largest min angle a mesh"
          " keeping all of them can have)" % (mesh, "none" if s is None else "%.2f°" % s))
PY
