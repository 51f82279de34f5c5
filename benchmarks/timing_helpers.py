"""Timing shared by the benchmarks (a helper module, not a benchmark: `make bench` runs only bench_*.py)."""
from __future__ import annotations

import time

import numpy as np


def min_median(fn, repeat: int, clock=time.perf_counter) -> tuple[float, float]:
    """(minimum, median) seconds by ``clock`` (wall: ``time.perf_counter``; CPU: ``time.process_time``) of
    ``fn()`` over ``repeat`` calls after one warm-up call."""
    fn()
    ts = []
    for _ in range(repeat):
        t = clock()
        fn()
        ts.append(clock() - t)
    return min(ts), float(np.median(ts))
