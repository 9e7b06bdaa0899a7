#!/usr/bin/env python3
"""Bad input through the whole CLI: broken meshes and random in-range parameters.

Writes damaged variants of data/cgal_fandisk.off and small hand-made meshes (empty, NaN,
out-of-range indices, non-manifold, holes, flipped faces, coordinates of
1e200 and 1e-200, ...), then runs `crestflow run` on graphs that feed them to the loading,
curvature, ridge, scale-selection, remeshing, Laplacian, eigenbasis, heat and smoothing nodes,
with and without `repair: true`, and with random parameters drawn from each node's allowed
range. Every run must end with exit code 0 (all nodes ran), 1 (some nodes failed with an error
message) or 2 (the graph was refused before running), within the time limit, and without a
panic. Prints one line per run and a summary; exits 1 if any run broke that rule.

Usage (from the repository root, after `cargo build --release`):
    python3 bench/fuzz/run.py [--runs 80] [--seed 1] [--timeout 120]
"""
import argparse
import math
import os
import random
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.path.join(ROOT, "target", "release", "crestflow")


def read_off(path):
    toks = []
    with open(path) as f:
        for line in f:
            toks += line.split("#")[0].split()
    nv, nf = int(toks[1]), int(toks[2])
    v = [tuple(map(float, toks[4 + 3 * i:7 + 3 * i])) for i in range(nv)]
    faces, i = [], 4 + 3 * nv
    for _ in range(nf):
        c = int(toks[i])
        faces.append(tuple(map(int, toks[i + 1:i + 1 + c])))
        i += 1 + c
    return v, faces


def off(v, faces):
    out = ["OFF", "%d %d 0" % (len(v), len(faces))]
    out += ["%r %r %r" % p for p in v]
    out += ["%d %s" % (len(t), " ".join(map(str, t))) for t in faces]
    return "\n".join(out) + "\n"


def cases(rng):
    """Name -> OFF text."""
    v, f = read_off(os.path.join(ROOT, "data", "cgal_fandisk.off"))
    n = len(v)
    grid = [(x / 10, y / 10, 0.0) for y in range(11) for x in range(11)]
    grid_f = [t for y in range(10) for x in range(10)
              for t in [(y * 11 + x, y * 11 + x + 1, (y + 1) * 11 + x + 1),
                        (y * 11 + x, (y + 1) * 11 + x + 1, (y + 1) * 11 + x)]]
    nan = list(v)
    nan[5] = (math.nan, 0.0, 0.0)
    text = off(v, f)
    return {
        "fandisk": text,
        "empty": "",
        "header_only": "OFF\n0 0 0\n",
        "truncated": text[:len(text) // 2],
        "header_lies": "OFF\n1000000 2000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "garbage": "OFF\n3 1 0\n0 0 zero\n1 0 0\n0 1 0\n3 0 1 2\n",
        "index_out_of_range": off(v, f[:-1] + [(0, 1, n + 5)]),
        "index_negative": "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n",
        "nan_vertex": off(nan, f),
        "one_triangle": off([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)]),
        "two_triangles_apart": off([(0, 0, 0), (1, 0, 0), (0, 1, 0), (5, 5, 5), (6, 5, 5),
                                    (5, 6, 5)], [(0, 1, 2), (3, 4, 5)]),
        "three_faces_on_an_edge": off([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1)],
                                      [(0, 1, 2), (1, 0, 3), (0, 1, 4)]),
        "bowtie": off([(0, 0, 0), (1, 0, 0), (0, 1, 0), (-1, 0, 0), (0, -1, 0)],
                      [(0, 1, 2), (0, 3, 4)]),
        "tetrahedron": off([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)],
                           [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]),
        "collinear": off([(i, 0, 0) for i in range(10)], [(i, i + 1, i + 2) for i in range(8)]),
        "all_one_point": off([(0, 0, 0)] * 4, [(0, 1, 2), (0, 2, 3), (0, 3, 1), (1, 3, 2)]),
        "needles": off([(0, 0, 0), (1, 0, 0), (0.5, 1e-9, 0), (0.5, -1e-9, 0)],
                       [(0, 1, 2), (1, 0, 3)]),
        "square": off(grid, grid_f),
        "quads": off([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1),
                      (1, 1, 1), (0, 1, 1)],
                     [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (2, 3, 7, 6), (1, 2, 6, 5),
                      (0, 4, 7, 3)]),
        "duplicate_faces": off(v, f + f[:50]),
        "repeated_index_faces": off(v, f + [(0, 0, 1), (2, 2, 2)]),
        "unreferenced_vertices": off(v + [(9, 9, 9)], f),
        "holes": off(v, [t for t in f if rng.random() > 0.05]),
        "sparse": off(v, [t for t in f if rng.random() > 0.7]),
        "flipped_faces": off(v, [(t[0], t[2], t[1]) if rng.random() < 0.3 else t for t in f]),
        "duplicated_vertices": off(v + v, [tuple(x + n for x in t) if k % 2 else t
                                           for k, t in enumerate(f)]),
        "huge": off([tuple(c * 1e200 for c in p) for p in v], f),
        "tiny": off([tuple(c * 1e-200 for c in p) for p in v], f),
    }


def pipeline(rng, repair):
    """A graph over every node family, parameters drawn from their allowed ranges (the
    first of each list, mostly the defaults, without `rng`)."""
    pick = rng.choice if rng else (lambda xs: xs[0])
    remesh = ", ".join([
        "target: %r" % pick([0.02, 0.002, 0.01, 0.5, 2.0]),
        "iterations: %d" % pick([10, 0, 1]),
        "sharp_edges: %s" % pick(["true", "false"]),
        "sharp_angle_deg: %r" % pick([30.0, 1.0, 179.0]),
        "corner_angle_deg: %r" % pick([60.0, 1.0, 179.0]),
        "smoothing_steps: %d" % pick([5, 0]),
        "feature_tolerance: %r" % pick([0.002, 0.0, 1.0]),
        "boundary_tolerance: %r" % pick([0.25, 0.0, 1.0, 1e-9]),
        "feature_grading: %r" % pick([0.0, 0.3, 3.0]),
        "max_vertices: 300000",
    ])
    eig = ", ".join([
        "k: %d" % pick([20, 1, 5, 121]),
        "inner_shift: %r" % pick([0.4, 0.0, 0.9]),
        "tol: %r" % pick([1e-9, 1e-12, 1e-4]),
        "block: %d" % pick([0, 1, 8]),
        "shift: %r" % pick([1e-5, 1e-9, 1e-2]),
        "max_steps: %d" % pick([1000, 3]),
    ])
    quality = ", ".join([
        "samples: %d" % pick([100000, 0, 7]),
        "tolerance: %r" % pick([1e-4, 0.0, 1e-12, 1.0]),
    ])
    scale = pick([0.02, 0.005, 0.3])
    return """Graph(params: {"mesh": "m.off", "out": "out"}, nodes: {
 "load": (kind: "io.load_mesh", params: (path: "$mesh", repair: %s)),
 "curv": (kind: "curvature.polynomial", params: (rings: %d, degree: %d),
          inputs: {"mesh": "load.mesh"}),
 "ridges": (kind: "ridges.trace", params: (min_strength: %r),
            inputs: {"mesh": "load.mesh", "curvature": "curv.field"}),
 "conform": (kind: "scale.conform", params: (scale: %r, time_limit_s: 20.0),
             inputs: {"curves": "ridges.network", "mesh": "load.mesh"}),
 "check": (kind: "scale.check", params: (scale: %r),
           inputs: {"curves": "conform.network", "mesh": "load.mesh"}),
 "remesh": (kind: "remesh.isotropic", params: (%s),
            inputs: {"mesh": "load.mesh", "curves": "check.network"}),
 "quality": (kind: "eval.mesh_quality", params: (%s),
             inputs: {"mesh": "remesh.mesh", "reference": "load.mesh"}),
 "lap": (kind: "spectral.laplacian", inputs: {"mesh": "load.mesh"}),
 "eig": (kind: "spectral.eigenbasis", params: (%s), inputs: {"operator": "lap.operator"}),
 "heat": (kind: "geodesic.heat", params: (vertices: [0]), inputs: {"mesh": "load.mesh"}),
 "smooth": (kind: "smooth.laplacian", inputs: {"mesh": "load.mesh"}),
 "sharp": (kind: "remesh.sharp_edges", inputs: {"mesh": "load.mesh"}),
 "save": (kind: "io.save_report", params: (path: "$out/quality.json"),
          inputs: {"report": "quality.report"}),
})
""" % ("true" if repair else "false", pick([2, 1, 3]), pick([4, 3]), pick([1.5, 0.5, 1.0]),
       scale, scale, remesh, quality, eig)


# Meshes every node must handle with default parameters: after the loader's clean-up, and
# after `repair: true`.
CLEAN = {"fandisk", "duplicate_faces", "repeated_index_faces", "unreferenced_vertices",
         "square"}
REPAIRABLE = {"holes", "sparse", "flipped_faces", "duplicated_vertices"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=80)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=120.0)
    args = ap.parse_args()
    if not os.path.exists(BIN):
        sys.exit("build the release binary first: cargo build --release")
    rng = random.Random(args.seed)
    meshes = cases(rng)
    names = sorted(meshes)
    broken = 0
    counts = {0: 0, 1: 0, 2: 0}
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in meshes.items():
            with open(os.path.join(tmp, name + ".off"), "w") as f:
                f.write(text)
        # Every mesh once with the defaults of both load modes, then random pipelines.
        plan = [(name, repair, False) for name in names for repair in (False, True)]
        plan += [(rng.choice(names), rng.random() < 0.5, True) for _ in range(args.runs)]
        for i, (name, repair, rand) in enumerate(plan):
            graph = os.path.join(tmp, "g%d.ron" % i)
            with open(graph, "w") as f:
                f.write(pipeline(rng if rand else None, repair))
            t = time.time()
            try:
                r = subprocess.run(
                    [BIN, "run", graph, "--no-cache", "--set", "mesh=%s.off" % name,
                     "--set", "out=out%d" % i],
                    capture_output=True, text=True, timeout=args.timeout, cwd=tmp)
                out, rc = r.stdout + r.stderr, r.returncode
            except subprocess.TimeoutExpired:
                out, rc = "timeout", None
            dt = time.time() - t
            # With default parameters, what the loader cleans up or repairs runs through.
            must_run = not rand and (name in CLEAN or (repair and name in REPAIRABLE))
            bad = rc not in (0, 1, 2) or "panicked" in out or (must_run and rc != 0)
            broken += bad
            if rc in counts:
                counts[rc] += 1
            summary = [l.strip() for l in out.splitlines() if " ran, " in l][-1:]
            print("%3d %-24s repair=%-5s rc=%-4s %6.1f s %s%s" % (
                i, name, repair, rc, dt, "BROKEN " if bad else "",
                summary[0] if summary else out.strip().splitlines()[-1][:100] if out.strip()
                else ""))
    print("%d runs: %d all ran, %d with failed nodes, %d refused, %d broken (panic, crash or "
          "timeout)" % (len(plan), counts[0], counts[1], counts[2], broken))
    sys.exit(1 if broken else 0)


if __name__ == "__main__":
    main()
