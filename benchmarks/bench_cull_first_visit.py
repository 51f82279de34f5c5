"""Cull slider first visits on a 900-frame take: refits shared by kept pose set, after Session.warm.

Prints: refits computed by the warm-up of 20 slider positions (5 %..100 %) vs the distinct kept pose sets,
the warm-up's CPU time, and the first visit of each position after the warm-up as a ratio to a cold
(unwarmed) visit measured in the same process; plus the load average (timings are noisy on a shared box).
Then the refit itself (``staggered.cull`` on each distinct kept set of percents 1..99, the editor's
first visits without a warm-up): CPU per refit, the least of 5 rounds per kept set (the least is the
figure least disturbed by other processes), median and max; baseline in the same process: the previous
fit (every sample, ``fit_samples=None``). Aim: <= 30 ms per refit (the editor adds ~40 ms of views and
replay to a first visit; goal 100 ms).
Run: PYTHONPATH=$PWD STAGGER_NB_DATA=/work/main/data python benchmarks/bench_cull_first_visit.py
(PYTHONPATH=/work/main measures the integration tree's code with the same script.)
"""
import os
import time

import numpy as np

import stagger_nb as sn
from stagger_nb import staggered
from stagger_nb.session import Session

m = sn.data.load("cmu_01_01")
m = m.slice(0, min(900, m.num_frames))
pcs = [float(p) for p in range(5, 101, 5)]
print(f"frames {m.num_frames}, load average {os.getloadavg()[0]:.1f}")

cold = Session(m)
cold.extraction()
cold.set_ops([{"op": "cull", "percent": 50.0}])
t = time.perf_counter()
cold.staggered()
baseline = time.perf_counter() - t

s = Session(m)
sm = s.extraction()
refits = []
s.observe_busy(lambda kind, started: refits.append(kind) if started and kind == "cull" else None)
t = time.process_time()
s.warm(("cull", pcs)).result()
print(f"warm-up of {len(pcs)} positions: {len(refits)} refits for "
      f"{len({tuple(staggered.cull_keep(sm, p)) for p in pcs})} distinct kept sets, "
      f"CPU {time.process_time() - t:.2f} s")
visits = []
for p in pcs:
    s.set_ops([{"op": "cull", "percent": p}])
    t = time.perf_counter()
    s.staggered()
    visits.append(time.perf_counter() - t)
visits.sort()
print(f"cold first visit {1000 * baseline:.0f} ms; after the warm-up: max {1000 * visits[-1]:.1f} ms "
      f"({visits[-1] / baseline:.3f} x cold), median {1000 * visits[len(visits) // 2]:.2f} ms")
s.close()
cold.close()


def refit_cpu(sm, pcs, **kw):
    """(K,) least-of-5 CPU seconds of ``cull(sm, pc, **kw)`` for each percent in ``pcs``."""
    for pc in pcs:
        staggered.cull(sm, pc, **kw)                   # warm-up (workspace buffers, imports)
    rounds = []
    for _ in range(5):
        row = []
        for pc in pcs:
            t = time.process_time()
            staggered.cull(sm, pc, **kw)
            row.append(time.process_time() - t)
        rounds.append(row)
    return np.min(np.array(rounds), axis=0)


sm = staggered.extract(m)
keys = sorted({tuple(staggered.cull_keep(sm, pc)) for pc in range(1, 100)}, key=len)
kpcs = [next(pc for pc in range(1, 100) if tuple(staggered.cull_keep(sm, pc)) == k) for k in keys]
now = refit_cpu(sm, kpcs)
prev = refit_cpu(sm, kpcs, fit_samples=None)
print(f"cull refit of each of {len(kpcs)} kept sets (K = {sm.num_poses}), CPU, least of 5 [aim 30 ms]: "
      f"median {1e3 * np.median(now):.1f} ms, max {1e3 * now.max():.1f} ms; previous fit (every sample): "
      f"median {1e3 * np.median(prev):.1f} ms ({np.median(prev) / np.median(now):.2f}x); "
      f"load average {os.getloadavg()[0]:.1f}")
