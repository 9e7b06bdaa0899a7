#!/usr/bin/env python3
"""Smoothing speed of the peers, in seconds per iteration (median of 3 runs), one JSON line
per (mesh, method).

    peer.py OUT_DIR MESH...

For every MESH: Gaussian noise of 0.1 % of the bbox diagonal per coordinate (numpy
default_rng(0)) is added and the noisy mesh written to OUT_DIR/<stem>_noisy.off, so that the
Rust benchmark smooths the very same file. Then, on the noisy mesh:

  pymeshlab_uniform_10  apply_coord_laplacian_smoothing(stepsmoothnum=10, boundary=True,
                        cotangentweight=False)
  pymeshlab_cotan_10    the same with cotangentweight=True
  igl_implicit_1        one implicit cotangent step (M + t L) U = M V, t = h^2 (h = mean edge
                        length): igl.cotmatrix, igl.massmatrix(BARYCENTRIC), scipy splu, solve;
                        the time covers all of it (libigl's sign convention: cotmatrix is
                        negative semi-definite, hence M - t C).
"""
import json
import os
import statistics
import sys
import time

import numpy as np


def bench(fn, setup=None, repeats=3):
    times = []
    for _ in range(repeats):
        arg = setup() if setup else None
        t0 = time.perf_counter()
        fn(arg) if setup else fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def write_off(path, V, F):
    with open(path, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(V), len(F)))
        for p in V:
            f.write("%.17e %.17e %.17e\n" % tuple(p))
        for t in F:
            f.write("3 %d %d %d\n" % tuple(t))


def main():
    import igl
    import pymeshlab
    from scipy.sparse.linalg import splu

    out_dir = sys.argv[1]
    os.makedirs(out_dir, exist_ok=True)
    for path in sys.argv[2:]:
        V, F = igl.read_triangle_mesh(path)
        V = np.ascontiguousarray(V, dtype=np.float64)
        F = np.ascontiguousarray(F, dtype=np.int64)
        diag = float(np.linalg.norm(V.max(0) - V.min(0)))
        Vn = V + np.random.default_rng(0).normal(0.0, 1e-3 * diag, V.shape)
        stem = os.path.splitext(os.path.basename(path))[0]
        noisy = os.path.join(out_dir, stem + "_noisy.off")
        write_off(noisy, Vn, F)

        def emit(method, iterations, secs):
            print(json.dumps({"impl": "peer", "mesh": os.path.basename(noisy),
                              "n_vertices": int(len(Vn)), "method": method, "threads": 1,
                              "iterations": iterations, "s_per_iter": secs / iterations}),
                  flush=True)

        def setup():
            ms = pymeshlab.MeshSet()
            ms.add_mesh(pymeshlab.Mesh(vertex_matrix=Vn, face_matrix=F.astype(np.int32)))
            return ms

        for name, cot in [("pymeshlab_uniform_10", False), ("pymeshlab_cotan_10", True)]:
            secs = bench(lambda ms, cot=cot: ms.apply_coord_laplacian_smoothing(
                stepsmoothnum=10, boundary=True, cotangentweight=cot), setup=setup)
            emit(name, 10, secs)

        E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
        h = float(np.linalg.norm(Vn[E[:, 0]] - Vn[E[:, 1]], axis=1).mean())

        def igl_step():
            C = igl.cotmatrix(Vn, F)
            M = igl.massmatrix(Vn, F, igl.MASSMATRIX_TYPE_BARYCENTRIC)
            lu = splu((M - h * h * C).tocsc())
            return lu.solve(M @ Vn)

        emit("igl_implicit_1", 1, bench(igl_step))


if __name__ == "__main__":
    main()
