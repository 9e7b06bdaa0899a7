#!/usr/bin/env python3
"""The remeshing benchmark's figures over the six axis orders of each input.

  python bench/remesh/orientations.py write MESH... --out DIR
  python bench/remesh/orientations.py summary RESULTS.jsonl

`write` saves, for each mesh, six copies whose coordinates are the six permutations of
(x, y, z) (the odd ones with their faces turned over, so that every copy keeps its outward
side): `DIR/<stem>_xyz.off`, `<stem>_xzy.off`, ... They are the same surface, congruent and
of the same diagonal, so every graded figure of an exact remesher would be the same for all
six. Ours and the peers visit vertices and edges in an order that depends on the axes (a
spatial renumbering, a sweep order), so the six runs show how much a figure of one run owes
to the order the work happened to take.

`summary` reads the JSON lines of `bench/remesh/peer.py` run on those copies and prints, per
mesh, target and method, the smallest, median and largest of the min angle, the valence-6
share, the Hausdorff distance, the time and its ratio to the fastest peer over the
orientations, and in how many of them each goal of the benchmark holds (min angle ≥ 30°,
valence 6 ≥ 80 %, Hausdorff distance at most the best peer's in the same orientation). `bench/remesh/orientations.sh` runs
both steps around the benches.
"""
import argparse
import itertools
import json
import math
import os
import statistics
import sys
from collections import defaultdict

import numpy as np

AXES = "xyz"


def read_off_or_obj(path):
    import pymeshlab
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(path)
    m = ms.current_mesh()
    return np.asarray(m.vertex_matrix(), float), np.asarray(m.face_matrix(), np.int64)


def write(meshes, out):
    os.makedirs(out, exist_ok=True)
    for path in meshes:
        V, F = read_off_or_obj(path)
        stem = os.path.splitext(os.path.basename(path))[0]
        for perm in itertools.permutations(range(3)):
            # An odd permutation mirrors the shape: turn the faces over to keep the outside.
            odd = np.linalg.det(np.eye(3)[list(perm)]) < 0
            W = V[:, perm]
            G = F[:, [0, 2, 1]] if odd else F
            name = "".join(AXES[k] for k in perm)
            dst = os.path.join(out, f"{stem}_{name}.off")
            with open(dst, "w") as f:
                f.write(f"OFF\n{len(W)} {len(G)} 0\n")
                np.savetxt(f, W, fmt="%.17g")
                np.savetxt(f, np.c_[np.full(len(G), 3), G], fmt="%d")
            print(dst)


def summary(results):
    rows = [json.loads(line) for line in open(results) if line.strip()]
    groups = defaultdict(list)
    for r in rows:
        if "time_s" not in r:
            continue
        base = r["mesh"].rsplit("_", 1)[0]
        groups[(base, r["target_pct"], r["method"])].append(r)

    def spread(vals, fmt):
        vals = sorted(vals)
        return "%s / %s / %s" % (fmt % vals[0], fmt % statistics.median(vals), fmt % vals[-1])

    # Per orientation: the fastest peer's time and the best peer's Hausdorff distance.
    fastest, best = {}, {}
    for r in rows:
        if "time_s" in r and not r["method"].startswith("crestflow"):
            key = (r["mesh"], r["target_pct"])
            fastest[key] = min(fastest.get(key, math.inf), r["time_s"])
            best[key] = min(best.get(key, math.inf), r["hausdorff_rel"])

    print("| mesh | target | method | orientations | min angle ° (min / median / max) | "
          "≥ 30° | valence 6 | ≥ 80 % | Hausdorff (diag) | ≤ best peer's | time s | "
          "fastest peer / this |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for (mesh, pct, method), g in sorted(groups.items()):
        angles = [r["min_angle_deg"] for r in g]
        val = [r["valence6_share"] or 0.0 for r in g]
        haus = [r["hausdorff_rel"] for r in g]
        at_best = sum(r["hausdorff_rel"] <= best.get((r["mesh"], pct), math.inf) for r in g)
        times = [r["time_s"] for r in g]
        ratios = [fastest[(r["mesh"], pct)] / r["time_s"] for r in g
                  if (r["mesh"], pct) in fastest and r["time_s"] > 0]
        print("| %s | %g %% | %s | %d | %s | %d | %s | %d | %s | %d | %s | %s |" % (
            mesh, pct, method, len(g), spread(angles, "%.2f"), sum(a >= 30.0 for a in angles),
            spread(val, "%.3f"), sum(v >= 0.8 for v in val), spread(haus, "%.5f"), at_best,
            spread(times, "%.3f"), spread(ratios, "%.1f×") if ratios else "–"))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("write")
    w.add_argument("meshes", nargs="+")
    w.add_argument("--out", required=True)
    s = sub.add_parser("summary")
    s.add_argument("results")
    a = ap.parse_args()
    if a.cmd == "write":
        write(a.meshes, a.out)
    else:
        summary(a.results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
