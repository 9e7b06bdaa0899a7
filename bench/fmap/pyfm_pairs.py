#!/usr/bin/env python3
"""pyFM (pip package `pyfmaps`) on the correspondence pairs of the fmap benchmark.

For each pair (source -> target) runs pyFM's descriptor pipeline with the same landmarks
that our curves join (WKS, 100 descriptors subsampled by 5, landmark WKS maps, k = 120
eigenfunctions for the descriptors, pyFM README weights), fits the map at K = (k, k), converts
it to a point map (target vertex -> source vertex, nearest neighbour) and refines it by
ZoomOut from 30 to 120 (step 5, like ours). The error is the Princeton protocol of
eval.correspondence: for EVERY target vertex, the geodesic distance on the SOURCE mesh
(potpourri3d heat method) between the predicted and the ground-truth source vertex, divided
by sqrt(source area).

  python bench/fmap/pyfm_pairs.py [--k 120] [--fit-k 30] [--ours-dir DIR]

With --ours-dir, point-map files DIR/<pair>.txt (one source vertex per target vertex, as
written by fmap.save_point_map) are scored by the same evaluator, as a cross-check.
"""
import argparse
import os
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.normpath(os.path.join(HERE, "../../../shared/data/meshes/correspondence"))


def load_obj(path):
    v, f = [], []
    with open(path) as fh:
        for line in fh:
            if line.startswith("v "):
                v.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                f.append([int(t.split("/")[0]) - 1 for t in line.split()[1:4]])
    return np.array(v), np.array(f, dtype=np.int64)


def area(V, F):
    return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()


def farthest_points(V, F, count, start=0):
    """Farthest-point sampling with Dijkstra edge-length distances (as our benchmark)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import dijkstra
    e = np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    w = np.linalg.norm(V[e[:, 0]] - V[e[:, 1]], axis=1)
    n = len(V)
    G = sp.coo_matrix((np.r_[w, w], (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])), shape=(n, n)).tocsr()
    # Duplicate edges were summed: recompute the length of every stored entry.
    coo = G.tocoo()
    G = sp.csr_matrix((np.linalg.norm(V[coo.row] - V[coo.col], axis=1), (coo.row, coo.col)), shape=(n, n))
    d = np.full(n, np.inf)
    out = []
    nxt = start
    for _ in range(count):
        out.append(nxt)
        d = np.minimum(d, dijkstra(G, indices=nxt))
        nxt = int(np.argmax(np.where(np.isfinite(d), d, -1)))
    return np.array(out)


def pairs():
    c = os.path.join(DATA, "sumner_cat_lion")
    lm = np.loadtxt(os.path.join(c, "pyfm_landmarks_cat_lion.txt"), dtype=int)
    gt_lion = np.loadtxt(os.path.join(c, "pyfm_lion2cat.txt"), dtype=int)
    man = os.path.join(DATA, "smpl_man_woman/human_man.obj")
    Vm, Fm = load_obj(man)
    fps = farthest_points(Vm, Fm, 20)
    return [
        ("cat-pose", os.path.join(c, "cat-poses/cat-reference.obj"), os.path.join(c, "cat-poses/cat-05.obj"),
         np.c_[lm[:, 0], lm[:, 0]], None),
        ("cat-lion", os.path.join(c, "cat-poses/cat-reference.obj"), os.path.join(c, "lion-poses/lion-reference.obj"),
         lm, gt_lion),
        ("smpl", man, os.path.join(DATA, "smpl_man_woman/human_woman.obj"), np.c_[fps, fps], None),
    ]


def evaluate(V, F, p2p, gt):
    import potpourri3d as pp3d
    solver = pp3d.MeshHeatMethodDistanceSolver(V, F)
    sq = np.sqrt(area(V, F))
    err = np.empty(len(p2p))
    for s in np.unique(gt):
        idx = np.nonzero(gt == s)[0]
        d = solver.compute_distance(int(s))
        err[idx] = np.where(p2p[idx] == s, 0.0, d[p2p[idx]])
    e = err / sq
    return {"mean": e.mean(), "cum_0.025": (e <= 0.025).mean(), "cum_0.05": (e <= 0.05).mean(),
            "cum_0.1": (e <= 0.1).mean(), "cum_0.25": (e <= 0.25).mean()}


def fmt(r):
    return "%.4f | %.3f | %.3f | %.3f | %.3f" % (r["mean"], r["cum_0.025"], r["cum_0.05"], r["cum_0.1"], r["cum_0.25"])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--k", type=int, default=120)
    ap.add_argument("--fit-k", type=int, default=30)
    ap.add_argument("--also-fit-full", action="store_true",
                    help="also fit at K = (k, k) (slow: minutes per pair with pyFM's L-BFGS)")
    ap.add_argument("--curves", default="5,10,20", help="landmark counts: q curves use landmarks 0..q")
    ap.add_argument("--ours-dir", default=None)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    from pyFM.functional import FunctionalMapping
    from pyFM.mesh import TriMesh

    print("pair | method | landmarks | mean | cum@0.025 | cum@0.05 | cum@0.1 | cum@0.25 | time s")
    for name, src, tgt, lm, gt in pairs():
        V1, F1 = load_obj(src)
        V2, F2 = load_obj(tgt)
        gt = np.arange(len(V2)) if gt is None else gt
        for q in [int(x) for x in args.curves.split(",")]:
            used = lm[: min(q + 1, len(lm))]
            t0 = time.perf_counter()
            model = FunctionalMapping(TriMesh(V1, F1), TriMesh(V2, F2))
            model.preprocess(n_descr=100, descr_type="WKS", subsample_step=5, landmarks=used,
                             k_process=args.k, k_descr=args.k, verbose=False)
            tpre = time.perf_counter() - t0
            fits = [("fit k=%d" % args.fit_k, args.fit_k)]
            if args.also_fit_full:
                fits.append(("fit k=%d" % args.k, args.k))
            for label, K in fits:
                t0 = time.perf_counter()
                model.fit(K=(K, K), w_descr=1e0, w_lap=1e-2, w_dcomm=1e-1, w_orient=0.0,
                          optinit="zeros", verbose=False)
                FM = np.array(model.FM).copy()
                p2p = np.asarray(model.get_p2p(FM=FM, n_jobs=1))
                tfit = time.perf_counter() - t0
                print("%s | pyFM %s | %d | %s | %.2f (+%.2f preprocess)" % (name, label, len(used), fmt(evaluate(V1, F1, p2p, gt)), tfit, tpre))
                sys.stdout.flush()
                if K == args.fit_k:
                    t0 = time.perf_counter()
                    FMz = model.zoomout_refine(FM, nit=(args.k - K) // 5, step=5, verbose=False)
                    p2pz = np.asarray(model.get_p2p(FM=FMz, n_jobs=1))
                    tz = time.perf_counter() - t0
                    if True:
                        print("%s | pyFM %s + ZoomOut->%d | %d | %s | %.2f" % (name, label, args.k, len(used), fmt(evaluate(V1, F1, p2pz, gt)), tz))
                        sys.stdout.flush()
        if args.ours_dir:
            for fn in sorted(os.listdir(args.ours_dir)):
                if fn.startswith(name + "_") and fn.endswith(".txt"):
                    p2p = np.loadtxt(os.path.join(args.ours_dir, fn), dtype=int)
                    print("%s | ours (%s, scored by this script) | | %s |" % (name, fn, fmt(evaluate(V1, F1, p2p, gt))))


if __name__ == "__main__":
    main()
