"""Cull slider first visits on a 900-frame take: refits shared by kept pose set, after Session.warm.

Prints: refits computed by the warm-up of 20 slider positions (5 %..100 %) vs the distinct kept pose sets,
the warm-up's CPU time, and the first visit of each position after the warm-up as a ratio to a cold
(unwarmed) visit measured in the same process; plus the load average (timings are noisy on a shared box).
Run: PYTHONPATH=$PWD STAGGER_NB_DATA=/work/main/data python benchmarks/bench_cull_first_visit.py
"""
import os
import time

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
