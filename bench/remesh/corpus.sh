#!/usr/bin/env bash
# The remeshing benchmark on every mesh of ../shared/data/meshes (cad, organic, scans): how
# the remesher does on inputs it was not tuned on. Run from the repository root:
#
#   PYTHON=../venv-peers/bin/python bench/remesh/corpus.sh
#
# Ours with default parameters and scale conforming (GRADING and LLOYD off), inputs loaded with
# `repair: true` (three of the meshes are not manifold), at 1 % and 2 %; PEERS="" by default
# (set PEERS=pymeshlab,gpytoolbox,cgal for the peers too; they take most of the time). Outputs and
# results.jsonl go to $OUT/corpus; prints run.sh's table, then bench/remesh/corpus.py's
# summary: per method, how many of the mesh × target rows reach each goal.
set -euo pipefail

PYTHON=${PYTHON:-python3}
OUT=${OUT:-target/bench-remesh}
DATA=../shared/data/meshes
MESHES=$(ls "$DATA"/cad/* "$DATA"/organic/* "$DATA"/scans/* | grep -v -i '\.md$' | tr '\n' ' ')
mkdir -p "$OUT/corpus"
MESHES="$MESHES" OUT="$OUT/corpus" PEERS=${PEERS-} GRADING=0 LLOYD=0 REPAIR=1 PYTHON="$PYTHON" \
    bash bench/remesh/run.sh
echo
"$PYTHON" bench/remesh/corpus.py "$OUT/corpus/results.jsonl"
