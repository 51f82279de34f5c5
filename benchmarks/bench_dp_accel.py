"""The constrained DP of guided time warping (Hsu et al. 2007, eqs. 3-4) with and without its C forward pass
(``timewarp/_cdp.c``), on CMU 01_01 (2,751 frames at 120 Hz) guided by itself: the searches an editor's first
changes run (issue 26): a compression to 90 %, the clip's own length played backward (upsample 2: the exact DP over
a band ~2,400 frames wide, the one that missed the 300 ms budget) and a lengthening to 110 % (upsample 3, above the
coarse-to-fine threshold). Tables are prepared once (not timed); each ``solve_warp`` is timed as CPU time, the
numpy path (``STAGGER_NB_NO_ACCEL=1``) and the C path alternately, best of ``REPEATS``; the frames must be equal.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_dp_accel.py``
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np

import stagger_nb as sn
from stagger_nb import timewarp
from stagger_nb.core.accel import NO_ACCEL_ENV
from stagger_nb.timewarp import dp

REPEATS = 5


def main():
    if not dp.accelerated():
        sys.exit("the C extension timewarp._cdp is not built (python setup.py build_ext --inplace)")
    m = sn.io.read_bvh(str(REPO / "data" / "cmu_01_01.bvh"))
    N = m.num_frames
    print(f"CMU 01_01: {N} frames; load {os.getloadavg()[0]:.1f}")
    cases = [("duration -10 %", round(0.9 * (N - 1)) + 1, False), ("backward at own length", N, True),
             ("duration +10 %", round(1.1 * (N - 1)) + 1, False)]
    for name, n, backward in cases:
        u = max(timewarp.required_upsample(N, n, skip=8), 2 if n == N else 1)
        tables = timewarp.prepare_warp(m, m, 8, u, reverse=backward)
        best = {"1": np.inf, "0": np.inf}
        frames = {}
        for _ in range(REPEATS):
            for env in ("1", "0"):
                os.environ[NO_ACCEL_ENV] = env
                c = time.process_time()
                sol = timewarp.solve_warp(tables, n)
                best[env] = min(best[env], time.process_time() - c)
                frames[env] = sol.frames
        os.environ.pop(NO_ACCEL_ENV, None)
        same = np.array_equal(frames["1"], frames["0"])
        print(f"{name:24s} searched {tables.n_up:5d} -> {n:5d} frames: numpy {best['1'] * 1e3:6.1f} ms  "
              f"C {best['0'] * 1e3:6.1f} ms  x{best['1'] / best['0']:.2f}  same frames {same}")
        assert same
    print(f"load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
