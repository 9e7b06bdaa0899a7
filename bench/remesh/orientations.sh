#!/usr/bin/env bash
# The remeshing benchmark on the six axis orders of each mesh (bench/remesh/orientations.py):
# how much of a figure is the order the work took. Run from the repository root:
#
#   PYTHON=../venv-peers/bin/python bench/remesh/orientations.sh
#
# Same meshes and environment variables as bench/remesh/run.sh (MESHES, TARGETS, GRADING,
# CONFORMING, LLOYD, PEERS; GRADING and LLOYD default to 0 here, PEERS to all three). The
# copies and outputs go to $OUT/orientations; prints run.sh's table, then one row per mesh,
# target and method with the spread over the six orientations.
set -euo pipefail

PYTHON=${PYTHON:-python3}
OUT=${OUT:-target/bench-remesh}
mkdir -p "$OUT"
if [ -z "${MESHES:-}" ]; then
    [ -f "$OUT/armadillo_sub1.off" ] || "$PYTHON" bench/remesh/subdivide.py \
        ../shared/data/meshes/organic/cgal_armadillo.off "$OUT/armadillo_sub1.off"
    MESHES="../shared/data/meshes/cad/cgal_fandisk_large.off ../shared/data/meshes/organic/cgal_bunny00.off $OUT/armadillo_sub1.off"
fi
DIR="$OUT/orientations"
# shellcheck disable=SC2086
COPIES=$("$PYTHON" bench/remesh/orientations.py write $MESHES --out "$DIR" | tr '\n' ' ')
MESHES="$COPIES" OUT="$DIR" GRADING=${GRADING:-0} LLOYD=${LLOYD:-0} PYTHON="$PYTHON" \
    bash bench/remesh/run.sh
echo
"$PYTHON" bench/remesh/orientations.py summary "$DIR/results.jsonl"
