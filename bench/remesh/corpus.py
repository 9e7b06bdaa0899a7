#!/usr/bin/env python3
"""Summary of a corpus run (bench/remesh/corpus.sh): per method and target, over the meshes,
how many rows reach each goal of the remeshing benchmark (min angle ≥ 30°, valence-6 share ≥
80 %, Hausdorff distance at most the best peer's when peers ran), the medians of the graded
figures, and the rows below 30° with their min angles.

  python bench/remesh/corpus.py RESULTS.jsonl
"""
import json
import statistics
import sys
from collections import defaultdict


def main(path):
    rows = [json.loads(l) for l in open(path) if l.strip()]
    rows = [r for r in rows if "time_s" in r]
    best_peer = {}
    for r in rows:
        if not r["method"].startswith("crestflow"):
            key = (r["mesh"], r["target_pct"])
            best_peer[key] = min(best_peer.get(key, float("inf")), r["hausdorff_rel"])
    groups = defaultdict(list)
    for r in rows:
        groups[(r["method"], r["target_pct"])].append(r)
    print("| method | target | meshes | ≥ 30° | valence 6 ≥ 80 % | Hausdorff ≤ best peer's | "
          "median min angle | median valence 6 | median Hausdorff | total time s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for (method, pct), g in sorted(groups.items()):
        ang = sum(r["min_angle_deg"] >= 30.0 for r in g)
        val = sum((r["valence6_share"] or 0) >= 0.8 for r in g)
        with_peer = [r for r in g if (r["mesh"], pct) in best_peer]
        hd = sum(r["hausdorff_rel"] <= best_peer[(r["mesh"], pct)] for r in with_peer)
        print("| %s | %g %% | %d | %d | %d | %s | %.2f° | %.3f | %.5f | %.2f |" % (
            method, pct, len(g), ang, val, "%d / %d" % (hd, len(with_peer)) if with_peer else "–",
            statistics.median(r["min_angle_deg"] for r in g),
            statistics.median(r["valence6_share"] or 0 for r in g),
            statistics.median(r["hausdorff_rel"] for r in g),
            sum(r["time_s"] for r in g)))
    print()
    for (method, pct), g in sorted(groups.items()):
        low = sorted((r["min_angle_deg"], r["mesh"]) for r in g if r["min_angle_deg"] < 30.0)
        if method.startswith("crestflow") and low:
            print("%s at %g %%, below 30°: %s" % (
                method, pct, ", ".join("%s %.1f°" % (m, a) for a, m in low)))


if __name__ == "__main__":
    main(sys.argv[1])
