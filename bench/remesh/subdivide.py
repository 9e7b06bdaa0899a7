#!/usr/bin/env python3
"""Midpoint subdivision (each triangle into four, new vertices at edge midpoints): the same
surface with four times the vertices, for a large-mesh remeshing benchmark.

  python bench/remesh/subdivide.py IN OUT.off [--times 1]

cgal_armadillo (26,002 vertices) once -> 104,006 vertices.
"""
import argparse

import numpy as np


def read_off(path):
    toks = open(path).read().split()
    assert toks[0] == "OFF"
    nv, nf = int(toks[1]), int(toks[2])
    V = np.array(toks[4:4 + 3 * nv], dtype=float).reshape(nv, 3)
    R = np.array(toks[4 + 3 * nv:4 + 3 * nv + 4 * nf], dtype=np.int64).reshape(nf, 4)
    assert (R[:, 0] == 3).all()
    return V, R[:, 1:].copy()


def subdivide(V, F):
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), 1)
    uE, inv = np.unique(E, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    m = len(V) + inv.reshape(3, -1).T  # midpoint index of edges (01, 12, 20) per face
    V2 = np.concatenate([V, 0.5 * (V[uE[:, 0]] + V[uE[:, 1]])])
    a, b, c = F[:, 0], F[:, 1], F[:, 2]
    ab, bc, ca = m[:, 0], m[:, 1], m[:, 2]
    F2 = np.concatenate([np.stack([a, ab, ca], 1), np.stack([ab, b, bc], 1),
                         np.stack([ca, bc, c], 1), np.stack([ab, bc, ca], 1)])
    return V2, F2


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("inp")
    ap.add_argument("out")
    ap.add_argument("--times", type=int, default=1)
    a = ap.parse_args()
    V, F = read_off(a.inp)
    for _ in range(a.times):
        V, F = subdivide(V, F)
    with open(a.out, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(V), len(F)))
        np.savetxt(f, V, fmt="%.17g")
        np.savetxt(f, np.concatenate([np.full((len(F), 1), 3), F], 1), fmt="%d")
    print("%s: %d vertices, %d faces" % (a.out, len(V), len(F)))


if __name__ == "__main__":
    main()
