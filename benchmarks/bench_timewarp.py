"""Guided time warping speed (issue 6), on real 31-joint poses (93-dim positions, 279-dim features).

Targets: Table-1 size (n = 493, m = 280, r = 493, s = 8) objective + optimisation <= 0.1 s;
n = 2,000, m = 1,200 <= 1 s; n = 5,000, m = 3,000 <= 10 s with < 2 GB peak memory (r = n: self reference).
Printed beside them, measured in this process: the straightforward loop implementation (one linear kNN search
per triple + the DP of eqs. 3-4 as Python loops) on the Table-1 size, the coarse-to-fine heuristic, and
dtw-python aligning the same two feature sequences.

Issue 13 additions: the whole public ``guided_warp`` call at Table-1 size (features, objective, DP with the
speed penalty, smoothing, resampling; target <= 80 ms), the approximate kNN's error against the exact
objective at Table-1 size, and a long take: 20,000 frames (xia walk/run copies at 120 Hz, self reference, 65 %
length) in a fresh child process, time, CPU and peak RSS (target <= 30 s, <= 2 GB), plus the ValueError beyond
``MAX_SEARCH_FRAMES``.

Run: ``.venv/bin/python benchmarks/bench_timewarp.py [--no-loop] [--no-long]`` (the loop baseline takes ~20-60 s).
Poses come from ``data/cmu_01_01.bvh`` (resampled so the clip has n frames) when prepared, else from the
procedural jump.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
import tracemalloc
from pathlib import Path

# The objective runs its own worker threads over the elementwise work; its few small GEMMs do not need
# OpenBLAS threads, which on a busy shared machine spin and cost 10-50x (measured: a 491x93x493 product took
# 40-60 ms with OpenBLAS threads under load, 1.3 ms single-threaded). Set before numpy loads OpenBLAS.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from stagger_nb import data
from stagger_nb.timewarp.dp import constrained_dp
from stagger_nb.timewarp.features import pose_features
from stagger_nb.timewarp.guided import solve_warp
from stagger_nb.timewarp.objective import knn_scores

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from timewarp_reference import constrained_dp_loop, knn_scores_loop

S = 8
K = 3
CASES = [(493, 280, 0.1), (2000, 1200, 1.0), (5000, 3000, 10.0)]
TIME_UNIT_WEIGHTS = (1.0, 1.0, 1.0)  # features per output frame; the pose/timing balance is not timed


def clip():
    name = "cmu_01_01" if data.path("cmu_01_01").is_file() else "jump"
    return name, data.load(name)


def features(motion, n):
    """Pose features (n, 93) of the whole clip resampled to n frames."""
    m = motion.resample(motion.duration / (n - 1))
    m = m.slice(0, n) if m.num_frames >= n else m.sample(np.linspace(0, m.num_frames - 1, n))
    return pose_features(m)


def best_of(fn, repeat):
    """Best wall time of ``repeat`` runs (and that run's CPU time over all threads in ``CPU[fn]``)."""
    best, out = np.inf, None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        wall = time.perf_counter() - t0
        if wall < best:
            best, CPU[fn.__name__ if hasattr(fn, "__name__") else "fn"] = wall, time.process_time() - c0
    return best, out


CPU: dict = {}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--no-loop", action="store_true", help="skip the straightforward loop baseline")
    ap.add_argument("--no-long", action="store_true", help="skip the 20,000-frame long take")
    ap.add_argument("--child-long", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child_long:
        return child_long(args.child_long)
    name, motion = clip()
    print(f"poses: {name} ({motion.num_joints} joints -> {3 * motion.num_joints}-dim positions, "
          f"{9 * motion.num_joints}-dim features), k = {K}, s = {S}; {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f} (times are wall clock, best of a few runs; CPU = process time, all threads)")
    print(f"{'n':>6} {'m':>6} {'r':>6}  {'objective':>10} {'DP':>9} {'total':>9} {'target':>7}  "
          f"{'coarse8 DP':>10}  {'peak MB (objective+DP, tracemalloc)':>8}")
    table1 = None
    for n, m, target in CASES:
        X = features(motion, n)
        R = X
        repeat = 5 if n < 1000 else (3 if n < 3000 else 1)
        def objective():
            return knn_scores(X, R, S, K)

        def optimisation():
            return constrained_dp(scores, m)

        t_obj, scores = best_of(objective, repeat)
        t_dp, (frames, cost) = best_of(optimisation, repeat)
        peak = ""
        if n >= 5000:  # peak traced memory of one objective + DP run
            tracemalloc.start()
            sc = knn_scores(X, R, S, K)
            constrained_dp(sc, m)
            peak = f"{tracemalloc.get_traced_memory()[1] / 2 ** 20:8.0f}"
            tracemalloc.stop()
            del sc
        # coarse-to-fine (paper: factor 8): the coarse problem + the banded full DP, objective table reused
        tables = _tables_from(motion, n, scores, X)
        t_c2f, sol = best_of(lambda: solve_warp(tables, m, coarse=8), repeat)
        total = t_obj + t_dp
        flag = "ok" if total <= target else "MISSED"
        print(f"{n:6d} {m:6d} {n:6d}  {t_obj:9.3f}s {t_dp:8.3f}s {total:8.3f}s {target:6.1f}s {flag:6s} "
              f"{t_c2f:8.3f}s (cost x{sol.cost / cost:.4f})  {peak}   [CPU: objective "
              f"{CPU['objective']:.3f}s, DP {CPU['optimisation']:.3f}s]")
        if table1 is None:
            table1 = (X, R, scores, frames, cost, total, t_obj, t_dp, m)
    X, R, scores, frames, cost, total, t_obj, t_dp, m = table1
    public_call(motion)
    approx_error(X, R, m)
    if not args.no_long:
        long_take()
    print("paper, Table 1 (V1, 2.4 GHz Pentium 4, C++ objective + MATLAB DP): 1.3 s + 2.7 s; heuristic 0.17 s")
    try:
        from dtw import dtw
        t_dtw, al = best_of(lambda: dtw(X, R, dist_method="euclidean"), 3)
        print(f"dtw-python 1.x aligning the same two {X.shape[0]} x {X.shape[1]} pose sequences "
              f"(euclidean, symmetric2): {t_dtw:.3f} s  (guided objective + DP: {total:.3f} s)")
    except ImportError:
        print("dtw-python not installed (pip install dtw-python): reference point skipped")
    if not args.no_loop:
        t0 = time.perf_counter()
        slow = knn_scores_loop(X, R, S, K)
        t_lobj = time.perf_counter() - t0
        t0 = time.perf_counter()
        lframes, lcost = constrained_dp_loop(slow, m)
        t_ldp = time.perf_counter() - t0
        fin = np.isfinite(slow)
        err = np.abs(slow[fin] - scores[fin]).max()
        print(f"straightforward loops (Table-1 size): objective {t_lobj:.2f} s, DP {t_ldp:.2f} s, total "
              f"{t_lobj + t_ldp:.2f} s -> vectorised is {(t_lobj + t_ldp) / total:.0f}x faster "
              f"(objective {t_lobj / t_obj:.0f}x, DP {t_ldp / t_dp:.0f}x); max |score diff| {err:.2e} "
              f"(float32 search), same frames: {bool(np.array_equal(lframes, frames))}, "
              f"cost ratio {lcost / cost:.6f}")
    return 0


def public_call(motion):
    """The whole public guided_warp at Table-1 size, against the straightforward baseline's pieces measured
    in this process: the float64 exact objective + the DP of eqs. 3-4 without the speed penalty or banding.
    Cold: the tables cache emptied before every call (a first call on a new clip); warm: the same call again
    (its features + kNN table come from :func:`stagger_nb.timewarp.cached_prepare_warp`)."""
    from stagger_nb import timewarp
    mm = motion.resample(motion.duration / 492)
    timewarp.guided_warp(mm, mm, 280)

    def cold():
        timewarp.clear_tables_cache()
        return timewarp.guided_warp(mm, mm, 280)
    t, _ = best_of(cold, 7)
    cpu = CPU["cold"]
    timewarp.guided_warp(mm, mm, 280)
    tw, _ = best_of(lambda: timewarp.guided_warp(mm, mm, 280), 7)
    cpu_w = CPU["<lambda>"]

    def baseline():
        tb = timewarp.prepare_warp(mm, mm, S, knn="exact", dtype=np.float64)
        return constrained_dp(tb.scores, 280)
    tb, _ = best_of(baseline, 3)
    print(f"public guided_warp(m, m, 280), n = {mm.num_frames} (Table-1 size, everything included), best of 7: "
          f"cold (new clip) {t * 1e3:.0f} ms wall, {cpu * 1e3:.0f} ms CPU (target <= 80 ms); warm (same call again, "
          f"tables cached) {tw * 1e3:.0f} ms wall, {cpu_w * 1e3:.0f} ms CPU; float64 objective + plain DP "
          f"{tb * 1e3:.0f} ms -> ratio baseline/cold {tb / t:.2f}x, baseline/warm {tb / tw:.2f}x")


def approx_error(X, R, m):
    """The long-take objective (k nearest among C candidate reference frames) against the exact one."""
    from stagger_nb.timewarp.dp import path_cost
    from stagger_nb.timewarp.objective import candidate_scores
    exact = knn_scores(X, R, S, K, dtype=np.float64)
    f0, c0 = constrained_dp(exact, m)
    for C in (8, 16, 32):
        t, approx = best_of(lambda: candidate_scores(X, R, S, K, candidates=C), 3)
        f1, _ = constrained_dp(approx, m)
        fin = np.isfinite(exact)
        rel = (approx[fin] - exact[fin]) / exact[fin]
        print(f"approximate kNN, C = {C} candidates, Table-1 size: objective {t * 1e3:.0f} ms; scores exact in "
              f"{np.mean(np.abs(rel) < 1e-6) * 100:.1f} % of triples (max over-estimate {rel.max() * 100:.0f} %); "
              f"its optimal warp costs x{path_cost(exact, f1) / c0:.4f} the exact optimum (exact objective)")


def child_long(F):
    import json
    import resource
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_wand import _long_clip, _peak_rss_mb

    from stagger_nb import timewarp
    m = _long_clip(F)
    c0, t0 = time.process_time(), time.perf_counter()
    tables = timewarp.prepare_warp(m, m, S)
    t_head, c_head = time.perf_counter() - t0, time.process_time() - c0
    num = int(round(0.65 * (F - 1))) + 1
    c0, t0 = time.process_time(), time.perf_counter()
    out, warp = timewarp.guided_warp(m, m, num, tables=tables)
    t_tail, c_tail = time.perf_counter() - t0, time.process_time() - c0
    j = timewarp.speed_jumps(warp, m.frame_time)
    try:
        timewarp.guided_warp(m, m, 10 * F)
        refused = "accepted?!"
    except ValueError as exc:
        refused = str(exc)
    del resource
    print(json.dumps(dict(F=F, knn=tables.knn, head=t_head, head_cpu=c_head, tail=t_tail, tail_cpu=c_tail,
                          rss=_peak_rss_mb(), p95=float(np.percentile(j, 95)), jmax=float(j.max()), refused=refused)))
    return 0


def long_take(F=20000):
    import json
    import subprocess
    out = subprocess.run([sys.executable, __file__, "--child-long", str(F)], capture_output=True, text=True)
    if out.returncode != 0:
        print(f"long take {F} frames: FAILED\n{out.stderr[-2000:]}")
        return
    r = json.loads(out.stdout.strip().splitlines()[-1])
    total = r["head"] + r["tail"]
    print(f"long take: {F} frames x 31 joints at 120 Hz -> 65 %, self reference, knn={r['knn']} (C = 32), "
          f"coarse-to-fine DP: tables {r['head']:.1f} s wall / {r['head_cpu']:.1f} s CPU, search + smoothing + "
          f"resampling {r['tail']:.1f} / {r['tail_cpu']:.1f} s, total {total:.1f} s wall (target <= 30 s); peak RSS "
          f"{r['rss']:.0f} MB (target <= 2 GB); speed jumps p95 {r['p95']:.3f}, max {r['jmax']:.3f}. "
          f"The exact search would need {warp_memory_gib(F):.1f} GiB.")
    print(f"   guided_warp(m, m, {10 * F}) -> ValueError: {r['refused']}")


def warp_memory_gib(F):
    from stagger_nb.timewarp import warp_memory
    return warp_memory(F, F, S, 1, 93, knn="exact") / 2 ** 30


def _tables_from(motion, n, scores, X):
    """WarpTables around an already computed score table (so the heuristic's time excludes the objective)."""
    from stagger_nb.timewarp.guided import WarpTables
    m = motion.resample(motion.duration / (n - 1))
    return WarpTables(m, m, S, 1, False, K, TIME_UNIT_WEIGHTS, X, X, scores)


if __name__ == "__main__":
    raise SystemExit(main())
