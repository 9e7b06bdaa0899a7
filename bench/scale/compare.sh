#!/usr/bin/env bash
# Thesis Fig. 5.1 / 5.3: remeshing constrained by nothing, by curvature-thresholded ridges, and
# by scale-conforming ridges (bench/scale/compare.ron), on a CAD and an organic mesh at 1 % and
# 2 % of the bounding-box diagonal. Needs the release binary (cargo build --release). Run from
# the repository root; prints the JSON log's reports as a Markdown table (Hausdorff relative to
# the diagonal, vertex count, min angle, share of angles < 30°, valence-6 share, curve edges).
set -euo pipefail

BIN=${BIN:-target/release/crestflow}
OUT=${OUT:-target/bench-scale/compare}
SCALES=${SCALES:-"0.01 0.02"}
EXTRA=${EXTRA:-}  # more --set overrides for compare.ron, e.g. EXTRA="--set ftol=0.25"
MESHES=${MESHES:-"../shared/data/meshes/cad/cgal_fandisk.off ../shared/data/meshes/organic/cgal_bunny00.off"}
mkdir -p "$OUT"
: > "$OUT/log.jsonl"
for m in $MESHES; do
    stem=$(basename "${m%.*}")
    for s in $SCALES; do
        dir=$(realpath "$OUT")/$stem-$s
        "$BIN" run bench/scale/compare.ron --log json --set "mesh=$(realpath "$m")" \
            --set "scale=$s" --set "out=$dir" $EXTRA 2>/dev/null \
            | python3 -c "import sys,json
for l in sys.stdin:
    e=json.loads(l); e['mesh']='$stem'; e['scale']=$s; print(json.dumps(e))" >> "$OUT/log.jsonl"
    done
done
python3 - "$OUT/log.jsonl" <<'PY'
import json, sys
rep = {}
for l in open(sys.argv[1]):
    e = json.loads(l)
    if "values" in e and "node" in e:
        rep.setdefault((e["mesh"], e["scale"]), {})[e["node"]] = e["values"]
print("| mesh | scale | constraint | curve edges | check violations | vertices | Hausdorff (rel) | min angle ° | angles < 30° | valence 6 |")
print("|---|---|---|---|---|---|---|---|---|---|")
for (mesh, s), r in sorted(rep.items()):
    for name, curves in [("none", None), ("thresholded", "check_thresholded"), ("conforming", "check")]:
        q = r.get("quality_" + name, {})
        c = r.get(curves, {}) if curves else {}
        ce = int(c.get("edges", 0)) if curves else 0
        cv = int(c["violations"]) if curves and "violations" in c else ""
        print(f"| {mesh} | {s} | {name} | {ce} | {cv} | {q.get('vertices', float('nan')):.0f} | "
              f"{q.get('hausdorff_rel', float('nan')):.5f} | {q.get('min_angle_deg', float('nan')):.2f} | "
              f"{100*q.get('frac_angles_lt_30', float('nan')):.2f} % | {100*q.get('valence6_share', float('nan')):.1f} % |")
PY
