#!/usr/bin/env python3
"""Compares the JSON of the crestflow eigenbasis benchmark with the scipy peer's.

Usage: compare.py CRESTFLOW.json SCIPY.json — prints, for each k: both times, the ratio
scipy / crestflow, the same ratio with the operator's assembly added on both sides (what a
pipeline from a mesh pays), the largest relative eigenvalue difference (over eigenvalues
above 1e-8 times the largest), and both quality figures.
"""
import json
import sys


def main():
    ours = json.load(open(sys.argv[1]))
    peer = json.load(open(sys.argv[2]))
    print("mesh %s  n=%d  threads=%s  build: crestflow %.3f s, libigl %.3f s" % (
        ours["mesh"], ours["n"], ours.get("threads"), ours["build_time"], peer["build_time"]))
    for key in sorted((k for k in ours if k.startswith("k") and k in peer), key=lambda s: int(s[1:])):
        a, b = ours[key], peer[key]
        va, vb = a["values"], b["values"]
        top = max(abs(x) for x in vb)
        rel = max(abs(x - y) / abs(y) for x, y in zip(va, vb) if abs(y) > 1e-8 * top)
        with_build = (b["time"] + peer["build_time"]) / (a["time"] + ours["build_time"])
        print("  %-5s crestflow %8.3f s  scipy %8.3f s  ratio %6.2fx  (with build %5.2fx)  "
              "max rel eig diff %.2e  residual %.1e / %.1e  M-orth %.1e / %.1e" % (
                  key, a["time"], b["time"], b["time"] / a["time"], with_build, rel,
                  a["max_rel_residual"], b["max_rel_residual"],
                  a["max_M_orthonormality_err"], b["max_M_orthonormality_err"]))


if __name__ == "__main__":
    main()
