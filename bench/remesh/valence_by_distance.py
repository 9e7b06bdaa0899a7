#!/usr/bin/env python3
"""Where a feature-constrained remesh loses its valence-6 share: the share among interior
vertices by their distance, in edges, from the nearest vertex on the feature network.

  python bench/remesh/valence_by_distance.py OUTPUT.obj CURVES.obj

OUTPUT.obj is a remeshed mesh and CURVES.obj the network that constrained it, as the remesh
bench writes them with `--conforming --save-curves` (`….curves.obj` beside the output). An
output vertex is on the network when it lies on one of the network's segments (within 1e-9 of
the bounding-box diagonal); those are distance 0. Valences count edges as `peer.py` does:
interior vertices only (no boundary edge at the vertex). Prints a Markdown table, the
valences of the network vertices, and the share over all interior vertices.
"""
import sys
from collections import Counter

import numpy as np

from peer import edges_and_valences


def read_obj(path):
    vs, faces, lines = [], [], []
    for row in open(path):
        t = row.split()
        if not t:
            continue
        if t[0] == "v":
            vs.append([float(x) for x in t[1:4]])
        elif t[0] == "f":
            faces.append([int(x.split("/")[0]) - 1 for x in t[1:4]])
        elif t[0] == "l":
            lines.append([int(x) - 1 for x in t[1:]])
    return np.array(vs, float), np.array(faces, np.int64).reshape(-1, 3), lines


def on_segments(P, A, B, tol):
    """Per point of P, whether it lies within tol of one of the segments A[k]–B[k]."""
    hit = np.zeros(len(P), bool)
    for a, b in zip(A, B):
        d = b - a
        dd = float(d @ d)
        t = np.clip(((P - a) @ d) / dd, 0.0, 1.0) if dd > 0 else np.zeros(len(P))
        q = a + t[:, None] * d
        hit |= np.einsum("ij,ij->i", P - q, P - q) <= tol * tol
    return hit


def main(mesh_path, curves_path):
    V, F, _ = read_obj(mesh_path)
    C, _, L = read_obj(curves_path)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    segs = [(l[k], l[k + 1]) for l in L for k in range(len(l) - 1)]
    on = on_segments(V, C[[s[0] for s in segs]], C[[s[1] for s in segs]], 1e-9 * diag) \
        if segs else np.zeros(len(V), bool)

    uE, _, val, used, inner = edges_and_valences(F, len(V))

    nbrs = [[] for _ in range(len(V))]
    for a, b in uE:
        nbrs[a].append(b)
        nbrs[b].append(a)
    dist = np.full(len(V), -1)
    front = list(np.flatnonzero(on & used))
    dist[front] = 0
    while front:
        nxt = []
        for v in front:
            for u in nbrs[v]:
                if dist[u] < 0:
                    dist[u] = dist[v] + 1
                    nxt.append(u)
        front = nxt

    print("| edges from the network | interior vertices | valence 6 |")
    print("|---|---|---|")
    top = 5
    for k in range(top + 1):
        sel = inner & ((dist == k) if k < top else (dist >= top))
        if sel.any():
            label = str(k) if k < top else f"{top} or more"
            print(f"| {label} | {int(sel.sum())} | {(val[sel] == 6).mean():.3f} |")
    far = inner & (dist < 0)
    if far.any():
        print(f"| not connected to the network | {int(far.sum())} | {(val[far] == 6).mean():.3f} |")
    at = inner & (dist == 0)
    print()
    print("valences on the network:", dict(sorted(Counter(val[at].tolist()).items())))
    print(f"valence-6 share of all {int(inner.sum())} interior vertices: "
          f"{(val[inner] == 6).mean():.4f}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
