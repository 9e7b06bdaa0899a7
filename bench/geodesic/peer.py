#!/usr/bin/env python3
"""potpourri3d's heat method on the same mesh and source as the crestflow heat benchmark.

Usage: peer.py MESH SOURCE [--repeats 5] [--sphere] — prints one JSON object: precompute
(MeshHeatMethodDistanceSolver construction, t_coef=1), solve_one (one source, steady state of
back-to-back calls) and solve_one_cold (the first three calls after the construction), and with
--sphere the error against the great-circle distance on the unit sphere (same figures as the
crestflow benchmark).
"""
import argparse
import json
import time

import numpy as np
import potpourri3d as pp3d


def read_off(path):
    with open(path) as f:
        tokens = [t for line in f for t in line.split("#")[0].split()]
    assert tokens[0] == "OFF", "not an OFF file"
    nv, nf = int(tokens[1]), int(tokens[2])
    k = 4
    V = np.array(tokens[k:k + 3 * nv], dtype=float).reshape(nv, 3)
    k += 3 * nv
    F = []
    for _ in range(nf):
        c = int(tokens[k])
        F.append([int(x) for x in tokens[k + 1:k + 1 + c]])
        k += 1 + c
    return V, np.array(F, dtype=np.int64)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("mesh")
    ap.add_argument("source", type=int)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--sphere", action="store_true")
    args = ap.parse_args()
    V, F = read_off(args.mesh)
    pre, one = [], []
    for _ in range(args.repeats):
        t = time.perf_counter()
        solver = pp3d.MeshHeatMethodDistanceSolver(V, F, t_coef=1.0)
        pre.append(time.perf_counter() - t)
    # As in the crestflow bench: the first three calls after the construction, then the
    # steady state of back-to-back calls after fifty more.
    cold = []
    for k in range(53 + max(args.repeats, 3)):
        t = time.perf_counter()
        d = solver.compute_distance(args.source)
        dt = time.perf_counter() - t
        if k < 3:
            cold.append(dt)
        elif k >= 53:
            one.append(dt)
    err = None
    if args.sphere:
        p0 = V[args.source] / np.linalg.norm(V[args.source])
        ref = np.arccos(np.clip(V @ p0 / np.linalg.norm(V, axis=1), -1, 1))
        m = ref.max()
        e = np.abs(d - ref)
        sel = ref > 0.01 * m
        err = {"mean_abs_err_rel": float(e.mean() / m), "max_abs_err_rel": float(e.max() / m),
               "mean_rel_err": float((e[sel] / ref[sel]).mean())}
    print(json.dumps({"mesh": args.mesh, "n": len(V), "precompute": float(np.median(pre)),
                      "solve_one": float(np.median(one)), "solve_one_cold": float(np.median(cold)),
                      "error": err}))


if __name__ == "__main__":
    main()
