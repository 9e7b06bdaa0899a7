#!/usr/bin/env python3
"""Benchmarks of watch and batch runs (issue: watch folders, batch runs and experiments).

1. Latency from a saved param change to the rerun starting, under `crestflow watch`: a
   pipeline (load -> curvature -> ridges -> report) on a real mesh is watched; the script edits
   `ridges.min_length` (a write in place, or an atomic rename-over save) and measures the time
   from the save to the `watch_run_started` event the watcher prints (its `unix_ms`), and to
   the end of the rerun. Goal: <= 300 ms to the start.
2. `run --each` throughput on the 10 cat poses
   (../shared/data/meshes/correspondence/sumner_cat_lion/cat-poses), files per second with
   --jobs 1 and --jobs 2, each with a fresh cache, for the default pipeline
   graphs/feature-curves.ron (load, curvature, ridges, saved mesh and curves, picture, report).

Run from the repository root after `cargo build --release`:

    python3 bench/watch/bench.py [--edits 10] [--debounce-ms 50]
"""

import argparse
import json
import os
import queue
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BIN = ROOT / "target" / "release" / "crestflow"
SHARED = ROOT / ".." / "shared" / "data" / "meshes"
POSES = SHARED / "correspondence" / "sumner_cat_lion" / "cat-poses"

GRAPH = """Graph(
    params: {{ "mesh": "mesh.off", "out": "out" }},
    nodes: {{
        "load": (kind: "io.load_mesh", params: (path: "$mesh")),
        "curvature": (kind: "curvature.polynomial", params: (rings: 2), inputs: {{ "mesh": "load.mesh" }}),
        "ridges": (
            kind: "ridges.trace",
            params: (min_strength: 1.5, min_length: {min_length}),
            inputs: {{ "mesh": "load.mesh", "curvature": "curvature.field" }},
        ),
        "report": (kind: "io.save_report", params: (path: "$out/report.json"), inputs: {{ "report": "ridges.report" }}),
    }},
)
"""


def reader(stream, q):
    for line in stream:
        line = line.strip()
        if line:
            try:
                q.put(json.loads(line))
            except json.JSONDecodeError:
                pass
    q.put(None)


def wait_for(q, pred, timeout=120.0):
    t0 = time.time()
    while True:
        left = timeout - (time.time() - t0)
        if left <= 0:
            raise TimeoutError("no matching event")
        ev = q.get(timeout=left)
        if ev is None:
            raise RuntimeError("the watcher exited")
        if pred(ev):
            return ev


def latency(edits, debounce_ms, mesh):
    d = Path(tempfile.mkdtemp(prefix="crestflow-watch-bench-"))
    try:
        shutil.copy(mesh, d / "mesh.off")
        (d / "graph.ron").write_text(GRAPH.format(min_length=3.0))
        p = subprocess.Popen(
            [str(BIN), "watch", "graph.ron", "--log", "json", "--debounce-ms", str(debounce_ms),
             "--exit-after", "600"],
            cwd=d, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        q = queue.Queue()
        threading.Thread(target=reader, args=(p.stdout, q), daemon=True).start()
        wait_for(q, lambda e: e.get("event") == "watch_run_finished")
        rows = []
        for k in range(edits):
            atomic = k % 2 == 1
            text = GRAPH.format(min_length=3.0 + 0.5 * (k + 1))
            time.sleep(0.3)  # let the previous rerun's events settle
            if atomic:
                tmp = d / ".graph.ron.tmp"
                tmp.write_text(text)
                t_save = time.time()
                os.replace(tmp, d / "graph.ron")
            else:
                t_save = time.time()
                (d / "graph.ron").write_text(text)
            start = wait_for(q, lambda e: e.get("event") == "watch_run_started")
            fin = wait_for(q, lambda e: e.get("event") == "watch_run_finished")
            t_end = time.time()
            rows.append((start["unix_ms"] - t_save * 1000.0, (t_end - t_save) * 1000.0,
                         fin["ran"], fin["cached"], "rename" if atomic else "write"))
        p.terminate()
        p.wait(timeout=30)
        return rows
    finally:
        shutil.rmtree(d, ignore_errors=True)


def each(jobs, files):
    d = Path(tempfile.mkdtemp(prefix="crestflow-each-bench-"))
    try:
        t0 = time.time()
        r = subprocess.run(
            [str(BIN), "run", str(ROOT / "graphs" / "feature-curves.ron"),
             "--each", str(POSES / "cat-*.obj"), "--jobs", str(jobs),
             "--cache", str(d / "cache"), "--set", f"out={d / 'out'}"],
            cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        wall = time.time() - t0
        if r.returncode != 0:
            print(r.stderr[-3000:], file=sys.stderr)
            raise RuntimeError(f"--each --jobs {jobs} failed with exit code {r.returncode}")
        t0 = time.time()
        r2 = subprocess.run(
            [str(BIN), "run", str(ROOT / "graphs" / "feature-curves.ron"),
             "--each", str(POSES / "cat-*.obj"), "--jobs", str(jobs),
             "--cache", str(d / "cache"), "--set", f"out={d / 'out'}"],
            cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        cached_wall = time.time() - t0
        return wall, cached_wall, r2.returncode
    finally:
        shutil.rmtree(d, ignore_errors=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--edits", type=int, default=10)
    ap.add_argument("--debounce-ms", type=int, default=50)
    ap.add_argument("--mesh", default=str(SHARED / "cad" / "cgal_fandisk.off"))
    args = ap.parse_args()
    if not BIN.exists():
        sys.exit(f"build first: cargo build --release ({BIN} is missing)")

    print(f"# watch: saved param change -> rerun ({args.edits} edits, debounce "
          f"{args.debounce_ms} ms, mesh {Path(args.mesh).name})")
    rows = latency(args.edits, args.debounce_ms, Path(args.mesh))
    print(f"{'edit':>4}  {'save':>6}  {'to start ms':>11}  {'to end ms':>9}  ran  cached")
    for k, (start, end, ran, cached, how) in enumerate(rows):
        print(f"{k + 1:>4}  {how:>6}  {start:>11.1f}  {end:>9.1f}  {ran:>3}  {cached:>6}")
    starts = [r[0] for r in rows]
    print(f"to start: median {statistics.median(starts):.1f} ms, max {max(starts):.1f} ms "
          f"(goal <= 300 ms)")

    files = sorted(POSES.glob("cat-*.obj"))
    print(f"\n# run --each on {len(files)} cat poses, graphs/feature-curves.ron, fresh cache")
    base = None
    for jobs in (1, 2):
        wall, cached_wall, rc = each(jobs, files)
        rate = len(files) / wall
        base = base or rate
        print(f"--jobs {jobs}: {wall:.2f} s, {rate:.2f} files/s ({rate / base:.2f}x of --jobs 1); "
              f"second batch (all cached) {cached_wall:.2f} s, exit {rc}")


if __name__ == "__main__":
    main()
