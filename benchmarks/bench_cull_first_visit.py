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
with_ev = refit_cpu(sm, kpcs, evaluated=staggered.evaluate(sm))
print(f"cull refit of each of {len(kpcs)} kept sets (K = {sm.num_poses}), CPU, least of 5 [aim 30 ms]: "
      f"median {1e3 * np.median(now):.1f} ms, max {1e3 * now.max():.1f} ms; previous fit (every sample): "
      f"median {1e3 * np.median(prev):.1f} ms ({np.median(prev) / np.median(now):.2f}x); "
      f"load average {os.getloadavg()[0]:.1f}")
print(f"  given evaluated=evaluate(sm) (what the editor holds): median {1e3 * np.median(with_ev):.1f} ms, max "
      f"{1e3 * with_ev.max():.1f} ms ({np.median(with_ev) / np.median(now):.2f}x of the refit without it)")


# evaluate_samples, the refit's source reads: one lexicographic search over all joints (now) against the
# previous per-joint np.unique / mask / searchsorted loop, on the scattered (time, joint) pairs of a refit
# (every frame of every joint, shuffled), same kernels after the segment search; CPU, least of 7
from stagger_nb.staggered.evaluation import _rotations_at, evaluate_samples
from stagger_nb.staggered.representation import knot_times


def evaluate_samples_per_joint_loop(sm, times, joints):
    J = sm.num_joints
    T = np.maximum.accumulate(knot_times(sm), axis=0)
    seg = np.empty(times.size, dtype=np.int64)
    for j in np.unique(joints):
        sel = joints == j
        seg[sel] = np.searchsorted(T[:, j], times[sel], side="right") - 1
    np.clip(seg, 0, sm.num_poses - 2, out=seg)
    a, b = T[seg, joints], T[seg + 1, joints]
    tn = np.clip(np.where(b > a, (times - a) / np.where(b > a, b - a, 1.0), 1.0), 0.0, 1.0)
    return np.array(_rotations_at(sm.rotations, seg * J + joints, tn).T)


rng = np.random.default_rng(0)
fr = np.repeat(np.arange(m.num_frames), sm.num_joints)
perm = rng.permutation(fr.size)
st, sj = (fr * sm.frame_time)[perm], np.tile(np.arange(sm.num_joints), m.num_frames)[perm]
best = {}
for f in (evaluate_samples_per_joint_loop, evaluate_samples) * 8:
    t = time.process_time()
    f(sm, st, sj)
    best[f] = min(best.get(f, 1e9), time.process_time() - t)
a, b = best[evaluate_samples_per_joint_loop], best[evaluate_samples]
print(f"evaluate_samples on {st.size} (time, joint) pairs, CPU least of 8: {1e3 * b:.2f} ms vs per-joint loop "
      f"{1e3 * a:.2f} ms (ratio {b / a:.2f}); max |diff| "
      f"{np.abs(evaluate_samples(sm, st, sj) - evaluate_samples_per_joint_loop(sm, st, sj)).max():.1e}; "
      f"load average {os.getloadavg()[0]:.1f}")
