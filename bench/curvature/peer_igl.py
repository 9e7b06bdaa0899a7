#!/usr/bin/env python3
"""Times libigl's principal_curvature (quadric fitting, its default radius 5, k-ring) on
OFF meshes and prints one JSON line per mesh: the median of 3 runs in µs per vertex, at the
thread count the environment allows (run.sh sets OMP_NUM_THREADS / the affinity).

With --torus R r the mesh is taken to be a torus around the z axis (major radius R, tube
radius r) and the mean relative errors of k_max and k_min against the closed form
(k_max = 1/r, k_min = cos v / (R + r cos v)) are added.

Usage: peer_igl.py MESH.off [MESH.off ...] [--torus R r] [--radius 5]
"""
import argparse
import json
import statistics
import sys
import time

import numpy as np


def read_off(path):
    with open(path) as f:
        tokens = []
        for line in f:
            line = line.split("#", 1)[0]
            tokens.extend(line.split())
    if tokens and tokens[0].endswith("OFF"):
        tokens = tokens[1:]
    nv, nf = int(tokens[0]), int(tokens[1])
    pos = 3
    V = np.array(tokens[pos:pos + 3 * nv], dtype=np.float64).reshape(nv, 3)
    pos += 3 * nv
    faces = []
    for _ in range(nf):
        k = int(tokens[pos])
        idx = [int(t) for t in tokens[pos + 1:pos + 1 + k]]
        pos += 1 + k
        for j in range(1, k - 1):
            faces.append((idx[0], idx[j], idx[j + 1]))
    return V, np.array(faces, dtype=np.int64)


def torus_truth(V, R, r):
    rho = np.hypot(V[:, 0], V[:, 1])
    cos_v = (rho - R) / r
    return np.full(len(V), 1.0 / r), cos_v / (R + r * cos_v)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--torus", nargs=2, type=float, default=None, metavar=("R", "r"))
    ap.add_argument("--radius", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()

    import igl

    for path in args.meshes:
        V, F = read_off(path)
        times = []
        out = None
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            out = igl.principal_curvature(V, F, args.radius, True)
            times.append(time.perf_counter() - t0)
        med = statistics.median(times)
        rec = {"mesh": path, "n_vertices": int(len(V)), "method": "igl.principal_curvature",
               "radius": args.radius, "us_per_vertex": med * 1e6 / len(V),
               "runs_s": [round(t, 4) for t in times]}
        if args.torus is not None:
            _, _, k1, k2 = out[:4]
            kmax = np.maximum(k1, k2)
            kmin = np.minimum(k1, k2)
            t_max, t_min = torus_truth(V, *args.torus)
            ok = np.abs(t_min) > 1e-6
            rec["k_max_mean_rel"] = float(np.mean(np.abs(kmax - t_max) / np.abs(t_max)))
            rec["k_min_mean_rel"] = float(np.mean(np.abs(kmin[ok] - t_min[ok]) / np.abs(t_min[ok])))
        print(json.dumps(rec))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
