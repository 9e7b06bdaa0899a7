#!/usr/bin/env python3
"""scipy peer of spectral.eigenbasis.

Reads a mesh, builds the cotangent Laplacian (libigl cotmatrix, negated to be positive
semi-definite) and the lumped mass matrix (libigl massmatrix, mixed Voronoi: the same
discretisation as spectral.laplacian's defaults), then times
scipy.sparse.linalg.eigsh(L, k, M, sigma=-1e-8, which='LM') (shift-invert; the SuperLU
factorisation of L - sigma M is inside the timing), median of --repeats runs, for each k.
Prints one JSON object with the times, the eigenvalues and the quality figures
(relative residual max_i ||L phi - lambda M phi|| / ((||L||_1 + |lambda| ||M||_1) ||phi||)
and max |Phi^T M Phi - I|).

Usage: peer_scipy.py MESH [--ks 20,60,120] [--repeats 3]
"""
import argparse
import json
import time

import numpy as np


def read_off(path):
    """Plain OFF reader (triangles only; comments after '#')."""
    toks = []
    with open(path) as f:
        for line in f:
            toks.extend(line.split("#", 1)[0].split())
    if toks[0] != "OFF":
        raise ValueError("%s: not an OFF file" % path)
    nv, nf = int(toks[1]), int(toks[2])
    V = np.array(toks[4:4 + 3 * nv], dtype=np.float64).reshape(nv, 3)
    F, i = [], 4 + 3 * nv
    for _ in range(nf):
        c = int(toks[i])
        if c != 3:
            raise ValueError("%s: face with %d corners" % (path, c))
        F.append([int(t) for t in toks[i + 1:i + 4]])
        i += 1 + c
    return V, np.array(F, dtype=np.int64)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("mesh")
    ap.add_argument("--ks", default="20,60,120")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sigma", type=float, default=-1e-8)
    args = ap.parse_args()

    import igl
    from scipy.sparse.linalg import eigsh
    from scipy.sparse.linalg import norm as spnorm

    if args.mesh.lower().endswith(".off"):
        V, F = read_off(args.mesh)
    else:
        V, F = igl.read_triangle_mesh(args.mesh)
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    t0 = time.perf_counter()
    L = (-igl.cotmatrix(V, F)).tocsc()
    M = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_VORONOI).tocsc()
    build = time.perf_counter() - t0
    v0 = np.random.default_rng(0).standard_normal(V.shape[0])
    out = {"mesh": args.mesh, "n": int(V.shape[0]), "faces": int(F.shape[0]),
           "build_time": build, "sigma": args.sigma}
    for k in [int(x) for x in args.ks.split(",")]:
        times = []
        for _ in range(args.repeats):
            t = time.perf_counter()
            lam, phi = eigsh(L, k=k, M=M, sigma=args.sigma, which="LM", v0=v0)
            times.append(time.perf_counter() - t)
        o = np.argsort(lam)
        lam, phi = lam[o], phi[:, o]
        Lp, Mp = L @ phi, M @ phi
        res = np.linalg.norm(Lp - Mp * lam[None, :], axis=0) / (
            (spnorm(L, 1) + np.abs(lam) * spnorm(M, 1)) * np.linalg.norm(phi, axis=0) + 1e-300)
        G = phi.T @ Mp
        out["k%d" % k] = {"time": float(np.median(times)), "times": times,
                          "max_rel_residual": float(res.max()),
                          "max_M_orthonormality_err": float(np.abs(G - np.eye(k)).max()),
                          "values": lam.tolist()}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
